// A-SVGF (denoisers/asvgf.cpp) on tiny rendered sequences beside SVGF: the gradient of a static
// scene is exactly zero and A-SVGF then is SVGF; it responds to a light switched off and to a
// moving shadow faster than SVGF at little steady-state error; plus the contracts (constant in ->
// constant out with the gradient paths active, bad parameters of A-SVGF and SLGF).
#include <gtest/gtest.h>

#include "tests/svgf_family_fixture.hpp"

namespace arena {
namespace {

using namespace test::svgf_family;

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
          "false";  // eq. 15 literally (Q2RTX's order: fidelity_asvgf_test)
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
