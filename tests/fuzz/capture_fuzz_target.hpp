#pragma once
// The capture importer's fuzz contract, shared by the libFuzzer target (capture_fuzzer.cpp, clang
// only) and the deterministic mutation test that always runs (tests/capture_fuzz_test.cpp): a
// capture folder (core/capture.hpp, docs/captures.md) in which any one file -- capture.json, a
// frame, a reference, a gradient file or a stored output -- holds arbitrary bytes either opens,
// reads frame by frame and validates (metrics/capture_checks.hpp), or is rejected with an
// arena::Error naming the file. Any other exception, a crash, a hang or a sanitizer report is a bug.
//
// The seed capture is written here (writeSeedCapture) rather than committed: a 6x4 three-frame
// capture with every frame layer, references with variance and an independent half, A-SVGF
// gradients and one stored output with its times.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/capture.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/sequence.hpp"
#include "metrics/capture_checks.hpp"
#include "metrics/evaluator.hpp"
#include "tests/fuzz/work_dir.hpp"

namespace arena::fuzz {

// Which file of the seed capture an input replaces (libFuzzer: its first byte, modulo the count).
enum class CaptureFile { Description, Frame, Reference, Gradients, Output };
inline constexpr int kCaptureFileKinds = 5;
inline constexpr int kSeedFrames = 3, kSeedWidth = 6, kSeedHeight = 4;

inline std::filesystem::path captureFileOf(CaptureFile kind, const std::filesystem::path& dir) {
  switch (kind) {
    case CaptureFile::Description:
      return dir / "capture.json";
    case CaptureFile::Frame:
      return captureFramePath(dir, 1);
    case CaptureFile::Reference:
      return captureReferencePath(dir, 1);
    case CaptureFile::Gradients:
      return captureGradientPath(dir, 1);
    case CaptureFile::Output:
      break;
  }
  return dir / "outputs" / "ext" / numberedFileName("frame", 1, 4);
}

// A smooth value per pixel and channel, so the seed passes validation (no check is at its limit).
inline float seedValue(int t, int x, int y, int c) {
  return 0.3f + 0.1f * std::sin(0.7f * float(x + 2 * t) + 1.3f * float(y) + 0.5f * float(c));
}

inline Image seedImage(int w, int h, int channels, int t, float scale = 1.0f) {
  Image img(w, h, channels);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c) img.at(x, y, c) = scale * seedValue(t, x, y, c);
  return img;
}

// Writes the seed capture to `dir` (which must not exist): a static camera looking at a plane 3
// units away, so zero motion, unit normals, constant depth and positions are all consistent.
inline void writeSeedCapture(const std::filesystem::path& dir) {
  const int w = kSeedWidth, h = kSeedHeight;
  const CameraState camera = CameraState::lookAt({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 45.0f, w, h);
  CaptureWriter writer(dir);
  nlohmann::json cameras = nlohmann::json::array();
  std::vector<int> ofFrame;
  std::vector<double> milliseconds;
  for (int t = 0; t < kSeedFrames; ++t) {
    cameras.push_back(captureCameraJson(camera));
    LayerSet frame;
    for (const LayerSpec& spec : channels::frameLayers()) {
      if (spec.topLevel) continue;
      Image img = seedImage(w, h, spec.channels(), t);
      if (spec.name == "normal" || spec.name == "motion" || spec.name == "meshId" || spec.name == "emission" ||
          spec.name == "position" || spec.name == "depth")
        img.fill(0.0f);
      if (spec.name == "normal")
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) img.at(x, y, 2) = 1.0f;
      if (spec.name == "depth") img.fill(3.0f);
      if (spec.name == "position")
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) {
            const glm::vec3 ray = camera.rayDirection(float(x) + 0.5f, float(y) + 0.5f);
            const glm::vec3 p = camera.eye + ray * (3.0f / glm::dot(ray, camera.forward));
            for (int c = 0; c < 3; ++c) img.at(x, y, c) = p[c];
          }
      frame.set(spec.name, std::move(img));
    }
    // The colour is its parts: albedo * diffuse + specAlbedo * specular + emission (zero).
    if (frame.has("diffuse") && frame.has("specular") && frame.has("albedo") && frame.has("specAlbedo")) {
      Image color(w, h, 3);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int c = 0; c < 3; ++c)
            color.at(x, y, c) = frame.get("albedo").at(x, y, c) * frame.get("diffuse").at(x, y, c) +
                                frame.get("specAlbedo").at(x, y, c) * frame.get("specular").at(x, y, c);
      frame.set("color", std::move(color));
    }
    writer.frame(t, frame);
    // The reference: the frame's mean colour everywhere, smoother than the input and apart from it
    // (a reference equal to its input is refused).
    Image mean(w, h, 3);
    for (int c = 0; c < 3; ++c) {
      double sum = 0;
      for (float v : frame.get("color").planeSpan(c)) sum += v;
      for (float& v : mean.planeSpan(c)) v = float(sum / double(w * h));
    }
    LayerSet reference;
    reference.set("color", mean);
    reference.set("colorVar", seedImage(w, h, 3, t, 1e-4f));
    reference.set("colorHalf", mean);
    writer.reference(t, reference);
    if (t > 0) {
      LayerSet gradients;
      for (const LayerSpec& spec : channels::gradientLayers()) {
        const int gw = (w + kGradientStratum - 1) / kGradientStratum, gh = (h + kGradientStratum - 1) / kGradientStratum;
        gradients.set(spec.name, seedImage(gw, gh, spec.channels(), t, 0.1f));
      }
      writer.gradients(t, gradients);
    }
    writer.output("ext", t, frame.get("color"));
    ofFrame.push_back(t);
    milliseconds.push_back(1.0 + 0.1 * t);
  }
  writer.commit({{"format", kCaptureFormatName},
                 {"version", kCaptureFormatVersion},
                 {"name", "fuzz"},
                 {"width", w},
                 {"height", h},
                 {"frames", kSeedFrames},
                 {"frameRate", 60},
                 {"cameras", cameras},
                 {"reference", {{"ofFrame", ofFrame}}},
                 {"outputs", {{"ext", {{"milliseconds", milliseconds}, {"device", "fuzz"}}}}}});
}

// Everything a run does with a capture: open it, read every frame, reference, gradient file and
// stored output, and validate it. True when it opened; false when it was rejected with an Error
// (whose message goes to `rejection` when given).
inline bool openCapture(const std::filesystem::path& dir, std::string* rejection = nullptr) {
  try {
    const Sequence sequence = Sequence::open(dir);
    const SequenceInfo& info = sequence.info();
    for (int t = 0; t < info.frames; ++t) {
      (void)sequence.frame(t);
      if (t > 0 && info.hasGradients) (void)sequence.gradients(t);
    }
    if (info.hasReference)
      for (int r = 0; r < int(info.referenceSpp.size()); ++r) (void)sequence.referenceByIndex(r);
    (void)validateCapture(sequence, readSequenceForEvaluation(sequence));
    if (sequence.isCapture())
      for (const auto& [name, output] : sequence.capture().outputs)
        for (int t = 0; t < info.frames; ++t) (void)readCaptureOutput(sequence.capture(), name, t);
    return true;
  } catch (const Error& e) {
    if (rejection) *rejection = e.what();
    return false;  // rejected with a message: the contract holds
  }
}

// The seed capture in `work`/capture (copied there once) with `kind`'s file replaced by `bytes`,
// opened, and the file put back: no copy per input, so the fuzzer spends its time in the reader.
inline bool openMutatedCapture(const std::filesystem::path& seed, const std::filesystem::path& work,
                               CaptureFile kind, const std::string& bytes, std::string* rejection = nullptr) {
  const std::filesystem::path dir = work / "capture";
  if (!std::filesystem::exists(dir / "capture.json")) {
    std::filesystem::remove_all(dir);
    std::filesystem::copy(seed, dir, std::filesystem::copy_options::recursive);
  }
  const std::filesystem::path file = captureFileOf(kind, dir);
  writeBytes(file, bytes);
  struct Restore {  // even when the reader throws something the contract forbids
    std::filesystem::path from, to, dir;
    ~Restore() {  // never throws: a copy that fails drops the folder, and the next input copies it anew
      std::error_code ec;
      std::filesystem::copy_file(from, to, std::filesystem::copy_options::overwrite_existing, ec);
      if (!ec) return;
      std::fprintf(stderr, "capture fuzz: could not restore %s (%s); the folder is copied anew\n", to.c_str(),
                   ec.message().c_str());
      std::filesystem::remove_all(dir, ec);
    }
  } restore{captureFileOf(kind, seed), file, dir};
  return openCapture(dir, rejection);
}

}  // namespace arena::fuzz
