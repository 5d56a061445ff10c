// `reengine` (CAPCOM RE ENGINE 2023, seed 004) and its low-resolution reconstruction block:
// every switch changes the output, all stages off is `temporal` bit for bit, the disocclusion rays
// lower the error where the history is fresh and are charged as rays per pixel, bad set-ups are
// errors that say what to do.
#include "denoisers/reengine.hpp"

#include <gtest/gtest.h>
#include <xmmintrin.h>

#include <cmath>
#include <cstdio>
#include <map>

#include "core/error.hpp"
#include "core/sequence.hpp"
#include "denoisers/common/lowres_upsample.hpp"
#include "denoisers/common/reprojection.hpp"
#include "harness/denoise_run.hpp"
#include "harness/run_matrix.hpp"
#include "reports/report.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// ---- The reconstruction block on a flat, camera-facing plane.
struct Plane {
  int w = 16, h = 8;
  Image depth{w, h, 1, 2.0f}, normal{w, h, 3}, meshId{w, h, 1, 0.0f}, position{w, h, 3};
  Plane() {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        normal.at(x, y, 2) = 1.0f;
        position.at(x, y, 0) = 0.01f * float(x);
        position.at(x, y, 1) = 0.01f * float(y);
        position.at(x, y, 2) = -2.0f;
      }
  }
  GBufferView view() const {
    GBufferView g;
    g.width = w;
    g.height = h;
    g.depth = depth.plane(0);
    g.meshId = meshId.plane(0);
    for (int c = 0; c < 3; ++c) {
      g.normal[size_t(c)] = normal.plane(c);
      g.position[size_t(c)] = position.plane(c);
    }
    return g;
  }
};

TEST(LowresUpsample, AConstantBufferReconstructsToItselfAndCountsTheTexelsRead) {
  Plane plane;
  const Image low(4, 2, 3, 2.0f);
  Image direction(4, 2, 3);
  for (size_t i = 0; i < direction.pixelCount(); ++i) direction.plane(2)[i] = 0.5f;  // along n
  Image need(plane.w, plane.h, 1), out(plane.w, plane.h, 3, -1.0f), confidence(plane.w, plane.h, 1);
  for (int y = 0; y < plane.h; ++y)
    for (int x = 0; x < 4; ++x) need.at(x, y) = 1.0f;  // the left quarter only
  LowresUpsampler up;
  up.setup(plane.w, plane.h, 4);
  const size_t texels =
      up.reconstruct({low, &direction, 4, 16}, plane.view(), nullptr, need, {}, out, confidence);
  for (int y = 0; y < plane.h; ++y)
    for (int x = 0; x < plane.w; ++x)
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(out.at(x, y, c), x < 4 ? 2.0f : -1.0f, 1e-5f)
            << x << "," << y;  // untouched elsewhere
  // Pixels 0..3 lie between the anchors of texel columns 0 and 1 (pixels 2 and 6): 2 x 2 texels.
  EXPECT_EQ(texels, 4u);
  EXPECT_DOUBLE_EQ(up.raysPerPixel(), 4.0 * 16.0 / (16.0 * 8.0));
  EXPECT_NEAR(confidence.at(1, 3), 1.0f, 1e-4f);
}

TEST(LowresUpsample, DirectionAndMomentsShapeTheResult) {
  Plane plane;
  // Tilt the right half's normal towards +x: light arriving along +z then falls off as the L1 SH
  // irradiance (1 + 2 d.n) / (1 + 2 d.n_anchor) wherever the anchor kept the old normal.
  for (int y = 0; y < plane.h; ++y)
    for (int x = 0; x < plane.w; ++x)
      if (x == 5) {  // one pixel between anchors 2 and 6, which face +z
        plane.normal.at(x, y, 0) = 0.6f;
        plane.normal.at(x, y, 2) = 0.8f;
      }
  const Image low(4, 2, 3, 1.0f);
  Image direction(4, 2, 3);
  for (size_t i = 0; i < direction.pixelCount(); ++i) direction.plane(2)[i] = 1.0f;
  Image need(plane.w, plane.h, 1, 1.0f), out(plane.w, plane.h, 3), confidence(plane.w, plane.h, 1);
  LowresUpsampler up;
  up.setup(plane.w, plane.h, 4);
  LowresUpsampleSettings s;
  s.weights.normal = false;  // let the tilted pixel read its neighbours' texels
  s.weights.planeDistance = false;
  up.reconstruct({low, &direction, 4, 8}, plane.view(), nullptr, need, s, out, confidence);
  EXPECT_NEAR(out.at(5, 3, 0), (1.0f + 2.0f * 0.8f) / 3.0f, 1e-4f);
  EXPECT_NEAR(out.at(4, 3, 0), 1.0f, 1e-5f);
  s.directional = false;
  up.reconstruct({low, &direction, 4, 8}, plane.view(), nullptr, need, s, out, confidence);
  EXPECT_NEAR(out.at(5, 3, 0), 1.0f, 1e-5f);
  // Moment clamp: the full-resolution box mean 0.25, sigma 0 pulls the luminance down to 0.25.
  Image moments(plane.w, plane.h, 6);
  for (int c = 0; c < 3; ++c)
    for (size_t i = 0; i < moments.pixelCount(); ++i) {
      moments.plane(c)[i] = 0.25f;
      moments.plane(c + 3)[i] = 0.0625f;
    }
  up.reconstruct({low, &direction, 4, 8}, plane.view(), &moments, need, s, out, confidence);
  EXPECT_NEAR(out.at(4, 3, 1), 0.25f, 1e-5f);
  s.momentClamp = false;
  up.reconstruct({low, &direction, 4, 8}, plane.view(), &moments, need, s, out, confidence);
  EXPECT_NEAR(out.at(4, 3, 1), 1.0f, 1e-5f);
}

TEST(LowresUpsample, AMismatchedBufferIsAnErrorNamingBothSizes) {
  Plane plane;
  const Image low(3, 2, 3, 1.0f);
  Image need(plane.w, plane.h, 1, 1.0f), out(plane.w, plane.h, 3), confidence(plane.w, plane.h, 1);
  LowresUpsampler up;
  up.setup(plane.w, plane.h, 4);
  try {
    up.reconstruct({low, nullptr, 4, 8}, plane.view(), nullptr, need, {}, out, confidence);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("3x2, expected 4x2"), std::string::npos) << e.what();
  }
}

// ---- The denoiser on tiny rendered sequences.
struct Rendered {
  Sequence sequence;
  std::vector<LayerSet> frames;
};

const Rendered& rendered(const std::string& scene, int w, int h, int frames, int refSpp,
                         int lowresFactor) {
  static std::map<std::string, std::unique_ptr<Rendered>> cache;
  const std::string key = scene + std::to_string(w) + "x" + std::to_string(h) + "f" +
                          std::to_string(frames) + "r" + std::to_string(refSpp) + "l" +
                          std::to_string(lowresFactor);
  auto it = cache.find(key);
  if (it != cache.end()) return *it->second;
  RenderSettings s = test::tinySettings(w, h, frames, refSpp);
  s.lowresFactor = lowresFactor;
  s.lowresSpp = 16;
  const fs::path dir =
      renderSequence(test::shippedScene(scene), s, test::freshDir("reengine_" + key), nullptr);
  auto r = std::make_unique<Rendered>(Rendered{Sequence::open(dir), {}});
  for (int t = 0; t < frames; ++t) r->frames.push_back(r->sequence.frame(t));
  return *cache.emplace(key, std::move(r)).first->second;
}

struct RunResult {
  std::vector<Image> color, diffuse, specular;
  std::vector<double> rays;
};

RunResult runDenoiser(const Rendered& r, const std::string& name,
                      std::map<std::string, std::string> params) {
  DenoiseRun run({name, std::move(params), name}, r.sequence);
  RunResult out;
  run.run([&](int t) -> const LayerSet& { return r.frames[size_t(t)]; },
          [&](const DenoisedFrame& f) {
            out.color.push_back(f.color);
            out.diffuse.push_back(f.diffuse);
            out.specular.push_back(f.specular);
            out.rays.push_back(f.extraRaysPerPixel);
          });
  return out;
}

bool sameOutput(const RunResult& a, const RunResult& b) {
  for (size_t t = 0; t < a.color.size(); ++t)
    if (!samePixels(a.color[t], b.color[t])) return false;
  return true;
}

TEST(ReEngine, EverySwitchChangesTheOutput) {
  // Glossy orbit: a mirror-like floor (roughness 0.15), rough objects, a moving camera, so every
  // stage -- smooth and rough specular, disocclusions, the low-resolution buffer -- has work.
  const Rendered& r = rendered("glossy_orbit", 48, 27, 5, 4, 4);
  const RunResult base = runDenoiser(r, "reengine", {});
  int switches = 0;
  for (const ParamSpec& spec : reEngineParams().specs()) {
    std::vector<std::string> alternatives;
    if (spec.type == ParamSpec::Type::Bool)
      alternatives = {spec.defaultValue != 0 ? "false" : "true"};
    if (spec.type == ParamSpec::Type::Choice)
      for (size_t k = 0; k < spec.choices.size(); ++k)
        if (int(k) != int(spec.defaultValue)) alternatives.push_back(spec.choices[k]);
    for (const std::string& value : alternatives) {
      const RunResult other = runDenoiser(r, "reengine", {{spec.name, value}});
      if (spec.name == "disocclusionRays" && value == "on") {
        // auto reads the buffer whenever the sequence has one, as here: the same output.
        EXPECT_TRUE(sameOutput(base, other));
        continue;
      }
      EXPECT_FALSE(sameOutput(base, other)) << spec.name << "=" << value << " changes nothing";
      ++switches;
    }
  }
  EXPECT_EQ(switches, 16);  // 12 booleans, space, 2 specular motions, disocclusionRays=off
}

TEST(ReEngine, AllStagesOffIsTemporalAccumulationBitForBit) {
  const Rendered& r = rendered("glossy_orbit", 48, 27, 5, 4, 4);
  const RunResult off = runDenoiser(r, "reengine",
                                    {{"propagation1", "false"},
                                     {"lumaRejection", "false"},
                                     {"specularColorClamp", "false"},
                                     {"specularMotion", "geometry"},
                                     {"propagation2", "false"},
                                     {"varianceCheck", "false"},
                                     {"spatialMerge", "false"},
                                     {"deflicker", "false"},
                                     {"disocclusionRays", "off"},
                                     {"spatialFilter", "false"},
                                     {"maxHistory", "32"}});
  const RunResult temporal = runDenoiser(r, "temporal", {{"maxHistory", "32"}});
  for (size_t t = 0; t < off.color.size(); ++t) {
    EXPECT_TRUE(samePixels(off.diffuse[t], temporal.diffuse[t])) << "frame " << t;
    EXPECT_TRUE(samePixels(off.specular[t], temporal.specular[t])) << "frame " << t;
    EXPECT_EQ(off.rays[t], 0.0);
  }
}

TEST(ReEngine, DisocclusionRaysOnWithoutTheBufferSaysHowToRenderIt) {
  const Rendered& r = rendered("glossy_orbit", 24, 14, 2, 4, 0);
  try {
    runDenoiser(r, "reengine", {{"disocclusionRays", "on"}});
    FAIL() << "accepted a sequence without the low-resolution buffer";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--lowres-factor"), std::string::npos) << e.what();
  }
  // auto runs without it and is charged nothing.
  const RunResult autoRays = runDenoiser(r, "reengine", {});
  for (double rays : autoRays.rays) EXPECT_EQ(rays, 0.0);
}

// Identical inputs give identical bits, whichever denormal mode the calling thread is in (the
// tracer leaves flush-to-zero on in threads it ran on): two instances, pass by pass.
TEST(ReEngine, IdenticalInputsGiveIdenticalPassesInAnyDenormalMode) {
  const Rendered& r = rendered("camera_pan_occluder", 64, 36, 10, 32, 4);
  const SequenceInfo& info = r.sequence.info();
  for (SignalKind kind : {SignalKind::Diffuse, SignalKind::Specular}) {
    const DenoiserInfo& registered = DenoiserRegistry::instance().find("reengine");
    const ParamSet params = registered.schema.resolve({}, "reengine");
    ReEngine a(reEngineParams().settings(params, "reengine"), kind),
        b(reEngineParams().settings(params, "reengine"), kind);
    a.setup(info.width, info.height);
    b.setup(info.width, info.height);
    Image outA(info.width, info.height, 3), outB(info.width, info.height, 3);
    const unsigned saved = _mm_getcsr();
    for (int t = 0; t < info.frames; ++t) {
      const LayerSet low = r.sequence.lowres(t);
      const LowresInputs lowres{low, info.lowresFactor(), info.lowresSpp()};
      FrameContext ctx;
      ctx.frameIndex = t;
      ctx.width = info.width;
      ctx.height = info.height;
      ctx.camera = info.cameras[size_t(t)];
      ctx.previousCamera = info.cameras[size_t(std::max(t - 1, 0))];
      ctx.reset = t == 0;
      const Image& signal = r.frames[size_t(t)].get(signalName(kind));
      _mm_setcsr(saved & ~0x8040u);
      a.denoise(ctx, {signal, r.frames[size_t(t)], nullptr, &lowres}, outA);
      _mm_setcsr(saved | 0x8040u);
      b.denoise(ctx, {signal, r.frames[size_t(t)], nullptr, &lowres}, outB);
      _mm_setcsr(saved);
      const auto passesA = a.passOutputs(), passesB = b.passOutputs();
      for (size_t k = 0; k < passesA.size(); ++k)
        ASSERT_TRUE(samePixels(*passesA[k].second, *passesB[k].second))
            << signalName(kind) << " frame " << t << ": " << passesA[k].first << " differs";
      ASSERT_TRUE(samePixels(outA, outB));
    }
  }
}

// Frames since each pixel was last disoccluded (1 = disoccluded now), by the shared reprojection's
// consistency tests, as `temporal` counts them.
std::vector<Image> historyAges(const Rendered& r) {
  const SequenceInfo& info = r.sequence.info();
  const std::vector<std::string> layers = {"depth", "normal", "meshId", "motion", "position"};
  Reprojection reprojection;
  reprojection.setup(info.width, info.height);
  GBufferHistory previous;
  previous.setup(info.width, info.height);
  Image derivatives(info.width, info.height, kGeometryDerivativeChannels);
  std::vector<Image> ages;
  for (int t = 0; t < info.frames; ++t) {
    const GBufferView g = GBufferView::fromFrame(r.frames[size_t(t)], layers, "test");
    computeGeometryDerivatives(g, derivatives);
    if (t == 0)
      reprojection.invalidateAll();
    else
      reprojection.compute(g, derivatives, previous.view(), reprojectionParams().defaults(),
                           &info.cameras[size_t(t)], &info.cameras[size_t(t - 1)]);
    Image age(info.width, info.height, 1);
    for (size_t i = 0; i < age.pixelCount(); ++i)
      age.plane(0)[i] =
          reprojection.valid(i) ? reprojection.sample(i, ages.back().plane(0)) + 1.0f : 1.0f;
    ages.push_back(std::move(age));
    previous.store(g);
  }
  return ages;
}

// relMSE (metrics.md: (x - r)^2 / (r^2 + 0.01), mean over channels) over the pixels disoccluded in
// the last 3 frames (age 1..3), frames 1.. (frame 0 is all "disoccluded").
double freshRelMse(const Rendered& r, const std::vector<Image>& ages, const RunResult& run,
                   long* count = nullptr) {
  double sum = 0;
  long n = 0;
  for (int t = 1; t < r.sequence.info().frames; ++t) {
    const LayerSet reference = r.sequence.reference(t);  // kept: ref points into it
    const Image& ref = reference.get("color");
    const Image& meshId = r.frames[size_t(t)].get("meshId");
    for (size_t i = 0; i < ref.pixelCount(); ++i) {
      if (ages[size_t(t)].plane(0)[i] > 3.0f || meshId.plane(0)[i] < 0.0f) continue;
      for (int c = 0; c < 3; ++c) {
        const double x = run.color[size_t(t)].plane(c)[i], v = ref.plane(c)[i];
        sum += (x - v) * (x - v) / (v * v + 0.01);
      }
      ++n;
    }
  }
  if (count) *count = n;
  return sum / double(3 * std::max(n, 1L));
}

TEST(ReEngine, DisocclusionRaysEarnTheirCostWhereHistoryIsFresh) {
  for (const std::string scene : {"camera_pan_occluder", "moving_object"}) {
    const Rendered& r = rendered(scene, 64, 36, 10, 32, 4);
    const std::vector<Image> ages = historyAges(r);
    const RunResult with = runDenoiser(r, "reengine", {{"disocclusionRays", "on"}});
    const RunResult without = runDenoiser(r, "reengine", {{"disocclusionRays", "off"}});
    long fresh = 0;
    const double errWith = freshRelMse(r, ages, with, &fresh),
                 errWithout = freshRelMse(r, ages, without);
    EXPECT_GT(fresh, 100) << scene;
    std::printf(
        "%s fresh pixels (age 1-3, %ld): relMSE with disocclusion rays %.5f, without %.5f; "
        "rays/pixel frame 0 %.3f\n",
        scene.c_str(), fresh, errWith, errWithout, with.rays[0]);
    EXPECT_LT(errWith, errWithout) << scene << ": with " << errWith << ", without " << errWithout;
    // Charged: frame 0 reads the buffer everywhere; later frames only around the fresh pixels.
    EXPECT_GT(with.rays[0], 0.5);
    double later = 0;
    for (size_t t = 1; t < with.rays.size(); ++t)
      later += with.rays[t] / double(with.rays.size() - 1);
    EXPECT_GT(later, 0.0) << scene;
    EXPECT_LT(later, with.rays[0]) << scene;
    std::printf("%s: later frames %.3f extra rays/pixel on average\n", scene.c_str(), later);
    for (double rays : without.rays) EXPECT_EQ(rays, 0.0);
  }
}

TEST(ReEngine, ARunChargesTheExtraRaysAtTheRendersOwnPathRate) {
  // The run records the paths read per pixel and their equivalent tracing time, and the report's
  // speed points carry both; tracing time = rays/pixel x pixels / the rate sequence.json records.
  RunConfig c;
  c.name = "reengine_tracing";
  c.out = test::freshDir("run_reengine_tracing");
  c.cache = test::freshDir("run_reengine_tracing_cache");
  c.render = test::tinySettings(48, 27, 5, 8);
  c.render.lowresFactor = 4;
  c.render.lowresSpp = 4;
  c.scenes = {test::shippedScene("moving_object")};
  c.denoisers = {{"reengine", {{"disocclusionRays", "on"}}, ""}, {"eaw", {}, ""}};
  c.baselines = false;
  c.warmup = 1;
  c.flip = "none";
  c.keepFrames = "none";
  const json r = runMatrix(c);
  ASSERT_EQ(r["pairs"].size(), 2u);
  const json& re = r["pairs"][0];
  ASSERT_EQ(re["status"], "ok") << re.dump();
  fs::path seqDir;
  // The sequence with the low-res buffer (its references live in, and link to, the seedless one's).
  for (const auto& entry : fs::directory_iterator(c.cache))
    if (fs::exists(entry.path() / "sequence.json")) seqDir = entry.path();
  const SequenceInfo info = Sequence::open(seqDir).info();
  ASSERT_GT(info.lowresPathsPerSecond, 0.0) << "the render did not record its path rate";
  const double rays = re["summary"]["extraRaysPerPixel"]["mean"].get<double>();
  ASSERT_GT(rays, 0.0);
  // The mean of per-frame charges equals the charge of the mean rays (a linear map).
  EXPECT_NEAR(re["summary"]["tracingMs"]["mean"].get<double>(),
              rays * 48 * 27 / info.lowresPathsPerSecond * 1e3, 1e-9 * (1 + rays));
  // A denoiser that reads no buffer is charged nothing, and says so by not having the field.
  EXPECT_FALSE(r["pairs"][1]["summary"].contains("tracingMs"));
  // The report's speed point carries the bar's length.
  const json data = reportData(r, c.out, nullptr);
  bool found = false;
  for (const json& p : data["speed"]["scenes"]["moving_object"]["relMse"]["points"])
    if (p["label"] == re["label"]) {
      found = true;
      EXPECT_EQ(p["tracingMs"], re["summary"]["tracingMs"]["mean"]);
    }
  EXPECT_TRUE(found);
}

}  // namespace
}  // namespace arena
