// SLGF (denoisers/slgf.cpp) on tiny rendered sequences beside SVGF: little steady-state error, a
// faster response to light changes; plus the contracts (constant in -> constant out, a darkened
// history corrected at once).
#include <gtest/gtest.h>

#include "tests/svgf_family_fixture.hpp"

namespace arena {
namespace {

using namespace test::svgf_family;

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

}  // namespace
}  // namespace arena
