// Captures (core/capture.hpp, docs/captures.md): the format's round trip through `arena export`,
// the validation that checks a capture before anything is ranked on it (metrics/capture_checks.hpp),
// stored outputs of denoisers that ran elsewhere (file: contenders), bad input, and Blender Cycles
// as a producer, end to end.
#include "core/capture.hpp"

#include <Imath/half.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfMultiPartOutputFile.h>
#include <ImfOutputFile.h>
#include <ImfOutputPart.h>
#include <ImfPartType.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/blender_import.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "harness/run_matrix.hpp"
#include "harness/study.hpp"
#include "metrics/capture_checks.hpp"
#include "metrics/compare.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A tiny render of a shipped scene, exported as a capture (both cached per test process).
const fs::path& cornellSequence() {
  static const fs::path dir = renderSequence(test::shippedScene("cornell_static"), test::tinySettings(40, 24, 10, 32),
                                             test::freshDir("capture_cache"), nullptr);
  return dir;
}

const fs::path& exportedCornell() {
  static const fs::path dir = [] {
    const fs::path out = test::freshDir("capture_export") / "cornell_static";
    exportCapture(Sequence::open(cornellSequence()), out);
    return out;
  }();
  return dir;
}

RunConfig captureRun(const fs::path& out, std::vector<DenoiserRequest> denoisers, std::vector<fs::path> captures) {
  RunConfig c;
  c.name = "capture";
  c.out = out;
  c.cache = test::freshDir("capture_run_cache");
  c.render = test::tinySettings(40, 24, 10, 32);
  c.captures = std::move(captures);
  c.denoisers = std::move(denoisers);
  c.warmup = 3;
  c.flip = "all";
  c.keepFrames = "none";
  return c;
}

// Copies a capture folder; `edit` may change capture.json before it is written back.
fs::path copyCapture(const fs::path& from, const std::string& name, const std::function<void(json&)>& edit = {}) {
  const fs::path to = test::freshDir("capture_copy_" + name) / name;
  fs::copy(from, to, fs::copy_options::recursive);
  json doc = parseJsonFile((to / "capture.json").string());
  doc["name"] = name;
  if (edit) edit(doc);
  std::ofstream(to / "capture.json") << doc.dump(1);
  return to;
}

// Rewrites every frame of a capture through `edit(t, layers)` (layers it drops are dropped).
void editFrames(const fs::path& dir, const std::function<void(int, LayerSet&)>& edit) {
  const CaptureDescription c = readCaptureDescription(dir);
  for (int t = 0; t < c.info.frames; ++t) {
    const LayerSet read = readCaptureFrame(c, t);
    LayerSet f;
    for (const auto& [name, image] : read.all())
      if (std::find(c.derived.begin(), c.derived.end(), name) == c.derived.end()) f.set(name, image);
    edit(t, f);
    std::vector<LayerSpec> specs;
    for (const LayerSpec& s : channels::frameLayers())
      if (!s.topLevel && f.has(s.name)) specs.push_back(s);
    writeExr(captureFramePath(dir, t), f, specs);
  }
}

// Every frame of the capture in `dir` rewritten without `layer`.
void dropLayer(const fs::path& dir, const std::string& layer) {
  editFrames(dir, [&](int, LayerSet& f) {
    LayerSet kept;
    for (const auto& [name, image] : f.all())
      if (name != layer) kept.set(name, image);
    f = kept;
  });
}

// A required layer written under near-miss channel names (motion.x and motion.y; a plain Z for the
// depth) is refused naming the channels the file holds with the ones they most likely are.
TEST(Capture, ARequiredLayerUnderOtherChannelNamesIsRefusedNamingThem) {
  const auto rewritten = [](const std::string& name, const LayerSpec& replacement) {
    const fs::path dir = copyCapture(exportedCornell(), name);
    const CaptureDescription c = readCaptureDescription(dir);
    for (int t = 0; t < c.info.frames; ++t) {
      const LayerSet f = readCaptureFrame(c, t);
      std::vector<LayerSpec> specs;
      for (const LayerSpec& s : channels::frameLayers())
        if (!s.topLevel && f.has(s.name) &&
            std::find(c.derived.begin(), c.derived.end(), s.name) == c.derived.end())
          specs.push_back(s.name == replacement.name ? replacement : s);
      writeExr(captureFramePath(dir, t), f, specs);
    }
    return test::errorOf([&] { readCaptureDescription(dir); });
  };
  const std::string lower = rewritten("motion_lower", {"motion", {"x", "y"}});
  EXPECT_NE(
      lower.find("missing layer 'motion' (motion.X, motion.Y): normals, view depth and motion "
                 "are required (docs/captures.md); the file's channels that no layer names: "
                 "motion.x (motion.X?), motion.y (motion.Y?)"),
      std::string::npos)
      << lower;
  const std::string bare = rewritten("depth_bare", {"depth", {"Z"}, false, true});
  EXPECT_NE(bare.find("missing layer 'depth' (depth.Z): "), std::string::npos) << bare;
  EXPECT_NE(bare.find("the file's channels that no layer names: Z (depth.Z?)"), std::string::npos)
      << bare;
}

json pairOf(const json& results, const std::string& label) {
  for (const json& p : results["pairs"])
    if (p["label"] == label) return p;
  ADD_FAILURE() << "no pair " << label;
  return {};
}

// ---- the round trip -------------------------------------------------------------------------

TEST(Capture, CameraMatricesRoundTripExactly) {
  const CameraState c = CameraState::lookAt({0.3f, 1.1f, 4.7f}, {0.1f, 0.9f, 0.0f}, {0, 1, 0}, 38.0f, 64, 36);
  const json j = captureCameraJson(c);
  const CameraState back =
      cameraFromMatrices(j["view"].get<std::vector<double>>(), j["projection"].get<std::vector<double>>(),
                         nullptr, 64, 36, "test");
  // Without the position the eye comes from the view matrix: equal to float rounding.
  EXPECT_NEAR(glm::length(back.eye - c.eye), 0.0f, 1e-5f);
  const std::vector<double> position = j["position"].get<std::vector<double>>();
  const CameraState exact = cameraFromMatrices(j["view"].get<std::vector<double>>(),
                                               j["projection"].get<std::vector<double>>(), &position, 64, 36, "test");
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(exact.eye[k], c.eye[k]);
    EXPECT_EQ(exact.forward[k], c.forward[k]);
    EXPECT_EQ(exact.right[k], c.right[k]);
    EXPECT_EQ(exact.up[k], c.up[k]);
  }
  EXPECT_EQ(exact.tanHalfFovY, c.tanHalfFovY);
  EXPECT_EQ(exact.aspect, c.aspect);
}

TEST(Capture, AnExportedSequenceGivesBitIdenticalResultsToTheSequenceItself) {
  // The format is proven by the suite's own producer: cornell_static rendered here, exported and
  // read back as a capture, gives every denoiser the same inputs and the evaluation the same values.
  const std::vector<DenoiserRequest> denoisers = {{"svgf", {}, ""}, {"asvgf", {}, ""}, {"reblur", {}, ""},
                                                  {"hybrid", {}, ""}, {"reengine", {}, ""}};
  RunConfig fromCache = captureRun(test::freshDir("capture_rt_a"), denoisers, {});
  fromCache.scenes = {test::shippedScene("cornell_static")};
  fromCache.cache = cornellSequence().parent_path();
  const json a = runMatrix(fromCache);
  const json b = runMatrix(captureRun(test::freshDir("capture_rt_b"), denoisers, {exportedCornell()}));
  ASSERT_EQ(a["pairs"].size(), b["pairs"].size());
  ASSERT_EQ(a["pairs"].size(), 7u);
  for (size_t i = 0; i < a["pairs"].size(); ++i) {
    const json &pa = a["pairs"][i], &pb = b["pairs"][i];
    ASSERT_EQ(pa["status"], "ok") << pa.dump().substr(0, 300);
    ASSERT_EQ(pb["status"], "ok") << pb.dump().substr(0, 300);
    json fa = pa["frames"], fb = pb["frames"];
    for (json* f : {&fa, &fb})
      for (json& frame : *f)
        for (const char* m : {"ms", "msWall", "tracingMs"}) frame.erase(m);
    EXPECT_EQ(fa, fb) << pa["label"];
    // Times are the machine's, not the format's: tracingMs prices extra paths at the rate the
    // cache measured while rendering, which a capture does not carry.
    json sa = pa["summary"], sb = pb["summary"];
    for (const char* m : {"ms", "msWall", "tracingMs"}) {
      sa.erase(m);
      sb.erase(m);
    }
    EXPECT_EQ(sa, sb) << pa["label"];
    EXPECT_EQ(pa["ghosting"], pb["ghosting"]);
  }
  EXPECT_EQ(a["scenes"]["cornell_static"]["referenceRelMse"], b["scenes"]["cornell_static"]["referenceRelMse"]);
  EXPECT_EQ(b["scenes"]["cornell_static"]["source"], "capture");
  EXPECT_EQ(b["scenes"]["cornell_static"]["validation"]["status"], "pass")
      << b["scenes"]["cornell_static"]["validation"].dump(1);
}

TEST(Capture, TheExampleInDocsCapturesIsAValidDescription) {
  // docs/captures.md's complete example: its JSON parses and its cameras satisfy the conventions.
  std::ifstream file(std::string(ARENA_SOURCE_DIR) + "/docs/captures.md");
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const size_t start = text.find("```json\n"), end = text.find("```", start + 8);
  ASSERT_NE(start, std::string::npos);
  const json example = parseJsonText(text.substr(start + 8, end - start - 8), "docs/captures.md");
  EXPECT_EQ(example["format"], kCaptureFormatName);
  EXPECT_EQ(example["version"], kCaptureFormatVersion);
  ASSERT_EQ(example["cameras"].size(), example["frames"].get<size_t>());
  for (const json& cam : example["cameras"]) {
    const std::vector<double> position = cam.value("position", std::vector<double>{});
    const CameraState c = cameraFromMatrices(cam["view"].get<std::vector<double>>(),
                                             cam["projection"].get<std::vector<double>>(),
                                             position.empty() ? nullptr : &position, example["width"],
                                             example["height"], "docs example");
    EXPECT_NEAR(c.eye.y, 1.6f, 1e-6f);
    EXPECT_NEAR(c.forward.z, -1.0f, 1e-6f);
  }
}

// ---- validation -----------------------------------------------------------------------------

// A synthetic capture with known motion: a textured plane 3 units in front of a camera that moves
// right and up with acceleration (so motion to the previous and to the next frame differ).
struct Synthetic {
  int w = 64, h = 36, frames = 6;
  bool constantVelocity = false;  // else the camera accelerates: the next frame's motion is not -e
  bool still = false;             // the camera never moves
  std::vector<CameraState> cameras;
  CameraState camera(int t) const {
    const float s = still ? 0.0f : constantVelocity ? 4.0f * float(t) : float(t * t);
    const glm::vec3 eye(0.12f * s, 0.05f * s, 0.0f);
    return CameraState::lookAt(eye, eye + glm::vec3(0, 0, -1), {0, 1, 0}, 45.0f, w, h);
  }
  static glm::vec3 texture(glm::vec3 p) {
    const float v = 0.25f + 0.2f * std::sin(3.0f * p.x) * std::cos(2.0f * p.y);
    return {v, 0.8f * v, 0.6f * v};
  }
  // Motion of pixel (x, y) at frame t to frame `other` (the plane z = -3).
  glm::vec2 motionTo(int t, int other, int x, int y) const {
    const CameraState c = camera(t);
    const glm::vec3 dir = c.rayDirection(float(x) + 0.5f, float(y) + 0.5f);
    const glm::vec3 p = c.eye + dir * (3.0f / glm::dot(dir, c.forward));
    glm::vec2 q(0.0f);
    camera(other).project(p, q);
    return q - glm::vec2(float(x) + 0.5f, float(y) + 0.5f);
  }
};

fs::path writeSynthetic(const std::string& name, float noise = 0.3f, float referenceNoise = 0.0f,
                        const Synthetic& s = Synthetic()) {
  const fs::path dir = test::freshDir("synthetic_" + name) / name;
  CaptureWriter writer(dir);
  json cameras = json::array();
  for (int t = 0; t < s.frames; ++t) {
    const CameraState c = s.camera(t);
    cameras.push_back(captureCameraJson(c));
    LayerSet f, ref;
    Image color(s.w, s.h, 3), reference(s.w, s.h, 3), normal(s.w, s.h, 3), depth(s.w, s.h, 1), motion(s.w, s.h, 2),
        albedo(s.w, s.h, 3, 0.5f), rough(s.w, s.h, 1, 0.5f), mesh(s.w, s.h, 1);
    for (int y = 0; y < s.h; ++y)
      for (int x = 0; x < s.w; ++x) {
        const glm::vec3 ray = c.rayDirection(float(x) + 0.5f, float(y) + 0.5f);
        const glm::vec3 p = c.eye + ray * (3.0f / glm::dot(ray, c.forward));
        const glm::vec3 v = Synthetic::texture(p);
        for (int k = 0; k < 3; ++k) {
          const float n = test::hashUniform(uint32_t(t), uint32_t(y * s.w + x), uint32_t(k)) - 0.5f;
          const float rn = test::hashUniform(uint32_t(t + 100), uint32_t(y * s.w + x), uint32_t(k)) - 0.5f;
          color.at(x, y, k) = std::max(0.0f, v[k] * (1.0f + 4.0f * noise * n));
          reference.at(x, y, k) = std::max(0.0f, v[k] * (1.0f + 4.0f * referenceNoise * rn));
        }
        normal.at(x, y, 2) = 1.0f;
        depth.at(x, y) = 3.0f;
        if (t > 0) {
          const glm::vec2 m = s.motionTo(t, t - 1, x, y);
          motion.at(x, y, 0) = m.x;
          motion.at(x, y, 1) = m.y;
        }
      }
    f.set("color", std::move(color));
    f.set("normal", std::move(normal));
    f.set("depth", std::move(depth));
    f.set("motion", std::move(motion));
    f.set("albedo", std::move(albedo));
    f.set("roughness", std::move(rough));
    f.set("meshId", std::move(mesh));
    writer.frame(t, f);
    ref.set("color", std::move(reference));
    writer.reference(t, ref);
  }
  std::vector<int> ofFrame;
  for (int t = 0; t < s.frames; ++t) ofFrame.push_back(t);
  writer.commit({{"format", kCaptureFormatName}, {"version", kCaptureFormatVersion}, {"name", name},
                 {"width", s.w}, {"height", s.h}, {"frames", s.frames}, {"frameRate", 60}, {"cameras", cameras},
                 {"reference", {{"ofFrame", ofFrame}}}});
  return dir;
}

CaptureValidation validate(const fs::path& dir) {
  const Sequence seq = Sequence::open(dir);
  return validateCapture(seq, readSequenceForEvaluation(seq));
}

// A copy: callers pass the validation of one call (`checkNamed(validate(dir), ...)`), gone at the
// end of their statement; a reference into it dangled (AddressSanitizer: heap-use-after-free).
CaptureCheck checkNamed(const CaptureValidation& v, const std::string& name) {
  for (const CaptureCheck& c : v.checks)
    if (c.name == name) return c;
  throw Error("no check " + name);
}

// A stored output's times: each positive (a timer that read 0 measured nothing, and would be the
// fastest of all), with the thing that measured them named; a device without times says nothing.
// Each fails that output's pair and its validation, not the capture.
TEST(Capture, AStoredOutputsTimesArePositiveAndSayWhatMeasuredThem) {
  auto problem = [](const std::string& name, const json& output) {
    const fs::path dir = copyCapture(exportedCornell(), name, [&](json& d) {
      d["outputs"] = {{"gpu", output}};
    });
    return readCaptureDescription(dir).outputs.at("gpu").timingProblem;
  };
  std::vector<double> ms(10, 1.25);
  ms[4] = 0;
  std::string e = problem("ms_zero", {{"milliseconds", ms}, {"device", "RTX 4080"}});
  EXPECT_NE(
      e.find("outputs.gpu.milliseconds[4]: expected a positive time of at most 1e9 ms, got 0"),
      std::string::npos)
      << e;
  ms[4] = 1e308;  // summed into the mean time, it stopped the whole run (a bad-input trial)
  e = problem("ms_absurd", {{"milliseconds", ms}, {"device", "RTX 4080"}});
  EXPECT_NE(e.find("milliseconds[4]: expected a positive time of at most 1e9 ms, got 1e+308"),
            std::string::npos)
      << e;
  ms[4] = 1.25;
  e = problem("device_empty", {{"milliseconds", ms}, {"device", " "}});
  EXPECT_NE(e.find("outputs.gpu.device: expected what measured the times"), std::string::npos) << e;
  e = problem("device_alone", {{"device", "RTX 4080"}});
  EXPECT_NE(e.find("outputs.gpu.device: names what measured \"milliseconds\", which the output "
                   "does not give"),
            std::string::npos)
      << e;
  EXPECT_EQ(problem("ms_fine", {{"milliseconds", ms}, {"device", "RTX 4080"}}), "");
  // Validation fails that output, and a run fails its pair alone (the input still scored).
  const fs::path dir = copyCapture(exportedCornell(), "device_alone_run", [&](json& d) {
    d["outputs"] = {{"gpu", {{"device", "RTX 4080"}}}};
  });
  const CaptureDescription c = readCaptureDescription(dir);
  EXPECT_EQ(checkNamed(validateCaptureOutputs(c, {}), "output.gpu.timing").status,
            CheckStatus::Fail);
  const json r =
      runMatrix(captureRun(test::freshDir("device_alone_run"), {{"file:gpu", {}, ""}}, {dir}));
  EXPECT_EQ(pairOf(r, "file:gpu")["status"], "failed");
  EXPECT_NE(pairOf(r, "file:gpu").value("error", "").find("which the output does not give"),
            std::string::npos);
  EXPECT_EQ(pairOf(r, "passthrough")["status"], "ok");
}

TEST(CaptureValidation, ACorrectSyntheticCapturePasses) {
  const CaptureValidation v = validate(writeSynthetic("good"));
  EXPECT_NE(v.status(), CheckStatus::Fail) << v.failures();
  EXPECT_EQ(checkNamed(v, "motion.consistency").status, CheckStatus::Pass) << checkNamed(v, "motion.consistency").detail;
  EXPECT_LT(checkNamed(v, "motion.consistency").value, 0.01);
  // The reference has no variance and no half: said, not assumed perfect.
  EXPECT_EQ(checkNamed(v, "reference.noiseFloorKnown").status, CheckStatus::Warn);
}

// A reference shared by frames whose camera moved scores them against another view: the last
// frame pointed at the reference before it (one reference too few) is refused, naming the frame;
// a still camera's frames may share one reference.
TEST(CaptureValidation, AReferenceSharedByAMovingCameraIsRefused) {
  const CaptureCheck& own =
      checkNamed(validate(writeSynthetic("own_references")), "reference.sharedAcrossCameras");
  EXPECT_EQ(own.status, CheckStatus::Pass);
  EXPECT_EQ(own.value, 0.0);
  const fs::path reused = copyCapture(writeSynthetic("reused_reference"), "reused_reference",
                                      [](json& d) { d["reference"]["ofFrame"][5] = 4; });
  const CaptureValidation v = validate(reused);
  const CaptureCheck& shared = checkNamed(v, "reference.sharedAcrossCameras");
  EXPECT_EQ(shared.status, CheckStatus::Fail) << shared.detail;
  EXPECT_GT(shared.value,
            10.0);  // the camera moves 1.1 units at a depth of 3 between frames 4 and 5
  EXPECT_EQ(shared.detail.rfind("frame 5 on reference 4 of frame 4 (", 0), 0u) << shared.detail;
  Synthetic still;
  still.still = true;
  const fs::path stillDir =
      copyCapture(writeSynthetic("still_shared", 0.3f, 0.0f, still), "still_shared",
                  [](json& d) { d["reference"]["ofFrame"] = {0, 0, 0, 0, 0, 0}; });
  const CaptureCheck& stillShared = checkNamed(validate(stillDir), "reference.sharedAcrossCameras");
  EXPECT_EQ(stillShared.status, CheckStatus::Pass) << stillShared.detail;
  EXPECT_LT(stillShared.value, 1e-3);
}

// A run on references whose noise is unknown (no colorVar, no colorHalf) says so under its
// ranking: a reference of a few samples would otherwise be scored as converged without a word.
TEST(CaptureValidation, ARunSaysWhenAReferencesQualityIsUnknown) {
  const fs::path dir = writeSynthetic("unknown_floor");
  const test::CommandResult cli =
      test::runCommand(std::string(ARENA_BINARY) + " run --capture '" + dir.string() +
                       "' --denoisers passthrough --no-baselines --flip none --warmup 2 --out '" +
                       (test::freshDir("unknown_floor_cli") / "run").string() + "'");
  EXPECT_EQ(cli.status, 0) << cli.output;
  EXPECT_NE(
      cli.output.find("reference quality: unknown_floor: reference quality unknown (no reference "
                      "noise floor: the capture's references give no colorVar or colorHalf"),
      std::string::npos)
      << cli.output;
}

struct MotionSlip {
  const char* name;
  const char* expected;  // what the explanation must name
  std::function<glm::vec2(const Synthetic&, int, int, int, glm::vec2)> motion;
};

TEST(CaptureValidation, MotionVectorSlipsAreRefusedAndNamed) {
  const std::vector<MotionSlip> slips = {
      {"flipped", "sign flipped", [](const Synthetic&, int, int, int, glm::vec2 m) { return -m; }},
      {"swapped", "axes swapped",
       [](const Synthetic&, int, int, int, glm::vec2 m) { return glm::vec2(m.y, m.x); }},
      {"doubled", "scaled by 2",
       [](const Synthetic&, int, int, int, glm::vec2 m) { return 2.0f * m; }},
      {"next", "next frame",
       [](const Synthetic& s, int t, int x, int y, glm::vec2) {
         return t + 1 < s.frames ? s.motionTo(t, t + 1, x, y) : glm::vec2(0);
       }},
      {"yflip", "y flipped",
       [](const Synthetic&, int, int, int, glm::vec2 m) { return glm::vec2(m.x, -m.y); }},
      // An engine's NDC vectors ([-1, 1] across the image), with y down and with y up.
      {"ndc", "in NDC units (2 / width",
       [](const Synthetic& s, int, int, int, glm::vec2 m) {
         return glm::vec2(2 * m.x / float(s.w), 2 * m.y / float(s.h));
       }},
      {"ndcup", "in NDC units with y up",
       [](const Synthetic& s, int, int, int, glm::vec2 m) {
         return glm::vec2(2 * m.x / float(s.w), -2 * m.y / float(s.h));
       }},
  };
  const Synthetic s;
  for (const MotionSlip& slip : slips) {
    const fs::path dir = writeSynthetic(std::string("slip_") + slip.name);
    editFrames(dir, [&](int t, LayerSet& f) {
      if (t == 0) return;
      Image& m = f.get("motion");
      for (int y = 0; y < s.h; ++y)
        for (int x = 0; x < s.w; ++x) {
          const glm::vec2 v = slip.motion(s, t, x, y, {m.at(x, y, 0), m.at(x, y, 1)});
          m.at(x, y, 0) = v.x;
          m.at(x, y, 1) = v.y;
        }
    });
    const CaptureValidation v = validate(dir);
    const CaptureCheck& c = checkNamed(v, "motion.consistency");
    EXPECT_EQ(c.status, CheckStatus::Fail) << slip.name << ": " << c.value << " " << c.detail;
    EXPECT_NE(c.detail.find(slip.expected), std::string::npos) << slip.name << ": " << c.detail;
    // And a run refuses it before any denoiser runs, naming the check.
    const json r = runMatrix(captureRun(test::freshDir(std::string("slip_run_") + slip.name), {}, {dir}));
    ASSERT_FALSE(r["pairs"].empty());
    EXPECT_EQ(r["pairs"][0]["status"], "failed");
    EXPECT_NE(r["pairs"][0]["error"].get<std::string>().find("motion.consistency"), std::string::npos);
    EXPECT_EQ(r["scenes"][std::string("slip_") + slip.name]["validation"]["status"], "fail");
  }
  // A few vectors of 1e30 px: the share off decides, and the mean error is a number (its squares
  // overflowed a float and the detail read "mean error inf px").
  {
    const fs::path dir = writeSynthetic("slip_huge");
    editFrames(dir, [&](int t, LayerSet& f) {
      if (t == 1) f.get("motion").at(2, 2, 0) = 1e30f;
    });
    const CaptureCheck& c = checkNamed(validate(dir), "motion.consistency");
    EXPECT_EQ(c.detail.find("inf"), std::string::npos) << c.detail;
    EXPECT_NE(c.detail.find("mean error "), std::string::npos) << c.detail;
  }
  // Vectors half the cameras' step on one frame alone: what a frame dropped and the rest renumbered
  // looks like (frame 3's camera two steps from frame 2's, its vectors one step): the missing
  // frame is offered beside the slip.
  {
    const fs::path dir = writeSynthetic("one_frame_halved");
    editFrames(dir, [&](int t, LayerSet& f) {
      if (t != 3) return;
      for (float& v : f.get("motion").raw()) v *= 0.5f;
    });
    const CaptureCheck& c = checkNamed(validate(dir), "motion.consistency");
    EXPECT_NE(c.detail.find("worst at frame 3 (100% off); most frames fit: where frame 3 is off "
                            "alone, its vectors or camera are, or a frame is missing before it"),
              std::string::npos)
        << c.detail;
  }
  // Cameras given as camera-to-world matrices (Blender's own convention) where capture.json wants
  // world-to-camera: the vectors are right, the cameras inverted; the check names that reading
  // (beside a flipped sign, which a camera that only moves cannot tell from it).
  {
    const fs::path inverted =
        copyCapture(writeSynthetic("cameras_inverted"), "cameras_inverted", [](json& d) {
          for (json& camera : d["cameras"]) {
            glm::dmat4 view;
            for (int k = 0; k < 16; ++k)
              view[k / 4][k % 4] = camera["view"][size_t(k)].get<double>();
            const glm::dmat4 toWorld = glm::inverse(view);
            for (int k = 0; k < 16; ++k) camera["view"][size_t(k)] = toWorld[k / 4][k % 4];
            camera.erase("position");
          }
        });
    const CaptureCheck& c = checkNamed(validate(inverted), "motion.consistency");
    EXPECT_EQ(c.status, CheckStatus::Fail) << c.detail;
    EXPECT_NE(c.detail.find("right for the inverse cameras (capture.json's view holding "
                            "camera-to-world matrices"),
              std::string::npos)
        << c.detail;
  }
  // At a constant camera velocity a flipped sign and vectors to the next frame are the same
  // vectors: named as such (the accelerating camera above told them apart).
  Synthetic steady;
  steady.constantVelocity = true;
  const fs::path dir = writeSynthetic("slip_steady_flipped", 0.3f, 0.0f, steady);
  editFrames(dir, [](int t, LayerSet& f) {
    if (t > 0)
      for (float& v : f.get("motion").raw()) v = -v;
  });
  const CaptureValidation v = validate(dir);
  const CaptureCheck& c = checkNamed(v, "motion.consistency");
  EXPECT_NE(c.detail.find("(or pointing to the next frame: where the camera's velocity changes "
                          "little from frame to frame the two predict nearly the same vectors"),
            std::string::npos)
      << c.detail;
  // A camera that moves without turning: inverse cameras predict the flipped vectors too, named.
  EXPECT_EQ(
      c.detail.rfind("the motion vectors look sign flipped or right for the inverse cameras", 0),
      0u)
      << c.detail;
  // A camera moving under 4 px a frame cannot tell a slip from an error: said, not left silent.
  Synthetic slow;
  slow.constantVelocity = true;
  slow.w = 16;
  slow.h = 9;
  const fs::path small = writeSynthetic("slip_slow_flipped", 0.3f, 0.0f, slow);
  editFrames(small, [](int t, LayerSet& f) {
    if (t > 0)
      for (float& m : f.get("motion").raw()) m = -m;
  });
  const CaptureCheck untried = checkNamed(validate(small), "motion.consistency");
  EXPECT_NE(untried.status, CheckStatus::Pass) << untried.detail;
  EXPECT_NE(untried.detail.find("under 4 px a frame on every pixel, too little to tell a sign, "
                                "scale or unit slip from an error: not tried"),
            std::string::npos)
      << untried.detail;
  // One frame's vectors flipped: the sequence's share may only warn, the frame is named.
  const fs::path one = writeSynthetic("slip_one_frame");
  editFrames(one, [](int t, LayerSet& f) {
    if (t == 4)
      for (float& m : f.get("motion").raw()) m = -m;
  });
  const CaptureCheck single = checkNamed(validate(one), "motion.consistency");
  EXPECT_NE(single.detail.find("; worst at frame 4 ("), std::string::npos) << single.detail;
  EXPECT_EQ(checkNamed(validate(writeSynthetic("motion_good")), "motion.consistency")
                .detail.find("worst at"),
            std::string::npos);
}

// Depth in other units, or a depth buffer's value where view depth belongs: the motion vectors
// (right) fit another reading of the depth, which the check names; a z-buffer without the
// capture's planes is said from its range.
TEST(CaptureValidation, DepthInOtherUnitsOrFromADepthBufferIsNamedByTheMotion) {
  const auto motionOf = [](const fs::path& dir) {
    return checkNamed(validate(dir), "motion.consistency");
  };
  const fs::path mm = writeSynthetic("depth_mm");
  editFrames(mm, [](int, LayerSet& f) {
    for (float& z : f.get("depth").raw()) z *= 1000.0f;
  });
  CaptureCheck c = motionOf(mm);
  EXPECT_EQ(c.status, CheckStatus::Fail) << c.detail;
  EXPECT_EQ(c.detail.rfind("the depth layer looks in millimetres (1000x the scene's units) (", 0),
            0u)
      << c.detail;
  // The motion predicted from that depth is small, but the slips' "not tried" does not follow: the
  // depth, not the camera, is what made it small.
  EXPECT_EQ(c.detail.find("not tried"), std::string::npos) << c.detail;
  // A ray tracer's hit distance written as depth: larger than view depth off the image's centre.
  const fs::path ray = writeSynthetic("depth_ray_distance");
  editFrames(ray, [](int t, LayerSet& frame) {
    const CameraState cam = Synthetic().camera(t);
    Image& depth = frame.get("depth");
    for (int y = 0; y < depth.height(); ++y)
      for (int x = 0; x < depth.width(); ++x)
        depth.at(x, y) /= glm::dot(
            glm::normalize(cam.rayDirection(float(x) + 0.5f, float(y) + 0.5f)), cam.forward);
  });
  c = motionOf(ray);
  EXPECT_NE(c.status, CheckStatus::Pass) << c.detail;
  EXPECT_EQ(c.detail.rfind("the depth layer looks a ray distance (eye to hit), not view depth", 0),
            0u)
      << c.detail;
  const float n = 0.5f, f = 100.0f;
  for (const bool reversed : {false, true}) {
    const fs::path dir =
        copyCapture(writeSynthetic(reversed ? "zbuffer_reversed_src" : "zbuffer_src"),
                    reversed ? "zbuffer_reversed" : "zbuffer", [&](json& j) {
                      j["near"] = n;
                      j["far"] = f;
                    });
    editFrames(dir, [&](int, LayerSet& frame) {
      for (float& z : frame.get("depth").raw())
        if (z > 0) z = reversed ? n * (f - z) / (z * (f - n)) : f * (z - n) / (z * (f - n));
    });
    c = motionOf(dir);
    EXPECT_EQ(c.status, CheckStatus::Fail) << c.detail;
    EXPECT_NE(c.detail.find(reversed ? "looks a reversed depth-buffer value (1 at near, 0 at far)"
                                     : "looks a depth-buffer value (0 at near, 1 at far)"),
              std::string::npos)
        << c.detail;
  }
  // The same depth buffer with the default planes (none given): its range is said.
  const fs::path unplaned = writeSynthetic("zbuffer_no_planes");
  editFrames(unplaned, [&](int, LayerSet& frame) {
    for (float& z : frame.get("depth").raw())
      if (z > 0) z = f * (z - n) / (z * (f - n));
  });
  c = motionOf(unplaned);
  EXPECT_NE(
      c.detail.find(
          "every depth lies in (0, 1]: a depth buffer's value rather than view depth? (read as "
          "one with near 0.01 and far 1000, capture.json's or the defaults"),
      std::string::npos)
      << c.detail;
  // Motion left empty (every vector 0) under a moving camera: no depth reading is blamed (one
  // 1000x too deep predicts no motion too).
  const fs::path empty = writeSynthetic("motion_empty");
  editFrames(empty, [](int, LayerSet& frame) {
    for (float& v : frame.get("motion").raw()) v = 0;
  });
  c = motionOf(empty);
  EXPECT_EQ(c.status, CheckStatus::Fail) << c.detail;
  EXPECT_EQ(c.detail.find("depth layer looks"), std::string::npos) << c.detail;
  // Right depth, right motion: no reading is named.
  EXPECT_EQ(motionOf(writeSynthetic("depth_right")).detail.find("depth layer looks"),
            std::string::npos);
}

TEST(CaptureValidation, NaNInNormalsIsAHardFailureNamingTheChannel) {
  const fs::path dir = writeSynthetic("nan_normals");
  editFrames(dir, [](int t, LayerSet& f) {
    if (t == 2) f.get("normal").at(5, 7, 1) = std::numeric_limits<float>::quiet_NaN();
  });
  const CaptureValidation v = validate(dir);
  const CaptureCheck& c = checkNamed(v, "nonFinite.normal");
  EXPECT_EQ(c.status, CheckStatus::Fail);
  EXPECT_EQ(c.value, 1.0);
  EXPECT_NE(c.detail.find("normal.Y x1; the first at frame 2, pixel (5, 7)"), std::string::npos)
      << c.detail;
  EXPECT_NE(v.failures().find("nonFinite.normal"), std::string::npos);
}

// A check the capture gives no data for warns that it was not checked; it never passes.
TEST(CaptureValidation, ACheckWithoutDataWarnsInsteadOfPassing) {
  const fs::path dir = writeSynthetic("all_sky");
  editFrames(dir, [](int, LayerSet& f) {
    for (float& z : f.get("depth").raw()) z = 0.0f;  // no surface anywhere: nothing to reproject
  });
  const CaptureCheck c = checkNamed(validate(dir), "motion.consistency");
  EXPECT_EQ(c.status, CheckStatus::Warn);
  EXPECT_TRUE(std::isnan(c.value));
  EXPECT_NE(c.detail.find("not checked: no static surface pixel"), std::string::npos) << c.detail;
}

TEST(CaptureValidation, NaNInTheColourIsCountedButNotRefused) {
  const fs::path dir = writeSynthetic("nan_colour");
  editFrames(dir, [](int t, LayerSet& f) {
    if (t == 1) f.get("color").at(3, 3, 0) = std::numeric_limits<float>::infinity();
  });
  const CaptureValidation v = validate(dir);
  const CaptureCheck c = checkNamed(v, "nonFinite.color");
  EXPECT_EQ(c.status, CheckStatus::Warn);
  EXPECT_EQ(c.value, 1.0);
  // The reference checks read the input as the denoisers do (the Inf as 0): one bad pixel no
  // longer turned them off as "the input equals the reference".
  const CaptureCheck& rough = checkNamed(v, "reference.roughnessVsInput");
  EXPECT_EQ(rough.status, CheckStatus::Pass) << rough.value << " " << rough.detail;
  EXPECT_TRUE(std::isfinite(rough.value)) << rough.detail;
  // A reference with a noise estimate (an export's two halves): its noise is still compared with
  // the input's error, which one NaN made NaN ("not checked: the input equals the reference").
  const fs::path exported = copyCapture(exportedCornell(), "nan_input");
  editFrames(exported, [](int t, LayerSet& f) {
    if (t == 1) f.get("color").at(3, 3, 0) = std::numeric_limits<float>::quiet_NaN();
  });
  const CaptureValidation withNaN = validate(exported);
  const CaptureCheck& noise = checkNamed(withNaN, "reference.noiseVsInput");
  EXPECT_TRUE(std::isfinite(noise.value)) << noise.detail;
  EXPECT_EQ(noise.detail.find("not checked"), std::string::npos) << noise.detail;
}

// A NaN in a reference's colour is named once: its colorVar, derived from colorHalf, is not in the
// file and is not named too.
TEST(CaptureValidation, ANaNInAReferenceIsNamedInTheLayersTheFileHolds) {
  const fs::path dir = writeSynthetic("nan_reference");
  const CaptureDescription c = readCaptureDescription(dir);
  LayerSet ref = readCaptureReference(c, 0);
  ref.set("colorHalf", ref.get("color"));
  ref.get("color").at(2, 2, 0) = std::numeric_limits<float>::quiet_NaN();
  writeExr(captureReferencePath(dir, 0), ref,
           {{"color", {"R", "G", "B"}}, {"colorHalf", {"R", "G", "B"}}});
  for (int r = 1; r < c.info.frames;
       ++r) {  // every reference with its half, as a capture gives them
    LayerSet other = readCaptureReference(c, r);
    other.set("colorHalf", other.get("color"));
    writeExr(captureReferencePath(dir, r), other,
             {{"color", {"R", "G", "B"}}, {"colorHalf", {"R", "G", "B"}}});
  }
  const std::string e = test::errorOf([&] { readSequenceForEvaluation(Sequence::open(dir)); });
  EXPECT_NE(e.find("reference_000.exr: color.R x1"), std::string::npos) << e;
  EXPECT_EQ(e.find("colorVar"), std::string::npos) << e;
}

TEST(CaptureValidation, AReferenceNoisierThanTheInputIsRefused) {
  const CaptureValidation good = validate(writeSynthetic("ref_ok", 0.3f, 0.0f));
  EXPECT_EQ(checkNamed(good, "reference.roughnessVsInput").status, CheckStatus::Pass)
      << checkNamed(good, "reference.roughnessVsInput").value;
  const CaptureValidation bad = validate(writeSynthetic("ref_noisy", 0.1f, 0.4f));
  const CaptureCheck& c = checkNamed(bad, "reference.roughnessVsInput");
  EXPECT_EQ(c.status, CheckStatus::Fail) << c.value;
  EXPECT_GT(c.value, 1.0);
}

// A reference's pixel noise against the input's, the picture cancelled between them, against the
// samples capture.json declares (a capture author's 1-sample reference declared as 4096 read
// 0.999 on roughnessVsInput, a warning, and was ranked on).
TEST(CaptureValidation, AReferenceNoisierThanItsDeclaredSamplesIsNamed) {
  const auto declared = [](const fs::path& dir, int samples) {
    json d = json::parse(readText(dir / "capture.json"));
    d["reference"]["samples"] = std::vector<int>(d["frames"].get<size_t>(), samples);
    writeTextAtomically(dir / "capture.json", d.dump(1));
    return checkNamed(validate(dir), "reference.noiseVsDeclared");
  };
  // As noisy as the input: a ratio about 1, refused when 4096 samples are declared.
  const CaptureCheck one = declared(writeSynthetic("ref_one_sample", 0.3f, 0.3f), 4096);
  EXPECT_EQ(one.status, CheckStatus::Fail) << one.value << " " << one.detail;
  EXPECT_NEAR(one.value, 1.0, 0.2) << one.detail;
  EXPECT_NE(one.detail.find("while their fewest declared is 4096"), std::string::npos)
      << one.detail;
  // Half the input's noise (the variance of 4 samples): warned of at 4096, passed at 4.
  const fs::path four = writeSynthetic("ref_four_samples", 0.3f, 0.15f);
  const CaptureCheck fourAsMany = declared(four, 4096);
  EXPECT_EQ(fourAsMany.status, CheckStatus::Warn) << fourAsMany.value;
  EXPECT_NEAR(fourAsMany.value, 0.25, 0.06);
  EXPECT_EQ(declared(four, 4).status, CheckStatus::Pass);
  // A converged reference passes whatever is declared: the texture cancels (roughnessVsInput, which
  // keeps it, reads a textured reference far higher).
  EXPECT_EQ(declared(writeSynthetic("ref_converged", 0.3f, 0.0f), 4096).status, CheckStatus::Pass);
}

// One frame's reference as noisy as an input, among converged ones: the sequence's mean stays
// below the threshold, the worst frame does not, and the check names it.
TEST(CaptureValidation, OneBadReferenceFrameIsNamed) {
  const fs::path dir = writeSynthetic("one_bad_reference");
  const CaptureDescription c = readCaptureDescription(dir);
  LayerSet bad;
  Image noisy = readCaptureFrame(c, 2).get("color");
  for (int y = 0; y < noisy.height(); ++y)
    for (int x = (y & 1); x < noisy.width(); x += 2)
      for (int k = 0; k < 3; ++k) noisy.at(x, y, k) *= 2.0f;  // rougher than the input
  bad.set("color", noisy);
  writeExr(Sequence::referencePath(dir, 2), bad, {{"color", {"R", "G", "B"}}}, {});
  const CaptureValidation v = validate(dir);
  EXPECT_NE(checkNamed(v, "reference.roughnessVsInput").status, CheckStatus::Fail)
      << checkNamed(v, "reference.roughnessVsInput").value;
  const CaptureCheck& worst = checkNamed(v, "reference.roughnessVsInput.worstFrame");
  EXPECT_EQ(worst.status, CheckStatus::Warn) << worst.value;  // said, not refused (one frame)
  EXPECT_GT(worst.value, 1.0);
  EXPECT_EQ(worst.detail, "worst at frame 2 (reference_002.exr)");
  // A capture whose references are all converged passes the worst frame too.
  EXPECT_EQ(checkNamed(validate(writeSynthetic("all_good_references")),
                       "reference.roughnessVsInput.worstFrame")
                .status,
            CheckStatus::Pass);
}

// A noisy input averages to its reference: a frame four times as bright (an exposure applied to it
// alone), a reference at twice the scale, or negative input radiance pass no other check.
// A layer's channels misspelt where the file lacks the layer: named with the likely one.
TEST(CaptureValidation, EventsTheFramesContradictAreNamed) {
  // The synthetic camera accelerates smoothly (no cut anywhere); its meshId layer holds only 0.
  const fs::path dir = writeSynthetic("event_checks");
  const json written = json::parse(readText(dir / "capture.json"));
  const auto withEvents = [&](const json& events, bool jump) {
    json d = written;
    d["events"] = events;
    if (jump)  // the camera jumps to another place and view from frame 3 on: a real cut
      for (size_t t = 3; t < d["cameras"].size(); ++t)
        d["cameras"][t] = captureCameraJson(CameraState::lookAt(
            {40, 2, 9}, {0, 0, -20}, {0, 1, 0}, 45.0f, Synthetic().w, Synthetic().h));
    writeTextAtomically(dir / "capture.json", d.dump(1));
    return validate(dir);
  };
  const CaptureValidation fine =
      withEvents({{{"frame", 2}, {"kind", "object_moves"}, {"meshId", 0}},
                  {{"frame", 3}, {"kind", "camera_cut"}}},
                 true);
  EXPECT_EQ(checkNamed(fine, "events.meshIdAbsent").status, CheckStatus::Pass)
      << checkNamed(fine, "events.meshIdAbsent").detail;
  EXPECT_EQ(checkNamed(fine, "events.cutWithoutMotion").status, CheckStatus::Pass)
      << checkNamed(fine, "events.cutWithoutMotion").detail;
  EXPECT_EQ(checkNamed(fine, "events.cutUnmarked").status, CheckStatus::Pass)
      << checkNamed(fine, "events.cutUnmarked").detail;
  // The same jump with no event: the cut is named (an engine that did not flag it scored on, the
  // denoisers keeping their history across it).
  const CaptureCheck unmarked = checkNamed(withEvents(json::array(), true), "events.cutUnmarked");
  EXPECT_EQ(unmarked.status, CheckStatus::Warn);
  EXPECT_EQ(unmarked.value, 1.0) << unmarked.detail;
  EXPECT_NE(unmarked.detail.find("the camera jumps at frame 3 (the eye moves "), std::string::npos)
      << unmarked.detail;
  EXPECT_NE(unmarked.detail.find("with no camera_cut event there"), std::string::npos)
      << unmarked.detail;

  const CaptureValidation wrong =
      withEvents({{{"frame", 2}, {"kind", "object_moves"}, {"meshId", 5}},
                  {{"frame", 3}, {"kind", "camera_cut"}}},
                 false);
  const CaptureCheck noObject = checkNamed(wrong, "events.meshIdAbsent");
  EXPECT_EQ(noObject.status, CheckStatus::Warn);
  EXPECT_NE(noObject.detail.find(
                "object_moves at frame 2, meshId 5: no frame's meshId layer holds that id"),
            std::string::npos)
      << noObject.detail;
  // The synthetic camera accelerating smoothly has no jump.
  EXPECT_EQ(checkNamed(wrong, "events.cutUnmarked").status, CheckStatus::Pass)
      << checkNamed(wrong, "events.cutUnmarked").detail;
  const CaptureCheck noCut = checkNamed(wrong, "events.cutWithoutMotion");
  EXPECT_EQ(noCut.status, CheckStatus::Warn);
  EXPECT_NE(
      noCut.detail.find(
          "camera_cut at frame 3: the camera moves there no more than on the frames around it"),
      std::string::npos)
      << noCut.detail;
  // A still camera does not cut either.
  Synthetic still;
  still.still = true;
  const fs::path stillDir = writeSynthetic("event_still", 0.3f, 0.0f, still);
  json d = json::parse(readText(stillDir / "capture.json"));
  d["events"] = {{{"frame", 4}, {"kind", "camera_cut"}}};
  writeTextAtomically(stillDir / "capture.json", d.dump(1));
  EXPECT_EQ(checkNamed(validate(stillDir), "events.cutWithoutMotion").status, CheckStatus::Warn);
}

TEST(CaptureValidation, AnUnknownChannelIsNamedWithTheChannelItLikelyMisspells) {
  const fs::path dir = writeSynthetic("misspelt_channel");
  const CaptureDescription c = readCaptureDescription(dir);
  LayerSet f = readCaptureFrame(c, 0);
  std::vector<LayerSpec> specs;
  for (const LayerSpec& spec : channels::frameLayers())
    if (!spec.topLevel && f.has(spec.name) &&
        std::count(c.layers.begin(), c.layers.end(), spec.name) && spec.name != "roughness")
      specs.push_back(spec);
  f.set("roughnes", f.get("roughness"));  // the only roughness: misspelt
  specs.push_back({"roughnes", {"X"}, false});
  writeExr(captureFramePath(dir, 0), f, specs, {{"arena.capture.frame", "0"}});
  const std::string e = test::errorOf([&] { validate(dir); });
  const CaptureDescription after = readCaptureDescription(dir);
  ASSERT_EQ(after.unknownChannels, std::vector<std::string>{"roughnes.X"});
}

TEST(CaptureValidation, BrightnessAgainstTheReferenceAndNegativeInputAreChecked) {
  const CaptureValidation good = validate(writeSynthetic("brightness_ok"));
  EXPECT_EQ(checkNamed(good, "reference.brightnessVsInput").status, CheckStatus::Pass)
      << checkNamed(good, "reference.brightnessVsInput").value;
  EXPECT_EQ(checkNamed(good, "color.negative").status, CheckStatus::Pass);
  const fs::path jump = writeSynthetic("exposure_jump");
  editFrames(jump, [](int t, LayerSet& f) {
    if (t == 3)
      for (float& x : f.get("color").raw()) x *= 4.0f;
  });
  const CaptureValidation jumped = validate(jump);
  // One frame warns (a 1-spp frame can miss the rare paths that carry the light), naming it.
  const CaptureCheck& b = checkNamed(jumped, "reference.brightnessVsInput.worstFrame");
  EXPECT_EQ(b.status, CheckStatus::Warn) << b.value;
  EXPECT_NEAR(b.value, 4.0, 0.2);
  EXPECT_EQ(b.detail.rfind("frame 3: the input's mean luminance is ", 0), 0u) << b.detail;
  EXPECT_EQ(checkNamed(jumped, "reference.brightnessVsInput").status,
            CheckStatus::Warn);  // 1.5x pooled
  const fs::path dim = writeSynthetic("dim_input");
  editFrames(dim, [](int, LayerSet& f) {
    for (float& x : f.get("color").raw()) x *= 0.8f;  // every frame 1.25x darker: a warning
  });
  EXPECT_EQ(checkNamed(validate(dim), "reference.brightnessVsInput").status, CheckStatus::Warn);
  const fs::path dark = writeSynthetic("dark_input");
  editFrames(dark, [](int, LayerSet& f) {
    for (float& x : f.get("color").raw())
      x *= 0.4f;  // a reference at 2.5x the input's scale: refused
  });
  const CaptureValidation darkV = validate(dark);
  const CaptureCheck& pooled = checkNamed(darkV, "reference.brightnessVsInput");
  EXPECT_EQ(pooled.status, CheckStatus::Fail) << pooled.value;
  EXPECT_NEAR(pooled.value, 2.5, 0.1);
  EXPECT_EQ(pooled.detail.rfind("over the sequence, the input's mean luminance is 0.", 0), 0u)
      << pooled.detail;
  const fs::path negative = writeSynthetic("negative_input");
  editFrames(negative, [](int t, LayerSet& f) {
    if (t == 1) f.get("color").at(5, 5, 0) = -0.5f;
  });
  EXPECT_EQ(checkNamed(validate(negative), "color.negative").status, CheckStatus::Warn);
}

TEST(CaptureValidation, RangesOfNormalsDepthAlbedoAndRoughness) {
  const fs::path dir = writeSynthetic("ranges");
  editFrames(dir, [](int, LayerSet& f) {
    f.get("normal").fill(0.0f);  // zero-length normals everywhere
    f.get("normal").planeSpan(2)[0] = 1.0f;
    f.get("albedo").at(0, 0, 0) = 1.5f;
    f.get("roughness").fill(-0.2f);
    f.get("depth").at(1, 1) = -1.0f;
  });
  const CaptureValidation v = validate(dir);
  EXPECT_EQ(checkNamed(v, "normal.unitLength").status, CheckStatus::Fail);
  EXPECT_EQ(checkNamed(v, "depth.positive").status, CheckStatus::Fail);
  EXPECT_EQ(checkNamed(v, "roughness.range").status, CheckStatus::Fail);
  EXPECT_EQ(checkNamed(v, "albedo.range").status, CheckStatus::Warn);  // 1 value in 13824: below the hard share
  EXPECT_EQ(checkNamed(v, "normal.unitLength").detail.find("sky written as the far plane"),
            std::string::npos);
  // The sky (here the top rows) written at the far plane with no normal: named, not only counted.
  const fs::path sky = writeSynthetic("sky_at_far");
  editFrames(sky, [](int, LayerSet& f) {
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < f.get("depth").width(); ++x) {
        f.get("depth").at(x, y) = 1000.0f;
        for (int c = 0; c < 3; ++c) f.get("normal").at(x, y, c) = 0.0f;
      }
  });
  const CaptureCheck far = checkNamed(validate(sky), "normal.unitLength");
  EXPECT_EQ(far.status, CheckStatus::Fail);
  EXPECT_NE(far.detail.find(
                "have no normal at their frame's largest depth (1000): sky written as the far "
                "plane? Write depth 0 where nothing was hit"),
            std::string::npos)
      << far.detail;
}

TEST(CaptureValidation, WithoutAReferenceOnlyNoReferenceMetricsAreScoredAndItIsSaid) {
  const fs::path dir = copyCapture(exportedCornell(), "noref", [](json& d) { d.erase("reference"); });
  const CaptureValidation v = validate(dir);
  EXPECT_EQ(checkNamed(v, "reference.present").status, CheckStatus::Warn);
  const json r = runMatrix(captureRun(test::freshDir("noref_run"), {{"eaw", {}, ""}}, {dir}));
  const json p = pairOf(r, "eaw");
  ASSERT_EQ(p["status"], "ok") << p.dump().substr(0, 400);
  EXPECT_FALSE(p["summary"].contains("relMse"));
  EXPECT_TRUE(p["summary"].contains("stabilityFine"));
  EXPECT_TRUE(p["summary"].contains("stabilityCoarse"));
  EXPECT_FALSE(p["summary"].contains("warpedFlicker"));  // relative to the reference's own flicker
  EXPECT_EQ(r["scenes"]["noref"]["hasReference"], false);
  EXPECT_TRUE(p["summary"]["stabilityFine"]["ci95"].is_array());
  // Its absent error metrics are said to want a reference, not to have been left out of the run;
  // and the validation promises no ranking that the statistics do not make.
  const std::vector<std::string> absent = absentSummaryLines(test::typed(r), {"relMse"});
  ASSERT_EQ(absent.size(), 1u);
  EXPECT_NE(absent[0].find(
                "noref: relMse absent in 3 pair(s): the scene has no reference (relMse needs one"),
            std::string::npos)
      << absent[0];
  EXPECT_FALSE(r["statistics"].value("scenes", json::object()).contains("noref"));
  EXPECT_NE(checkNamed(v, "reference.present").detail.find("the scene is not ranked"),
            std::string::npos);
  // An output at another exposure is still found without references: against the noisy inputs,
  // which average to them (the trial's 10x output passed unsaid).
  const fs::path lit = copyCapture(dir, "noref_lit", [](json& d) {
    d["outputs"] = {{"lit", json::object()}};
  });
  const CaptureDescription litCapture = readCaptureDescription(lit);
  for (int t = 0; t < litCapture.info.frames; ++t) {
    Image c = readCaptureFrame(litCapture, t).get("color");
    for (float& x : c.raw()) x *= 10;
    fs::create_directories(lit / "outputs" / "lit");
    LayerSet l;
    l.set("color", c);
    writeExr(lit / "outputs" / "lit" / numberedFileName("frame", t, 4), l,
             {{"color", {"R", "G", "B"}, false}});
  }
  const CaptureValidation litChecks = validateCaptureOutputs(litCapture, {});
  const CaptureCheck& litCheck = checkNamed(litChecks, "output.lit.brightnessVsInput");
  EXPECT_EQ(litCheck.status, CheckStatus::Warn) << litCheck.detail;  // a noisy mean: a warning
  EXPECT_NE(litCheck.detail.find("x the noisy inputs' (there are no references)"),
            std::string::npos)
      << litCheck.detail;
  const json litRun =
      runMatrix(captureRun(test::freshDir("noref_lit_run"), {{"file:lit", {}, ""}}, {lit}));
  EXPECT_EQ(pairOf(litRun, "file:lit")["status"], "ok");
  EXPECT_NEAR(pairOf(litRun, "file:lit").value("brightnessVsInput", 0.0), 10.0, 1e-3);
  EXPECT_NE(pairOf(litRun, "file:lit")["warnings"].dump().find("10x the noisy inputs'"),
            std::string::npos)
      << pairOf(litRun, "file:lit")["warnings"];
  // The run's printout shows what was measured (every relMSE cell is "-"): each method's stability.
  const test::CommandResult cli = test::runCommand(
      std::string(ARENA_BINARY) + " run --capture '" + dir.string() +
      "' --denoisers eaw --no-baselines --flip none --warmup 2 --keep-frames none --out '" +
      (test::freshDir("noref_cli") / "run").string() + "'");
  ASSERT_EQ(cli.status, 0) << cli.output;
  EXPECT_NE(cli.output.find("noref has no reference: the output's own temporal stability"),
            std::string::npos)
      << cli.output;
  const size_t row = cli.output.find("\n  eaw ");
  ASSERT_NE(row, std::string::npos) << cli.output;
  const std::string eawRow = cli.output.substr(row + 1, cli.output.find('\n', row + 1) - row - 1);
  EXPECT_EQ(std::count(eawRow.begin(), eawRow.end(), '['), 2) << eawRow;  // both, with intervals
  // With its frames kept (the default for one capture): the images there are, no error map (every
  // pair failed writing an empty one before).
  RunConfig kept = captureRun(test::freshDir("noref_kept"), {{"eaw", {}, ""}}, {dir});
  kept.keepFrames = "all";
  const json k = runMatrix(kept);
  ASSERT_EQ(pairOf(k, "eaw")["status"], "ok") << pairOf(k, "eaw").dump().substr(0, 400);
  const fs::path images = kept.out / pairOf(k, "eaw")["images"]["dir"].get<std::string>();
  EXPECT_TRUE(fs::exists(images / "frame_0004.png"));
  EXPECT_FALSE(fs::exists(images / "relerr_0004.png"));
}

// A colour layer with no finite value in a frame is no data: refused, where a few NaNs are counted.
TEST(CaptureValidation, AFrameWithoutAFiniteColourIsRefusedNamingTheFrame) {
  const fs::path dir = writeSynthetic("nan_frame");
  editFrames(dir, [](int t, LayerSet& f) {
    if (t == 2)
      for (float& v : f.get("color").raw()) v = std::numeric_limits<float>::quiet_NaN();
  });
  const CaptureValidation v = validate(dir);
  const CaptureCheck& c = checkNamed(v, "nonFinite.color.wholeFrames");
  EXPECT_EQ(c.status, CheckStatus::Fail);
  EXPECT_EQ(c.value, 1.0);
  EXPECT_NE(c.detail.find("frame(s) 2 "), std::string::npos) << c.detail;
  EXPECT_EQ(checkNamed(validate(writeSynthetic("nan_none")), "nonFinite.color.wholeFrames").status,
            CheckStatus::Pass);
  // The run refuses it: no pair is scored on zeros standing in for a frame.
  const json r =
      runMatrix(captureRun(test::freshDir("nan_frame_run"), {{"passthrough", {}, ""}}, {dir}));
  for (const json& p : r["pairs"]) {
    EXPECT_EQ(p["status"], "failed") << p["label"];
    EXPECT_NE(p.value("error", "").find("nonFinite.color.wholeFrames"), std::string::npos)
        << p.value("error", "");
  }
}

// Rewrites every reference colour of a synthetic capture (colour only, as writeSynthetic gives).
void editReferences(const fs::path& dir, const std::function<void(int, Image&)>& edit) {
  const CaptureDescription c = readCaptureDescription(dir);
  int refs = 0;
  for (int r : c.info.referenceOfFrame) refs = std::max(refs, r + 1);
  for (int r = 0; r < refs; ++r) {
    LayerSet ref;
    ref.set("color", readCaptureReference(c, r).get("color"));
    edit(r, ref.get("color"));
    writeExr(captureReferencePath(dir, r), ref, {{"color", {"R", "G", "B"}, false}});
  }
}

// References written one frame late or early: every input lies on its neighbour's reference.
// A still camera decides nothing (the references are one image), and references of unequal noise
// beside each other are no misalignment.
// A run records what the capture's pixels are (checksums of its files): compare refuses runs of
// other input frames under one name and warns of other references, where the hash of capture.json
// and the files' sizes saw neither (an engine's capture exported again, references re-rendered).
TEST(CaptureContract, CompareTellsOtherInputsAndOtherReferencesOfOneCapture) {
  const fs::path capture = copyCapture(exportedCornell(), "content");
  auto run = [&](const std::string& name) {
    return test::typed(
        runMatrix(captureRun(test::freshDir("content_" + name), {{"eaw", {}, ""}}, {capture})));
  };
  const RunResults first = run("first"), again = run("again");
  ASSERT_TRUE(first.scenes["content"].contains("content")) << first.scenes.dump().substr(0, 400);
  EXPECT_TRUE(settingsDifferences(first, again).empty());
  EXPECT_TRUE(referenceDifferences(first, again).empty());
  // The same capture under another path (moved, copied): the checksums decide, not the path.
  const fs::path moved = test::freshDir("content_moved") / "elsewhere";
  fs::copy(capture, moved, fs::copy_options::recursive);
  const RunResults fromMoved = test::typed(
      runMatrix(captureRun(test::freshDir("content_moved_run"), {{"eaw", {}, ""}}, {moved})));
  EXPECT_TRUE(settingsDifferences(first, fromMoved).empty())
      << settingsDifferences(first, fromMoved).front();
  // Who wrote it, what it is for and which outputs it stores are not its pixels.
  const CaptureContent before = captureContent(readCaptureDescription(capture));
  json doc = parseJsonFile((capture / "capture.json").string());
  doc["source"] = {{"engine", "another build"}};
  doc["purpose"] = "another description";
  std::ofstream(capture / "capture.json") << doc.dump(1);
  EXPECT_EQ(captureContent(readCaptureDescription(capture)).inputs, before.inputs);
  EXPECT_EQ(captureContent(readCaptureDescription(capture)).references, before.references);

  editReferences(capture, [](int, Image& c) {
    for (float& v : c.raw()) v *= 1.5f;
  });
  const RunResults brighter = run("brighter");
  EXPECT_TRUE(settingsDifferences(first, brighter).empty());
  const std::vector<std::string> refs = referenceDifferences(first, brighter);
  ASSERT_EQ(refs.size(), 1u);
  EXPECT_NE(refs[0].find("scenes.content.content.references: "), std::string::npos) << refs[0];

  editFrames(capture, [](int, LayerSet& f) {
    for (float& v : f.get("diffuse").raw()) v *= 0.5f;
  });
  const std::vector<std::string> differ = settingsDifferences(brighter, run("darker"));
  ASSERT_EQ(differ.size(), 1u);
  EXPECT_NE(differ[0].find("scenes.content.content.inputs: "), std::string::npos) << differ[0];
  EXPECT_NE(differ[0].find("(other inputs: "), std::string::npos) << differ[0];
}

// Reference file r rewritten to hold reference source(r, frames)'s image, with a variance of 0 (the
// synthetic references are exact): references shifted or swapped, with their noise known.
void exactReferencesFrom(const fs::path& dir, const std::function<int(int, int)>& source) {
  const CaptureDescription c = readCaptureDescription(dir);
  std::vector<Image> refs;
  for (int r = 0; r < c.info.frames; ++r) refs.push_back(readCaptureReference(c, r).get("color"));
  for (int r = 0; r < c.info.frames; ++r) {
    LayerSet ref;
    ref.set("color", refs[size_t(source(r, c.info.frames))]);
    ref.set("colorVar", Image(c.info.width, c.info.height, 3, 0.0f));
    writeExr(captureReferencePath(dir, r), ref,
             {{"color", {"R", "G", "B"}, false}, {"colorVar", {"R", "G", "B"}, false}});
  }
}

TEST(CaptureValidation, ReferencesOneFrameOffTheirInputsAreRefused) {
  const auto alignment = [](const CaptureValidation& v, const std::string& side) {
    return checkNamed(v, "reference.alignment." + side);
  };
  const CaptureValidation good = validate(writeSynthetic("aligned"));
  for (const char* side : {"before", "after"}) {
    EXPECT_EQ(alignment(good, side).status, CheckStatus::Pass) << alignment(good, side).detail;
    EXPECT_EQ(alignment(good, side).detail, "");
  }
  EXPECT_EQ(checkNamed(good, "reference.alignment.swapped").status, CheckStatus::Pass);
  // References 1 and 2 swapped (exact, so with their variance of 0): named as a swap, not as two
  // frames each alone on a neighbour's reference.
  const fs::path swapped = writeSynthetic("references_swapped");
  exactReferencesFrom(swapped, [](int r, int) { return r == 1 ? 2 : r == 2 ? 1 : r; });
  const CaptureValidation sw = validate(swapped);
  const CaptureCheck swap = checkNamed(sw, "reference.alignment.swapped");
  EXPECT_EQ(swap.status, CheckStatus::Fail) << swap.detail;
  EXPECT_NE(swap.detail.find("frames 1 and 2 each lie on the other's reference"), std::string::npos)
      << swap.detail;
  // Reference file r holds frame r+1's image (the last repeats its own): one frame ahead. With
  // the references' variance (these are exact: 0) the check refuses it.
  const fs::path ahead = writeSynthetic("references_ahead");
  exactReferencesFrom(ahead, [](int r, int frames) { return std::min(r + 1, frames - 1); });
  const CaptureValidation a = validate(ahead);
  EXPECT_EQ(alignment(a, "before").status, CheckStatus::Fail) << alignment(a, "before").value;
  // Frame 3 is not judged: the texture's period is near the camera's move from frame 3 to 5, so
  // both neighbours' references look nearer than its own, as a noisy reference would.
  EXPECT_EQ(alignment(a, "before")
                .detail.rfind("frame(s) 1, 2, 4 lie on the reference of the frame before, 3 of the "
                              "3 frames decided",
                              0),
            0u)
      << alignment(a, "before").detail;
  EXPECT_NE(alignment(a, "before")
                .detail.find("one frame ahead of their inputs (each holds the "
                             "frame after's image"),
            std::string::npos);
  EXPECT_EQ(alignment(a, "after").status, CheckStatus::Pass) << alignment(a, "after").detail;
  // One frame behind: reference file r holds frame r-1's image.
  const fs::path behind = writeSynthetic("references_behind");
  {
    const CaptureDescription c = readCaptureDescription(behind);
    std::vector<Image> refs;
    for (int r = 0; r < c.info.frames; ++r) refs.push_back(readCaptureReference(c, r).get("color"));
    editReferences(behind, [&](int r, Image& ref) { ref = refs[size_t(std::max(r - 1, 0))]; });
  }
  // Without their variance a less converged reference beside better ones can read so: a warning.
  const CaptureValidation b = validate(behind);
  EXPECT_EQ(alignment(b, "after").status, CheckStatus::Warn) << alignment(b, "after").detail;
  EXPECT_NE(alignment(b, "after")
                .detail.find("one frame behind their inputs (each holds the frame "
                             "before's image"),
            std::string::npos);
  EXPECT_NE(alignment(b, "after").detail.find("(a warning: without the references' colorVar"),
            std::string::npos);
  EXPECT_EQ(alignment(b, "before").status, CheckStatus::Pass) << alignment(b, "before").detail;
  // Correct references, a still camera, and a step in their noise (the first half rendered at
  // fewer samples, each later one nested in the earlier: no variance given): no pattern.
  Synthetic stillStep;
  stillStep.still = true;
  const fs::path step = writeSynthetic("still_noise_step", 0.3f, 0.0f, stillStep);
  editReferences(step, [](int r, Image& ref) {
    if (r < 3)
      for (size_t i = 0; i < ref.raw().size(); ++i)
        ref.raw()[i] *= 1.0f + 0.2f * float(3 - r) * (test::hashUniform(99, uint32_t(i)) - 0.5f);
  });
  const CaptureValidation st = validate(step);
  for (const char* side : {"before", "after"})
    EXPECT_NE(alignment(st, side).status, CheckStatus::Fail)
        << side << ": " << alignment(st, side).detail;
  // A slightly dark input during a fade (4% low against a 5% step a frame) lies on its own
  // reference: the input is scaled to it first.
  const fs::path fade = writeSynthetic("fade_dark_input", 0.05f, 0.0f, stillStep);
  editReferences(fade, [](int r, Image& ref) {
    for (float& x : ref.raw()) x *= std::pow(0.95f, float(r));
  });
  editFrames(fade, [](int t, LayerSet& f) {
    for (float& x : f.get("color").raw()) x *= 0.96f * std::pow(0.95f, float(t));
  });
  const CaptureValidation fd = validate(fade);
  for (const char* side : {"before", "after"})
    EXPECT_EQ(alignment(fd, side).status, CheckStatus::Pass)
        << side << ": " << alignment(fd, side).detail;
  // A still camera, references of very unequal noise (every other one noisy): nothing decided.
  Synthetic still;
  still.still = true;
  const fs::path unequal = writeSynthetic("still_unequal_references", 0.3f, 0.0f, still);
  editReferences(unequal, [](int r, Image& ref) {
    if (r % 2 == 0)
      for (size_t i = 0; i < ref.raw().size(); ++i)
        ref.raw()[i] *= 1.0f + 0.8f * (test::hashUniform(uint32_t(r + 7), uint32_t(i)) - 0.5f);
  });
  const CaptureValidation u = validate(unequal);
  for (const char* side : {"before", "after"})
    EXPECT_EQ(alignment(u, side).status, CheckStatus::Pass)
        << side << ": " << alignment(u, side).detail;
}

// No data is never a perfect score: an input or a reference black in every frame, a reference
// that repeats its input or holds negative radiance is refused; a few black frames (a fade) warn.
TEST(CaptureValidation, BlackNegativeOrRepeatedColourIsRefusedNamingTheFrames) {
  const CaptureValidation good = validate(writeSynthetic("signal_ok"));
  for (const char* name : {"color.blackFrames", "reference.blackFrames", "reference.negative",
                           "reference.equalsInput"})
    EXPECT_EQ(checkNamed(good, name).status, CheckStatus::Pass)
        << name << ": " << checkNamed(good, name).detail;

  const fs::path fade = writeSynthetic("input_fade");
  editFrames(fade, [](int t, LayerSet& f) {
    if (t == 4) f.get("color").fill(0.0f);
  });
  const CaptureCheck oneBlack = checkNamed(validate(fade), "color.blackFrames");
  EXPECT_EQ(oneBlack.status, CheckStatus::Warn);
  EXPECT_NE(oneBlack.detail.find("frame(s) 4 "), std::string::npos) << oneBlack.detail;

  const fs::path dark = writeSynthetic("input_black");
  editFrames(dark, [](int, LayerSet& f) { f.get("color").fill(0.0f); });
  const CaptureValidation darkV = validate(dark);
  EXPECT_EQ(checkNamed(darkV, "color.blackFrames").status, CheckStatus::Fail);
  EXPECT_EQ(checkNamed(darkV, "color.blackFrames").value, 6.0);
  // ... and the run refuses it: no pair is scored on it.
  const json r =
      runMatrix(captureRun(test::freshDir("input_black_run"), {{"passthrough", {}, ""}}, {dark}));
  ASSERT_FALSE(r["pairs"].empty());
  for (const json& p : r["pairs"]) {
    EXPECT_EQ(p["status"], "failed") << p["label"];
    EXPECT_NE(p.value("error", "").find("color.blackFrames"), std::string::npos)
        << p.value("error", "");
  }

  const fs::path blackRef = writeSynthetic("reference_black");
  editReferences(blackRef, [](int, Image& c) { c.fill(0.0f); });
  EXPECT_EQ(checkNamed(validate(blackRef), "reference.blackFrames").status, CheckStatus::Fail);
  const fs::path oneBlackRef = writeSynthetic("reference_one_black");
  editReferences(oneBlackRef, [](int k, Image& c) {
    if (k == 2) c.fill(0.0f);
  });
  EXPECT_EQ(checkNamed(validate(oneBlackRef), "reference.blackFrames").status, CheckStatus::Warn);

  const fs::path negated = writeSynthetic("reference_negated");
  editReferences(negated, [](int, Image& c) {
    for (float& v : c.raw()) v = -v;
  });
  const CaptureCheck neg = checkNamed(validate(negated), "reference.negative");
  EXPECT_EQ(neg.status, CheckStatus::Fail);
  EXPECT_GT(neg.value, 0.5);

  const fs::path repeated = writeSynthetic("reference_is_input");
  const CaptureDescription c = readCaptureDescription(repeated);
  editReferences(repeated, [&](int k, Image& ref) { ref = readCaptureFrame(c, k).get("color"); });
  const CaptureCheck eq = checkNamed(validate(repeated), "reference.equalsInput");
  EXPECT_EQ(eq.status, CheckStatus::Fail);
  EXPECT_EQ(eq.value, 6.0);
  EXPECT_NE(eq.detail.find("frame(s) 0, 1, 2, 3, 4, 5 "), std::string::npos) << eq.detail;
  // The same with one NaN pixel in each input frame: equal on every finite value is equal (the NaN,
  // read as 0, hid it and the input ranked at a near-perfect score: a re-trial).
  const fs::path nanned = writeSynthetic("reference_is_input_but_a_nan");
  editReferences(nanned, [&](int k, Image& ref) { ref = readCaptureFrame(c, k).get("color"); });
  editFrames(nanned, [](int, LayerSet& f) {
    f.get("color").at(1, 1, 0) = std::numeric_limits<float>::quiet_NaN();
  });
  EXPECT_EQ(checkNamed(validate(nanned), "reference.equalsInput").status, CheckStatus::Fail);

  // A fade: frame 3 black in the input and its reference alike. Both are said (warnings); the
  // frames are not "equal to the input" (nothing to score), so the capture is not refused.
  const fs::path fadeBoth = writeSynthetic("fade_both");
  editFrames(fadeBoth, [](int t, LayerSet& f) {
    if (t == 3) f.get("color").fill(0.0f);
  });
  editReferences(fadeBoth, [](int k, Image& img) {
    if (k == 3) img.fill(0.0f);
  });
  const CaptureValidation fadeV = validate(fadeBoth);
  EXPECT_EQ(checkNamed(fadeV, "reference.equalsInput").status, CheckStatus::Pass)
      << checkNamed(fadeV, "reference.equalsInput").detail;
  EXPECT_EQ(checkNamed(fadeV, "color.blackFrames").status, CheckStatus::Warn);
  EXPECT_EQ(checkNamed(fadeV, "reference.blackFrames").status, CheckStatus::Warn);
  EXPECT_NE(fadeV.status(), CheckStatus::Fail) << fadeV.failures();
  // One frame's reference copied from its input: a warning; every frame's: refused (above).
  const fs::path oneCopied = writeSynthetic("reference_one_copied");
  const CaptureDescription oc = readCaptureDescription(oneCopied);
  editReferences(oneCopied, [&](int k, Image& ref) {
    if (k == 1) ref = readCaptureFrame(oc, k).get("color");
  });
  EXPECT_EQ(checkNamed(validate(oneCopied), "reference.equalsInput").status, CheckStatus::Warn);
  // Copied on every frame a run scores but the warm-up's: validate, which knows no warm-up, warns;
  // a run with a warm-up of 2 refuses the capture (the input would score a perfect 0 there).
  const fs::path lateCopied = writeSynthetic("reference_copied_after_warmup");
  const CaptureDescription lc = readCaptureDescription(lateCopied);
  editReferences(lateCopied, [&](int k, Image& ref) {
    if (k >= 2) ref = readCaptureFrame(lc, k).get("color");
  });
  EXPECT_EQ(checkNamed(validate(lateCopied), "reference.equalsInput").status, CheckStatus::Warn);
  RunConfig late =
      captureRun(test::freshDir("reference_copied_run"), {{"eaw", {}, ""}}, {lateCopied});
  late.warmup = 2;
  const json lateRun = runMatrix(late);
  ASSERT_FALSE(lateRun["pairs"].empty());
  for (const json& pair : lateRun["pairs"]) {  // eaw and the baselines
    EXPECT_EQ(pair["status"], "failed");
    EXPECT_NE(pair.value("error", "")
                  .find("every frame the run scores (from frame 2, after the "
                        "warm-up) equals its reference value for value"),
              std::string::npos)
        << pair.value("error", "");
  }
  // The same where the input holds a NaN the reference holds as 0: the input as denoisers read it.
  const fs::path nanCopied = writeSynthetic("reference_copied_nan");
  editFrames(nanCopied, [](int, LayerSet& f) {
    f.get("color").at(1, 1, 0) = std::numeric_limits<float>::quiet_NaN();
  });
  const CaptureDescription nc = readCaptureDescription(nanCopied);
  editReferences(nanCopied, [&](int k, Image& ref) {
    if (k < 2) return;
    ref = readCaptureFrame(nc, k).get("color");
    ref.at(1, 1, 0) = 0.0f;
  });
  RunConfig nanRun =
      captureRun(test::freshDir("reference_copied_nan_run"), {{"eaw", {}, ""}}, {nanCopied});
  nanRun.warmup = 2;
  for (const json& pair : runMatrix(nanRun)["pairs"])
    EXPECT_NE(pair.value("error", "").find("equals its reference value for value"),
              std::string::npos)
        << pair.dump().substr(0, 300);
  late.warmup = 1;  // frame 1 is scored too, and differs: measured
  late.out = test::freshDir("reference_copied_run_1");
  for (const json& pair : runMatrix(late)["pairs"]) EXPECT_EQ(pair["status"], "ok");
  // A fade to black held from frame 2, in the input and its references alike: validate warns
  // (not every frame is black); a run with a warm-up of 2 refuses the capture (every output
  // would be measured against black: nothing to measure), and one with a warm-up of 1 measures.
  const fs::path lateBlack = writeSynthetic("reference_black_after_warmup");
  editFrames(lateBlack, [](int t, LayerSet& f) {
    if (t >= 2) f.get("color").fill(0.0f);
  });
  editReferences(lateBlack, [](int k, Image& ref) {
    if (k >= 2) ref.fill(0.0f);
  });
  const CaptureValidation lateBlackV = validate(lateBlack);
  EXPECT_EQ(checkNamed(lateBlackV, "reference.blackFrames").status, CheckStatus::Warn);
  EXPECT_NE(lateBlackV.status(), CheckStatus::Fail) << lateBlackV.failures();
  RunConfig black =
      captureRun(test::freshDir("reference_black_run"), {{"eaw", {}, ""}}, {lateBlack});
  black.warmup = 2;
  const json blackRun = runMatrix(black);
  ASSERT_FALSE(blackRun["pairs"].empty());
  for (const json& pair : blackRun["pairs"]) {
    EXPECT_EQ(pair["status"], "failed");
    EXPECT_NE(pair.value("error", "")
                  .find("the reference of every frame the run scores (from frame 2, after the "
                        "warm-up) is black"),
              std::string::npos)
        << pair.value("error", "");
  }
  black.warmup = 1;
  black.out = test::freshDir("reference_black_run_1");
  for (const json& pair : runMatrix(black)["pairs"]) EXPECT_EQ(pair["status"], "ok");
  // A filtered reference's tiny negative values (a negative filter lobe) are not negative radiance.
  const fs::path lobes = writeSynthetic("reference_lobes");
  editReferences(lobes, [](int, Image& img) {
    for (size_t i = 0; i < img.raw().size(); i += 3) img.raw()[i] = -1e-7f;
  });
  EXPECT_EQ(checkNamed(validate(lobes), "reference.negative").status, CheckStatus::Pass);
}

// A stored position must be where depth and camera put it: one in other units (millimetres) is
// refused and the ratio said; one from a sample off the pixel centre (jitter) and stored as half
// floats passes; a capture without positions derives them and is not checked.
TEST(CaptureValidation, PositionsInOtherUnitsThanDepthAreRefused) {
  const Synthetic s;
  const fs::path dir = writeSynthetic("positions");
  auto writePositions = [&](glm::vec2 sampleOffset, bool halfFloats) {
    editFrames(dir, [&](int t, LayerSet& f) {
      const CameraState cam = s.camera(t);
      Image position(s.w, s.h, 3);
      for (int y = 0; y < s.h; ++y)
        for (int x = 0; x < s.w; ++x) {
          const glm::vec3 ray =
              cam.rayDirection(float(x) + 0.5f + sampleOffset.x, float(y) + 0.5f + sampleOffset.y);
          const glm::vec3 p =
              cam.eye + ray * (f.get("depth").at(x, y) / glm::dot(ray, cam.forward));
          for (int k = 0; k < 3; ++k) position.at(x, y, k) = halfFloats ? float(half(p[k])) : p[k];
        }
      f.set("position", std::move(position));
    });
  };
  writePositions({0.7f, -0.6f}, true);
  const CaptureCheck jittered = checkNamed(validate(dir), "position.consistency");
  EXPECT_EQ(jittered.status, CheckStatus::Pass) << jittered.value << " " << jittered.detail;
  writePositions({0.0f, 0.0f}, false);
  const CaptureCheck good = checkNamed(validate(dir), "position.consistency");
  EXPECT_EQ(good.status, CheckStatus::Pass) << good.value << " " << good.detail;
  EXPECT_NEAR(good.value, 0.0, 1e-9);
  editFrames(dir, [](int, LayerSet& f) {
    for (float& v : f.get("position").raw()) v *= 1000.0f;
  });
  const CaptureCheck mm = checkNamed(validate(dir), "position.consistency");
  EXPECT_EQ(mm.status, CheckStatus::Fail) << mm.value;
  EXPECT_NE(mm.detail.find("depth layer 1000"), std::string::npos) << mm.detail;
  EXPECT_THROW(checkNamed(validate(writeSynthetic("positions_derived")), "position.consistency"),
               Error);
}

// A capture of the colour alone (with its required guides): passthrough, which reads nothing but
// its signal, scores the colour as given -- exactly what it scores on the same capture with the
// parts -- while a filter that needs the parts fails naming them.
TEST(Capture, PassthroughScoresAColourOnlyCaptureAsTheInputItIs) {
  const fs::path full = copyCapture(exportedCornell(), "with_parts");
  const fs::path bare = copyCapture(exportedCornell(), "colour_only");
  editFrames(bare, [](int, LayerSet& f) {
    LayerSet kept;
    for (const char* layer : {"color", "normal", "depth", "motion"}) kept.set(layer, f.get(layer));
    f = std::move(kept);
  });
  const std::vector<std::string> layers = readCaptureDescription(bare).layers;
  ASSERT_EQ(std::count(layers.begin(), layers.end(), "diffuse"), 0);
  const json withParts =
      runMatrix(captureRun(test::freshDir("with_parts_run"), {{"passthrough", {}, ""}}, {full}));
  const json colourOnly = runMatrix(captureRun(
      test::freshDir("colour_only_run"), {{"passthrough", {}, ""}, {"svgf", {}, ""}}, {bare}));
  const json a = pairOf(withParts, "passthrough"), b = pairOf(colourOnly, "passthrough");
  ASSERT_EQ(b["status"], "ok") << b.dump().substr(0, 400);
  // Passthrough's output is the colour layer itself, with or without the parts: the same bits.
  EXPECT_EQ(b["signals"], "color");
  EXPECT_EQ(a["signals"], "color");
  EXPECT_EQ(b["outputChecksum"], a["outputChecksum"]);
  EXPECT_EQ(b["summary"]["relMse"]["mean"].get<double>(),
            a["summary"]["relMse"]["mean"].get<double>());
  const json svgf = pairOf(colourOnly, "svgf");
  EXPECT_EQ(svgf["status"], "failed");
  EXPECT_NE(svgf.value("error", "").find("'diffuse'"), std::string::npos)
      << svgf.value("error", "");
}

// `arena validate` reads the stored outputs as a run would: a missing, mis-sized or non-finite
// frame fails (naming the file), an undeclared folder warns; a run fails only that output's pair.
TEST(CaptureValidation, StoredOutputsAreCheckedLikeARunReadsThem) {
  const fs::path dir = copyCapture(exportedCornell(), "outputs_checked", [](json& d) {
    d["outputs"] = {
        {"good", json::object()},   {"short", json::object()},  {"small", json::object()},
        {"nan", json::object()},    {"oracle", json::object()}, {"copied", json::object()},
        {"bright", json::object()}, {"absent", json::object()}, {"black", json::object()},
        {"warm", json::object()},   {"dark", json::object()},   {"partoracle", json::object()}};
  });
  const CaptureDescription base = readCaptureDescription(exportedCornell());
  const int w = base.info.width, h = base.info.height;
  auto write = [&](const std::string& name, int t, const Image& color) {
    fs::create_directories(dir / "outputs" / name);
    LayerSet l;
    l.set("color", color);
    writeExr(dir / "outputs" / name / numberedFileName("frame", t, 4), l,
             {{"color", {"R", "G", "B"}, false}});
  };
  for (int t = 0; t < base.info.frames; ++t) {
    Image good = readCaptureReference(base, base.info.referenceOfFrame[size_t(t)]).get("color");
    for (float& v : good.raw()) v *= 1.05f;  // readable, at the references' exposure
    write("good", t, good);
    if (t != 3) write("short", t, Image(w, h, 3, 0.5f));
    write("small", t, Image(t == 1 ? w / 2 : w, h, 3, 0.5f));
    Image bad(w, h, 3, 0.5f);
    if (t == 5) bad.at(1, 1, 0) = std::numeric_limits<float>::quiet_NaN();
    write("nan", t, bad);
    write("oracle", t,
          readCaptureReference(base, base.info.referenceOfFrame[size_t(t)]).get("color"));
    Image part = readCaptureReference(base, base.info.referenceOfFrame[size_t(t)]).get("color");
    if (t == base.info.frames - 1)
      for (float& v : part.raw()) v *= 1.05f;  // the reference but on its last frame
    write("partoracle", t, part);
    write("copied", t, readCaptureFrame(base, t).get("color"));  // the noisy input itself
    Image bright = readCaptureReference(base, base.info.referenceOfFrame[size_t(t)]).get("color");
    Image warm = bright;
    for (float& v : bright.raw()) v *= 3;  // another exposure
    write("bright", t, bright);
    for (float& v : warm.raw()) v *= 1.5f;  // a warning, still scored
    write("warm", t, warm);
    Image dark = readCaptureReference(base, base.info.referenceOfFrame[size_t(t)]).get("color");
    for (float& v : dark.raw()) v *= 0.3f;  // as much light as hybrid keeps of hard_light's
    write("dark", t, dark);
    write("black", t, Image(w, h, 3, 0.0f));  // the extreme case: no light at all
  }
  fs::create_directories(dir / "outputs" / "forgotten");
  const CaptureValidation v = validateCaptureOutputs(
      readCaptureDescription(dir), readSequenceForEvaluation(Sequence::open(dir)).references);
  EXPECT_EQ(checkNamed(v, "output.good").status, CheckStatus::Pass) << checkNamed(v, "output.good").detail;
  const CaptureCheck &missing = checkNamed(v, "output.short"), &small = checkNamed(v, "output.small"),
                     &nan = checkNamed(v, "output.nan"), &forgotten = checkNamed(v, "outputs.undeclared");
  EXPECT_EQ(missing.status, CheckStatus::Fail);
  EXPECT_NE(missing.detail.find("frame(s) 3 "), std::string::npos) << missing.detail;
  EXPECT_NE(missing.detail.find("frame_0003.exr"), std::string::npos) << missing.detail;
  // Said as a missing input frame is: the numbering expected and what the folder holds (an output
  // numbered from 1 got a bare "file does not exist").
  EXPECT_NE(missing.detail.find("frame_0003.exr: file does not exist; short's frames are "
                                "frame_0000.exr to "),
            std::string::npos)
      << missing.detail;
  EXPECT_NE(missing.detail.find("(numbered from 0, four digits); the folder holds frame_0000.exr, "
                                "frame_0001.exr, frame_0002.exr, ... ("),
            std::string::npos)
      << missing.detail;
  EXPECT_EQ(small.status, CheckStatus::Fail);
  EXPECT_NE(small.detail.find("expected " + std::to_string(w) + "x" + std::to_string(h)), std::string::npos) << small.detail;
  EXPECT_EQ(nan.status, CheckStatus::Fail);
  EXPECT_NE(nan.detail.find("1 non-finite colour values"), std::string::npos) << nan.detail;
  // A declared folder that is not there fails that output, not the capture.
  const CaptureCheck& absent = checkNamed(v, "output.absent");
  EXPECT_EQ(absent.status, CheckStatus::Fail);
  EXPECT_NE(absent.detail.find("outputs.absent: folder " + (dir / "outputs" / "absent").string() +
                               " does not exist (capture.json declares it)"),
            std::string::npos)
      << absent.detail;
  EXPECT_EQ(forgotten.status, CheckStatus::Warn);
  EXPECT_NE(forgotten.detail.find("forgotten"), std::string::npos) << forgotten.detail;
  // An output that is the reference on some frames scores perfectly there: a warning; on every
  // frame it is no denoiser's output (a run fails its pair), and fails.
  EXPECT_EQ(checkNamed(v, "output.oracle").status, CheckStatus::Pass);
  const CaptureCheck& oracle = checkNamed(v, "output.oracle.equalsReference");
  EXPECT_EQ(oracle.status, CheckStatus::Fail);
  EXPECT_EQ(oracle.value, double(base.info.frames));
  const CaptureCheck& partOracle = checkNamed(v, "output.partoracle.equalsReference");
  EXPECT_EQ(partOracle.status, CheckStatus::Warn);
  EXPECT_EQ(partOracle.value, double(base.info.frames - 1));
  EXPECT_THROW(checkNamed(v, "output.good.equalsReference"), Error);
  // An output at another exposure is said before it is scored as a poor denoiser.
  const CaptureCheck& bright = checkNamed(v, "output.bright.brightnessVsReference");
  EXPECT_EQ(bright.status, CheckStatus::Fail) << bright.detail;
  EXPECT_NEAR(bright.value, 3.0, 1e-3);
  EXPECT_NE(bright.detail.find("mean luminance 3x the references'"), std::string::npos)
      << bright.detail;
  EXPECT_EQ(checkNamed(v, "output.oracle.brightnessVsReference").status, CheckStatus::Pass);
  EXPECT_EQ(checkNamed(v, "output.warm.brightnessVsReference").status, CheckStatus::Warn);
  // Darker is a warning: a denoiser that clamps fireflies loses light (failing it failed a stored
  // copy of hybrid's output on hard_light, about 0.3x).
  const CaptureCheck& dark = checkNamed(v, "output.dark.brightnessVsReference");
  EXPECT_EQ(dark.status, CheckStatus::Warn) << dark.detail;
  EXPECT_NE(dark.detail.find("a denoiser that clamps fireflies loses light too"), std::string::npos)
      << dark.detail;
  const CaptureCheck& black = checkNamed(v, "output.black.brightnessVsReference");
  EXPECT_EQ(black.status, CheckStatus::Fail) << black.detail;
  EXPECT_NE(black.detail.find("mean luminance 0x the references'"), std::string::npos)
      << black.detail;
  // The capture itself stays usable: a run scores the good output and fails only the bad ones.
  const json r = runMatrix(captureRun(test::freshDir("outputs_checked_run"),
                                      {{"file:good", {}, ""},
                                       {"file:short", {}, ""},
                                       {"file:absent", {}, ""},
                                       {"passthrough", {}, ""}},
                                      {dir}));
  EXPECT_EQ(pairOf(r, "file:absent")["status"], "failed");
  EXPECT_NE(pairOf(r, "file:absent")["error"].get<std::string>().find("does not exist"),
            std::string::npos)
      << pairOf(r, "file:absent")["error"];
  EXPECT_EQ(pairOf(r, "file:good")["status"], "ok") << pairOf(r, "file:good").dump().substr(0, 300);
  EXPECT_EQ(pairOf(r, "passthrough")["status"], "ok");
  EXPECT_EQ(pairOf(r, "file:short")["status"], "failed");
  // An output that is its input on every frame is scored, and said to have filtered nothing
  // (passthrough, an identity by design, is not); with no time recorded, its ms summary says so.
  const json copied =
      runMatrix(captureRun(test::freshDir("outputs_copied_run"),
                           {{"file:copied", {}, ""}, {"passthrough", {}, ""}}, {dir}));
  const json copy = pairOf(copied, "file:copied");
  ASSERT_EQ(copy["status"], "ok") << copy.dump().substr(0, 300);
  EXPECT_TRUE(copy.value("equalsInputEveryFrame", false));
  EXPECT_NE(copy["warnings"][0].get<std::string>().find(
                "the output is its input value for value on all " +
                std::to_string(base.info.frames) + " frames"),
            std::string::npos)
      << copy["warnings"];
  EXPECT_FALSE(pairOf(copied, "passthrough").contains("equalsInputEveryFrame"));
  // A run scores both, each with its warning: a denoiser that clamps fireflies loses light (hybrid
  // keeps about 0.3x of hard_light's), so a run cannot tell a slip from a bias by the factor;
  // validate fails only the brighter side beyond 2x (tried: failing a run's pair beyond 2x failed a
  // stored copy of hybrid's own output while the built-in ranked first).
  const json lit = runMatrix(captureRun(test::freshDir("outputs_bright_run"),
                                        {{"file:bright", {}, ""}, {"file:warm", {}, ""}}, {dir}));
  const json& brighter = pairOf(lit, "file:bright");
  ASSERT_EQ(brighter["status"], "ok") << brighter.dump().substr(0, 300);
  EXPECT_NEAR(brighter.value("brightnessVsReference", 0.0), 3.0, 1e-3);
  EXPECT_NE(brighter["warnings"].dump().find("its output's mean luminance is 3x the references'"),
            std::string::npos)
      << brighter["warnings"];
  const json& warmer = pairOf(lit, "file:warm");
  ASSERT_EQ(warmer["status"], "ok") << warmer.dump().substr(0, 300);
  EXPECT_NEAR(warmer.value("brightnessVsReference", 0.0), 1.5, 1e-3);
  EXPECT_NE(warmer["warnings"].dump().find("its output's mean luminance is 1.5x the references'"),
            std::string::npos)
      << warmer["warnings"];
  EXPECT_FALSE(copy.contains("brightnessVsReference"));  // a noisy input averages to its reference
  // The reference wired in as the output: a perfect score, said while the run goes, not only kept.
  RunConfig wired =
      captureRun(test::freshDir("outputs_oracle_run"),
                 {{"file:oracle", {}, ""}, {"file:partoracle", {}, ""}, {"eaw", {}, ""}}, {dir});
  std::vector<std::string> said;
  wired.progress = [&](const std::string& line) { said.push_back(line); };
  const json wiredRun = runMatrix(wired);
  // It is no denoiser's best: the reference's verdict is judged on the real one (a corrected
  // relMSE of 0 or less left it unknown for every method).
  const std::string verdict =
      wiredRun["scenes"][readCaptureDescription(dir).info.scene]["referenceQuality"].value(
          "verdict", "");
  EXPECT_NE(verdict.find(" (eaw) = "), std::string::npos) << verdict;
  EXPECT_NE(std::find_if(
                said.begin(), said.end(),
                [](const std::string& l) {
                  return l.rfind("  warning: the output equals its reference value for value on ",
                                 0) == 0;
                }),
            said.end());
  // The reference on every frame scored: the pair fails, saying why; the other is scored, warned.
  const json& wiredPair = pairOf(wiredRun, "file:oracle");
  EXPECT_EQ(wiredPair["status"], "failed");
  EXPECT_NE(wiredPair.value("error", "")
                .find("the output equals its reference value for value on every frame scored"),
            std::string::npos)
      << wiredPair.value("error", "");
  EXPECT_EQ(pairOf(wiredRun, "file:partoracle")["status"], "ok");
  EXPECT_NE(copy["summary"]["ms"].value("absent", "").find("not recorded in the capture"),
            std::string::npos)
      << copy["summary"]["ms"];
  // The warning repeating it says the same, not "not finite" (no value was).
  const std::string warnings = copy["warnings"].dump();
  EXPECT_NE(warnings.find("ms has no summary: not recorded in the capture"), std::string::npos)
      << warnings;
  EXPECT_EQ(warnings.find("not finite"), std::string::npos) << warnings;
}

// Parts written before demodulation (an engine's lit diffuse): the denoisers, which read the
// parts, would be ranked on another image than the colour. Named, and the capture fails.
TEST(CaptureValidation, PartsThatWereNotDemodulatedAreNamed) {
  const fs::path clean = exportedCornell();
  EXPECT_EQ(checkNamed(validate(clean), "color.equalsParts").status, CheckStatus::Pass);
  const fs::path lit = copyCapture(clean, "parts_lit");
  editFrames(lit, [](int, LayerSet& f) {
    Image& d = f.get("diffuse");
    const Image& a = f.get("albedo");
    for (size_t i = 0; i < d.raw().size(); ++i) d.raw()[i] *= a.raw()[i];
  });
  const CaptureCheck c = checkNamed(validate(lit), "color.equalsParts");
  EXPECT_EQ(c.status, CheckStatus::Fail) << c.value << " " << c.detail;
  EXPECT_NE(c.detail.find("diffuse holds lit radiance, not demodulated"), std::string::npos)
      << c.detail;
  // Parts that differ in no named way (another lobe in the colour) only warn, saying what it means.
  const fs::path other = copyCapture(clean, "parts_other");
  editFrames(other, [](int, LayerSet& f) {
    for (float& v : f.get("color").raw()) v = v * 1.1f + 0.01f;
  });
  const CaptureCheck w = checkNamed(validate(other), "color.equalsParts");
  EXPECT_EQ(w.status, CheckStatus::Warn) << w.value << " " << w.detail;
  EXPECT_NE(w.detail.find("the denoisers read the parts, not this colour"), std::string::npos)
      << w.detail;
  // No emission layer where a light is in view: the parts lack its light, which a share of values
  // hid (a few pixels); counted as a share of the colour's light, it is said.
  const fs::path unlit = copyCapture(clean, "parts_no_emission");
  dropLayer(unlit, "emission");
  const CaptureValidation noEmission = validate(unlit);
  const CaptureCheck& missing = checkNamed(noEmission, "emission.missing");
  EXPECT_EQ(missing.status, CheckStatus::Warn) << missing.value << " " << missing.detail;
  EXPECT_GT(missing.value, 0.01);
  EXPECT_THROW(checkNamed(validate(clean), "emission.missing"), Error);  // emission given
}

// What the folder holds beyond its description is said, never silently ignored: a channel no layer
// names (a typo), files no frame or reference is, an independent half equal to its mean; a frame
// whose attribute names another frame (copied over it) is refused.
TEST(CaptureValidation, UndescribedFilesUnknownChannelsAndMisplacedFramesAreSaid) {
  const CaptureValidation clean = validate(exportedCornell());
  for (const char* name : {"channels.unknown", "files.unexpected", "reference.halfEqualsMean"})
    EXPECT_EQ(checkNamed(clean, name).status, CheckStatus::Pass)
        << name << ": " << checkNamed(clean, name).detail;

  const fs::path dir = copyCapture(exportedCornell(), "undescribed");
  const CaptureDescription c = readCaptureDescription(dir);
  {  // frame 0 with a misspelt roughness channel beside its layers
    LayerSet f = readCaptureFrame(c, 0);
    std::vector<LayerSpec> specs;
    for (const LayerSpec& spec : channels::frameLayers())
      if (!spec.topLevel && f.has(spec.name) &&
          std::count(c.layers.begin(), c.layers.end(), spec.name))
        specs.push_back(spec);
    f.set("roughnes", f.get("roughness"));
    specs.push_back({"roughnes", {"X"}, false});
    writeExr(captureFramePath(dir, 0), f, specs, {{"arena.capture.frame", "0"}});
  }
  fs::copy_file(captureFramePath(dir, 1), dir / numberedFileName("frame", c.info.frames, 4));
  std::ofstream(dir / "notes.txt") << "x";
  {  // every reference's half set to its mean
    for (int r = 0; r < int(c.info.referenceSpp.size()); ++r) {
      LayerSet ref = readCaptureReference(c, r);
      ref.set("colorHalf", ref.get("color"));
      writeExr(captureReferencePath(dir, r), ref,
               {{"color", {"R", "G", "B"}},
                {"colorVar", {"R", "G", "B"}},
                {"colorHalf", {"R", "G", "B"}}});
    }
  }
  const CaptureValidation v = validate(dir);
  const CaptureCheck &unknown = checkNamed(v, "channels.unknown"),
                     &stray = checkNamed(v, "files.unexpected"),
                     &half = checkNamed(v, "reference.halfEqualsMean");
  EXPECT_EQ(unknown.status, CheckStatus::Warn);
  EXPECT_NE(unknown.detail.find("roughnes.X"), std::string::npos) << unknown.detail;
  // Beside the roughness it misspells, no hint: the file holds roughness already.
  EXPECT_EQ(unknown.detail.find("(roughness?)"), std::string::npos) << unknown.detail;
  EXPECT_EQ(stray.status, CheckStatus::Warn);
  EXPECT_EQ(stray.value, 2.0);
  EXPECT_NE(stray.detail.find(numberedFileName("frame", c.info.frames, 4) + ", notes.txt"),
            std::string::npos)
      << stray.detail;
  EXPECT_EQ(half.status, CheckStatus::Warn);
  EXPECT_NE(v.status(), CheckStatus::Fail) << v.failures();

  // Frame 1 copied over frame 2: its attribute says it is frame 1.
  fs::copy_file(captureFramePath(dir, 1), captureFramePath(dir, 2),
                fs::copy_options::overwrite_existing);
  const std::string error = test::errorOf([&] { readCaptureDescription(dir); });
  EXPECT_NE(
      error.find(
          "frame_0002.exr: holds frame 1 (its arena.capture.frame attribute), where the frames "
          "before it say frame 2"),
      std::string::npos)
      << error;
  // Frames renumbered after a trim keep one offset between name and attribute: they stand.
  const fs::path shifted = copyCapture(exportedCornell(), "shifted");
  const CaptureDescription sc = readCaptureDescription(shifted);
  std::vector<LayerSpec> given;
  for (const LayerSpec& spec : channels::frameLayers())
    if (!spec.topLevel && std::count(sc.layers.begin(), sc.layers.end(), spec.name) &&
        !std::count(sc.derived.begin(), sc.derived.end(), spec.name))
      given.push_back(spec);
  for (int t = 0; t < sc.info.frames; ++t)
    writeExr(captureFramePath(shifted, t), readExr(captureFramePath(shifted, t), given).layers,
             given, {{"arena.capture.frame", std::to_string(t + 5)}});
  EXPECT_NO_THROW(readCaptureDescription(shifted));
}

// Every frame holds frame 0's layers: one a later frame adds, whole or in part, is refused (it
// would be ignored), as one it lacks is.
TEST(CaptureContract, ALayerOnlyALaterFrameHasIsRefused) {
  const fs::path whole = writeSynthetic("later_layer");
  editFrames(whole, [](int t, LayerSet& f) {
    if (t == 2) f.set("specular", Image(f.width(), f.height(), 3));
  });
  const CaptureDescription c = readCaptureDescription(whole);
  EXPECT_NO_THROW(readCaptureFrame(c, 1));
  {
    const std::string error = test::errorOf([&] { readCaptureFrame(c, 2); });
    EXPECT_NE(
        error.find("frame_0002.exr: layer 'specular' is in this frame but not in frame_0000.exr"),
        std::string::npos)
        << error;
  }
  const fs::path partial = writeSynthetic("later_partial");
  {
    LayerSet f = readCaptureFrame(readCaptureDescription(partial), 3);
    f.set("diffuse", Image(f.width(), f.height(), 1));
    std::vector<LayerSpec> specs;
    for (const LayerSpec& s : channels::frameLayers())
      if (!s.topLevel && f.has(s.name) && s.name != "diffuse" && s.name != "emission" &&
          s.name != "position")
        specs.push_back(s);
    specs.push_back({"diffuse", {"R"}});  // diffuse.R alone
    writeExr(captureFramePath(partial, 3), f, specs);
  }
  {
    const std::string error =
        test::errorOf([&] { readCaptureFrame(readCaptureDescription(partial), 3); });
    EXPECT_NE(error.find("layer 'diffuse' lacks channel(s) 'diffuse.G', 'diffuse.B'"),
              std::string::npos)
        << error;
  }
}

// A reference without a variance (or an independent half) has an unknown noise floor: the run
// says so and scores everything else; a capture no longer than the warm-up runs with every
// summary absent, warned, never NaN.
TEST(Capture, AnUnknownFloorAndAShortCaptureRunToTheEnd) {
  const fs::path dir = copyCapture(exportedCornell(), "no_variance");
  {
    const CaptureDescription c = readCaptureDescription(dir);
    ASSERT_TRUE(c.referenceHasVariance);
    for (size_t r = 0; r < c.info.referenceSpp.size(); ++r) {
      LayerSet colourOnly;
      colourOnly.set("color", readCaptureReference(c, int(r)).get("color"));
      writeExr(captureReferencePath(dir, int(r)), colourOnly, {{"color", {"R", "G", "B"}}});
    }
    ASSERT_FALSE(readCaptureDescription(dir).referenceHasVariance);
  }
  const json r = runMatrix(captureRun(test::freshDir("no_variance_run"), {{"eaw", {}, ""}}, {dir}));
  const json p = pairOf(r, "eaw");
  ASSERT_EQ(p["status"], "ok") << p.dump().substr(0, 400);
  EXPECT_GT(p["summary"]["relMse"]["mean"].get<double>(), 0.0);
  ASSERT_TRUE(p["timing"].contains("gpuPredicted"));  // what the short run below must leave out
  const json& quality = r["scenes"]["no_variance"]["referenceQuality"];
  EXPECT_FALSE(quality.contains("floor")) << quality;
  EXPECT_NE(quality["verdict"].get<std::string>().find("unknown"), std::string::npos) << quality;

  RunConfig shortRun = captureRun(test::freshDir("short_capture_run"), {{"eaw", {}, ""}}, {dir});
  shortRun.warmup = 10;  // the capture has 10 frames
  const json s = runMatrix(shortRun);
  const json q = pairOf(s, "eaw");
  ASSERT_EQ(q["status"], "ok") << q.dump().substr(0, 400);
  EXPECT_FALSE(q["summary"]["relMse"].contains("mean"));
  EXPECT_TRUE(q["summary"]["relMse"].contains("absent"));
  EXPECT_FALSE(q["timing"].contains("gpuPredicted")) << q["timing"];
  EXPECT_FALSE(q["timing"].contains("msMedian"))
      << q["timing"];  // the warm-up's times are not the method's
  EXPECT_NE(q["timing"].value("absent", "").find("no frame after the warm-up"), std::string::npos)
      << q["timing"];
  const test::CommandResult cli =
      test::runCommand(std::string(ARENA_BINARY) + " run --capture '" + dir.string() +
                       "' --denoisers passthrough --no-baselines --flip none --warmup 10 --out '" +
                       (test::freshDir("short_capture_cli") / "run").string() + "'");
  EXPECT_NE(cli.output.find("warning: " + dir.string() +
                            ": the sequence has 10 frames and the warm-up excludes the first 10"),
            std::string::npos)
      << cli.output;
}
// A beauty pass stored in plain R, G, B (a viewer's copy, never read) and no color.*: refused
// saying so, not with a bare "no colour".
TEST(CaptureContract, AColourInPlainRgbIsRefusedSayingSo) {
  const fs::path dir = copyCapture(exportedCornell(), "plain_rgb");
  const CaptureDescription c = readCaptureDescription(dir);
  std::vector<LayerSpec> guides = {{"color", {"R", "G", "B"}, false, true}};
  for (const LayerSpec& spec : channels::frameLayers())
    if (!spec.topLevel && spec.name != "color" && spec.name != "diffuse" &&
        std::count(c.layers.begin(), c.layers.end(), spec.name) &&
        !std::count(c.derived.begin(), c.derived.end(), spec.name))
      guides.push_back(spec);
  writeExr(captureFramePath(dir, 0), readCaptureFrame(c, 0), guides);
  const std::string error = test::errorOf([&] { readCaptureDescription(dir); });
  EXPECT_NE(error.find("no colour: give 'color'"), std::string::npos) << error;
  EXPECT_NE(
      error.find("the file holds plain R, G, B, which are a viewer's copy and never read: name "
                 "them color.R, color.G, color.B"),
      std::string::npos)
      << error;
  // A reference or a stored output in plain R, G, B: the same hint.
  const fs::path refDir = copyCapture(exportedCornell(), "plain_rgb_reference");
  const CaptureDescription rc = readCaptureDescription(refDir);
  const LayerSet reference = readCaptureReference(rc, 0);
  writeExr(captureReferencePath(refDir, 0), reference, {{"color", {"R", "G", "B"}, false, true}});
  const std::string refError = test::errorOf([&] { readCaptureDescription(refDir); });
  EXPECT_NE(refError.find(
                "missing channel 'color.R' (the reference's colour); the file holds plain R, G, B"),
            std::string::npos)
      << refError;
  const fs::path output = test::freshDir("plain_rgb_output") / "frame_0000.exr";
  writeExr(output, reference, {{"color", {"R", "G", "B"}, false, true}});
  const std::string outError =
      test::errorOf([&] { readOutputFrame(output, "engine", rc.info.width, rc.info.height); });
  EXPECT_NE(outError.find(
                "missing channel 'color.R' (the output's colour); the file holds plain R, G, B"),
            std::string::npos)
      << outError;
}

// A capture whose parts lack the albedo that remodulation needs: every built-in that demodulates is
// left out, saying why, and passthrough, whose output is the colour itself, is what the run
// measures (before, it needed the albedo too and the run measured nothing: a capture's colour,
// given or made from its parts, is always there, so passthrough can always run).
TEST(Capture, AContenderLackingItsInputsIsLeftOutNamingThem) {
  const fs::path dir = copyCapture(exportedCornell(), "no_albedo");
  dropLayer(dir, "albedo");
  const fs::path out = test::freshDir("no_albedo_cli") / "run";
  const test::CommandResult cli =
      test::runCommand(std::string(ARENA_BINARY) + " run --capture '" + dir.string() +
                       "' --flip none --warmup 2 --out '" + out.string() + "'");
  EXPECT_EQ(cli.status, 0) << cli.output;
  EXPECT_NE(
      cli.output.find("  svgf not run on no_albedo: svgf needs channel(s) 'albedo' that capture"),
      std::string::npos)
      << cli.output;
  const json r = parseJsonFile((out / "results.json").string());
  ASSERT_EQ(r["pairs"].size(), 1u) << r["pairs"].dump().substr(0, 300);
  EXPECT_EQ(r["pairs"][0]["label"], "passthrough");
  EXPECT_EQ(r["pairs"][0]["status"], "ok");
  EXPECT_GE(r["scenes"]["no_albedo"]["notRun"].size(), 8u);
}

// ---- file: contenders -------------------------------------------------------------------------

TEST(Capture, AStoredOutputScoresExactlyLikeTheBuiltInThatMadeIt) {
  // svgf runs on the capture, keeping every output frame; those frames stored in a copy of the
  // capture as outputs/svgf_elsewhere are scored as file:svgf_elsewhere.
  RunConfig first = captureRun(test::freshDir("file_first"), {{"svgf", {}, ""}}, {exportedCornell()});
  first.keepFrames = "all";
  first.baselines = false;
  const json a = runMatrix(first);
  const json builtIn = pairOf(a, "svgf");
  ASSERT_EQ(builtIn["status"], "ok");
  const fs::path frames = first.out / builtIn["images"]["dir"].get<std::string>();
  const fs::path dir = copyCapture(exportedCornell(), "cornell_static", [](json& d) {
    d["outputs"] = {{"svgf_elsewhere", {{"milliseconds", std::vector<double>(10, 1.25)}, {"device", "test GPU"}}}};
  });
  fs::create_directories(dir / "outputs" / "svgf_elsewhere");
  for (int t = 0; t < 10; ++t) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04d.exr", t);
    fs::copy_file(frames / name, dir / "outputs" / "svgf_elsewhere" / name);
  }
  RunConfig second = captureRun(test::freshDir("file_second"), {{"file:svgf_elsewhere", {}, ""}}, {dir});
  second.baselines = false;
  const json b = runMatrix(second);
  const json stored = pairOf(b, "file:svgf_elsewhere");
  ASSERT_EQ(stored["status"], "ok") << stored.dump().substr(0, 400);
  json sa = builtIn["summary"], sb = stored["summary"];
  for (const char* m : {"ms", "msWall"}) {
    sa.erase(m);
    sb.erase(m);
  }
  EXPECT_EQ(sa, sb);
  EXPECT_DOUBLE_EQ(stored["summary"]["ms"]["mean"].get<double>(), 1.25);
  EXPECT_EQ(stored["timing"]["clock"], "capture");
  EXPECT_EQ(stored["timing"]["device"], "test GPU");
  EXPECT_EQ(builtIn["timing"]["clock"], "cpu");
}

// ---- bad input ----------------------------------------------------------------------------------

void expectError(const fs::path& dir, const std::string& fragment) {
  try {
    readCaptureDescription(dir);
    ADD_FAILURE() << "accepted; expected an error with '" << fragment << "'";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(CaptureContract, BadDescriptionsAreErrorsNamingTheFieldOrFile) {
  const fs::path good = writeSynthetic("contract_src");
  expectError(copyCapture(good, "v2", [](json& d) { d["version"] = 2; }), "version 2");
  expectError(copyCapture(good, "noframes", [](json& d) { d.erase("frames"); }), "frames");
  expectError(copyCapture(good, "typo", [](json& d) { d["frameRat"] = 30; }), "frameRat");
  // Neither frameRate nor deltaTime: both are named (it named frameRate alone).
  expectError(copyCapture(good, "norate", [](json& d) { d.erase("frameRate"); }),
              "frameRate: missing; expected a number (frames per second; or give deltaTime, a "
              "list of per-frame seconds)");
  expectError(copyCapture(good, "kind_typo",
                          [](json& d) {
                            d["events"] = {{{"frame", 2}, {"kind", "light_of"}}};
                          }),
              "events[0].kind: expected one of light_off, light_on, light_change, object_moves, "
              "camera_cut, got \"light_of\" (light_off?)");
  expectError(copyCapture(good, "view_typo",
                          [](json& d) {
                            d["cameras"][3]["veiw"] = d["cameras"][3]["view"];
                            d["cameras"][3].erase("view");
                          }),
              "cameras[3].view: missing; expected an array of numbers (the object has \"veiw\": a "
              "misspelling of \"view\"?)");
  expectError(copyCapture(good, "cams", [](json& d) { d["cameras"].erase(0); }), "cameras has 5 entries");
  expectError(copyCapture(good, "scaled", [](json& d) { d["cameras"][1]["view"][0] = 2.0; }), "cameras[1].view");
  expectError(copyCapture(good, "offcentre", [](json& d) { d["cameras"][0]["projection"][8] = 0.1; }), "jitter");
  expectError(copyCapture(good, "badref", [](json& d) { d["reference"]["ofFrame"] = {0, 1}; }), "reference.ofFrame");
  expectError(copyCapture(good, "bigframes", [](json& d) { d["frames"] = 7; }), "cameras has 6 entries");
  const fs::path missing = copyCapture(good, "missing");
  fs::remove(captureFramePath(missing, 4));
  expectError(missing, "frame_0004.exr");
  // Matrices written row-major, as many engines hold them: said to look transposed.
  auto transposed = [](json m) {
    json t = m;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) t[size_t(c * 4 + r)] = m[size_t(r * 4 + c)];
    return t;
  };
  expectError(
      copyCapture(good, "view_rows",
                  [&](json& d) { d["cameras"][1]["view"] = transposed(d["cameras"][1]["view"]); }),
      "cameras[1].view: the last row must be (0, 0, 0, 1); it looks transposed");  // camera 0 sits
                                                                                   // at the origin
  expectError(copyCapture(good, "projection_rows",
                          [&](json& d) {
                            d["cameras"][0]["projection"] =
                                transposed(d["cameras"][0]["projection"]);
                          }),
              "expected -1 (a camera looking down -Z, OpenGL clip space); it looks transposed");
  // Frames numbered from 1, as Blender numbers them: the folder's files are named.
  const fs::path fromOne = copyCapture(good, "from_one");
  for (int t = 5; t >= 0; --t)
    fs::rename(captureFramePath(fromOne, t), captureFramePath(fromOne, t + 1));
  expectError(
      fromOne,
      "frame_0000.exr: file does not exist; frames are frame_0000.exr to frame_0005.exr (numbered "
      "from 0, four digits); the folder holds frame_0001.exr, frame_0002.exr, frame_0003.exr, ...");
  // A layer with only some of its channels.
  const fs::path partial = copyCapture(good, "partial");
  {
    LayerSet f = readExr(captureFramePath(partial, 0), {{"color", {"R", "G", "B"}}, {"normal", {"X", "Y", "Z"}},
                                                        {"depth", {"Z"}}, {"motion", {"X", "Y"}}})
                     .layers;
    f.set("motion", Image(f.width(), f.height(), 1));  // motion.X only
    writeExr(captureFramePath(partial, 0), f,
             {{"color", {"R", "G", "B"}}, {"normal", {"X", "Y", "Z"}}, {"depth", {"Z"}}, {"motion", {"X"}, false}});
  }
  {
    const std::string error = test::errorOf([&] { readCaptureDescription(partial); });
    EXPECT_NE(error.find("motion.Y"), std::string::npos) << error;
  }
}

TEST(CaptureContract, BadValuesAndNamesAreErrorsNamingThem) {
  const fs::path good = writeSynthetic("values_src");
  // A camera-to-world matrix given as the view, with the camera's position beside it: the
  // position is the matrix's translation column, which says what the matrix is.
  expectError(
      copyCapture(good, "camera_to_world2",
                  [](json& d) {
                    json& camera = d["cameras"][2];
                    glm::dmat4 view;
                    for (int k = 0; k < 16; ++k)
                      view[k / 4][k % 4] = camera["view"][size_t(k)].get<double>();
                    const glm::dmat4 toWorld = glm::inverse(view);
                    for (int k = 0; k < 16; ++k) camera["view"][size_t(k)] = toWorld[k / 4][k % 4];
                    camera["position"] = {toWorld[3][0], toWorld[3][1], toWorld[3][2]};
                  }),
      "cameras[2].position: (0.480000, 0.200000, 0.000000) disagrees with the view matrix's "
      "eye (-0.480000, -0.200000, -0.000000); it equals the view's translation column, as in "
      "a camera-to-world matrix");
  expectError(copyCapture(good, "spp",
                          [](json& d) { d["reference"]["samples"] = {64, 64, 2.7, 64, 64, 64}; }),
              "reference.samples[2]: expected a whole number");
  expectError(copyCapture(good, "spp_neg",
                          [](json& d) { d["reference"]["samples"] = {64, 64, 64, 64, 64, -5}; }),
              "reference.samples[5]");
  // As many samples as references, which ofFrame sets: the count got and why that many.
  expectError(copyCapture(good, "spp_count", [](json& d) { d["reference"]["samples"] = {64}; }),
              "reference.samples: expected one number per reference, 6 (reference.ofFrame names "
              "references 0 to 5), got 1");
  expectError(copyCapture(good, "offrame", [](json& d) { d["reference"]["ofFrame"][1] = 0.5; }),
              "reference.ofFrame[1]: expected a whole reference index");
  // An event at frame 0 has nothing before it to be measured against.
  expectError(copyCapture(good, "event0",
                          [](json& d) {
                            d["events"] = {{{"frame", 0}, {"kind", "light_off"}}};
                          }),
              "events[0].frame: expected an integer in [1, ");
  // A mesh id belongs to an object_moves event; the same event twice is a slip, not two events.
  expectError(copyCapture(good, "event_mesh",
                          [](json& d) {
                            d["events"] = {{{"frame", 2}, {"kind", "light_off"}, {"meshId", 3}}};
                          }),
              "events[0].meshId: only an object_moves event names a mesh");
  expectError(copyCapture(good, "event_twice",
                          [](json& d) {
                            d["events"] = {{{"frame", 2}, {"kind", "camera_cut"}}, {{"frame", 2}, {"kind", "camera_cut"}}};
                          }),
              "events[1].kind: this event (camera_cut at frame 2) is given twice");
  EXPECT_NO_THROW(readCaptureDescription(copyCapture(good, "two_objects", [](json& d) {
    d["events"] = {{{"frame", 2}, {"kind", "object_moves"}, {"meshId", 3}},
                   {{"frame", 2}, {"kind", "object_moves"}, {"meshId", 7}}};
  })));
  EXPECT_NO_THROW(readCaptureDescription(copyCapture(good, "two_lights", [](json& d) {
    d["events"] = {{{"frame", 2}, {"kind", "light_off"}, {"what", "a"}}, {{"frame", 2}, {"kind", "light_off"}, {"what", "b"}}};
  })));
  for (const double exposure : {0.0, -1.0})
    expectError(copyCapture(good, "exposure", [&](json& d) { d["exposure"] = exposure; }),
                "exposure: a positive number");
  // Recorded planes that cannot be: refused, naming the field.
  expectError(copyCapture(good, "near", [](json& d) { d["near"] = 0.0; }),
              "near: a positive distance");
  expectError(copyCapture(good, "far", [](json& d) { d["near"] = 5.0, d["far"] = 1.0; }),
              "far: a finite distance beyond near (5.0");
  expectError(copyCapture(good, "units", [](json& d) { d["units"] = ""; }),
              "units: the world units");
  // The description's path instead of its folder: said so.
  expectError(copyCapture(good, "json_path") / "capture.json", "give the capture's folder");
  // A frame whose header claims another size: refused with both sizes before its pixels are read.
  const fs::path resized = copyCapture(good, "resized");
  {
    LayerSet f;
    f.set("color", Image(640, 480, 3));
    writeExr(captureFramePath(resized, 3), f, {{"color", {"R", "G", "B"}}});
  }
  {
    const Sequence seq = Sequence::open(resized);
    const std::string error = test::errorOf([&] { seq.frame(3); });
    EXPECT_NE(error.find("frame_0003.exr: 640x480, expected 64x36"), std::string::npos) << error;
  }
  // Names that are folders in a run: never "." or "..".
  expectError(copyCapture(good, "dots", [](json& d) { d["name"] = ".."; }), "not . or ..");
  expectError(copyCapture(good, "out_dots",
                          [](json& d) {
                            d["outputs"] = {{"..", json::object()}};
                          }),
              "outputs: key \"..\"");
  // A control character or a byte that is not UTF-8 names no folder anyone can read (a newline
  // split the run's unfinished mark over two lines; a NUL cut the folder's name).
  expectError(copyCapture(good, "newline", [](json& d) { d["name"] = "a\nb"; }),
              "name \"a\\nb\": expected a non-empty name in UTF-8 without spaces, slashes, "
              "commas or control characters");
  expectError(copyCapture(good, "nul", [](json& d) { d["name"] = std::string("a\0b", 3); }),
              "name \"a\\u0000b\"");
  // A negative variance in a reference: the file, the channel and the pixel.
  const fs::path negative = copyCapture(exportedCornell(), "negative_var");
  const CaptureDescription c = readCaptureDescription(negative);
  ASSERT_TRUE(c.referenceHasVariance);
  LayerSet ref = readCaptureReference(c, 0);
  ref.get("colorVar").at(2, 1, 1) = -0.25f;
  std::vector<LayerSpec> specs = {{"color", {"R", "G", "B"}}, {"colorVar", {"R", "G", "B"}}};
  if (c.referenceHasHalf) specs.push_back({"colorHalf", {"R", "G", "B"}});
  writeExr(captureReferencePath(negative, 0), ref, specs);
  {
    const std::string error = test::errorOf([&] { readCaptureReference(c, 0); });
    EXPECT_NE(error.find("reference_000.exr: channel colorVar.G at pixel (2, 1)"),
              std::string::npos)
        << error;
  }
}

// Pixels stored in a data window other than the display window (a cropped border render) would be
// read shifted: refused with both windows.
TEST(CaptureContract, AnExrWhoseDataWindowIsNotTheImageIsRefused) {
  const fs::path file = test::freshDir("data_window") / "shifted.exr";
  {
    const Imath::Box2i display(Imath::V2i(0, 0), Imath::V2i(7, 7)),
        data(Imath::V2i(3, 0), Imath::V2i(10, 7));
    Imf::Header header(display, data);
    header.channels().insert("R", Imf::Channel(Imf::FLOAT));
    std::vector<float> pixels(8 * 8, 1.0f);
    Imf::FrameBuffer fb;
    fb.insert("R", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(pixels.data() - 3), sizeof(float),
                              8 * sizeof(float)));
    Imf::OutputFile out(file.c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(8);
  }
  {
    const std::string error = test::errorOf([&] { readExr(file, {{"R", {}}}); });
    EXPECT_NE(
        error.find("data window (3, 0)-(10, 7) differs from the display window (0, 0)-(7, 7)"),
        std::string::npos)
        << error;
  }
}

// A multi-part file would be read as its first part: a layer in another part reported missing
// although the file holds it. Refused as what it is; a single-part file with the same channels
// reads.
TEST(CaptureContract, AMultiPartExrIsRefusedAsOne) {
  const fs::path dir = test::freshDir("multipart");
  std::vector<float> pixels(4 * 2, 1.0f);
  auto slice = [&] {
    return Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(pixels.data()), sizeof(float),
                      4 * sizeof(float));
  };
  {
    std::vector<Imf::Header> headers(2, Imf::Header(4, 2));
    const char* channel[] = {"color.R", "diffuse.R"};
    for (int p = 0; p < 2; ++p) {
      headers[size_t(p)].setName(std::string("part") + std::to_string(p));
      headers[size_t(p)].setType(Imf::SCANLINEIMAGE);
      headers[size_t(p)].channels().insert(channel[p], Imf::Channel(Imf::FLOAT));
    }
    Imf::MultiPartOutputFile file((dir / "two.exr").c_str(), headers.data(), 2);
    for (int p = 0; p < 2; ++p) {
      Imf::OutputPart part(file, p);
      Imf::FrameBuffer fb;
      fb.insert(channel[p], slice());
      part.setFrameBuffer(fb);
      part.writePixels(2);
    }
  }
  const std::string error = test::errorOf([&] { readExrHeader(dir / "two.exr"); });
  EXPECT_NE(error.find("two.exr: a multi-part OpenEXR file (2 parts); expected a single-part file"),
            std::string::npos)
      << error;
  {
    Imf::Header header(4, 2);
    header.channels().insert("color.R", Imf::Channel(Imf::FLOAT));
    header.channels().insert("diffuse.R", Imf::Channel(Imf::FLOAT));
    Imf::FrameBuffer fb;
    fb.insert("color.R", slice());
    fb.insert("diffuse.R", slice());
    Imf::OutputFile out((dir / "one.exr").c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(2);
  }
  EXPECT_EQ(readExrHeader(dir / "one.exr").channels.size(), 2u);
}

// A capture its own reader would refuse is never committed: the writer leaves nothing behind.
TEST(CaptureContract, AWriterNeverCommitsAnInvalidCapture) {
  const fs::path root = test::freshDir("invalid_commit");
  {
    CaptureWriter writer(root / "capture");
    EXPECT_THROW(writer.commit({{"format", kCaptureFormatName},
                                {"version", kCaptureFormatVersion},
                                {"name", "x"},
                                {"width", 8},
                                {"height", 8},
                                {"frames", 1},
                                {"frameRate", 0}}),
                 Error);
  }
  EXPECT_FALSE(fs::exists(root / "capture"));
  {  // The error names the folder the capture would have been, not the temporary one.
    CaptureWriter writer(root / "capture");
    const std::string error = test::errorOf([&] {
      writer.commit({{"format", kCaptureFormatName}, {"version", kCaptureFormatVersion}, {"name", "x"}, {"width", 8},
                     {"height", 8}, {"frames", 1}, {"frameRate", 0}});
    });
    EXPECT_NE(error.find((root / "capture" / "capture.json").string() + ": $.frameRate"), std::string::npos) << error;
    EXPECT_EQ(error.find(".tmp"), std::string::npos) << error;
  }
  for (const auto& e : fs::directory_iterator(root)) ADD_FAILURE() << "left behind: " << e.path();
  // The Blender importer names its capture after the source folder (a trailing slash included),
  // and refuses a folder name that cannot be one before reading anything else.
  fs::create_directories(root / "my render");
  std::ofstream(root / "my render" / "cameras.json") << "{}";
  const std::string spaced =
      test::errorOf([&] { importBlender(root / "my render", root / "out", {}); });
  EXPECT_NE(spaced.find("\"my render\" cannot name a capture"), std::string::npos) << spaced;
  EXPECT_NE(spaced.find("--name"), std::string::npos) << spaced;
  fs::create_directories(root / "render");
  std::ofstream(root / "render" / "cameras.json") << "{}";
  const std::string slashed =
      test::errorOf([&] { importBlender(root.string() + "/render/", root / "out", {}); });
  EXPECT_EQ(slashed.find("cannot name a capture"), std::string::npos) << slashed;
  EXPECT_NE(slashed.find("cameras.json"), std::string::npos) << slashed;
  EXPECT_FALSE(fs::exists(root / "out"));
}

TEST(CaptureContract, ADenoiserNeedingALayerTheCaptureLacksFailsThatPairOnly) {
  // Without meshId, every filter that tests object ids fails naming the layer; passthrough, which
  // reads no guide, runs; the run records both.
  const fs::path dir = copyCapture(exportedCornell(), "no_mesh_id");
  editFrames(dir, [](int, LayerSet& f) {
    LayerSet kept;
    for (const auto& [name, image] : f.all())
      if (name != "meshId") kept.set(name, image);
    f = kept;
  });
  const json r = runMatrix(captureRun(test::freshDir("lacking_run"), {{"svgf", {}, ""}}, {dir}));
  const json p = pairOf(r, "svgf");
  EXPECT_EQ(p["status"], "failed");
  EXPECT_NE(p["error"].get<std::string>().find("'meshId'"), std::string::npos) << p["error"];
  EXPECT_NE(p["error"].get<std::string>().find("docs/captures.md"), std::string::npos)
      << p["error"];
  EXPECT_EQ(pairOf(r, "passthrough")["status"], "ok");
  ASSERT_EQ(r["pairs"].size(), 3u);
  const json derived = r["scenes"]["no_mesh_id"]["derivedLayers"];
  EXPECT_NE(std::find(derived.begin(), derived.end(), "meshId"), derived.end());
  const json given =
      r["scenes"]["no_mesh_id"]["layers"];  // what the capture gives, not what was made
  EXPECT_EQ(std::find(given.begin(), given.end(), "meshId"), given.end()) << given;
  EXPECT_NE(std::find(given.begin(), given.end(), "normal"), given.end()) << given;
  // Every denoiser there is (--denoisers all): the one the capture lacks the inputs for is not
  // run, and the scene says why; nothing fails.
  RunConfig every = captureRun(test::freshDir("lacking_every"), {{"svgf", {}, ""}}, {dir});
  every.everyDenoiser = true;
  const json e = runMatrix(every);
  ASSERT_EQ(e["pairs"].size(), 1u);  // passthrough
  EXPECT_EQ(e["pairs"][0]["status"], "ok");
  const json notRun = e["scenes"]["no_mesh_id"]["notRun"];  // the temporal baseline tests ids too
  ASSERT_EQ(notRun.size(), 2u) << notRun;
  EXPECT_EQ(notRun[0]["label"], "temporal");  // the baselines run first
  EXPECT_EQ(notRun[1]["label"], "svgf");
  EXPECT_NE(notRun[1]["reason"].get<std::string>().find("'meshId'"), std::string::npos) << notRun;
  // Sharded, the pairs not run are accounted for by the merge (not "lost by a shard"), and every
  // shard's list of them is kept.
  std::vector<fs::path> shards;
  for (int i = 0; i < 2; ++i) {
    RunConfig shard = every;
    shard.shardIndex = i;
    shard.shardCount = 2;
    shard.out = test::freshDir("lacking_shard" + std::to_string(i));
    runMatrix(shard);
    shards.push_back(shard.out);
  }
  const json merged = mergeRuns(shards, test::freshDir("lacking_merged"));
  EXPECT_EQ(merged["pairs"].size(), 1u);
  EXPECT_EQ(merged["scenes"]["no_mesh_id"]["notRun"].size(), 2u)
      << merged["scenes"]["no_mesh_id"]["notRun"];
  // The study runs every denoiser there is: it skips the same way.
  EXPECT_TRUE(studyRun({}, RenderSettings{}).everyDenoiser);
}

// Under --denoisers all (and in the study), a stored output runs only on the capture that stores
// it: a rendered scene or another capture of the run does not run it and says why (a docs audit's
// run of cornell_static beside a capture with outputs failed file:NAME on the scene, exit 1).
TEST(CaptureContract, EveryDenoiserRunsAStoredOutputOnlyWhereItIsStored) {
  const fs::path stored = copyCapture(exportedCornell(), "with_outputs", [](json& d) {
    d["outputs"] = {{"copied", json::object()}};
  });
  const CaptureDescription base = readCaptureDescription(stored);
  fs::create_directories(stored / "outputs" / "copied");
  for (int t = 0; t < base.info.frames; ++t) {
    LayerSet l;
    l.set("color", readCaptureFrame(base, t).get("color"));
    writeExr(stored / "outputs" / "copied" / numberedFileName("frame", t, 4), l,
             {{"color", {"R", "G", "B"}, false}});
  }
  // Beside the scene rendered here, a capture without outputs (named apart from the scene).
  const fs::path other = copyCapture(exportedCornell(), "without_outputs");
  RunConfig cfg =
      captureRun(test::freshDir("stored_where_stored"), {{"file:copied", {}, ""}}, {stored, other});
  cfg.scenes = {test::shippedScene("cornell_static")};
  cfg.baselines = false;
  cfg.everyDenoiser = true;
  const json r = runMatrix(cfg);
  ASSERT_EQ(r["pairs"].size(), 1u) << r["pairs"].dump().substr(0, 400);
  EXPECT_EQ(r["pairs"][0]["scene"], "with_outputs");
  EXPECT_EQ(r["pairs"][0]["status"], "ok");
  const json& onScene = r["scenes"]["cornell_static"]["notRun"];
  ASSERT_EQ(onScene.size(), 1u) << r["scenes"]["cornell_static"].dump().substr(0, 400);
  EXPECT_EQ(onScene[0]["label"], "file:copied");
  EXPECT_NE(onScene[0]["reason"].get<std::string>().find("a scene rendered here stores no denoiser "
                                                         "outputs"),
            std::string::npos)
      << onScene;
  const json& onOther = r["scenes"]["without_outputs"]["notRun"];
  ASSERT_EQ(onOther.size(), 1u);
  EXPECT_EQ(onOther[0]["reason"], "the capture stores no output 'copied' (another capture does)");
  // Named by the user, it still fails where it is not stored (a misspelt scene list is theirs).
  cfg.everyDenoiser = false;
  cfg.out = test::freshDir("stored_where_named");
  const json named = runMatrix(cfg);
  ASSERT_EQ(named["pairs"].size(), 3u);
  for (const json& pair : named["pairs"])
    EXPECT_EQ(pair["status"], pair["scene"] == "with_outputs" ? "ok" : "failed") << pair["scene"];
}

// A run into the folder of a capture it reads (or below it) is refused before any work: its results
// and images landed among the capture's files (a bad-input trial).
TEST(CaptureContract, ARunIntoItsCapturesFolderIsRefused) {
  const fs::path dir = copyCapture(exportedCornell(), "run_into");
  for (const fs::path& out : {dir, dir / "runs" / "mine"}) {
    const std::string e = test::errorOf([&] {
      runMatrix(captureRun(out, {{"passthrough", {}, ""}}, {dir}));
    });
    EXPECT_NE(e.find("lies in the capture " + dir.string() + " the run reads"), std::string::npos)
        << e;
  }
  // Nor into another capture, nor with the capture inside the run's images/ (which a run replaces:
  // a capture's stored outputs there were overwritten, then removed).
  const fs::path other = copyCapture(exportedCornell(), "run_into_other");
  EXPECT_NE(test::errorOf([&] {
              runMatrix(captureRun(other, {{"passthrough", {}, ""}}, {dir}));
            }).find(" is a capture (capture.json)"),
            std::string::npos);
  const fs::path holder = test::freshDir("run_holding_capture");
  fs::create_directories(holder / "images");
  fs::copy(dir, holder / "images" / "run_into", fs::copy_options::recursive);
  EXPECT_NE(
      test::errorOf([&] {
        runMatrix(captureRun(holder, {{"passthrough", {}, ""}}, {holder / "images" / "run_into"}));
      }).find("/images, which the run replaces"),
      std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "results.json"));
  EXPECT_EQ(validate(dir).status(), CheckStatus::Pass);
}

// A byte that is not UTF-8 in a name the results quote (a stray file's, here in the validation's
// files.unexpected) is written as U+FFFD: it ended a finished run with "invalid UTF-8 byte",
// exit 3, every pair's results lost (a bad-input trial).
TEST(CaptureContract, ANameNotInUtf8DoesNotStopTheResults) {
  const fs::path dir = copyCapture(exportedCornell(), "odd_bytes");
  std::ofstream(dir / "note\xff.txt") << "a stray file";
  RunConfig cfg = captureRun(test::freshDir("odd_bytes_run"), {{"passthrough", {}, ""}}, {dir});
  cfg.baselines = false;
  const json r = runMatrix(cfg);
  ASSERT_EQ(pairOf(r, "passthrough")["status"], "ok");
  const json saved = parseJsonFile((cfg.out / "results.json").string());
  EXPECT_NE(saved["scenes"]["odd_bytes"]["validation"].dump().find("note\xEF\xBF\xBD.txt"),
            std::string::npos)
      << saved["scenes"]["odd_bytes"]["validation"].dump();
}

TEST(CaptureContract, AFileContenderOnARenderedSceneOrAnUnknownOutputIsAnError) {
  RunConfig cfg =
      captureRun(test::freshDir("file_bad"), {{"file:nothing", {}, ""}}, {exportedCornell()});
  const json r = runMatrix(cfg);
  const json p = pairOf(r, "file:nothing");
  EXPECT_EQ(p["status"], "failed");
  EXPECT_NE(p["error"].get<std::string>().find("no denoiser output 'nothing'"), std::string::npos)
      << p["error"];
  RunConfig noCapture = captureRun(test::freshDir("file_bad2"), {{"file:x", {}, ""}}, {});
  noCapture.scenes = {test::shippedScene("cornell_static")};
  EXPECT_THROW(runMatrix(noCapture), Error);
}

TEST(CaptureContract, AnExportNeverLeavesAHalfWrittenFolder) {
  const fs::path out = test::freshDir("export_fail") / "capture";
  // An output folder without the frames: the export fails and leaves nothing.
  EXPECT_THROW(exportCapture(Sequence::open(cornellSequence()), out,
                             {{"ghost", test::freshDir("empty_outputs")}}),
               Error);
  EXPECT_FALSE(fs::exists(out));
  for (const auto& e : fs::directory_iterator(out.parent_path())) ADD_FAILURE() << "left behind: " << e.path();
  // Output frames of another size, or with a NaN, would make a capture its own run refuses: the
  // export fails naming the file, and leaves nothing.
  const Sequence sequence = Sequence::open(cornellSequence());
  const SequenceInfo& info = sequence.info();
  for (const bool nan : {false, true}) {
    const fs::path frames = test::freshDir(nan ? "nan_outputs" : "small_outputs");
    for (int t = 0; t < info.frames; ++t) {
      LayerSet l;
      l.set("color", Image(nan ? info.width : info.width / 2, info.height, 3, 0.5f));
      if (nan && t == 2) l.get("color").at(0, 0, 1) = std::numeric_limits<float>::quiet_NaN();
      writeExr(frames / numberedFileName("frame", t, 4), l, {{"color", {"R", "G", "B"}, false}});
    }
    try {
      exportCapture(Sequence::open(cornellSequence()), out, {{"odd", frames}});
      ADD_FAILURE() << "exported outputs " << (nan ? "with a NaN" : "of another size");
    } catch (const Error& e) {
      const std::string expected =
          nan ? "frame_0002.exr: 1 non-finite colour values in the output of 'odd'"
              : "frame_0000.exr: " + std::to_string(info.width / 2) + "x" +
                    std::to_string(info.height) + ", expected";
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(out));
  }
  // Another scene's output (a run's frames name their scene), and an output of more frames than
  // the sequence's (a longer run): refused, naming the file.
  for (const bool otherScene : {true, false}) {
    const fs::path frames = test::freshDir(otherScene ? "other_scene_outputs" : "longer_outputs");
    for (int t = 0; t < info.frames + (otherScene ? 0 : 2); ++t) {
      LayerSet l;
      l.set("color", Image(info.width, info.height, 3, 0.5f));
      writeExr(
          frames / numberedFileName("frame", t, 4), l, {{"color", {"R", "G", "B"}, false}},
          otherScene ? ExrAttributes{{"arena.scene", "camera_pan_occluder"}} : ExrAttributes{});
    }
    try {
      exportCapture(Sequence::open(cornellSequence()), out, {{"odd", frames}});
      ADD_FAILURE() << (otherScene ? "exported another scene's output"
                                   : "exported a longer output");
    } catch (const Error& e) {
      const std::string expected =
          otherScene
              ? "frame_0000.exr: an output of scene 'camera_pan_occluder' (its arena.scene), "
                "not of '" +
                    info.scene + "'"
              : numberedFileName("frame", info.frames, 4) +
                    ": the output of 'odd' holds more "
                    "frames than the " +
                    std::to_string(info.frames) + " exported";
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(out));
  }
  // And an existing folder is never overwritten.
  fs::create_directories(out);
  EXPECT_THROW(exportCapture(Sequence::open(cornellSequence()), out), Error);
}

// An export into an existing folder, or of an output folder that is not one, is refused before the
// render (minutes on a real scene), which therefore leaves nothing in the cache.
TEST(CaptureCommands, AnExportIsRefusedBeforeItRenders) {
  const fs::path work = test::freshDir("export_refused");
  fs::create_directories(work / "taken");
  const std::string arena = std::string(ARENA_BINARY) +
                            " export cornell_static --resolution 16x8 --frames 2 " +
                            "--ref-spp 4 --cache '" + (work / "cache").string() + "'";
  test::CommandResult r = test::runCommand(arena + " --out '" + (work / "taken").string() + "'");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("already exists"), std::string::npos) << r.output;
  r = test::runCommand(arena + " --out '" + (work / "new").string() +
                       "' --output 'mine=" + (work / "nowhere").string() + "'");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("is not a folder"), std::string::npos) << r.output;
  r = test::runCommand(arena + " --out '" + (work / "new").string() +
                       "' --output '..=" + (work / "taken").string() + "'");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("not . or .."), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(work / "new"));
  EXPECT_TRUE(!fs::exists(work / "cache") || fs::is_empty(work / "cache"))
      << "rendered before refusing";
}

TEST(CaptureCommands, ExportValidateRunAndReportFromTheCommandLine) {
  const fs::path work = test::freshDir("capture_cli");
  const std::string arena = ARENA_BINARY;
  const std::string tiny = " --resolution 32x18 --frames 6 --ref-spp 16 --cache '" + (work / "cache").string() + "'";
  test::CommandResult r = test::runCommand(arena + " export moving_object" + tiny + " --out '" +
                                           (work / "capture").string() + "'");
  ASSERT_EQ(r.status, 0) << r.output;
  r = test::runCommand(arena + " validate '" + (work / "capture").string() + "'");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("motion.consistency"), std::string::npos) << r.output;
  {  // Every check's value ends in one column, however long the check names are.
    std::set<long> valueEnds;
    std::istringstream lines(r.output);
    const std::regex row(R"(^  (pass|warn|fail) +\S+ +\S+)");
    for (std::string line; std::getline(lines, line);)
      if (std::smatch m; std::regex_search(line, m, row)) valueEnds.insert(m.length(0));
    EXPECT_EQ(valueEnds.size(), 1u) << r.output;
  }
  r = test::runCommand(arena + " run --capture '" + (work / "capture").string() + "' --denoisers eaw --warmup 2 --out '" +
                       (work / "run").string() + "'");
  EXPECT_EQ(r.status, 0) << r.output;
  const json results = parseJsonFile((work / "run" / "results.json").string());
  EXPECT_EQ(results["scenes"]["moving_object"]["source"], "capture");
  EXPECT_EQ(results["pairs"].size(), 3u);  // only the capture: no scene was asked for
  // A stored output the capture lacks (a misspelt file:NAME) is refused before the work.
  r = test::runCommand(arena + " run --capture '" + (work / "capture").string() +
                       "' --denoisers eaw,file:dlss --warmup 2 --out '" + (work / "typo").string() +
                       "'");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(
      r.output.find("--denoisers file:dlss: no capture of this run stores an output 'dlss' (they "
                    "store none"),
      std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(work / "typo"));
  // Rendering options on a run of captures alone would be ignored without a word: refused.
  r = test::runCommand(arena + " run --capture '" + (work / "capture").string() +
                       "' --denoisers eaw --warmup 2 --resolution 16x8 --seeds 2 --out '" +
                       (work / "ignored").string() + "'");
  EXPECT_NE(r.status, 0) << r.output;
  EXPECT_NE(
      r.output.find(
          "--resolution 16x8, --seeds 2: rendering options, for the scenes a run renders; this run "
          "scores captures only"),
      std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(work / "ignored" / "results.json"));
  r = test::runCommand(arena + " report '" + (work / "run").string() + "' --out '" + (work / "report").string() + "'");
  EXPECT_EQ(r.status, 0) << r.output;
  // A broken capture: validate exits 1 naming the check, and an export never overwrites.
  editFrames(work / "capture", [](int, LayerSet& f) {
    for (float& v : f.get("normal").raw()) v *= 3.0f;
  });
  r = test::runCommand(arena + " validate '" + (work / "capture").string() + "'");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("normal.unitLength"), std::string::npos) << r.output;
  r = test::runCommand(arena + " export moving_object" + tiny + " --out '" + (work / "capture").string() + "'");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("already exists"), std::string::npos) << r.output;
}

// ---- Blender Cycles, end to end ----------------------------------------------------------------

TEST(CaptureBlender, ARenderedSequenceImportsValidatesAndRunsEveryDenoiserItHasTheLayersFor) {
  // scripts/setup.sh installs Debian's Blender for the tests; without it this test fails (it must
  // not pass by skipping what it is for).
  ASSERT_EQ(test::runCommand("command -v blender >/dev/null").status, 0) << "blender is not installed";
  const fs::path work = test::freshDir("blender");
  const std::string script = std::string(ARENA_SOURCE_DIR) + "/scripts/blender/render_capture.py";
  const test::CommandResult render = test::runCommand("blender -b --factory-startup --python '" + script + "' -- '" +
                                                      (work / "render").string() +
                                                      "' --frames 5 --width 96 --height 54 --spp 1 --reference-spp 128");
  ASSERT_EQ(render.status, 0) << render.output.substr(render.output.size() > 3000 ? render.output.size() - 3000 : 0);
  importBlender(work / "render", work / "capture", {"blender_room"});
  const Sequence seq = Sequence::open(work / "capture");
  const EvaluationInput input = readSequenceForEvaluation(seq);
  const CaptureValidation v = validateCapture(seq, input);
  // Cycles' Vector pass, read with our sign and axis conventions, agrees with depth + cameras.
  const CaptureCheck& motion = checkNamed(v, "motion.consistency");
  EXPECT_EQ(motion.status, CheckStatus::Pass) << motion.value << " " << motion.detail;
  EXPECT_NE(v.status(), CheckStatus::Fail) << v.failures();
  EXPECT_EQ(checkNamed(v, "reference.roughnessVsInput").status, CheckStatus::Pass)
      << checkNamed(v, "reference.roughnessVsInput").value;
  EXPECT_EQ(checkNamed(v, "reference.noiseVsInput").status, CheckStatus::Pass);
  // Its references are where they belong, and the check decides so (1 spp of Cycles: the sums
  // weigh each value as relMSE does, else its bright pixels' noise decided nothing).
  for (const char* side : {"before", "after"}) {
    const CaptureCheck& aligned = checkNamed(v, std::string("reference.alignment.") + side);
    EXPECT_EQ(aligned.status, CheckStatus::Pass) << aligned.detail;
    EXPECT_EQ(aligned.detail, "") << side;
  }
  // The references written one frame late (frame k holds frame k-1's): refused, naming the side.
  const fs::path late = work / "late_references";
  fs::copy(work / "render", late, fs::copy_options::recursive);
  for (const char* half : {"reference_a", "reference_b"})
    for (int k = 4; k >= 1; --k) {
      char from[32], to[32];
      std::snprintf(from, sizeof from, "frame_%04d.exr", k - 1);
      std::snprintf(to, sizeof to, "frame_%04d.exr", k);
      fs::copy_file(late / half / from, late / half / to, fs::copy_options::overwrite_existing);
    }
  importBlender(late, work / "late_capture", {"late_references"});
  const CheckStatus lateAfter =
      checkNamed(validate(work / "late_capture"), "reference.alignment.after").status;
  EXPECT_EQ(lateAfter, CheckStatus::Fail);
  // A camera whose matrix is scaled (a scaled camera object): refused in Blender's words, naming
  // cameras.json's field (the capture's reader named the view it would become).
  const fs::path scaled = work / "scaled_camera";
  fs::copy(work / "render", scaled, fs::copy_options::recursive);
  json scaledCams = parseJsonFile((scaled / "cameras.json").string());
  json& matrix = scaledCams["cameras"][2]["cameraToWorld"];
  for (size_t r = 0; r < 3; ++r)
    for (size_t c = 0; c < 3; ++c) matrix[r][c] = 2.0 * matrix[r][c].get<double>();
  std::ofstream(scaled / "cameras.json") << scaledCams.dump();
  const std::string scaledError =
      test::errorOf([&] { importBlender(scaled, work / "scaled_capture", {"scaled"}); });
  EXPECT_NE(scaledError.find(
                (scaled / "cameras.json").string() +
                ": $.cameras[2].cameraToWorld: the camera object is scaled (its X axis "
                "has length 2.000000); clear the scale of the camera and of its parents to 1 "
                "(Object > Clear > Scale"),
            std::string::npos)
      << scaledError;
  EXPECT_FALSE(fs::exists(work / "scaled_capture"));
  // A lens shift and an orthographic camera: said so (the shift was advised a "jitter", the
  // orthographic camera read "P[3][2] = 0, expected -1").
  for (const auto& [what, expected] :
       {std::pair{"shift",
                  "$.cameras[1].projection: a lens shift (P[0][2] = 0.200000, P[1][2] = "
                  "0.000000); a capture needs a centred projection: set the camera's "
                  "Shift X and Y to 0"},
        std::pair{"ortho",
                  "$.cameras[1].projection: an orthographic camera; a capture needs a "
                  "perspective one"}}) {
    json cams = parseJsonFile((work / "render" / "cameras.json").string());
    json& projection = cams["cameras"][1]["projection"];
    if (std::string(what) == "shift") {
      projection[0][2] = 0.2;
    } else {
      projection[2][2] = -0.1, projection[2][3] = 0, projection[3][2] = 0, projection[3][3] = 1;
    }
    const fs::path dir = work / (std::string("camera_") + what);
    fs::copy(work / "render", dir, fs::copy_options::recursive);
    std::ofstream(dir / "cameras.json") << cams.dump();
    const std::string error =
        test::errorOf([&] { importBlender(dir, work / "camera_capture", {"c"}); });
    EXPECT_NE(error.find(expected), std::string::npos) << error;
    EXPECT_FALSE(fs::exists(work / "camera_capture"));
  }
  // Read without our y negation, the same vectors are refused as "y flipped".
  std::vector<LayerSet> raw = input.frames;
  for (LayerSet& f : raw)
    for (float& y : f.get("motion").planeSpan(1)) y = -y;
  std::vector<int> cuts;
  const MotionConsistency flipped = checkMotion(raw, seq.info().cameras, cuts);
  EXPECT_GT(flipped.offShare, 0.25);
  EXPECT_NE(flipped.explanation.find("y flipped"), std::string::npos) << flipped.explanation;
  // The demodulated signals remodulate to Combined exactly (emission holds the rest).
  const LayerSet& f = input.frames[2];
  double worst = 0;
  for (size_t i = 0; i < f.get("color").raw().size(); ++i) {
    const float sum = f.get("albedo").raw()[i] * f.get("diffuse").raw()[i] +
                      f.get("specAlbedo").raw()[i] * f.get("specular").raw()[i] +
                      f.get("emission").raw()[i];
    worst = std::max(worst, double(std::abs(sum - f.get("color").raw()[i])));
  }
  EXPECT_LT(worst, 1e-5);

  RunConfig cfg = captureRun(work / "run", {}, {work / "capture"});
  for (const std::string& n : DenoiserRegistry::instance().names())
    if (n != "passthrough" && n != "temporal") cfg.denoisers.push_back({n, {}, ""});
  cfg.warmup = 1;
  const json r = runMatrix(cfg);
  int ok = 0;
  for (const json& p : r["pairs"]) {
    if (p["status"] == "ok") {
      ++ok;
      EXPECT_GT(p["summary"]["relMse"]["mean"].get<double>(), 0.0) << p["label"];
      continue;
    }
    // What cannot run says which input the capture lacks: gradient samples or a hit distance.
    const std::string error = p["error"];
    EXPECT_TRUE(error.find("gradient samples") != std::string::npos ||
                error.find("specHitDist") != std::string::npos)
        << p["label"] << ": " << error;
  }
  EXPECT_GE(ok, 5);  // passthrough, temporal, eaw, svgf, slgf at least
  EXPECT_EQ(r["scenes"]["blender_room"]["validation"]["status"],
            v.status() == CheckStatus::Warn ? "warn" : "pass");

  // Copies of the render whose files a case edits: every channel of a file read, changed, written
  // back.
  const auto editFrames =
      [&](const fs::path& dir, const std::string& folder,
          const std::function<void(int, LayerSet&, std::vector<LayerSpec>&)>& edit) {
        for (int t = 0; t < 5; ++t) {
          const fs::path file = dir / folder / numberedFileName("frame", t, 4);
          std::map<std::string, std::vector<std::string>> byLayer;
          for (const std::string& c : readExrHeader(file).channels)
            byLayer[c.substr(0, c.rfind('.'))].push_back(c.substr(c.rfind('.') + 1));
          std::vector<LayerSpec> specs;
          for (const auto& [layer, suffixes] : byLayer) specs.push_back({layer, suffixes, false});
          LayerSet passes = readExr(file, specs).layers;
          edit(t, passes, specs);
          writeExr(file, passes, specs);
        }
      };
  const auto copied = [&](const char* name) {
    const fs::path dir = work / name;
    fs::copy(work / "render", dir, fs::copy_options::recursive);
    return dir;
  };
  // A NaN or negative depth is imported as written, so the validation names it (it became sky);
  // a clip end at or below the clip start is refused naming the field (it made every pixel sky).
  const fs::path bad = copied("bad_depth");
  editFrames(bad, "noisy", [](int t, LayerSet& passes, std::vector<LayerSpec>&) {
    if (t != 2) return;
    passes.get("ViewLayer.Depth").at(3, 3) = std::numeric_limits<float>::quiet_NaN();
    passes.get("ViewLayer.Depth").at(5, 5) = -2.0f;
  });
  importBlender(bad, work / "bad_capture", {"bad_depth"});
  const CaptureValidation badV = validate(work / "bad_capture");
  EXPECT_EQ(checkNamed(badV, "nonFinite.depth").status, CheckStatus::Fail);
  EXPECT_EQ(checkNamed(badV, "nonFinite.depth").value, 1.0);
  EXPECT_EQ(checkNamed(badV, "depth.positive").status, CheckStatus::Fail);
  json cams = parseJsonFile((bad / "cameras.json").string());
  cams["clipEnd"] = cams["clipStart"].get<double>() / 2;
  std::ofstream(bad / "cameras.json") << cams.dump();
  const std::string clip = test::errorOf([&] { importBlender(bad, work / "clip_capture", {"clip"}); });
  EXPECT_NE(clip.find("cameras.json: $.clipEnd: expected a number above clipStart"), std::string::npos) << clip;
  EXPECT_FALSE(fs::exists(work / "clip_capture"));
  // A sample count is cameras.json's field, named there (it surfaced as the capture's).
  cams = parseJsonFile((work / "render" / "cameras.json").string());
  cams["referenceSpp"] = 0;
  std::ofstream(bad / "cameras.json") << cams.dump();
  const std::string spp = test::errorOf([&] { importBlender(bad, work / "spp_capture", {"spp"}); });
  EXPECT_NE(spp.find("cameras.json: $.referenceSpp: expected an integer in [1, "), std::string::npos) << spp;
  // One reference folder: the reference without a noise floor; none: a capture without a reference.
  const fs::path one = work / "one_reference", none = work / "no_reference";
  fs::copy(work / "render", one, fs::copy_options::recursive);
  fs::remove_all(one / "reference_b");
  importBlender(one, work / "one_capture", {"one"});
  const CaptureDescription oneC = readCaptureDescription(work / "one_capture");
  EXPECT_TRUE(oneC.info.hasReference);
  EXPECT_FALSE(oneC.referenceHasHalf);
  EXPECT_EQ(checkNamed(validate(work / "one_capture"), "reference.noiseFloorKnown").status,
            CheckStatus::Warn);
  fs::copy(one, none, fs::copy_options::recursive);
  fs::remove_all(none / "reference_a");
  importBlender(none, work / "none_capture", {"none"});
  EXPECT_FALSE(readCaptureDescription(work / "none_capture").info.hasReference);
  EXPECT_EQ(checkNamed(validate(work / "none_capture"), "reference.present").status,
            CheckStatus::Warn);

  // What a Blender user trips on (a technical artist's trial), each case on its own copy.
  // A second view layer (an override layer sorting first): it was imported in place of the scene's
  // own, silently. Refused, naming both; --view-layer picks one, recorded in capture.json.
  const fs::path twoLayers = copied("two_layers");
  for (const char* folder : {"noisy", "reference_a", "reference_b"})
    editFrames(twoLayers, folder, [](int, LayerSet& passes, std::vector<LayerSpec>& specs) {
      for (LayerSpec spec : std::vector<LayerSpec>(specs)) {
        const std::string copy = "AAA_fg" + spec.name.substr(spec.name.find('.'));
        Image image = passes.get(spec.name);
        for (float& x : image.raw()) x *= 0.5f;
        passes.set(copy, std::move(image));
        spec.name = copy;
        specs.push_back(spec);
      }
    });
  EXPECT_NE(
      test::errorOf([&] { importBlender(twoLayers, work / "two_capture", {"two"}); })
          .find("frame_0000.exr: 2 view layers ('AAA_fg', 'ViewLayer'); name the one to import "
                "with --view-layer"),
      std::string::npos);
  EXPECT_NE(test::errorOf([&] {
              importBlender(twoLayers, work / "two_capture", {"two", "Main"});
            }).find("no view layer 'Main' (--view-layer); it holds 'AAA_fg', 'ViewLayer'"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(work / "two_capture"));
  importBlender(twoLayers, work / "two_capture", {"two", "ViewLayer"});
  EXPECT_EQ(readCaptureDescription(work / "two_capture").source["viewLayer"], "ViewLayer");
  {
    // (Held: a span into a temporary's image dangles.)
    const EvaluationInput two = readSequenceForEvaluation(Sequence::open(work / "two_capture"));
    const auto chosen = two.frames[2].get("color").raw();
    const auto own = input.frames[2].get("color").raw();
    EXPECT_TRUE(std::equal(chosen.begin(), chosen.end(), own.begin(), own.end()));
  }
  // Passes missing (as EEVEE's files lack them): all named at once, with where Blender enables
  // them.
  const fs::path lacking = copied("lacking");
  editFrames(lacking, "noisy", [](int, LayerSet&, std::vector<LayerSpec>& specs) {
    std::erase_if(specs, [](const LayerSpec& l) {
      return l.name == "ViewLayer.DiffInd" || l.name == "ViewLayer.IndexOB";
    });
  });
  const std::string lacks =
      test::errorOf([&] { importBlender(lacking, work / "lacking_capture", {"l"}); });
  EXPECT_NE(
      lacks.find("frame_0000.exr: view layer 'ViewLayer' lacks 2 passes the capture needs: "
                 "DiffInd (Light > Diffuse > Indirect), IndexOB (Data > Indexes > Object Index); "
                 "enable them in View Layer Properties > Passes and render with Cycles"),
      std::string::npos)
      << lacks;
  // A pass only partly there names the channels it lacks; Combined's alpha is not read (an RGB
  // output imports). A reference half whose view layer is not the frames' says where the name
  // came from (it named --view-layer, which was not given).
  const auto keepChannels = [](std::vector<std::string> kept) {
    return [kept](int, LayerSet& passes, std::vector<LayerSpec>& specs) {
      for (LayerSpec& l : specs) {
        if (l.name != "ViewLayer.Combined") continue;
        const Image& all = passes.get(l.name);
        Image fewer(all.width(), all.height(), int(kept.size()));
        for (int c = 0; c < int(kept.size()); ++c)
          std::copy(all.plane(c), all.plane(c) + all.pixelCount(), fewer.plane(c));
        passes.set(l.name, std::move(fewer));
        l = {l.name, kept, false};
      }
    };
  };
  const fs::path noAlpha = copied("no_alpha");
  editFrames(noAlpha, "noisy", keepChannels({"R", "G", "B"}));
  importBlender(noAlpha, work / "no_alpha_capture", {"no_alpha"});
  editFrames(noAlpha, "noisy", keepChannels({"R", "G"}));
  EXPECT_NE(test::errorOf([&] {
              importBlender(noAlpha, work / "no_blue_capture", {"nb"});
            }).find("lacks a pass the capture needs: Combined (its channel B missing)"),
            std::string::npos);
  const fs::path otherLayer = copied("other_layer");
  editFrames(otherLayer, "reference_b", [](int, LayerSet& passes, std::vector<LayerSpec>& specs) {
    for (LayerSpec& l : specs) {
      const std::string renamed = "Other" + l.name.substr(l.name.find('.'));
      passes.set(renamed, Image(passes.get(l.name)));
      l.name = renamed;
    }
  });
  EXPECT_NE(
      test::errorOf([&] { importBlender(otherLayer, work / "other_capture", {"o"}); })
          .find("reference_b/frame_0000.exr: no view layer 'ViewLayer' (the one " +
                (otherLayer / "noisy" / "frame_0000.exr").string() + " holds); it holds 'Other'"),
      std::string::npos);
  // More than 1 spp: Cycles averages a pixel's normals, shorter than 1 over an edge (a capture at
  // 4 spp was refused as "normals must be unit length"). Renormalised, and the share recorded.
  const fs::path averaged = copied("averaged_normals");
  editFrames(averaged, "noisy", [](int t, LayerSet& passes, std::vector<LayerSpec>&) {
    if (t != 1) return;
    Image& n = passes.get("ViewLayer.Normal");
    for (size_t i = 0; i < n.pixelCount(); i += 4)
      for (int c = 0; c < 3; ++c) n.plane(c)[i] *= 0.7f;
  });
  importBlender(averaged, work / "averaged_capture", {"averaged"});
  EXPECT_GT(
      readCaptureDescription(work / "averaged_capture").source["normalsRenormalised"].get<double>(),
      0.03);
  const EvaluationInput renormalised =
      readSequenceForEvaluation(Sequence::open(work / "averaged_capture"));
  const LayerSet& f1 = renormalised.frames[1];
  double worstLength = 0;
  for (size_t i = 0; i < f1.get("normal").pixelCount(); ++i) {
    if (f1.get("depth").raw()[i] == 0) continue;
    const Image& n = f1.get("normal");
    worstLength = std::max(
        worstLength,
        std::abs(std::hypot(double(n.plane(0)[i]), double(n.plane(1)[i]), double(n.plane(2)[i])) -
                 1.0));
  }
  EXPECT_LT(worstLength, 1e-3);  // stored as half floats
  EXPECT_EQ(checkNamed(validate(work / "averaged_capture"), "normal.unitLength").status,
            CheckStatus::Pass);
  // A quarter of the pixels renormalised passes (edges at more than 1 spp); a pass of no unit
  // normals at all, renormalised everywhere, warns (the renormalising would hide it).
  EXPECT_EQ(checkNamed(validate(work / "averaged_capture"), "normal.renormalised").status,
            CheckStatus::Pass);
  const fs::path unnormal = copied("unnormal");
  editFrames(unnormal, "noisy", [](int, LayerSet& passes, std::vector<LayerSpec>&) {
    for (float& x : passes.get("ViewLayer.Normal").raw()) x *= 3.0f;
  });
  importBlender(unnormal, work / "unnormal_capture", {"unnormal"});
  EXPECT_EQ(checkNamed(validate(work / "unnormal_capture"), "normal.renormalised").status,
            CheckStatus::Warn);
  // Light kept in emission beyond Emit and Env (a volume's, transmission's) reaches every output
  // unfiltered: a warning above 2% of the colour.
  EXPECT_EQ(checkNamed(v, "emission.beyondEmitEnv").status, CheckStatus::Pass)
      << checkNamed(v, "emission.beyondEmitEnv").value;
  const fs::path foggy = work / "foggy_capture";
  fs::copy(work / "capture", foggy, fs::copy_options::recursive);
  json foggyDoc = parseJsonFile((foggy / "capture.json").string());
  foggyDoc["source"]["emissionBeyondEmitEnv"] = 0.12;
  std::ofstream(foggy / "capture.json") << foggyDoc.dump();
  EXPECT_EQ(checkNamed(validate(foggy), "emission.beyondEmitEnv").status, CheckStatus::Warn);
  // A figure that is no share (edited) fails its check, naming the field (-5 passed); a NaN pixel
  // in Combined leaves the share of the finite pixels (it wrote NaN, which passed).
  foggyDoc["source"]["emissionBeyondEmitEnv"] = -5;
  std::ofstream(foggy / "capture.json") << foggyDoc.dump();
  const CaptureCheck& edited = checkNamed(validate(foggy), "emission.beyondEmitEnv");
  EXPECT_EQ(edited.status, CheckStatus::Fail);
  EXPECT_NE(edited.detail.find("source.emissionBeyondEmitEnv is no figure the importer writes"),
            std::string::npos)
      << edited.detail;
  const fs::path nanPixel = copied("nan_pixel");
  editFrames(nanPixel, "noisy", [](int t, LayerSet& passes, std::vector<LayerSpec>&) {
    if (t == 0) passes.get("ViewLayer.Combined").raw()[0] = std::nanf("");
  });
  importBlender(nanPixel, work / "nan_pixel_capture", {"nan_pixel"});
  const double share =
      parseJsonFile(
          (work / "nan_pixel_capture" / "capture.json").string())["source"]["emissionBeyondEmitEnv"]
          .get<double>();
  EXPECT_NEAR(share, checkNamed(v, "emission.beyondEmitEnv").value, 1e-3);
  // Each render's Cycles settings (cameras.json "renders", which the script writes): a reference
  // of other light than the noisy frames is refused naming the setting (one without bounces
  // passed every check); Cycles' denoiser is refused; a fixed seed for the noisy frames warns.
  EXPECT_EQ(checkNamed(v, "render.settings").status, CheckStatus::Pass)
      << checkNamed(v, "render.settings").detail;
  const auto withRenders = [&](const char* name, const std::function<void(json&)>& edit) {
    const fs::path dir = copied(name);
    json described = parseJsonFile((dir / "cameras.json").string());
    edit(described["renders"]);
    std::ofstream(dir / "cameras.json") << described.dump();
    return dir;
  };
  struct Refused {
    const char* name;
    std::function<void(json&)> edit;
    const char* error;
  };
  for (const Refused& refused :
       {Refused{"unbounced", [](json& renders) { renders["reference_a"]["maxBounces"] = 0; },
                "$.renders.reference_a.maxBounces: 0, where the noisy frames' is 4: a reference "
                "must render the same light"},
        Refused{"resampled", [](json& renders) { renders["noisy"]["samples"] = 4; },
                "$.renders.noisy.samples: 4, where cameras.json's spp declares 1"},
        Refused{"denoised", [](json& renders) { renders["noisy"]["denoising"] = true; },
                "$.renders.noisy.denoising: Cycles' denoiser was on"}}) {
    const fs::path dir = withRenders(refused.name, refused.edit),
                   capture = work / (std::string(refused.name) + "_c");
    EXPECT_NE(
        test::errorOf([&] { importBlender(dir, capture, {refused.name}); }).find(refused.error),
        std::string::npos)
        << refused.name;
    EXPECT_FALSE(fs::exists(capture)) << refused.name;
  }
  const fs::path fixedSeed =
      withRenders("fixed_seed", [](json& renders) { renders["noisy"]["animatedSeed"] = false; });
  importBlender(fixedSeed, work / "fixed_seed_capture", {"fixed_seed"});
  const CaptureCheck& seeded = checkNamed(validate(work / "fixed_seed_capture"), "render.settings");
  EXPECT_EQ(seeded.status, CheckStatus::Warn);
  EXPECT_NE(seeded.detail.find("the noisy frames' seed is not animated"), std::string::npos)
      << seeded.detail;
  // The render folder given where a capture is wanted: said what to do with it.
  for (const std::string& error : {test::errorOf([&] { readCaptureDescription(work / "render"); }),
                                   test::errorOf([&] { Sequence::open(work / "render"); })})
    EXPECT_NE(error.find("not a capture (no capture.json) but a Blender render (cameras.json, "
                         "noisy/); import it first: arena import blender " +
                         (work / "render").string() + " --out CAPTURE"),
              std::string::npos)
        << error;
  // Motion blur on: Cycles' Vector pass holds no frame-to-frame motion (here: zero); the failure
  // says what to look at, and a run on the refused capture says it was refused (it read "no
  // reference noise floor" of a capture with colorHalf).
  const fs::path blurred = copied("motion_blur");
  editFrames(blurred, "noisy", [](int, LayerSet& passes, std::vector<LayerSpec>&) {
    for (float& x : passes.get("ViewLayer.Vector").raw()) x = 0;
  });
  importBlender(blurred, work / "blurred_capture", {"blurred"});
  const CaptureCheck blur = checkNamed(validate(work / "blurred_capture"), "motion.consistency");
  EXPECT_EQ(blur.status, CheckStatus::Fail);
  EXPECT_NE(blur.detail.find("from Blender: was motion blur on?"), std::string::npos)
      << blur.detail;
  RunConfig blurredRun = captureRun(work / "blurred_run", {}, {work / "blurred_capture"});
  blurredRun.denoisers = {{"eaw", {}, ""}};
  blurredRun.warmup = 1;
  const json br = runMatrix(blurredRun);
  EXPECT_EQ(br["scenes"]["blurred"]["referenceQuality"]["verdict"],
            "blurred: reference quality unknown (the capture was refused: its validation failed, "
            "and nothing was measured)");
  // A frame beyond those cameras.json declares was dropped silently; frames numbered from 1
  // (Blender's default) are named as such.
  const fs::path extra = copied("extra_frame");
  fs::copy_file(extra / "noisy" / "frame_0004.exr", extra / "noisy" / "frame_0005.exr");
  EXPECT_NE(test::errorOf([&] { importBlender(extra, work / "extra_capture", {"extra"}); })
                .find("noisy: holds frame_0005.exr beyond the 5 frames " +
                      (extra / "cameras.json").string() + " declares ($.frames)"),
            std::string::npos);
  const fs::path fromOne = copied("from_one");
  for (int t = 4; t >= 0; --t)
    fs::rename(fromOne / "noisy" / numberedFileName("frame", t, 4),
               fromOne / "noisy" / numberedFileName("frame", t + 1, 4));
  EXPECT_NE(test::errorOf([&] { importBlender(fromOne, work / "one_capture2", {"one2"}); })
                .find("noisy/frame_0000.exr: file does not exist; frames are frame_0000.exr to "
                      "frame_0004.exr (numbered from 0, four digits; this folder is numbered from "
                      "1, Blender's frame numbers: name the files from 0 whatever the scene's "
                      "first frame, as scripts/blender/render_capture.py writes frame f as f - "
                      "frame_start); the folder holds frame_0001.exr, frame_0002.exr, "
                      "frame_0003.exr, ... (5 in all)"),
            std::string::npos);
}

}  // namespace
}  // namespace arena
