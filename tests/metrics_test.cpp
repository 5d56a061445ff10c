// Metrics against hand-computed values (docs/metrics.md).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/display.hpp"
#include "core/error.hpp"
#include "metrics/error.hpp"
#include "metrics/ghosting.hpp"
#include "metrics/summary.hpp"
#include "metrics/temporal.hpp"

namespace arena {
namespace {

Image constant(int w, int h, float v, int c = 3) { return Image(w, h, c, v); }

Image noisy(int w, int h, float mean, float sigma, unsigned seed) {
  Image img(w, h, 3);
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, sigma);
  for (float& v : img.raw()) v = std::max(0.0f, mean + n(rng));
  return img;
}

TEST(Metrics, IdenticalImagesHaveZeroError) {
  Image a = noisy(20, 10, 0.5f, 0.1f, 1);
  ErrorStats e = linearError(a, a, nullptr);
  EXPECT_EQ(e.relMse, 0.0);
  EXPECT_EQ(e.mse, 0.0);
  EXPECT_EQ(psnrFromMse(meanSquaredError(a, a)), kPsnrCapDb);
  EXPECT_NEAR(ssim(a, a), 1.0, 1e-12);
}

TEST(Metrics, ConstantOffsetGivesTheExactRelMse) {
  Image r = constant(16, 8, 2.0f), d = constant(16, 8, 2.5f);
  ErrorStats e = linearError(d, r, nullptr);
  EXPECT_NEAR(e.relMse, 0.25 / (4.0 + 0.01), 1e-9);
  EXPECT_NEAR(e.mse, 0.25, 1e-9);
  EXPECT_NEAR(e.rmse, 0.5, 1e-9);
}

TEST(Metrics, PsnrOfAKnownMse) {
  Image a = constant(8, 8, 0.5f), b = constant(8, 8, 0.6f);
  EXPECT_NEAR(psnrFromMse(meanSquaredError(a, b)), 20.0, 1e-4);  // MSE 0.01 -> 20 dB
}

TEST(Metrics, SsimOfConstantImagesMatchesTheFormula) {
  // Constant images: variances and covariance vanish, SSIM = (2ab + C1) / (a^2 + b^2 + C1).
  const double a = 0.3, b = 0.6, c1 = 1e-4;
  double expected = (2 * a * b + c1) / (a * a + b * b + c1);
  EXPECT_NEAR(ssim(constant(32, 32, float(a)), constant(32, 32, float(b))), expected, 1e-6);
}

TEST(Metrics, SsimDropsWithNoise) {
  Image clean = constant(48, 48, 0.5f);
  double s1 = ssim(clean, noisy(48, 48, 0.5f, 0.02f, 3)), s2 = ssim(clean, noisy(48, 48, 0.5f, 0.2f, 3));
  EXPECT_LT(s1, 1.0);
  EXPECT_LT(s2, s1);
  EXPECT_LT(s2, 0.5);  // clearly noisy images must not score ~1 (OpenCV's 0..255 pitfall)
}

TEST(Metrics, ReferenceNoiseFloorAndCorrection) {
  Image r = constant(10, 10, 1.0f), var = constant(10, 10, 0.01f), d = constant(10, 10, 1.2f);
  EXPECT_NEAR(referenceRelMse(r, var), 0.01 / 1.01, 1e-9);
  ErrorStats e = linearError(d, r, &var);
  EXPECT_NEAR(e.relMse, 0.04 / 1.01, 1e-7);
  EXPECT_NEAR(e.relMseCorrected, 0.03 / 1.01, 1e-7);
}

TEST(Metrics, SizeMismatchIsAnError) {
  EXPECT_THROW(linearError(constant(4, 4, 1), constant(5, 4, 1), nullptr), Error);
  EXPECT_THROW(ssim(constant(4, 4, 1), constant(4, 5, 1)), Error);
}

TEST(Metrics, StaticReferenceAndStaticOutputHaveNoFlicker) {
  Image r = noisy(12, 12, 1.0f, 0.3f, 5), d = noisy(12, 12, 1.0f, 0.3f, 6);
  EXPECT_EQ(temporalRelativeMae(d, d, r, r), 0.0);
  EXPECT_EQ(temporalPsnr(d, d, r, r), kPsnrCapDb);
  // A flickering output against a static reference does flicker.
  Image d2 = noisy(12, 12, 1.0f, 0.3f, 7);
  EXPECT_GT(temporalRelativeMae(d2, d, r, r), 0.1);
}

LayerSet flatGBuffer(int w, int h, float motionX) {
  LayerSet g;
  g.set("depth", Image(w, h, 1, 2.0f));
  Image n(w, h, 3);
  for (size_t i = 0; i < n.pixelCount(); ++i) n.plane(2)[i] = 1.0f;
  g.set("normal", n);
  g.set("meshId", Image(w, h, 1, 0.0f));
  Image m(w, h, 2);
  for (size_t i = 0; i < m.pixelCount(); ++i) m.plane(0)[i] = motionX;
  g.set("motion", m);
  return g;
}

TEST(Metrics, WarpedFlickerOfAnOutputEqualToTheReferenceIsZero) {
  // The image content moves 2 px to the right per frame; the output equals the reference.
  const int w = 16, h = 8;
  Image rPrev = noisy(w, h, 1, 0.5f, 8), r(w, h, 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) r.at(x, y, c) = rPrev.atClamped(x - 2, y, c);
  Image zero(w, h, 3);
  LayerSet g = flatGBuffer(w, h, -2.0f), gPrev = flatGBuffer(w, h, -2.0f);
  WarpedFlicker f = warpedFlicker(zero, zero, g, gPrev);
  EXPECT_EQ(f.value, 0.0);
  EXPECT_GT(f.validFraction, 0.7);
  // An error that crawls (independent noise each frame) shows up; one that moves with the
  // surface does not.
  Image ePrev = noisy(w, h, 0, 0.2f, 9), eNow(w, h, 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) eNow.at(x, y, c) = ePrev.atClamped(x - 2, y, c);
  EXPECT_NEAR(warpedFlicker(eNow, ePrev, g, gPrev).value, 0.0, 1e-6);
  EXPECT_GT(warpedFlicker(noisy(w, h, 0, 0.2f, 10), ePrev, g, gPrev).value, 0.1);
}

TEST(Metrics, GhostingStepThatRecoversInKFrames) {
  // Event at t0 = 10, window from 5: flat 0.1, jumps to 1.0, decays linearly back to 0.1 in
  // exactly k = 4 frames, then stays.
  const int t0 = 10, begin = 5, k = 4;
  std::vector<double> curve;
  for (int t = begin; t <= t0 + 30; ++t) {
    double v = 0.1;
    if (t >= t0 && t < t0 + k) v = 1.0 - 0.9 * double(t - t0) / k;
    curve.push_back(v);
  }
  // The secondary figures on E_M (metrics.md); the response is measured on the bias (0.5 here,
  // never within 5%: not settled).
  GhostingResult g = analyseGhosting(t0, begin, curve, std::vector<double>(curve.size(), 0.5));
  EXPECT_NEAR(g.steadyState, 0.1, 1e-12);
  EXPECT_NEAR(g.peakExcess, 0.9, 1e-12);
  EXPECT_FALSE(g.settled);
  EXPECT_NEAR(g.ghostEnergy, 0.9 + 0.675 + 0.45 + 0.225, 1e-9);
  EXPECT_NEAR(g.signedBias, 0.5, 1e-12);
}

TEST(Metrics, ChangedRegionAndTrail) {
  Image before = constant(4, 1, 1.0f), after = constant(4, 1, 1.0f);
  for (int c = 0; c < 3; ++c) after.at(1, 0, c) = 0.5f;  // 50% darker: inside
  for (int c = 0; c < 3; ++c) after.at(2, 0, c) = 0.9f;  // 10% darker: outside (tau 0.2)
  Image mask = changedRegion(after, before);
  EXPECT_EQ(mask.at(0, 0), 0.0f);
  EXPECT_EQ(mask.at(1, 0), 1.0f);
  EXPECT_EQ(mask.at(2, 0), 0.0f);
  Image idPrev(4, 1, 1, 0.0f), idNow(4, 1, 1, 0.0f);
  idPrev.at(3, 0) = 7.0f;  // object 7 was at pixel 3 and left
  addTrail(mask, 7, {&idPrev}, idNow);
  EXPECT_EQ(mask.at(3, 0), 1.0f);
}

TEST(Metrics, SummaryAfterWarmup) {
  std::vector<double> v = {100, 100, 1, 2, 3, 4, NAN};
  Summary s = summarize(v, 2);
  EXPECT_EQ(s.frames, 4);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_NEAR(s.p95, 3.85, 1e-12);
}

TEST(Metrics, DisplayTransformIsMonotoneAndBounded) {
  DisplayTransform t;
  t.exposure = 1.0f;
  float prev = -1;
  for (float x : {0.0f, 0.01f, 0.1f, 1.0f, 3.0f}) {
    float y = t.apply(x);
    EXPECT_GE(y, 0.0f);
    EXPECT_LE(y, 1.0f);
    EXPECT_GT(y, prev);
    prev = y;
  }
  EXPECT_NEAR(t.apply(1000.0f), 1.0f, 1e-6);  // saturates
  EXPECT_LE(t.apply(1000.0f), 1.0f);          // never exceeds
}

}  // namespace
}  // namespace arena
