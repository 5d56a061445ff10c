#include "core/capture.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <set>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/json_reader.hpp"
#include "core/non_finite.hpp"
#include "core/text.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

std::string blenderRenderText(const fs::path& dir) {
  if (!fs::exists(dir / "cameras.json") || !fs::is_directory(dir / "noisy")) return "";
  return dir.string() +
         ": not a capture (no capture.json) but a Blender render (cameras.json, noisy/); import it "
         "first: arena import blender " +
         dir.string() + " --out CAPTURE";
}

std::string exrFilesHeld(const fs::path& dir) {
  std::vector<std::string> exrs;
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec))
    if (e.path().extension() == ".exr") exrs.push_back(e.path().filename().string());
  std::sort(exrs.begin(), exrs.end());
  if (exrs.empty()) return "; the folder holds no .exr file";
  std::string held;
  for (size_t i = 0; i < exrs.size() && i < 3; ++i) held += (i ? ", " : "") + exrs[i];
  if (exrs.size() > 3) held += ", ... (" + std::to_string(exrs.size()) + " in all)";
  return "; the folder holds " + held;
}

namespace {

// The frame layers a capture may carry (every frame layer except the viewer-facing R,G,B copy).
std::vector<LayerSpec> captureFrameSpecs() {
  std::vector<LayerSpec> out;
  for (const LayerSpec& s : channels::frameLayers())
    if (!s.topLevel) out.push_back(s);
  return out;
}

const LayerSpec& frameSpec(const std::string& name) {
  for (const LayerSpec& s : channels::frameLayers())
    if (s.name == name && !s.topLevel) return s;
  throw Error("internal: no frame layer '" + name + "'");
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

// The layers of `specs` a file holds completely; a layer with some of its channels is an error
// naming the missing ones (a half-written layer is an integration bug, never silently dropped).
std::vector<LayerSpec> layersPresent(const fs::path& file, const ExrHeader& header, const std::vector<LayerSpec>& specs) {
  std::vector<LayerSpec> present;
  for (const LayerSpec& spec : specs) {
    std::vector<std::string> missing;
    for (int c = 0; c < spec.channels(); ++c)
      if (!contains(header.channels, spec.channelName(c))) missing.push_back(spec.channelName(c));
    if (missing.empty()) {
      present.push_back(spec);
    } else if (int(missing.size()) != spec.channels()) {
      std::string list;
      for (const std::string& m : missing) list += (list.empty() ? "'" : ", '") + m + "'";
      throw Error(file.string() + ": layer '" + spec.name + "' lacks channel(s) " + list +
                  " (a layer is given with all its channels or not at all; docs/captures.md)");
    }
  }
  return present;
}

const std::vector<LayerSpec>& referenceSpecs() {
  static const std::vector<LayerSpec> specs = {{"color", {"R", "G", "B"}, false},
                                               {"colorVar", {"R", "G", "B"}, false},
                                               {"colorHalf", {"R", "G", "B"}, false}};
  return specs;
}

}  // namespace

bool isPlainName(const std::string& name) {
  // A control character (a newline split the run's unfinished mark over two lines; a NUL cut the
  // folder's name), a space of any kind, or a byte that is not UTF-8 would name folders and
  // results no one can read or type; a comma, one no list of names (--scenes, --denoisers) can
  // hold.
  if (name.empty() || name == "." || name == ".." || validUtf8(name) != name ||
      name.find_first_of("/\\,") != std::string::npos)
    return false;
  for (size_t i = 0; i < name.size();) {
    const auto byte = [&](size_t k) { return uint32_t((unsigned char)name[i + k]); };
    const uint32_t lead = byte(0);
    const size_t length = lead < 0x80 ? 1 : lead < 0xe0 ? 2 : lead < 0xf0 ? 3 : 4;
    uint32_t c = length == 1 ? lead : lead & (0x7fu >> length);
    for (size_t k = 1; k < length; ++k) c = (c << 6) | (byte(k) & 0x3f);
    i += length;
    const bool control = c < 0x20 || (c >= 0x7f && c <= 0x9f);
    const bool space = c == 0x20 || c == 0xa0 || c == 0x1680 || (c >= 0x2000 && c <= 0x200b) ||
                       c == 0x2028 || c == 0x2029 || c == 0x202f || c == 0x205f || c == 0x3000 ||
                       c == 0xfeff;
    if (control || space) return false;
  }
  return true;
}

// The same names as the cache's (core/sequence.cpp): a capture folder reads like a sequence folder.
fs::path captureFramePath(const fs::path& dir, int t) { return Sequence::framePath(dir, t); }
fs::path captureReferencePath(const fs::path& dir, int r) { return Sequence::referencePath(dir, r); }
fs::path captureGradientPath(const fs::path& dir, int t) { return Sequence::gradientPath(dir, t); }
fs::path captureOutputPath(const CaptureOutput& output, int t) { return output.dir / numberedFileName("frame", t, 4); }

bool isCapture(const fs::path& dir) { return fs::exists(dir / "capture.json"); }

const CaptureOutput& CaptureDescription::output(const std::string& name) const {
  auto it = outputs.find(name);
  if (it != outputs.end()) return it->second;
  std::string list;
  for (const auto& [n, o] : outputs) list += (list.empty() ? "" : ", ") + n;
  throw Error((dir / "capture.json").string() + ": no denoiser output '" + name + "' (outputs: " +
              (list.empty() ? "none" : list) + ")");
}

namespace {

// What a matrix whose transpose fits says: the usual slip of a row-major engine.
constexpr const char* kTransposed =
    "; it looks transposed: capture.json holds matrices column-major (element (row r, column c) at "
    "index c * 4 + r), as OpenGL and glm store them";

// Plain R, G, B are a viewer's copy (what `export` writes beside color.*), never read: the usual
// slip of a writer that stored the beauty pass under them. The hint for a file that lacks
// color.R/G/B but holds them ("" otherwise).
std::string plainRgbHint(const ExrHeader& h) {
  const auto holds = [&](const char* k) {
    return std::find(h.channels.begin(), h.channels.end(), k) != h.channels.end();
  };
  return holds("R") && holds("G") && holds("B") && !holds("color.R")
             ? "; the file holds plain R, G, B, which are a viewer's copy and never read: name "
               "them color.R, color.G, color.B"
             : "";
}

}  // namespace

CameraState cameraFromMatrices(const std::vector<double>& view, const std::vector<double>& projection,
                               const std::vector<double>* position, int width, int height, const std::string& where) {
  // Column-major: element (row r, column c) is m[c * 4 + r].
  auto at = [](const std::vector<double>& m, int row, int col) { return m[size_t(col * 4 + row)]; };
  for (double v : view)
    if (!std::isfinite(v)) throw Error(where + ".view: a non-finite element");
  for (double v : projection)
    if (!std::isfinite(v)) throw Error(where + ".projection: a non-finite element");
  CameraState c;
  c.right = glm::vec3(float(at(view, 0, 0)), float(at(view, 0, 1)), float(at(view, 0, 2)));
  c.up = glm::vec3(float(at(view, 1, 0)), float(at(view, 1, 1)), float(at(view, 1, 2)));
  c.forward = -glm::vec3(float(at(view, 2, 0)), float(at(view, 2, 1)), float(at(view, 2, 2)));
  // The rotation part must be orthonormal (a view matrix with scale or shear is not a camera).
  const glm::dvec3 r(at(view, 0, 0), at(view, 0, 1), at(view, 0, 2)), u(at(view, 1, 0), at(view, 1, 1), at(view, 1, 2)),
      b(at(view, 2, 0), at(view, 2, 1), at(view, 2, 2));
  const double err = std::max({std::abs(glm::length(r) - 1), std::abs(glm::length(u) - 1), std::abs(glm::length(b) - 1),
                               std::abs(glm::dot(r, u)), std::abs(glm::dot(r, b)), std::abs(glm::dot(u, b))});
  if (err > 1e-3)
    throw Error(where + ".view: the rotation is not orthonormal (deviation " + std::to_string(err) +
                "); expected a world-to-camera matrix without scale (docs/captures.md)");
  if (std::abs(at(view, 3, 0)) + std::abs(at(view, 3, 1)) + std::abs(at(view, 3, 2)) > 1e-6 ||
      std::abs(at(view, 3, 3) - 1) > 1e-6)
    throw Error(
        where + ".view: the last row must be (0, 0, 0, 1)" +
        (std::abs(at(view, 0, 3)) + std::abs(at(view, 1, 3)) + std::abs(at(view, 2, 3)) < 1e-6 &&
                 std::abs(at(view, 3, 3) - 1) < 1e-6
             ? std::string(kTransposed)
             : std::string()));
  const glm::dvec3 t(at(view, 0, 3), at(view, 1, 3), at(view, 2, 3));
  const glm::dvec3 eye = -(r * t.x + u * t.y + b * t.z);
  if (position) {
    const glm::dvec3 p((*position)[0], (*position)[1], (*position)[2]);
    if (glm::length(p - eye) > 1e-3 * std::max(1.0, glm::length(eye)))
      throw Error(where + ".position: (" + std::to_string(p.x) + ", " + std::to_string(p.y) + ", " +
                  std::to_string(p.z) + ") disagrees with the view matrix's eye (" +
                  std::to_string(eye.x) + ", " + std::to_string(eye.y) + ", " +
                  std::to_string(eye.z) + ")" +
                  // A camera-to-world matrix holds the eye as its translation column.
                  (glm::length(p - t) <= 1e-3 * std::max(1.0, glm::length(p))
                       ? "; it equals the view's translation column, as in a camera-to-world "
                         "matrix: capture.json's view is world-to-camera (invert the matrices)"
                       : ""));
    c.eye = glm::vec3(float(p.x), float(p.y), float(p.z));
  } else {
    c.eye = glm::vec3(eye);
  }
  // A symmetric perspective projection: P(1,1) = 1 / tan(fovY / 2), P(0,0) = P(1,1) / aspect.
  const double p00 = at(projection, 0, 0), p11 = at(projection, 1, 1);
  if (!(p11 > 0) || !(p00 > 0))
    throw Error(where + ".projection: expected a perspective projection with positive P[0][0] and P[1][1], got " +
                std::to_string(p00) + " and " + std::to_string(p11));
  if (std::abs(at(projection, 0, 2)) > 1e-6 || std::abs(at(projection, 1, 2)) > 1e-6)
    throw Error(where + ".projection: off-centre (P[0][2] = " + std::to_string(at(projection, 0, 2)) +
                ", P[1][2] = " + std::to_string(at(projection, 1, 2)) +
                "); give the unjittered projection and the sub-pixel offset in \"jitter\"");
  if (std::abs(at(projection, 3, 2) + 1) > 1e-6)
    throw Error(
        where + ".projection: P[3][2] = " + std::to_string(at(projection, 3, 2)) +
        ", expected -1 (a camera looking down -Z, OpenGL clip space)" +
        (std::abs(at(projection, 2, 3) + 1) < 1e-6 ? std::string(kTransposed) : std::string()));
  const double aspect = p11 / p00, pixels = double(width) / double(height);
  if (std::abs(aspect / pixels - 1) > 1e-3)
    throw Error(where + ".projection: aspect " + std::to_string(aspect) + " differs from width / height " +
                std::to_string(pixels) + " (square pixels expected)");
  c.tanHalfFovY = float(1.0 / p11);
  c.width = width;
  c.height = height;
  c.aspect = float(width) / float(height);
  return c;
}

json captureCameraJson(const CameraState& c) {
  // Rows of the view matrix: right, up, -forward; translation -axis . eye (in double).
  const glm::dvec3 eye(c.eye), axes[3] = {glm::dvec3(c.right), glm::dvec3(c.up), -glm::dvec3(c.forward)};
  double view[16] = {};
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) view[col * 4 + row] = axes[row][col];
    view[3 * 4 + row] = -glm::dot(axes[row], eye);
  }
  view[15] = 1;
  const double n = 0.01, f = 1000.0, tanHalf = double(c.tanHalfFovY), aspect = double(c.aspect);
  double proj[16] = {};
  proj[0] = 1.0 / (aspect * tanHalf);
  proj[5] = 1.0 / tanHalf;
  proj[10] = -(f + n) / (f - n);
  proj[11] = -1;
  proj[14] = -2 * f * n / (f - n);
  return {{"view", std::vector<double>(view, view + 16)},
          {"projection", std::vector<double>(proj, proj + 16)},
          {"position", {double(c.eye.x), double(c.eye.y), double(c.eye.z)}}};
}

CaptureDescription readCaptureDescription(const fs::path& dir) {
  const fs::path file = dir / "capture.json";
  if (!fs::exists(file)) {
    if (dir.filename() == "capture.json" && fs::is_regular_file(dir))
      throw Error(dir.string() + ": give the capture's folder, " + dir.parent_path().string() +
                  ", not its capture.json");
    if (const std::string render = blenderRenderText(dir); !render.empty()) throw Error(render);
    throw Error(dir.string() + ": not a capture (no capture.json; docs/captures.md)");
  }
  const json doc = parseJsonFile(file.string());
  JsonReader root(doc, file.string());
  CaptureDescription c;
  c.dir = dir;
  const std::string format = root.string("format");
  if (format != kCaptureFormatName)
    throw Error(file.string() + ": format '" + format + "', expected '" + kCaptureFormatName + "'");
  const int version = root.integer("version");
  if (version != kCaptureFormatVersion)
    throw Error(file.string() + ": capture format version " + std::to_string(version) + ", this arena reads version " +
                std::to_string(kCaptureFormatVersion));
  SequenceInfo& info = c.info;
  info.scene = root.string("name");
  if (!isPlainName(info.scene))
    throw Error(file.string() + ": name " + quotedText(info.scene) +
                ": expected a non-empty name in UTF-8 without spaces, slashes, commas or control "
                "characters, not . or .. (it names the capture's folders in a run)");
  info.purpose = root.string("purpose", "capture");
  info.width = root.integerIn("width", 1, 16384);
  info.height = root.integerIn("height", 1, 16384);
  info.frames = root.integerIn("frames", 1, 100000);
  info.source = "capture";
  const int n = info.frames;
  if (root.has("deltaTime")) {
    std::vector<double> dt = root.numbers("deltaTime", size_t(n));
    for (size_t t = 0; t < dt.size(); ++t)
      if (!(dt[t] > 0)) throw Error(file.string() + ": deltaTime[" + std::to_string(t) + "] must be positive");
    c.deltaTime = dt;
    if (root.has("frameRate")) root.fail("frameRate", "either frameRate or deltaTime, not both");
  } else {
    double rate = 0;
    try {
      rate = root.number("frameRate");
    } catch (const Error& e) {
      // Neither given: the message names both ways of saying it.
      if (root.has("frameRate")) throw;
      throw Error(std::string(e.what()) +
                  " (frames per second; or give deltaTime, a list of per-frame seconds)");
    }
    if (!(rate > 0) || !std::isfinite(rate)) root.fail("frameRate", "a positive number of frames per second");
    c.deltaTime.assign(size_t(n), 1.0 / rate);
  }
  c.exposure = root.number("exposure", 1.0);
  if (!(c.exposure > 0) || !std::isfinite(c.exposure))
    root.fail("exposure", "a positive number (recorded; the colour is scored as stored)");
  c.reverseZ = root.boolean("reverseZ", false);
  // Recorded, not used (the arena reads linear view depth), but recorded only when they can be
  // true.
  c.nearPlane = root.number("near", 0.01);
  if (!(c.nearPlane > 0) || !std::isfinite(c.nearPlane))
    root.fail("near", "a positive distance to the near plane");
  c.farPlane = root.number("far", 1000.0);
  if (!(c.farPlane > c.nearPlane) || !std::isfinite(c.farPlane))
    root.fail("far", "a finite distance beyond near (" + std::to_string(c.nearPlane) + ")");
  c.units = root.string("units", "m");
  if (c.units.empty()) root.fail("units", "the world units of positions and depth, e.g. \"m\"");
  if (auto source = root.optionalChild("source")) c.source = source->node();

  std::vector<JsonReader> cameras = root.requiredArray("cameras");
  if (int(cameras.size()) != n)
    throw Error(file.string() + ": cameras has " + std::to_string(cameras.size()) + " entries, expected one per frame (" +
                std::to_string(n) + ")");
  for (int t = 0; t < n; ++t) {
    JsonReader& cam = cameras[size_t(t)];
    const std::vector<double> view = cam.numbers("view", 16), proj = cam.numbers("projection", 16);
    std::optional<std::vector<double>> position;
    if (cam.has("position")) position = cam.numbers("position", 3);
    std::array<double, 2> jitter = {0, 0};
    if (cam.has("jitter")) {
      const std::vector<double> j = cam.numbers("jitter", 2);
      if (std::abs(j[0]) > 1 || std::abs(j[1]) > 1) cam.fail("jitter", "a sub-pixel offset in pixels, |x|, |y| <= 1");
      jitter = {j[0], j[1]};
    }
    cam.rejectUnread();
    info.cameras.push_back(cameraFromMatrices(view, proj, position ? &*position : nullptr, info.width, info.height,
                                              file.string() + ": cameras[" + std::to_string(t) + "]"));
    c.jitter.push_back(jitter);
  }
  for (JsonReader& e : root.optionalArray("events")) {
    // At frame 0 an event has no earlier frame to be measured against: the metrics would skip it.
    if (n < 2)
      e.fail("frame",
             "a capture of one frame has no frame for an event (events lie in frames 1..N-1)");
    const int frame = e.integerIn("frame", 1, n - 1);
    const std::string kind = e.string("kind");
    const std::optional<EventKind> k = eventKindFromName(kind);
    if (!k) {
      const std::string meant = closestName(kind, eventKindNameList());
      e.fail("kind", "expected one of " + eventKindNames() + ", got " + json(kind).dump() +
                         (meant.empty() ? "" : " (" + meant + "?)"));
    }
    const SequenceEvent event{frame, *k, e.string("what", ""), e.integer("meshId", -1)};
    if (e.has("meshId") && *k != EventKind::ObjectMoves)
      e.fail(
          "meshId",
          "only an object_moves event names a mesh (its moving object's id in the meshId layer)");
    for (const SequenceEvent& other : info.events)
      if (other.frame == event.frame && other.kind == event.kind && other.what == event.what &&
          other.meshId == event.meshId)
        e.fail("kind", "this event (" + kind + " at frame " + std::to_string(frame) +
                           (event.what.empty() ? "" : " of '" + event.what + "'") +
                           ") is given twice");
    info.events.push_back(event);
    e.rejectUnread();
  }
  // References: reference_NNN.exr, shared by the frames that name them.
  if (auto ref = root.optionalChild("reference")) {
    info.referenceOfFrame.clear();
    const std::vector<double> ofFrame = ref->numbers("ofFrame", size_t(n));  // one per frame
    int count = 0;
    for (size_t t = 0; t < ofFrame.size(); ++t) {
      if (ofFrame[t] != std::floor(ofFrame[t]) || ofFrame[t] < 0 || ofFrame[t] > 100000)
        throw Error(file.string() + ": reference.ofFrame[" + std::to_string(t) +
                    "]: expected a whole reference index from 0 to 100000, got " +
                    json(ofFrame[t]).dump());
      info.referenceOfFrame.push_back(int(ofFrame[t]));
      count = std::max(count, info.referenceOfFrame.back() + 1);
    }
    if (ref->has("samples")) {
      // One per reference: as many as ofFrame names (its largest index + 1).
      if (const json& s = ref->value("samples"); s.is_array() && s.size() != size_t(count))
        ref->fail("samples", "expected one number per reference, " + std::to_string(count) +
                                 " (reference.ofFrame names references 0 to " +
                                 std::to_string(count - 1) + "), got " + std::to_string(s.size()));
      const std::vector<double> spp = ref->numbers("samples", size_t(count));
      for (size_t r = 0; r < spp.size(); ++r) {
        if (!(spp[r] >= 1 && spp[r] <= 1e9 && spp[r] == std::floor(spp[r])))
          throw Error(file.string() + ": reference.samples[" + std::to_string(r) +
                      "]: expected a whole number of samples per pixel, 1 to 1e9, got " +
                      json(spp[r]).dump());
        info.referenceSpp.push_back(int(spp[r]));
      }
    } else {
      info.referenceSpp.assign(size_t(count), 0);
    }
    ref->rejectUnread();
    info.referenceEstimatedRelMse.assign(size_t(count), 0.0);
    info.referenceCapped.assign(size_t(count), false);
    bool allVar = true, allHalf = true;
    for (int r = 0; r < count; ++r) {
      const fs::path rf = captureReferencePath(dir, r);
      const ExrHeader h = readExrHeader(rf);
      if (h.width != info.width || h.height != info.height)
        throw Error(rf.string() + ": " + std::to_string(h.width) + "x" + std::to_string(h.height) + ", expected " +
                    std::to_string(info.width) + "x" + std::to_string(info.height));
      const std::vector<LayerSpec> present = layersPresent(rf, h, referenceSpecs());
      auto has = [&](const char* name) {
        return std::any_of(present.begin(), present.end(), [&](const LayerSpec& s) { return s.name == name; });
      };
      if (!has("color"))
        throw Error(rf.string() + ": missing channel 'color.R' (the reference's colour)" +
                    plainRgbHint(h));
      allVar = allVar && has("colorVar");
      allHalf = allHalf && has("colorHalf");
    }
    c.referenceHasVariance = allVar;
    c.referenceHasHalf = allHalf;
  } else {
    info.hasReference = false;
    info.referenceOfFrame.assign(size_t(n), 0);  // unused: the capture has no reference
  }
  // Denoisers that ran elsewhere.
  if (auto outputs = root.optionalChild("outputs")) {
    for (const std::string& name : outputs->memberNames()) {
      JsonReader o = outputs->child(name);
      if (!isPlainName(name))
        throw Error(file.string() + ": outputs: key " + quotedText(name) +
                    ": expected a folder name in outputs/ in UTF-8 without spaces, slashes, commas "
                    "or control characters, not . or ..");
      CaptureOutput out;
      out.name = name;
      out.dir = dir / "outputs" / name;
      if (o.has("milliseconds")) {
        out.milliseconds = o.numbers("milliseconds", size_t(n));
        // A timer that read 0 measured nothing: a time of 0 would be the fastest of all. Such
        // times fail this output's pair and its validation, not the capture.
        for (size_t t = 0; t < out.milliseconds.size() && out.timingProblem.empty(); ++t)
          if (!(out.milliseconds[t] > 0) || !(out.milliseconds[t] <= kMaxFrameMilliseconds))
            out.timingProblem = file.string() + ": outputs." + name + ".milliseconds[" +
                                std::to_string(t) +
                                "]: expected a positive time of at most 1e9 ms, got " +
                                shortestText(out.milliseconds[t]) +
                                " (leave \"milliseconds\" out where the frames were not timed)";
        out.device = o.string("device");
        if (out.timingProblem.empty() && out.device.find_first_not_of(" \t") == std::string::npos)
          out.timingProblem = file.string() + ": outputs." + name +
                              ".device: expected what measured the times (\"RTX 4080, GPU "
                              "timestamps\"), got an empty name";
      } else if (o.has("device")) {
        out.device = o.string("device");
        out.timingProblem = file.string() + ": outputs." + name +
                            ".device: names what measured \"milliseconds\", which the output "
                            "does not give (give both, or neither)";
      }
      o.rejectUnread();
      // A declared folder that is not there fails its `file:` pair (readCaptureOutput), not the
      // capture: the frames and the other contenders are still scored.
      c.outputs[name] = out;
    }
  }
  root.rejectUnread();

  // The layers: every frame holds the same set (checked on each read), taken from frame 0.
  const fs::path first = captureFramePath(dir, 0);
  if (!fs::exists(first))
    throw Error(first.string() + ": file does not exist; frames are frame_0000.exr to " +
                captureFramePath({}, info.frames - 1).string() + " (numbered from 0, four digits)" +
                exrFilesHeld(dir));
  const ExrHeader h = readExrHeader(first);
  if (h.width != info.width || h.height != info.height)
    throw Error(first.string() + ": " + std::to_string(h.width) + "x" + std::to_string(h.height) + ", expected " +
                std::to_string(info.width) + "x" + std::to_string(info.height) + " (capture.json)");
  for (const LayerSpec& s : layersPresent(first, h, captureFrameSpecs())) c.layers.push_back(s.name);
  for (const std::string& channel : h.channels) {
    bool named = false;
    for (const LayerSpec& s : channels::frameLayers())
      for (int k = 0; k < s.channels() && !named; ++k) named = s.channelName(k) == channel;
    if (!named) c.unknownChannels.push_back(channel);
  }
  for (const char* required : {"normal", "depth", "motion"})
    if (!contains(c.layers, required)) {
      // The channels the file holds that no layer names, each with the channel of this layer it
      // most likely is (motion.x for motion.X, a plain Z for depth.Z): a near miss is the usual
      // cause.
      const LayerSpec& spec = frameSpec(required);
      std::vector<std::string> wanted;
      for (int k = 0; k < spec.channels(); ++k) wanted.push_back(spec.channelName(k));
      const auto lowered = [](std::string text) {
        for (char& ch : text) ch = char(std::tolower(static_cast<unsigned char>(ch)));
        return text;
      };
      std::string near;
      for (size_t i = 0; i < c.unknownChannels.size() && i < 8; ++i) {
        std::string likely = closestName(c.unknownChannels[i], wanted);
        for (const std::string& w : wanted)  // a bare channel: Z for depth.Z
          if (likely.empty() && lowered(w.substr(w.find('.') + 1)) == lowered(c.unknownChannels[i]))
            likely = w;
        near += (near.empty() ? "" : ", ") + c.unknownChannels[i] +
                (likely.empty() ? "" : " (" + likely + "?)");
      }
      if (c.unknownChannels.size() > 8) near += ", ...";
      std::string all;
      for (const std::string& w : wanted) all += (all.empty() ? "" : ", ") + w;
      throw Error(
          first.string() + ": missing layer '" + std::string(required) + "' (" + all +
          "): normals, view depth and motion are required (docs/captures.md)" +
          (near.empty() ? std::string() : "; the file's channels that no layer names: " + near));
    }
  const bool parts = contains(c.layers, "diffuse") && contains(c.layers, "specular") && contains(c.layers, "albedo") &&
                     contains(c.layers, "specAlbedo");
  if (!contains(c.layers, "color") && !parts)
    throw Error(first.string() +
                ": no colour: give 'color' (color.R/G/B) or the demodulated 'diffuse' and "
                "'specular' with 'albedo' and 'specAlbedo' (docs/captures.md)" +
                plainRgbHint(h));
  // Gradient samples: all frames 1.. or none.
  info.hasGradients = info.frames > 1 && fs::exists(captureGradientPath(dir, 1));
  for (int t = 1; t < info.frames && info.hasGradients; ++t)
    if (!fs::exists(captureGradientPath(dir, t)))
      throw Error(captureGradientPath(dir, t).string() + ": missing (gradients_0001.exr exists, so every frame "
                  "from 1 needs its gradient samples)");
  if (!contains(c.layers, "color")) c.derived.push_back("color");
  if (parts && !contains(c.layers, "emission")) c.derived.push_back("emission");
  if (!contains(c.layers, "position")) c.derived.push_back("position");
  if (!contains(c.layers, "meshId")) c.derived.push_back("meshId");
  // What a denoiser may read: the layers given, plus those derived exactly (colour, position, a
  // zero emission when the parts are given); never the filled-in meshId.
  for (const std::string& d : c.derived)
    if (d != "meshId") c.layers.push_back(d);
  info.layers = c.layers;
  // The identity of the capture: its description and the size of every file it names.
  std::ifstream in(file, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  uint64_t hash = 1469598103934665603ull;
  auto mix = [&](const std::string& s) {
    for (unsigned char ch : s) hash = (hash ^ ch) * 1099511628211ull;
  };
  mix(text);
  std::optional<long> frameOffset;  // arena.capture.frame - t, from the first frame that has one
  for (int t = 0; t < n; ++t) {
    const fs::path f = captureFramePath(dir, t);
    if (!fs::exists(f)) throw Error(f.string() + ": frame " + std::to_string(t) + " of " + std::to_string(n) + " is missing");
    // Frames that say which one they are (arena export writes the attribute) keep their order: a
    // file copied over another or frames swapped are refused, not scored in the wrong place. A
    // constant offset is a trimmed sequence renumbered, and stands.
    const ExrAttributes attributes = readExrAttributes(f);
    if (const auto it = attributes.find("arena.capture.frame"); it != attributes.end()) {
      long index = 0;
      try {
        index = std::stol(it->second);
      } catch (const std::exception&) {
        throw Error(f.string() + ": arena.capture.frame '" + it->second + "' is not a frame index");
      }
      if (!frameOffset) frameOffset = index - t;
      if (index - t != *frameOffset)
        throw Error(f.string() + ": holds frame " + it->second +
                    " (its arena.capture.frame attribute), where the "
                    "frames before it say frame " +
                    std::to_string(t + *frameOffset) + ": copied over another, or out of order");
    }
    mix(std::to_string(fs::file_size(f)));
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(hash));
  info.hash = std::string(buf).substr(0, 12);
  info.settings = {{"source", "capture"}, {"captureFormat", kCaptureFormatVersion}, {"capture", c.source}};
  return c;
}

namespace {

// FNV-1a over the file's 32-bit words (wordChecksum's rule, chunk by chunk), its tail bytes and
// its length.
void addFileBytes(Hasher& hasher, const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(file.string() + ": cannot be read");
  std::vector<char> chunk(size_t(1) << 20);
  uint64_t h = 1469598103934665603ull, length = 0;
  while (in) {
    in.read(chunk.data(), std::streamsize(chunk.size()));
    const size_t got = size_t(in.gcount());
    if (got == 0) break;
    length += got;
    const size_t words = got / 4;
    h = wordChecksum(chunk.data(), words, h);
    for (size_t i = 4 * words; i < got; ++i)
      h = (h ^ static_cast<unsigned char>(chunk[i])) * 1099511628211ull;
  }
  if (in.bad()) throw Error(file.string() + ": read failed");
  hasher.add(checksumHex(h)).add(std::to_string(length));
}

}  // namespace

CaptureContent captureContent(const CaptureDescription& c) {
  json described = parseJsonFile((c.dir / "capture.json").string());
  const json reference = described.contains("reference") ? described["reference"] : json();
  for (const char* k : {"reference", "outputs", "source", "purpose"}) described.erase(k);
  Hasher inputs;
  inputs.add(jsonText(described));
  for (int t = 0; t < c.info.frames; ++t) {
    addFileBytes(inputs, captureFramePath(c.dir, t));
    if (t > 0 && c.info.hasGradients) addFileBytes(inputs, captureGradientPath(c.dir, t));
  }
  CaptureContent content;
  content.inputs = inputs.hex().substr(0, 12);
  if (c.info.hasReference) {
    Hasher references;
    references.add(jsonText(reference));
    for (int r = 0; r < int(c.info.referenceSpp.size()); ++r)
      addFileBytes(references, captureReferencePath(c.dir, r));
    content.references = references.hex().substr(0, 12);
  }
  return content;
}

LayerSet readCaptureFrame(const CaptureDescription& c, int t) {
  const SequenceInfo& info = c.info;
  if (t < 0 || t >= info.frames) throw Error(c.dir.string() + ": frame " + std::to_string(t) + " out of range");
  const fs::path file = captureFramePath(c.dir, t);
  std::vector<LayerSpec> specs;
  for (const LayerSpec& s : captureFrameSpecs())
    if (contains(c.layers, s.name) && !contains(c.derived, s.name)) specs.push_back(s);
  // Every frame holds frame 0's layers: readExr names the file and channel when one lacks a layer
  // frame 0 had; a layer only this frame has (whole or partial) would be ignored, so it is refused
  // (from the channel list of the same read).
  ExrContents contents = readExr(file, specs, ExrSize{info.width, info.height});
  for (const LayerSpec& s : layersPresent(file, contents.header, captureFrameSpecs()))
    if (!contains(c.layers, s.name) || contains(c.derived, s.name))
      throw Error(file.string() + ": layer '" + s.name + "' is in this frame but not in " +
                  captureFramePath(c.dir, 0).filename().string() +
                  " (every frame of a capture holds the same layers)");
  LayerSet layers = std::move(contents.layers);
  const int w = info.width, hgt = info.height;
  const size_t pixels = size_t(w) * size_t(hgt);
  if (contains(c.derived, "emission")) layers.set("emission", Image(w, hgt, 3));
  if (contains(c.derived, "color")) {
    Image color(w, hgt, 3);
    const Image &a = layers.get("albedo"), &d = layers.get("diffuse"), &sa = layers.get("specAlbedo"),
                &s = layers.get("specular"), &e = layers.get("emission");
    for (size_t i = 0; i < pixels * 3; ++i) color.raw()[i] = a.raw()[i] * d.raw()[i] + sa.raw()[i] * s.raw()[i] + e.raw()[i];
    layers.set("color", std::move(color));
  }
  if (contains(c.derived, "position")) {
    // The surface at the pixel centre: eye + dir * depth / (dir . forward); 0 where depth is 0 (sky).
    const CameraState& cam = info.cameras[size_t(t)];
    const Image& depth = layers.get("depth");
    Image position(w, hgt, 3);
    for (int y = 0; y < hgt; ++y)
      for (int x = 0; x < w; ++x) {
        const float z = depth.at(x, y);
        if (!(z > 0)) continue;
        const glm::vec3 p = cam.pointAtDepth(float(x) + 0.5f, float(y) + 0.5f, z);
        for (int k = 0; k < 3; ++k) position.at(x, y, k) = p[k];
      }
    layers.set("position", std::move(position));
  }
  if (contains(c.derived, "meshId")) layers.set("meshId", Image(w, hgt, 1));
  return layers;
}

LayerSet readCaptureReference(const CaptureDescription& c, int r) {
  const fs::path file = captureReferencePath(c.dir, r);
  std::vector<LayerSpec> specs = {referenceSpecs()[0]};
  if (c.referenceHasVariance) specs.push_back(referenceSpecs()[1]);
  if (c.referenceHasHalf) specs.push_back(referenceSpecs()[2]);
  LayerSet layers = readExr(file, specs, ExrSize{c.info.width, c.info.height}).layers;
  if (c.referenceHasVariance) {
    // A variance below zero is not one: the noise floor and the corrected relMSE would come out
    // negative, and the correction would flatter every method.
    const Image& var = layers.get("colorVar");
    for (int y = 0; y < var.height(); ++y)
      for (int x = 0; x < var.width(); ++x)
        for (int k = 0; k < 3; ++k)
          if (var.at(x, y, k) < 0)
            throw Error(file.string() + ": channel colorVar." + "RGB"[k] + " at pixel (" +
                        std::to_string(x) + ", " + std::to_string(y) + ") is " +
                        std::to_string(var.at(x, y, k)) +
                        ": expected a variance (>= 0) of the reference's mean");
  } else {
    // With an independent half, (mean - half)^2 is an unbiased one-sample estimate of the mean's
    // variance (mean - half = (other half - half) / 2); with neither, zeros and an unknown floor.
    Image var(c.info.width, c.info.height, 3);
    if (c.referenceHasHalf) {
      const Image &m = layers.get("color"), &h = layers.get("colorHalf");
      for (size_t i = 0; i < var.raw().size(); ++i) var.raw()[i] = (m.raw()[i] - h.raw()[i]) * (m.raw()[i] - h.raw()[i]);
    }
    layers.set("colorVar", std::move(var));
  }
  return layers;
}

Image readOutputFrame(const fs::path& file, const std::string& name, int width, int height) {
  if (std::error_code ec; fs::exists(file, ec))
    if (const std::string hint = plainRgbHint(readExrHeader(file)); !hint.empty())
      throw Error(file.string() + ": missing channel 'color.R' (the output's colour)" + hint);
  LayerSet layers =
      readExr(file, {{"color", {"R", "G", "B"}, false}}, ExrSize{width, height}).layers;
  Image color = std::move(layers.get("color"));
  if (const long bad = nonFiniteValues(color))
    throw Error(file.string() + ": " + std::to_string(bad) +
                " non-finite colour values in the output of '" + name +
                "' (an output is scored as given, never repaired)");
  return color;
}

Image readCaptureOutput(const CaptureDescription& c, const std::string& name, int t) {
  const CaptureOutput& output = c.output(name);
  if (std::error_code ec; !fs::is_directory(output.dir, ec))
    throw Error((c.dir / "capture.json").string() + ": outputs." + name + ": folder " +
                output.dir.string() + " does not exist (capture.json declares it)");
  const fs::path file = captureOutputPath(output, t);
  if (std::error_code ec; !fs::exists(file, ec))  // numbered from 1, or another width: said
    throw Error(file.string() + ": file does not exist; " + name +
                "'s frames are frame_0000.exr to " +
                captureFramePath({}, c.info.frames - 1).string() +
                " (numbered from 0, four digits)" + exrFilesHeld(output.dir));
  return readOutputFrame(file, name, c.info.width, c.info.height);
}

std::vector<std::string> undescribedEntries(const CaptureDescription& c) {
  std::set<std::string> described = {"capture.json", "outputs", ".arena.lock"};
  for (int t = 0; t < c.info.frames; ++t) {
    described.insert(captureFramePath(c.dir, t).filename().string());
    if (t > 0 && c.info.hasGradients)
      described.insert(captureGradientPath(c.dir, t).filename().string());
  }
  for (size_t r = 0; r < c.info.referenceSpp.size(); ++r)
    described.insert(captureReferencePath(c.dir, int(r)).filename().string());
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(c.dir, ec))
    if (!described.count(entry.path().filename().string()))
      out.push_back(entry.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::string> undeclaredOutputs(const CaptureDescription& c) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(c.dir / "outputs", ec))
    if (entry.is_directory(ec) && !c.outputs.count(entry.path().filename().string()))
      out.push_back(entry.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

CaptureWriter::CaptureWriter(fs::path out) : out_(std::move(out)) {
  if (fs::exists(out_)) throw Error(out_.string() + ": already exists; a capture is written to a new folder");
  if (!out_.parent_path().empty()) fs::create_directories(out_.parent_path());
  // The temporary folders of killed writes here (an import stopped with Ctrl-C) go first.
  removeStaleTemporaries(out_.parent_path().empty() ? fs::path(".") : out_.parent_path(), 600,
                         true);
  tmp_ = temporaryPathFor(out_);
  fs::create_directories(tmp_);
}

CaptureWriter::~CaptureWriter() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(tmp_, ec);
}

void CaptureWriter::frame(int t, const LayerSet& layers) {
  std::vector<LayerSpec> specs;
  for (const LayerSpec& s : captureFrameSpecs())
    if (layers.has(s.name)) specs.push_back(s);
  if (layers.has("color")) specs.push_back({"color", {"R", "G", "B"}, false, true});  // for any EXR viewer
  writeExr(captureFramePath(tmp_, t), layers, specs, {{"arena.capture.frame", std::to_string(t)}});
}

void CaptureWriter::reference(int r, const LayerSet& layers) {
  std::vector<LayerSpec> specs;
  for (const LayerSpec& s : referenceSpecs())
    if (layers.has(s.name)) specs.push_back(s);
  writeExr(captureReferencePath(tmp_, r), layers, specs);
}

void CaptureWriter::gradients(int t, const LayerSet& layers) {
  writeExr(captureGradientPath(tmp_, t), layers, channels::gradientLayers());
}

void CaptureWriter::output(const std::string& name, int t, const Image& color) {
  const CaptureOutput o{name, tmp_ / "outputs" / name, {}, ""};
  fs::create_directories(o.dir);
  LayerSet l;
  l.set("color", color);
  writeExr(captureOutputPath(o, t), l, {{"color", {"R", "G", "B"}, false}});
}

void CaptureWriter::commit(const json& description) {
  writeAtomically(tmp_ / "capture.json", [&](const fs::path& p) {
    std::ofstream f(p);
    f << jsonText(description, 1) << "\n";
    if (!f) throw Error(p.string() + ": could not write");
  });
  // Read back as any user of it would: a capture its own reader refuses is never committed (the
  // folder is removed with the writer).
  try {
    readCaptureDescription(tmp_);
  } catch (const Error& e) {
    // Named as the folder it would have become, not the temporary one it was written in.
    std::string what = e.what();
    const std::string tmp = tmp_.string();
    for (size_t at = what.find(tmp); at != std::string::npos; at = what.find(tmp, at + 1))
      what.replace(at, tmp.size(), out_.string());
    throw Error(out_.string() + ": not written, the capture would not be valid: " + what);
  }
  fs::rename(tmp_, out_);
  committed_ = true;
}

void exportCapture(const Sequence& sequence, const fs::path& out, const std::map<std::string, fs::path>& outputs) {
  const SequenceInfo& info = sequence.info();
  if (sequence.isCapture()) throw Error(sequence.dir().string() + ": already a capture");
  CaptureWriter writer(out);
  json cameras = json::array();
  for (const CameraState& cam : info.cameras) cameras.push_back(captureCameraJson(cam));
  json events = json::array();
  for (const SequenceEvent& e : info.events) {
    json ev = {{"frame", e.frame}, {"kind", eventKindName(e.kind)}, {"what", e.what}};
    if (e.meshId >= 0) ev["meshId"] = e.meshId;
    events.push_back(ev);
  }
  for (int t = 0; t < info.frames; ++t) {
    writer.frame(t, sequence.frame(t));
    if (t > 0 && info.hasGradients) writer.gradients(t, sequence.gradients(t));
  }
  int refs = 0;
  for (int r : info.referenceOfFrame) refs = std::max(refs, r + 1);
  for (int r = 0; r < refs; ++r) writer.reference(r, sequence.referenceByIndex(r));
  json doc = {{"format", kCaptureFormatName},
              {"version", kCaptureFormatVersion},
              {"name", info.scene},
              {"purpose", info.purpose},
              {"width", info.width},
              {"height", info.height},
              {"frames", info.frames},
              {"frameRate", 30},
              {"units", "m"},
              {"exposure", 1.0},
              {"reverseZ", false},
              {"near", 0.01},
              {"far", 1000.0},
              {"cameras", cameras},
              {"events", events},
              {"reference", {{"ofFrame", info.referenceOfFrame}, {"samples", info.referenceSpp}}},
              {"source", {{"producer", "arena export"}, {"sequence", info.hash}, {"settings", info.settings}}}};
  for (const auto& [name, from] : outputs) {
    for (int t = 0; t < info.frames; ++t) {
      const fs::path src = from / numberedFileName("frame", t, 4);
      if (!fs::exists(src))
        throw Error(src.string() + ": output frame " + std::to_string(t) + " of '" + name +
                    "' is missing (`arena run --keep-frames all` writes every frame)");
      // A run's output frame names its scene: another scene's output would be scored against
      // these references.
      const ExrAttributes attributes = readExrAttributes(src);
      if (const auto scene = attributes.find("arena.scene");
          scene != attributes.end() && scene->second != info.scene)
        throw Error(src.string() + ": an output of scene '" + scene->second +
                    "' (its arena.scene), not of '" + info.scene +
                    "', the scene exported: it would be scored against another scene's references");
      // Read as the capture's reader will: a frame it would refuse is never exported.
      writer.output(name, t, readOutputFrame(src, name, info.width, info.height));
    }
    // Frames beyond the sequence's: the output of a longer run, of which only the first are taken.
    if (const fs::path beyond = from / numberedFileName("frame", info.frames, 4);
        fs::exists(beyond))
      throw Error(beyond.string() + ": the output of '" + name + "' holds more frames than the " +
                  std::to_string(info.frames) +
                  " exported: an output of another run (export with that run's --frames)");
    doc["outputs"][name] = json::object();
  }
  writer.commit(doc);
}

}  // namespace arena
