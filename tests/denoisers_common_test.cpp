// The shared denoiser blocks (denoisers/common/): analytic and property tests on tiny synthetic
// G-buffers of odd sizes, built here (no files).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/consistency.hpp"
#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "core/non_finite.hpp"
#include "denoisers/common/atrous.hpp"
#include "denoisers/common/edge_stopping.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/common/history_clamp.hpp"
#include "denoisers/common/median.hpp"
#include "denoisers/common/poisson_blur.hpp"
#include "denoisers/common/remodulation.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/common/simd.hpp"
#include "denoisers/common/temporal_accumulation.hpp"
#include "denoisers/common/variance.hpp"
#include "denoisers/svgf.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

using test::hashUniform;

Image randomImage(int w, int h, int channels, uint32_t seed, float lo = 0.0f, float hi = 1.0f) {
  Image image(w, h, channels);
  for (int c = 0; c < channels; ++c)
    for (int i = 0; i < w * h; ++i) image.plane(c)[i] = lo + (hi - lo) * hashUniform(seed, c, i);
  return image;
}

// A synthetic G-buffer: a camera-facing plane at depth 2, normal +Z, mesh 0, zero motion.
struct SyntheticGBuffer {
  int w, h;
  Image depth, normal, meshId, motion, position;
  SyntheticGBuffer(int width, int height)
      : w(width),
        h(height),
        depth(width, height, 1, 2.0f),
        normal(width, height, 3),
        meshId(width, height, 1, 0.0f),
        motion(width, height, 2, 0.0f),
        position(width, height, 3) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        normal.at(x, y, 2) = 1.0f;
        position.at(x, y, 0) = 0.01f * float(x);
        position.at(x, y, 1) = -0.01f * float(y);
        position.at(x, y, 2) = -2.0f;
      }
  }
  // Bumpy, tilted geometry: depth ramps, normals vary, two meshes, a sky corner.
  void makeVaried(uint32_t seed) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        depth.at(x, y) = 1.5f + 0.05f * float(x) + 0.02f * float(y);
        float nx = 0.3f * (hashUniform(seed, x, y) - 0.5f),
              ny = 0.3f * (hashUniform(seed + 1, x, y) - 0.5f);
        float nz = std::sqrt(1.0f - nx * nx - ny * ny);
        normal.at(x, y, 0) = nx;
        normal.at(x, y, 1) = ny;
        normal.at(x, y, 2) = nz;
        meshId.at(x, y) = x < w / 2 ? 0.0f : 1.0f;
        position.at(x, y, 2) = -depth.at(x, y);
        if (x + y < 3) {  // sky corner
          meshId.at(x, y) = -1.0f;
          depth.at(x, y) = 0.0f;
        }
      }
  }
  GBufferView view() const {
    GBufferView v;
    v.width = w;
    v.height = h;
    v.depth = depth.plane(0);
    v.meshId = meshId.plane(0);
    for (int c = 0; c < 3; ++c) v.normal[size_t(c)] = normal.plane(c);
    for (int c = 0; c < 2; ++c) v.motion[size_t(c)] = motion.plane(c);
    for (int c = 0; c < 3; ++c) v.position[size_t(c)] = position.plane(c);
    return v;
  }
  Image derivatives() const {
    Image d(w, h, kGeometryDerivativeChannels);
    computeGeometryDerivatives(view(), d);
    return d;
  }
};

// SVGF's terms at its defaults (its parameter table: depth, normal and luminance on).
EdgeStoppingSettings svgfEdges() { return svgfParams().defaults().atrous.edges; }
// SVGF's sigmas with every term on; the colour term at EAW's default sigma (2).
EdgeStoppingSettings allTermsOn() {
  EdgeStoppingSettings s = svgfEdges();
  s.depth = s.normal = s.luminance = s.position = s.color = s.id = true;
  s.sigmaColor = 2.0f;
  return s;
}
EdgeStoppingSettings allTermsOff() {
  EdgeStoppingSettings s = allTermsOn();
  s.depth = s.normal = s.luminance = s.position = s.color = s.id = false;
  return s;
}

// ---------------------------------------------------------------------------------------------
// Edge-stopping

TEST(DenoiserBlocksEdgeStopping, WeightsInUnitIntervalAndOneAtCentre) {
  SyntheticGBuffer g(17, 13);
  g.makeVaried(7);
  Image derivatives = g.derivatives();
  Image color = randomImage(17, 13, 3, 3, 0.0f, 5.0f);
  Image variance = randomImage(17, 13, 1, 4, 0.0f, 0.5f);
  for (NormalWeightForm form :
       {NormalWeightForm::CosinePower, NormalWeightForm::GaussianDistance}) {
    EdgeStoppingSettings s = allTermsOn();
    s.normalForm = form;
    s.sigmaN = form == NormalWeightForm::CosinePower ? 128.0f : 0.1f;
    EdgeStopping edges(s, g.view(), &derivatives, color, &variance, 0.5f);
    int below = 0;
    for (int y = 0; y < 13; ++y)
      for (int x = 0; x < 17; ++x) {
        size_t p = size_t(y) * 17 + size_t(x);
        auto centre = edges.centre(p);
        EXPECT_EQ(edges.weight(centre, p, 0, 0), 1.0f);
        for (int dy = -2; dy <= 2; ++dy)
          for (int dx = -2; dx <= 2; ++dx) {
            int qx = x + 2 * dx, qy = y + 2 * dy;
            if (qx < 0 || qy < 0 || qx >= 17 || qy >= 13) continue;
            float w = edges.weight(centre, size_t(qy) * 17 + size_t(qx), 2 * dx, 2 * dy);
            ASSERT_GE(w, 0.0f);
            ASSERT_LE(w, 1.0f);
            below += w < 1.0f;
          }
      }
    EXPECT_GT(below, 1000);  // the terms do act on varied input
  }
}

TEST(DenoiserBlocksEdgeStopping, TermsMatchTheirFormulas) {
  // SVGF eq. 3 with grad z = (0.1, 0) at offset (2, 0): exp(-|1 - 1.3| / (1 * 0.2 + 1e-3 * 1)).
  EXPECT_NEAR(depthWeight(1.0f, 1.3f, 0.1f, 0.0f, 2.0f, 0.0f, 1.0f, 1e-3f),
              std::exp(-0.3f / 0.201f), 1e-6f);
  EXPECT_NEAR(cosinePowerWeight(0.5f, 2.0f), 0.25f, 1e-7f);
  EXPECT_EQ(cosinePowerWeight(-0.5f, 128.0f), 0.0f);
  EXPECT_NEAR(gaussianWeight(0.2f, 0.1f), std::exp(-2.0f), 1e-7f);
  EXPECT_NEAR(luminanceWeight(1.0f, 2.0f, 4.0f), std::exp(-0.25f), 1e-7f);
}

TEST(DenoiserBlocksEdgeStopping, FastExpAndLogMatchTheLibrary) {
  EXPECT_EQ(expNonPositive(0.0f), 1.0f);
  EXPECT_EQ(expNonPositive(-100.0f), 0.0f);
  double worstExp = 0, worstLog = 0;
  for (int i = 0; i <= 100000; ++i) {
    float x = -80.0f * float(i) / 100000.0f;
    worstExp = std::max(worstExp, std::abs(double(expNonPositive(x)) / std::exp(double(x)) - 1.0));
    ASSERT_LE(expNonPositive(x), 1.0f);
    float y = std::pow(10.0f, -6.0f * float(i) / 100000.0f);  // (1e-6, 1]
    worstLog = std::max(worstLog, std::abs(double(logPositive(y)) - std::log(double(y))));
  }
  // Float rounding of x log2(e) bounds the exp error at about |x| 3e-8 relative (measured 3.7e-6
  // at x = -80 without FMA contraction, which the build disables for determinism); log's at half
  // an ulp of ln(1e-6) = -13.8.
  EXPECT_LT(worstExp, 5e-6);
  EXPECT_LT(worstLog, 2e-6);
}

TEST(DenoiserBlocksEdgeStopping, CombinedWeightIsTheProductOfTheTerms) {
  SyntheticGBuffer g(9, 7);
  g.makeVaried(2);
  Image derivatives = g.derivatives();
  Image color = randomImage(9, 7, 3, 8, 0.0f, 1.0f);
  Image variance(9, 7, 1, 0.3f);
  EdgeStoppingSettings s = allTermsOn();
  s.id = false;
  s.sigmaN = 16.0f;
  s.sigmaX = 0.5f;
  EdgeStopping edges(s, g.view(), &derivatives, color, &variance, 0.7f);
  const size_t p = 3 * 9 + 4, q = 4 * 9 + 6;  // offset (2, 1)
  auto lum = [&](size_t i) {
    return luminance(color.plane(0)[i], color.plane(1)[i], color.plane(2)[i]);
  };
  float d2x = 0, d2c = 0;
  for (int c = 0; c < 3; ++c) {
    d2x += std::pow(g.position.plane(c)[p] - g.position.plane(c)[q], 2.0f);
    d2c += std::pow(color.plane(c)[p] - color.plane(c)[q], 2.0f);
  }
  float expected =
      depthWeight(g.depth.plane(0)[p], g.depth.plane(0)[q], derivatives.plane(kDepthDx)[p],
                  derivatives.plane(kDepthDy)[p], 2.0f, 1.0f, s.sigmaZ, s.depthEpsilon) *
      cosinePowerWeight(g.view().normalDot(p, q), s.sigmaN) *
      luminanceWeight(lum(p), lum(q), s.sigmaL * std::sqrt(0.3f) + s.luminanceEpsilon) *
      gaussianWeight(d2x, s.sigmaX) * gaussianWeight(d2c, 0.7f);
  EXPECT_GT(expected, 1e-3f);
  EXPECT_NEAR(edges.weight(edges.centre(p), q, 2, 1), expected, 1e-5f * expected + 1e-9f);
}

// ---------------------------------------------------------------------------------------------
// À-trous

TEST(DenoiserBlocksAtrous, ConstantImageUnchangedAtEveryIterationAllTermsOn) {
  const int w = 19, h = 15;
  SyntheticGBuffer g(w, h);
  g.makeVaried(11);
  Image derivatives = g.derivatives();
  Image variance(w, h, 1, 0.0f), filteredVariance(w, h, 1);
  prefilterVariance3x3(variance, g.view(), filteredVariance);
  for (AtrousKernel kernel : {AtrousKernel::B3Spline5x5, AtrousKernel::Compact3x3}) {
    AtrousSettings settings{kernel, allTermsOn()};
    Image a(w, h, 3), b(w, h, 3), varOut(w, h, 1);
    for (int c = 0; c < 3; ++c) std::fill_n(a.plane(c), w * h, 0.25f + 0.5f * float(c));
    for (int i = 0; i < 5; ++i) {
      atrousIteration(i, settings, {g.view(), &derivatives, &filteredVariance}, 0.5f, a, b,
                      &variance, &varOut);
      for (int c = 0; c < 3; ++c)
        for (int p = 0; p < w * h; ++p)
          // A few ulps per iteration: the sums are fused multiply-adds, the weight sum plain adds.
          ASSERT_NEAR(b.plane(c)[p], 0.25f + 0.5f * float(c), 3e-6f) << "iteration " << i;
      for (int p = 0; p < w * h; ++p) ASSERT_EQ(varOut.plane(0)[p], 0.0f);
      std::swap(a, b);
    }
  }
}

// Reference convolution: the separable kernel over taps 2^i apart, off-image taps dropped and
// the rest renormalised.
Image directConvolution(const Image& in, int iteration, const std::vector<float>& kernel1d) {
  const int w = in.width(), h = in.height(), r = int(kernel1d.size()) / 2, step = 1 << iteration;
  Image out(w, h, in.channels());
  for (int c = 0; c < in.channels(); ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        double sum = 0, weights = 0;
        for (int j = -r; j <= r; ++j)
          for (int i = -r; i <= r; ++i) {
            int qx = x + i * step, qy = y + j * step;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
            double k = double(kernel1d[size_t(i + r)]) * double(kernel1d[size_t(j + r)]);
            sum += k * in.at(qx, qy, c);
            weights += k;
          }
        out.at(x, y, c) = float(sum / weights);
      }
  return out;
}

TEST(DenoiserBlocksAtrous, AllTermsOffIsPlainB3BlurWithRenormalisedBorder) {
  const int w = 17, h = 13;
  SyntheticGBuffer g(w, h);
  g.makeVaried(5);
  for (int p = 0; p < w * h; ++p) g.meshId.plane(0)[p] = 0.0f;  // no sky: a plain blur
  Image in = randomImage(w, h, 3, 21, 0.0f, 10.0f);
  struct Case {
    AtrousKernel kernel;
    std::vector<float> taps;
  };
  for (const Case& k :
       {Case{AtrousKernel::B3Spline5x5, {1 / 16.f, 1 / 4.f, 3 / 8.f, 1 / 4.f, 1 / 16.f}},
        Case{AtrousKernel::Compact3x3, {2 / 3.f, 1.f, 2 / 3.f}}}) {
    for (int iteration = 0; iteration < 4; ++iteration) {
      Image out(w, h, 3);
      atrousIteration(iteration, {k.kernel, allTermsOff()}, {g.view()}, 1.0f, in, out);
      Image expected = directConvolution(in, iteration, k.taps);
      double maxError = 0;
      for (size_t i = 0; i < out.raw().size(); ++i)
        maxError = std::max(maxError, double(std::abs(out.raw()[i] - expected.raw()[i])));
      EXPECT_LT(maxError, 2e-5) << "iteration " << iteration;
      // And it did blur: the output differs from the input.
      EXPECT_GT(std::abs(out.at(8, 6) - in.at(8, 6)), 1e-3f);
    }
  }
}

TEST(DenoiserBlocksAtrous, VariancePropagatesWithSquaredWeights) {
  // With every edge term off, one iteration on a constant variance v gives v * sum(h^2) in the
  // interior: sum over the 5x5 of (h_x h_y)^2 = (sum h^2)^2 = (0.2734375)^2.
  const int w = 21, h = 21;
  SyntheticGBuffer g(w, h);
  Image color(w, h, 3, 1.0f), out(w, h, 3), variance(w, h, 1, 2.0f), varOut(w, h, 1);
  atrousIteration(0, {AtrousKernel::B3Spline5x5, allTermsOff()}, {g.view()}, 1.0f, color, out,
                  &variance, &varOut);
  const double s = 2.0 * (1.0 / 256 + 1.0 / 16) + 9.0 / 64;
  EXPECT_NEAR(varOut.at(10, 10), 2.0 * s * s, 1e-6);
}

// Two halves with different constant values must stay exactly separate through 5 iterations.
void expectHalvesSeparate(SyntheticGBuffer& g, const EdgeStoppingSettings& edges) {
  const int w = g.w, h = g.h;
  Image derivatives = g.derivatives();
  Image a(w, h, 3), b(w, h, 3), variance(w, h, 1, 0.0f), filtered(w, h, 1), varOut(w, h, 1);
  auto valueAt = [&](int x) { return x < w / 2 ? 0.5f : 3.0f; };
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) a.at(x, y, c) = valueAt(x);
  // A variance as after accumulation of a noisy signal, so the luminance term alone would not stop.
  variance.fill(4.0f);
  for (int i = 0; i < 5; ++i) {
    prefilterVariance3x3(variance, g.view(), filtered);
    atrousIteration(i, {AtrousKernel::B3Spline5x5, edges}, {g.view(), &derivatives, &filtered},
                    1e3f, a, b, &variance, &varOut);
    std::swap(a, b);
    std::swap(variance, varOut);
  }
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) ASSERT_NEAR(a.at(x, y, c), valueAt(x), 1e-6f) << x << "," << y;
}

TEST(DenoiserBlocksAtrous, DepthDiscontinuityIsNeverCrossed) {
  SyntheticGBuffer g(17, 13);
  for (int y = 0; y < 13; ++y)
    for (int x = 8; x < 17; ++x) g.depth.at(x, y) = 3.0f;  // same mesh, same normal
  EdgeStoppingSettings depthOnly = allTermsOff();
  depthOnly.depth = true;
  expectHalvesSeparate(g, depthOnly);
  EdgeStoppingSettings svgfDefaults = svgfEdges();  // depth, normal, luminance
  expectHalvesSeparate(g, svgfDefaults);
}

TEST(DenoiserBlocksAtrous, IdDiscontinuityIsNeverCrossed) {
  SyntheticGBuffer g(17, 13);  // coplanar: same depth and normal, a "poster" mesh on the right
  for (int y = 0; y < 13; ++y)
    for (int x = 8; x < 17; ++x) g.meshId.at(x, y) = 4.0f;
  EdgeStoppingSettings idOnly = allTermsOff();
  idOnly.id = true;
  expectHalvesSeparate(g, idOnly);
  EdgeStoppingSettings all = allTermsOn();
  all.sigmaColor = 1e3f;
  expectHalvesSeparate(g, all);
}

TEST(DenoiserBlocksAtrous, SkyIsNeverGatheredAndPassesThrough) {
  const int w = 15, h = 9;
  SyntheticGBuffer g(w, h);
  Image in(w, h, 3), out(w, h, 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        bool sky = x < 5;
        if (sky) g.meshId.at(x, y) = -1.0f;
        in.at(x, y, c) = sky ? 100.0f + float(x) : 1.0f;
      }
  for (int i = 0; i < 3; ++i) {
    atrousIteration(i, {AtrousKernel::B3Spline5x5, allTermsOff()}, {g.view()}, 1.0f, in, out);
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          ASSERT_NEAR(out.at(x, y, c), in.at(x, y, c), 1e-6f) << x << "," << y;
  }
}

// The direct form of one iteration: for every surface pixel the normalised sum of
// h(q) w(p, q) c(q) over the in-image, non-sky taps, w from EdgeStopping::weight.
Image directAtrous(int iteration, const AtrousSettings& settings, const GBufferView& g,
                   const Image& derivatives, const Image& luminanceVariance, float colorSigma,
                   const Image& in) {
  const int w = in.width(), h = in.height(), step = 1 << iteration;
  const EdgeStopping edges(settings.edges, g, &derivatives, in, &luminanceVariance, colorSigma);
  const int r = settings.kernel == AtrousKernel::B3Spline5x5 ? 2 : 1;
  const std::vector<double> k1 =
      r == 2 ? std::vector<double>{1 / 16.0, 1 / 4.0, 3 / 8.0, 1 / 4.0, 1 / 16.0}
             : std::vector<double>{2 / 3.0, 1.0, 2 / 3.0};
  Image out(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      if (g.isSky(p)) {
        for (int c = 0; c < 3; ++c) out.at(x, y, c) = in.at(x, y, c);
        continue;
      }
      const EdgeStopping::Centre centre = edges.centre(p);
      double sum[3] = {0, 0, 0}, weights = 0;
      for (int j = -r; j <= r; ++j)
        for (int i = -r; i <= r; ++i) {
          const int qx = x + i * step, qy = y + j * step;
          if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
          const size_t q = size_t(qy) * size_t(w) + size_t(qx);
          if (g.isSky(q)) continue;
          const double weight = k1[size_t(i + r)] * k1[size_t(j + r)] *
                                double(edges.weight(centre, q, i * step, j * step));
          for (int c = 0; c < 3; ++c) sum[c] += weight * in.at(qx, qy, c);
          weights += weight;
        }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(sum[c] / weights);
    }
  return out;
}

// Wide enough for the kernel's unmasked interior blocks (16 lanes plus 2 x 2 x 2^i each side).
TEST(DenoiserBlocksAtrous, MatchesTheDirectWeightedSumWithEveryTerm) {
  const int w = 83, h = 21;
  SyntheticGBuffer g(w, h);
  g.makeVaried(3);
  const Image derivatives = g.derivatives();
  const Image in = randomImage(w, h, 3, 8, 0.0f, 2.0f);
  Image variance = randomImage(w, h, 1, 9, 0.0f, 0.5f), filtered(w, h, 1);
  prefilterVariance3x3(variance, g.view(), filtered);
  EdgeStoppingSettings gaussianNormals = allTermsOn();
  gaussianNormals.normalForm = NormalWeightForm::GaussianDistance;
  gaussianNormals.sigmaN = 0.5f;
  EdgeStoppingSettings logNormals = svgfEdges();  // SVGF's terms, a sigmaN no power of two
  logNormals.sigmaN = 100.0f;
  for (const EdgeStoppingSettings& edges :
       {svgfEdges(), allTermsOn(), gaussianNormals, logNormals})
    for (AtrousKernel kernel : {AtrousKernel::B3Spline5x5, AtrousKernel::Compact3x3})
      for (int iteration = 0; iteration < 4; ++iteration) {
        const AtrousSettings settings{kernel, edges};
        Image out(w, h, 3);
        atrousIteration(iteration, settings, {g.view(), &derivatives, &filtered}, 0.7f, in, out);
        const Image expected =
            directAtrous(iteration, settings, g.view(), derivatives, filtered, 0.7f, in);
        double maxError = 0;
        for (size_t i = 0; i < out.raw().size(); ++i)
          maxError = std::max(maxError, double(std::abs(out.raw()[i] - expected.raw()[i])));
        EXPECT_LT(maxError, 2e-5) << "iteration " << iteration;
      }
}

TEST(DenoiserBlocksAtrous, SixteenAndEightLaneKernelsGiveTheSameBits) {
  if (!simdUsesAvx512()) GTEST_SKIP() << "this CPU has no AVX-512: only the 8-lane kernel runs";
  const int w = 101, h = 17;
  SyntheticGBuffer g(w, h);
  g.makeVaried(4);
  const Image derivatives = g.derivatives();
  const Image in = randomImage(w, h, 3, 5, 0.0f, 4.0f);
  Image variance = randomImage(w, h, 1, 6, 0.0f, 1.0f), filtered(w, h, 1);
  prefilterVariance3x3(variance, g.view(), filtered);
  for (const EdgeStoppingSettings& edges : {svgfEdges(), allTermsOn()})
    for (int iteration = 0; iteration < 5; ++iteration) {
      Image wide(w, h, 3), narrow(w, h, 3), wideVariance(w, h, 1), narrowVariance(w, h, 1);
      const AtrousSettings settings{AtrousKernel::B3Spline5x5, edges};
      const AtrousGuide guide{g.view(), &derivatives, &filtered};
      atrousIteration(iteration, settings, guide, 0.5f, in, wide, &variance, &wideVariance);
      const bool previous = allowAvx512(false);
      atrousIteration(iteration, settings, guide, 0.5f, in, narrow, &variance, &narrowVariance);
      allowAvx512(previous);
      EXPECT_TRUE(samePixels(wide, narrow)) << "iteration " << iteration;
      EXPECT_TRUE(samePixels(wideVariance, narrowVariance)) << "iteration " << iteration;
    }
}

// ---------------------------------------------------------------------------------------------
// Geometry derivatives

TEST(DenoiserBlocksDerivatives, SmallerOneSidedDifferenceOnTheSameMesh) {
  const int w = 21, h = 6;  // a partial last block, mesh borders, sky
  SyntheticGBuffer g(w, h);
  g.makeVaried(8);
  g.meshId.at(4, 3) = 2.0f;  // a one-pixel mesh: no neighbour counts, derivatives 0
  const Image d = g.derivatives();
  const GBufferView v = g.view();
  struct Difference {
    bool exists = false;
    float dz = 0, dn[3] = {0, 0, 0};
  };
  auto difference = [&](int x, int y, int qx, int qy, float sign) {
    Difference r;
    if (qx < 0 || qy < 0 || qx >= w || qy >= h || g.meshId.at(qx, qy) != g.meshId.at(x, y))
      return r;
    r.exists = true;
    r.dz = sign * (g.depth.at(qx, qy) - g.depth.at(x, y));
    for (int c = 0; c < 3; ++c) r.dn[c] = sign * (g.normal.at(qx, qy, c) - g.normal.at(x, y, c));
    return r;
  };
  auto size = [](const Difference& r) {
    return std::abs(r.dz) + std::sqrt(r.dn[0] * r.dn[0] + r.dn[1] * r.dn[1] + r.dn[2] * r.dn[2]);
  };
  auto smaller = [&](const Difference& a, const Difference& b) {
    if (!a.exists) return b;
    if (!b.exists) return a;
    return size(a) <= size(b) ? a : b;
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool sky = v.isSky(size_t(y) * size_t(w) + size_t(x));
      const Difference dx =
          smaller(difference(x, y, x + 1, y, 1.0f), difference(x, y, x - 1, y, -1.0f));
      const Difference dy =
          smaller(difference(x, y, x, y + 1, 1.0f), difference(x, y, x, y - 1, -1.0f));
      float f[3];
      for (int c = 0; c < 3; ++c) f[c] = std::abs(dx.dn[c]) + std::abs(dy.dn[c]);
      const float fwidth = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
      EXPECT_EQ(d.at(x, y, kDepthDx), sky ? 0.0f : dx.dz) << x << "," << y;
      EXPECT_EQ(d.at(x, y, kDepthDy), sky ? 0.0f : dy.dz) << x << "," << y;
      EXPECT_EQ(d.at(x, y, kNormalFwidth), sky ? 0.0f : fwidth) << x << "," << y;
    }
  EXPECT_EQ(d.at(4, 3, kDepthDx), 0.0f);
  EXPECT_NEAR(d.at(10, 3, kDepthDx), 0.05f, 1e-6f);  // the depth ramp, seen from inside a mesh
  EXPECT_NEAR(d.at(10, 3, kDepthDy), 0.02f, 1e-6f);
}

// ---------------------------------------------------------------------------------------------
// Median

// The lower median of p's in-image, non-sky 3x3 neighbours, by sorting.
float referenceMedian(const Image& in, const GBufferView* g, int x, int y, int c) {
  std::vector<float> values;
  forEachNeighbour3x3(x, y, in.width(), in.height(), g, false,
                      [&](size_t q) { values.push_back(in.plane(c)[q]); });
  std::sort(values.begin(), values.end());
  return values[(values.size() - 1) / 2];
}

TEST(DenoiserBlocksMedian, IsTheLowerMedianOfWhatIsThere) {
  const int w = 29, h = 7;  // a partial last block of lanes, and every border case
  SyntheticGBuffer g(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (hashUniform(99, x, y) < 0.3f) g.meshId.at(x, y) = -1.0f;  // scattered sky
  const Image in = randomImage(w, h, 3, 17, 0.0f, 5.0f);
  for (bool withSky : {true, false}) {
    const GBufferView view = g.view();
    const GBufferView* guide = withSky ? &view : nullptr;
    Image out(w, h, 3);
    median3x3(in, guide, out);
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
          const bool sky = withSky && g.meshId.at(x, y) < 0.0f;
          ASSERT_EQ(out.at(x, y, c), sky ? in.at(x, y, c) : referenceMedian(in, guide, x, y, c))
              << x << "," << y << " channel " << c << (withSky ? " with sky" : "");
        }
  }
}

TEST(DenoiserBlocksMedian, RemovesAFireflyAndKeepsAConstant) {
  const int w = 11, h = 9;
  Image in(w, h, 3, 0.5f), out(w, h, 3);
  median3x3(in, nullptr, out);
  EXPECT_TRUE(samePixels(out, in));
  in.at(5, 4, 1) = 1e4f;
  median3x3(in, nullptr, out);
  EXPECT_EQ(out.at(5, 4, 1), 0.5f);
}

// ---------------------------------------------------------------------------------------------
// Poisson-disk blur

TEST(DenoiserBlocksPoisson, MatchesThePerPixelGatherWithEveryTerm) {
  const int w = 37, h = 19;
  SyntheticGBuffer g(w, h);  // a camera-facing plane, slightly bumpy normals, some sky
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      g.normal.at(x, y, 0) = 0.1f * (hashUniform(30, x, y) - 0.5f);
      g.normal.at(x, y, 2) = std::sqrt(1.0f - g.normal.at(x, y, 0) * g.normal.at(x, y, 0));
      if (hashUniform(31, x, y) < 0.1f) g.meshId.at(x, y) = -1.0f;
    }
  const Image roughness = randomImage(w, h, 1, 12, 0.3f, 0.32f);
  const Image hitDistance = randomImage(w, h, 1, 13, 1.0f, 1.1f);
  const Image radiusScale = randomImage(w, h, 1, 14, 0.2f, 1.0f);
  const Image in = randomImage(w, h, 4, 15, 0.0f, 3.0f);
  const GBufferView view = g.view();
  const SurfaceGuide guide{view, roughness.plane(0), hitDistance.plane(0)};
  PoissonBlurSettings settings{9.0f, surfaceWeightParams().defaults()};
  settings.weights.hitDistance = settings.weights.roughness = true;
  const float rotation = poissonRotation(3);
  Image out(w, h, 4);
  poissonDiskBlur(in, guide, settings, rotation, &radiusScale, out);

  const SurfaceWeights weight(settings.weights, guide);
  const auto disk = poissonDisk(rotation);
  int blurred = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      double sum[4], weightSum = 1.0;
      for (int c = 0; c < 4; ++c) sum[c] = in.plane(c)[p];
      if (!view.isSky(p)) {
        const float radius = settings.radius * radiusScale.plane(0)[p];
        for (const auto& tap : disk) {
          const int qx = x + int(std::lround(tap[0] * radius));
          const int qy = y + int(std::lround(tap[1] * radius));
          if (qx < 0 || qy < 0 || qx >= w || qy >= h || (qx == x && qy == y)) continue;
          const size_t q = size_t(qy) * size_t(w) + size_t(qx);
          const double wq = weight(p, q);
          for (int c = 0; c < 4; ++c) sum[c] += wq * in.plane(c)[q];
          weightSum += wq;
        }
      }
      blurred += weightSum > 1.5 ? 1 : 0;
      for (int c = 0; c < 4; ++c)
        ASSERT_NEAR(out.plane(c)[p], sum[c] / weightSum, 1e-5 * (1.0 + sum[c] / weightSum))
            << x << "," << y << " channel " << c;
    }
  EXPECT_GT(blurred, w * h / 4);  // the weights let a good share of the taps through
  {  // a pixel whose radius scale is 0 passes through; skipping idle blocks changes nothing
    Image sparseScale = radiusScale;
    for (int i = 0; i < w * h; ++i)
      if (hashUniform(16, uint32_t(i)) < 0.9f) sparseScale.plane(0)[i] = 0.0f;
    Image dense(w, h, 4), skipping(w, h, 4);
    sparseBlur(in, guide, settings.weights, disk.data(), kPoissonTaps, settings.radius,
               &sparseScale, dense, false);
    sparseBlur(in, guide, settings.weights, disk.data(), kPoissonTaps, settings.radius,
               &sparseScale, skipping, true);
    EXPECT_TRUE(samePixels(dense, skipping));
    // Its GPU count: the centre for every pixel, the taps for the pixels that gather only (their
    // share here about a tenth), as data-dependent taps are counted where they happen.
    PassTraffic sparse, full;
    {
      TrafficScope scope(&sparse);
      sparseBlur(in, guide, settings.weights, disk.data(), kPoissonTaps, settings.radius,
                 &sparseScale, dense, true);
    }
    {
      TrafficScope scope(&full);
      sparseBlur(in, guide, settings.weights, disk.data(), kPoissonTaps, settings.radius,
                 &radiusScale, dense, false);
    }
    // The pixels that gather: a scale above 0 on a surface (a sky pixel passes through).
    const auto gatheringShare = [&](const Image& scale) {
      int n = 0;
      for (int i = 0; i < w * h; ++i) n += scale.plane(0)[i] > 0.0f && view.meshId[i] >= 0.0f;
      return double(n) / double(w * h);
    };
    const double gathering = gatheringShare(sparseScale), surfaces = gatheringShare(radiusScale);
    ASSERT_GT(gathering, 0.02);
    ASSERT_LT(gathering, 0.2);
    ASSERT_LT(surfaces, 1.0);  // the guide has sky pixels
    const auto radianceFetches = [](const PassTraffic& t) {
      for (const BufferTraffic& b : t.buffers)
        if (!b.write && b.name == gpu_buffers::kRadiance.name) return b.fetches;
      return -1.0;
    };
    const double pixels = double(w) * double(h);
    EXPECT_NEAR(radianceFetches(sparse), pixels * (1.0 + kPoissonTaps * gathering), 1e-6 * pixels);
    EXPECT_NEAR(radianceFetches(full), pixels * (1.0 + kPoissonTaps * surfaces), 1e-6 * pixels);
    sparseBlur(in, guide, settings.weights, disk.data(), kPoissonTaps, settings.radius,
               &sparseScale, dense, false);
    int changed = 0;
    for (int i = 0; i < w * h; ++i)
      for (int c = 0; c < 4; ++c) {
        if (sparseScale.plane(0)[i] == 0.0f)
          ASSERT_EQ(dense.plane(c)[i], in.plane(c)[i]) << i;
        else
          changed += dense.plane(c)[i] != in.plane(c)[i];
      }
    EXPECT_GT(changed, 0);
  }
  if (simdUsesAvx512()) {  // and the 8-lane build gives the same bits as the 16-lane one
    Image narrow(w, h, 4);
    const bool previous = allowAvx512(false);
    poissonDiskBlur(in, guide, settings, rotation, &radiusScale, narrow);
    allowAvx512(previous);
    EXPECT_TRUE(samePixels(narrow, out));
  }
}

// ---------------------------------------------------------------------------------------------
// Reprojection

TEST(DenoiserBlocksReprojection, ZeroMotionIsIdentity) {
  const int w = 17, h = 13;
  SyntheticGBuffer g(w, h);
  g.makeVaried(3);
  Image derivatives = g.derivatives();
  Reprojection reprojection;
  reprojection.setup(w, h);
  reprojection.compute(g.view(), derivatives, g.view(), reprojectionParams().defaults());
  Image history = randomImage(w, h, 3, 9, 0.0f, 4.0f), out(w, h, 3);
  reprojection.resample(history, out, -1.0f);
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < w * h; ++i) {
      if (g.meshId.plane(0)[i] < 0) {
        EXPECT_EQ(out.plane(c)[i], -1.0f);  // sky is never reprojected
      } else {
        EXPECT_EQ(out.plane(c)[i], history.plane(c)[i]) << i;
      }
    }
  EXPECT_NEAR(reprojection.readTapsPerPixel(), 1.0 * (w * h - 6) / (w * h), 1e-9);
}

TEST(DenoiserBlocksReprojection, IntegerShiftMovesTheImageExactly) {
  const int w = 17, h = 13;
  SyntheticGBuffer g(w, h);
  Image derivatives = g.derivatives();
  Image history = randomImage(w, h, 2, 17, 0.0f, 4.0f), out(w, h, 2);
  struct Shift {
    int mx, my;
  };
  for (Shift s : {Shift{-2, 0}, Shift{3, 0}, Shift{0, -1}, Shift{1, 2}}) {
    for (int i = 0; i < w * h; ++i) {
      g.motion.plane(0)[i] = float(s.mx);
      g.motion.plane(1)[i] = float(s.my);
    }
    ReprojectionSettings settings = reprojectionParams().defaults();
    settings.fallback3x3 = false;
    Reprojection reprojection;
    reprojection.setup(w, h);
    reprojection.compute(g.view(), derivatives, g.view(), settings);
    reprojection.resample(history, out, -1.0f);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        int px = x + s.mx, py = y + s.my;
        bool inside = px >= 0 && py >= 0 && px < w && py < h;
        EXPECT_EQ(reprojection.valid(size_t(y * w + x)), inside);
        for (int c = 0; c < 2; ++c)
          EXPECT_EQ(out.at(x, y, c), inside ? history.at(px, py, c) : -1.0f)
              << "shift " << s.mx << "," << s.my << " at " << x << "," << y;
      }
  }
}

TEST(DenoiserBlocksReprojection, HalfPixelMotionAveragesTwoTaps) {
  const int w = 9, h = 7;
  SyntheticGBuffer g(w, h);
  for (int i = 0; i < w * h; ++i) g.motion.plane(0)[i] = -0.5f;
  Image derivatives = g.derivatives();
  Reprojection reprojection;
  reprojection.setup(w, h);
  reprojection.compute(g.view(), derivatives, g.view(), reprojectionParams().defaults());
  Image history = randomImage(w, h, 1, 2), out(w, h, 1);
  reprojection.resample(history, out);
  EXPECT_NEAR(out.at(4, 3), 0.5f * (history.at(3, 3) + history.at(4, 3)), 1e-6f);
  // At x = 0 the left tap is off-screen: the surviving tap's weight is renormalised to 1.
  EXPECT_NEAR(out.at(0, 3), history.at(0, 3), 1e-6f);
}

TEST(DenoiserBlocksReprojection, InconsistentTapsAreRejectedPerTap) {
  const int w = 11, h = 9;
  SyntheticGBuffer current(w, h), previous(w, h);
  // Previous frame: a different mesh in column 3, a far depth in column 5, a turned normal in 7.
  for (int y = 0; y < h; ++y) {
    previous.meshId.at(3, y) = 2.0f;
    previous.depth.at(5, y) = 2.5f;
    previous.normal.at(7, y, 2) = 0.0f;
    previous.normal.at(7, y, 0) = 1.0f;
  }
  Image derivatives = current.derivatives();
  ReprojectionSettings settings = reprojectionParams().defaults();
  settings.fallback3x3 = false;
  Reprojection reprojection;
  reprojection.setup(w, h);
  reprojection.compute(current.view(), derivatives, previous.view(), settings);
  for (int x = 0; x < w; ++x)
    EXPECT_EQ(reprojection.valid(size_t(4 * w + x)), x != 3 && x != 5 && x != 7) << x;
  // With the 3x3 fallback the thin rejected columns find their neighbours (SVGF §4.1).
  settings.fallback3x3 = true;
  reprojection.compute(current.view(), derivatives, previous.view(), settings);
  EXPECT_TRUE(reprojection.valid(size_t(4 * w + 5)));
  EXPECT_EQ(reprojection.record(size_t(4 * w + 5)).footprint, ReprojectionFootprint::Box3x3);
  Image history(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) history.at(x, y) = float(x);
  EXPECT_NEAR(reprojection.sample(size_t(4 * w + 5), history.plane(0)), 5.0f, 1e-6f);  // (4+6)/2
  reprojection.invalidateAll();
  EXPECT_EQ(reprojection.validFraction(), 0.0);
}

// Issue 15, item 12: the depth test's derivative is Falcor's max(|dz/dx|, |dz/dy|)
// (SVGFPackLinearZAndNormal), not HLSL fwidth's sum. A plane whose depth ramps 0.05 per pixel in x
// and y (max 0.05, sum 0.1) against a previous frame shifted by dz: rejected where
// dz / (0.05 + 0.01) > 10, i.e. dz > 0.6 (the sum would allow up to 10 (0.1 + 0.01) = 1.1).
TEST(DenoiserBlocksReprojection, DepthTestUsesTheLargerDepthDerivative) {
  const int w = 12, h = 9;
  SyntheticGBuffer current(w, h), previous(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) current.depth.at(x, y) = 2.0f + 0.05f * float(x + y);
  const Image derivatives = current.derivatives();
  for (size_t p = 0; p < size_t(w * h); ++p)
    ASSERT_NEAR(depthFwidth(derivatives, p), 0.05f, 1e-5f) << p;
  Reprojection reprojection;
  reprojection.setup(w, h);
  for (float shift : {0.5f, 0.8f}) {
    for (int i = 0; i < w * h; ++i) previous.depth.plane(0)[i] = current.depth.plane(0)[i] + shift;
    reprojection.compute(current.view(), derivatives, previous.view(),
                         reprojectionParams().defaults());
    EXPECT_EQ(reprojection.validFraction(), shift < 0.6f ? 1.0 : 0.0) << "dz " << shift;
  }
}

// The per-pixel definition of compute() (SVGF §4.1): 2x2 bilinear taps each tested by
// consistent(), renormalised when their weight sum reaches minWeightSum, else the 3x3 box.
ReprojectionRecord referenceRecord(const SyntheticGBuffer& cur, const SyntheticGBuffer& prev,
                                   const Image& derivatives, const ReprojectionSettings& settings,
                                   int x, int y) {
  const int w = cur.w, h = cur.h;
  ReprojectionRecord rec;
  if (cur.meshId.at(x, y) < 0.0f) return rec;
  const float px = float(x) + 0.5f + cur.motion.at(x, y, 0);
  const float py = float(y) + 0.5f + cur.motion.at(x, y, 1);
  const SurfaceSample surface = surfaceAt(cur.depth, cur.normal, cur.meshId, x, y);
  const size_t p = size_t(y) * size_t(w) + size_t(x);
  const SurfaceDerivatives fwidth{depthFwidth(derivatives, p), derivatives.plane(kNormalFwidth)[p]};
  auto ok = [&](int qx, int qy) {
    return qx >= 0 && qy >= 0 && qx < w && qy < h &&
           consistent(surface, fwidth, surfaceAt(prev.depth, prev.normal, prev.meshId, qx, qy),
                      ConsistencyThresholds{settings.depthThreshold, settings.normalThreshold});
  };
  // A position beyond any image (or NaN) is disoccluded, before it is converted to int.
  if (!(std::abs(px) <= 1e7f && std::abs(py) <= 1e7f)) return rec;
  const float fx = px - 0.5f, fy = py - 0.5f;
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const float tx = fx - float(x0), ty = fy - float(y0);
  const float bilinear[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
  float sum = 0;
  for (int k = 0; k < 4; ++k)
    if (bilinear[k] > 0.0f && ok(x0 + k % 2, y0 + k / 2)) {
      rec.mask |= uint16_t(1u << k);
      sum += bilinear[k];
    }
  if (sum >= settings.minWeightSum) {
    rec.footprint = ReprojectionFootprint::Bilinear2x2;
    rec.x0 = x0;
    rec.y0 = y0;
    for (int k = 0; k < 4; ++k) rec.weights[k] = (rec.mask >> k) & 1u ? bilinear[k] / sum : 0.0f;
    return rec;
  }
  rec.mask = 0;
  const int cx = int(std::floor(px)), cy = int(std::floor(py));
  for (int k = 0; k < 9; ++k)
    if (ok(cx - 1 + k % 3, cy - 1 + k / 3)) rec.mask |= uint16_t(1u << k);
  if (rec.mask == 0) return rec;
  rec.footprint = ReprojectionFootprint::Box3x3;
  rec.x0 = cx - 1;
  rec.y0 = cy - 1;
  rec.weights[0] = 1.0f / float(std::popcount(rec.mask));
  return rec;
}

TEST(DenoiserBlocksReprojection, MatchesThePerPixelDefinitionUnderRandomMotion) {
  const int w = 45, h = 13;
  SyntheticGBuffer cur(w, h), prev(w, h);
  cur.makeVaried(21);
  prev.makeVaried(21);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      // Fractional and integer motion, some of it off-screen; depth steps and a turned normal in
      // the previous frame; one non-finite motion vector.
      const bool integer = hashUniform(40, x, y) < 0.2f;
      cur.motion.at(x, y, 0) = integer ? std::round(6.0f * hashUniform(41, x, y) - 3.0f)
                                       : 6.0f * hashUniform(41, x, y) - 3.0f;
      cur.motion.at(x, y, 1) = 4.0f * hashUniform(42, x, y) - 2.0f;
      if (hashUniform(43, x, y) < 0.15f) prev.depth.at(x, y) += 0.5f;
      if (hashUniform(44, x, y) < 0.1f) {
        prev.normal.at(x, y, 0) = 1.0f;
        prev.normal.at(x, y, 2) = 0.0f;
      }
    }
  cur.motion.at(7, 5, 0) = std::numeric_limits<float>::quiet_NaN();
  const Image derivatives = cur.derivatives();
  ReprojectionSettings settings = reprojectionParams().defaults();
  Reprojection reprojection;
  reprojection.setup(w, h);
  reprojection.compute(cur.view(), derivatives, prev.view(), settings);
  int box = 0, bilinear = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const ReprojectionRecord& got = reprojection.record(size_t(y) * size_t(w) + size_t(x));
      const ReprojectionRecord want = referenceRecord(cur, prev, derivatives, settings, x, y);
      ASSERT_EQ(got.footprint, want.footprint) << x << "," << y;
      ASSERT_EQ(got.mask, want.mask) << x << "," << y;
      if (want.footprint == ReprojectionFootprint::Disoccluded) continue;
      ASSERT_EQ(got.x0, want.x0) << x << "," << y;
      ASSERT_EQ(got.y0, want.y0) << x << "," << y;
      for (int k = 0; k < 4; ++k) ASSERT_EQ(got.weights[k], want.weights[k]) << x << "," << y;
      (want.footprint == ReprojectionFootprint::Box3x3 ? box : bilinear) += 1;
    }
  EXPECT_GT(box, 0);  // every path was exercised
  EXPECT_GT(bilinear, w * h / 4);
  // The fused accumulation (eight pixels at a time) equals the three separate passes exactly.
  {
    const Image signal = randomImage(w, h, 3, 50, 0.0f, 4.0f);
    const Image colorHistory = randomImage(w, h, 3, 51, 0.0f, 4.0f);
    const Image momentsHistory = randomImage(w, h, 2, 52, 0.0f, 4.0f);
    const Image previousLength = randomImage(w, h, 1, 53, 1.0f, 40.0f);
    const Image perPixelAlpha = randomImage(w, h, 1, 54, 0.0f, 0.6f);
    const AccumulationAlpha colorAlpha{0.2f, &perPixelAlpha}, momentsAlpha{0.2f, nullptr};
    Image length(w, h, 1), accumulated(w, h, 3), moments(w, h, 2);
    accumulateColorAndMoments(reprojection, previousLength, 32.0f, signal, colorHistory,
                              momentsHistory, colorAlpha, momentsAlpha, length, accumulated,
                              moments);
    Image length2(w, h, 1), accumulated2(w, h, 3), moments2(w, h, 2);
    updateHistoryLength(reprojection, previousLength, 32.0f, length2);
    accumulateTemporally(reprojection, signal, colorHistory, length2, colorAlpha, accumulated2);
    accumulateMoments(reprojection, signal, momentsHistory, length2, momentsAlpha, moments2);
    EXPECT_TRUE(samePixels(length, length2));
    EXPECT_TRUE(samePixels(accumulated, accumulated2));
    EXPECT_TRUE(samePixels(moments, moments2));
  }
  // Eight pixels at a time (HistoryLanes) read exactly what sample() reads, box lanes included.
  const Image history = randomImage(w, h, 1, 46, 0.0f, 10.0f);
  for (int y = 0; y < h; ++y)
    for (int x0 = 0; x0 < w; x0 += 8) {
      const size_t i = size_t(y) * size_t(w) + size_t(x0);
      const int count = std::min(8, w - x0);
      const Lanes8 lanes = reprojection.lanes(i, count).apply(history.plane(0));
      for (int lane = 0; lane < count; ++lane)
        ASSERT_EQ(lanes[lane], reprojection.sample(i + size_t(lane), history.plane(0)))
            << x0 + lane << "," << y;
    }
}

// ---------------------------------------------------------------------------------------------
// Temporal accumulation, moments, variance

TEST(DenoiserBlocksTemporal, AlphaAndHistoryLength) {
  EXPECT_EQ(blendAlpha(1.0f, 0.05f), 1.0f);
  EXPECT_NEAR(blendAlpha(10.0f, 0.05f), 0.1f, 1e-7f);
  EXPECT_NEAR(blendAlpha(32.0f, 0.05f), 0.05f, 1e-7f);
  EXPECT_EQ(nextHistoryLength(true, 5.0f, 32.0f), 6.0f);
  EXPECT_EQ(nextHistoryLength(true, 32.0f, 32.0f), 32.0f);
  EXPECT_EQ(nextHistoryLength(false, 12.0f, 32.0f), 1.0f);
  Image perPixel(1, 1, 1, 0.5f);
  EXPECT_EQ((AccumulationAlpha{0.2f, &perPixel}.at(0)), 0.5f);
  perPixel.fill(0.1f);
  EXPECT_EQ((AccumulationAlpha{0.2f, &perPixel}.at(0)), 0.2f);  // raises, never lowers the floor
}

TEST(DenoiserBlocksTemporal, RunningMeanAndPerPixelAlphaOverride) {
  const int w = 7, h = 5;
  SyntheticGBuffer g(w, h);
  Image derivatives = g.derivatives();
  Reprojection reprojection;
  reprojection.setup(w, h);
  Image history(w, h, 3), accumulated(w, h, 3), length(w, h, 1), previousLength(w, h, 1);
  // Frames carry the values 1, 2, 3, 4: with alphaMin 0 the accumulation is their running mean.
  for (int t = 0; t < 4; ++t) {
    if (t == 0)
      reprojection.invalidateAll();
    else
      reprojection.compute(g.view(), derivatives, g.view(), reprojectionParams().defaults());
    Image current(w, h, 3, float(t + 1));
    updateHistoryLength(reprojection, previousLength, 32.0f, length);
    accumulateTemporally(reprojection, current, history, length, {0.0f, nullptr}, accumulated);
    EXPECT_NEAR(accumulated.at(3, 2, 1), 0.5f * float(t + 2), 1e-6f) << t;
    EXPECT_EQ(length.at(3, 2), float(t + 1));
    history = accumulated;
    std::swap(length, previousLength);
  }
  // A per-pixel alpha of 1 (A-SVGF after a strong gradient) discards the history there.
  Image alpha(w, h, 1, 0.0f);
  alpha.at(2, 2) = 1.0f;
  Image current(w, h, 3, 10.0f);
  updateHistoryLength(reprojection, previousLength, 32.0f, length);
  accumulateTemporally(reprojection, current, history, length, {0.0f, &alpha}, accumulated);
  EXPECT_EQ(accumulated.at(2, 2, 0), 10.0f);
  EXPECT_NEAR(accumulated.at(3, 2, 0), (2.5f * 4 + 10.0f) / 5, 1e-5f);
}

TEST(DenoiserBlocksTemporal, VarianceOfConstantSignalIsZero) {
  const int w = 13, h = 11;
  SyntheticGBuffer g(w, h);
  g.makeVaried(1);
  Image derivatives = g.derivatives();
  Reprojection reprojection;
  reprojection.setup(w, h);
  Image signal(w, h, 3), moments(w, h, 2), momentsHistory(w, h, 2), length(w, h, 1),
      previousLength(w, h, 1), variance(w, h, 1, -1.0f);
  for (int c = 0; c < 3; ++c) std::fill_n(signal.plane(c), w * h, 0.3f + 0.4f * float(c));
  RowTapCounter taps;
  taps.setup(h);
  for (int t = 0; t < 6; ++t) {
    if (t == 0)
      reprojection.invalidateAll();
    else
      reprojection.compute(g.view(), derivatives, g.view(), reprojectionParams().defaults());
    updateHistoryLength(reprojection, previousLength, 32.0f, length);
    accumulateMoments(reprojection, signal, momentsHistory, length, {0.2f, nullptr}, moments);
    double fetched = estimateVariance(moments, length, signal, g.view(), derivatives,
                                      VarianceSettings{}, variance, taps);
    // Spatial 7x7 while h < 4 (frames 0..2), temporal afterwards.
    if (t < 3) {
      EXPECT_GT(fetched, 20.0) << t;
    } else {
      EXPECT_EQ(fetched, 0.0) << t;
    }
    for (int i = 0; i < w * h; ++i) ASSERT_NEAR(variance.plane(0)[i], 0.0f, 1e-6f) << t;
    std::swap(moments, momentsHistory);
    std::swap(length, previousLength);
  }
}

TEST(DenoiserBlocksTemporal, VarianceOfNoiseMatchesItsSpread) {
  // Luminance uniform in [0, 1] per frame: variance 1/12. Spatial (frame 0) and temporal (after
  // many frames with alpha 0.05) estimates both land near it.
  const int w = 31, h = 29;
  SyntheticGBuffer g(w, h);
  Image derivatives = g.derivatives();
  Reprojection reprojection;
  reprojection.setup(w, h);
  Image moments(w, h, 2), momentsHistory(w, h, 2), length(w, h, 1), previousLength(w, h, 1),
      variance(w, h, 1);
  RowTapCounter taps;
  taps.setup(h);
  VarianceSettings settings;
  settings.phiColor = 1e9f;  // a plain 7x7 mean, to compare with 1/12
  settings.boostYoungHistory = false;
  for (int t = 0; t < 120; ++t) {
    if (t == 0)
      reprojection.invalidateAll();
    else
      reprojection.compute(g.view(), derivatives, g.view(), reprojectionParams().defaults());
    Image signal(w, h, 3);
    for (int i = 0; i < w * h; ++i)
      for (int c = 0; c < 3; ++c) signal.plane(c)[i] = hashUniform(uint32_t(t), uint32_t(i), 99);
    updateHistoryLength(reprojection, previousLength, 1000.0f, length);
    accumulateMoments(reprojection, signal, momentsHistory, length, {0.02f, nullptr}, moments);
    estimateVariance(moments, length, signal, g.view(), derivatives, settings, variance, taps);
    if (t == 0 || t == 119) {
      double mean = 0;
      for (int i = 0; i < w * h; ++i) mean += variance.plane(0)[i];
      mean /= double(w * h);
      EXPECT_NEAR(mean, 1.0 / 12.0, 0.012) << "frame " << t;
    }
    std::swap(moments, momentsHistory);
    std::swap(length, previousLength);
  }
}

TEST(DenoiserBlocksTemporal, SpatialVarianceOfAYoungPixelDoesNotDependOnItsNeighboursAge) {
  // All pixels young (one run per row, read in place) and a scattered few (gathered): each young
  // pixel's spatial estimate is the same, bit for bit; the old pixels keep the temporal one.
  const int w = 37, h = 11;
  SyntheticGBuffer g(w, h);
  g.makeVaried(13);  // two meshes, a sky corner, varied normals and depth
  const Image derivatives = g.derivatives();
  const Image moments = randomImage(w, h, 2, 60, 0.0f, 2.0f);
  const Image color = randomImage(w, h, 3, 61, 0.0f, 2.0f);
  Image allYoung(w, h, 1, 1.0f), scattered(w, h, 1, 10.0f);
  for (int i = 0; i < w * h; ++i)
    if (hashUniform(62, uint32_t(i)) < 0.2f) scattered.plane(0)[i] = 2.0f;
  RowTapCounter taps;
  taps.setup(h);
  const VarianceSettings settings;
  Image dense(w, h, 1), sparse(w, h, 1);
  estimateVariance(moments, allYoung, color, g.view(), derivatives, settings, dense, taps);
  estimateVariance(moments, scattered, color, g.view(), derivatives, settings, sparse, taps);
  int young = 0;
  for (int i = 0; i < w * h; ++i) {
    if (scattered.plane(0)[i] != 2.0f || g.view().isSky(size_t(i))) continue;
    ++young;
    // The boost scales by minHistory / h: 4/1 for the dense case, 4/2 for the scattered one.
    ASSERT_EQ(sparse.plane(0)[i] * 2.0f, dense.plane(0)[i]) << i;
  }
  EXPECT_GT(young, w * h / 10);
}

// Falcor SVGFFilterMoments' colour at a young pixel (x, y), written out per pixel: the 7x7 mean of
// the colour weighted by exp(-|l(p) - l(q)| / phiColor - |z(p) - z(q)| / (phiDepth max(|dz/dx|,
// |dz/dy|) |p - q|)) max(0, n(p).n(q))^phiNormal, sky neighbours left out, the centre weight 1.
std::array<double, 3> falcorYoungColor(const SyntheticGBuffer& g, const Image& derivatives,
                                       const Image& color, const VarianceSettings& s, int x,
                                       int y) {
  auto lum = [&](int qx, int qy) {
    return luminance(color.at(qx, qy, 0), color.at(qx, qy, 1), color.at(qx, qy, 2));
  };
  const float depthScale = std::max(s.phiDepth * std::max(std::abs(derivatives.at(x, y, kDepthDx)),
                                                          std::abs(derivatives.at(x, y, kDepthDy))),
                                    1e-8f);
  std::array<double, 3> sum = {0, 0, 0};
  double weightSum = 0;
  for (int dy = -s.radius; dy <= s.radius; ++dy)
    for (int dx = -s.radius; dx <= s.radius; ++dx) {
      const int qx = x + dx, qy = y + dy;
      if (qx < 0 || qy < 0 || qx >= g.w || qy >= g.h || g.meshId.at(qx, qy) < 0) continue;
      double weight = 1.0;
      if (dx != 0 || dy != 0) {
        double cosine = 0;
        for (int c = 0; c < 3; ++c) cosine += g.normal.at(x, y, c) * g.normal.at(qx, qy, c);
        weight = std::exp(-std::abs(lum(x, y) - lum(qx, qy)) / s.phiColor -
                          std::abs(g.depth.at(x, y) - g.depth.at(qx, qy)) /
                              (depthScale * std::hypot(double(dx), double(dy)))) *
                 std::pow(std::max(0.0, cosine), double(s.phiNormal));
      }
      weightSum += weight;
      for (int c = 0; c < 3; ++c) sum[size_t(c)] += weight * color.at(qx, qy, c);
    }
  for (double& v : sum) v /= weightSum;
  return sum;
}

// Issue 15, item 5.
TEST(DenoiserBlocksTemporal, YoungColourIsTheBilateralMeanOfItsNeighbours) {
  const int w = 29, h = 17;
  SyntheticGBuffer g(w, h);
  g.makeVaried(17);  // two meshes, a sky corner, varied normals and depth
  const Image derivatives = g.derivatives();
  const Image color = randomImage(w, h, 3, 7, 0.0f, 2.0f);
  const Image moments = randomImage(w, h, 2, 8, 0.0f, 1.0f);
  // Young (h < 4) in a scattered 30 % (gathered) and in the whole of row 9 (read in place).
  Image length(w, h, 1, 10.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (y == 9 || hashUniform(9, x, y) < 0.3f) length.at(x, y) = 1.0f + float((x + y) % 3);
  const VarianceSettings settings;
  RowTapCounter taps;
  taps.setup(h);
  Image variance(w, h, 1), mean(w, h, 3, -7.0f);
  estimateVariance(moments, length, color, g.view(), derivatives, settings, variance, taps, &mean);
  Image replaced = color;
  replaceYoungColor(mean, length, g.view(), settings, replaced);
  int young = 0, movedFar = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const bool isYoung = length.at(x, y) < 4.0f && g.meshId.at(x, y) >= 0.0f;
      if (!isYoung) {  // neither written nor replaced
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(mean.at(x, y, c), -7.0f) << x << "," << y;
          ASSERT_EQ(replaced.at(x, y, c), color.at(x, y, c)) << x << "," << y;
        }
        continue;
      }
      ++young;
      const std::array<double, 3> want = falcorYoungColor(g, derivatives, color, settings, x, y);
      for (int c = 0; c < 3; ++c) {
        ASSERT_NEAR(replaced.at(x, y, c), want[size_t(c)], 2e-3 * (1.0 + want[size_t(c)]))
            << x << "," << y << " channel " << c;
        movedFar += std::abs(replaced.at(x, y, c) - color.at(x, y, c)) > 0.1f;
      }
    }
  EXPECT_GT(young, w * h / 4);
  EXPECT_GT(movedFar, young);  // the mean is not the pixel's own colour
}

// ---------------------------------------------------------------------------------------------
// History clamp / clip

TEST(DenoiserBlocksClamp, ClipMovesAlongTheSegmentClampPerChannel) {
  float lo[2] = {-1, -1}, hi[2] = {1, 1}, target[2] = {0, 0};
  float clipped[2] = {3, 1.5f};
  clipToBox(clipped, target, lo, hi, 2);
  EXPECT_NEAR(clipped[0], 1.0f, 1e-6f);
  EXPECT_NEAR(clipped[1], 0.5f, 1e-6f);
  float clamped[2] = {3, 1.5f};
  clampToBox(clamped, lo, hi, 2);
  EXPECT_EQ(clamped[0], 1.0f);
  EXPECT_EQ(clamped[1], 1.0f);
  float inside[2] = {0.5f, -0.25f};
  clipToBox(inside, target, lo, hi, 2);
  EXPECT_EQ(inside[0], 0.5f);  // already inside: untouched
  EXPECT_EQ(inside[1], -0.25f);
}

TEST(DenoiserBlocksClamp, ResultsLieInsideTheNeighbourhoodBox) {
  const int w = 17, h = 13;
  Image current = randomImage(w, h, 3, 31, 0.0f, 2.0f);
  Image history = randomImage(w, h, 3, 32, -3.0f, 5.0f);
  RowTapCounter taps;
  taps.setup(h);
  for (HistoryClampMode mode : {HistoryClampMode::Clamp, HistoryClampMode::Clip}) {
    HistoryClampSettings settings{mode, 1, 1.5f};
    Image out(w, h, 3);
    double fetched = clampHistory(history, current, nullptr, settings, out, taps);
    EXPECT_GT(fetched, 8.0);
    EXPECT_LE(fetched, 9.0);
    int moved = 0, onSegment = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        double lo[3], hi[3];
        bool currentInside = true;
        for (int c = 0; c < 3; ++c) {
          double sum = 0, sumSq = 0;
          int n = 0;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              int qx = x + dx, qy = y + dy;
              if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
              sum += current.at(qx, qy, c);
              sumSq += double(current.at(qx, qy, c)) * current.at(qx, qy, c);
              ++n;
            }
          double mean = sum / n, sigma = std::sqrt(std::max(0.0, sumSq / n - mean * mean));
          lo[c] = mean - 1.5 * sigma;
          hi[c] = mean + 1.5 * sigma;
          float v = out.at(x, y, c);
          ASSERT_GE(v, lo[c] - 1e-5);
          ASSERT_LE(v, hi[c] + 1e-5);
          moved += v != history.at(x, y, c);
          currentInside =
              currentInside && current.at(x, y, c) >= lo[c] && current.at(x, y, c) <= hi[c];
        }
        // Clip: with the current value inside the box, the result lies on the segment
        // history -> current: the same fraction t in every channel.
        bool separated = true;
        for (int c = 0; c < 3; ++c)
          separated = separated && std::abs(current.at(x, y, c) - history.at(x, y, c)) > 1e-2f;
        if (mode == HistoryClampMode::Clip && currentInside && separated) {
          float t[3];
          for (int c = 0; c < 3; ++c)
            t[c] = (out.at(x, y, c) - history.at(x, y, c)) /
                   (current.at(x, y, c) - history.at(x, y, c));
          EXPECT_NEAR(t[0], t[1], 1e-3f);
          EXPECT_NEAR(t[0], t[2], 1e-3f);
          ++onSegment;
        }
      }
    if (mode == HistoryClampMode::Clip) {
      EXPECT_GT(onSegment, w * h / 2);
    }
    EXPECT_GT(moved, w * h);  // most history values were outside and moved
  }
}

// Remodulation (denoisers/common/remodulation.hpp): the albedos multiply their own signal and the
// emission is added, channel by channel; layers of different sizes are refused.
TEST(Remodulation, PutsEachAlbedoBackOnItsSignalAndAddsTheEmission) {
  Image albedo(2, 1, 3), diffuse(2, 1, 3), specAlbedo(2, 1, 3), specular(2, 1, 3), emission(2, 1, 3), color;
  for (int c = 0; c < 3; ++c)
    for (int x = 0; x < 2; ++x) {
      albedo.at(x, 0, c) = 0.5f + 0.1f * c;
      diffuse.at(x, 0, c) = 2.0f + x;
      specAlbedo.at(x, 0, c) = 0.25f;
      specular.at(x, 0, c) = 4.0f * (x + 1);
      emission.at(x, 0, c) = x == 1 ? 3.0f : 0.0f;
    }
  remodulate(albedo, diffuse, specAlbedo, specular, emission, color);
  ASSERT_EQ(color.width(), 2);
  for (int c = 0; c < 3; ++c) {
    EXPECT_FLOAT_EQ(color.at(0, 0, c), (0.5f + 0.1f * c) * 2.0f + 0.25f * 4.0f);
    EXPECT_FLOAT_EQ(color.at(1, 0, c), (0.5f + 0.1f * c) * 3.0f + 0.25f * 8.0f + 3.0f);
  }
  const Image small(1, 1, 3);
  EXPECT_THROW(remodulate(albedo, small, specAlbedo, specular, emission, color), Error);
}

// The non-finite helpers the denoiser run uses (core/non_finite.hpp): a sample with any NaN/Inf
// channel is marked invalid, values are counted over every channel, valid pixels by their flag.
TEST(NonFinite, InvalidSamplesAreMarkedAndCounted) {
  Image samples(3, 1, 3, 1.0f);
  samples.at(1, 0, 0) = std::numeric_limits<float>::quiet_NaN();
  samples.at(2, 0, 1) = std::numeric_limits<float>::infinity();
  EXPECT_EQ(nonFiniteValues(samples), 2);
  EXPECT_EQ(nonZeroPixels(samples, 2), 3);
  EXPECT_EQ(invalidateNonFinitePixels(samples, 2), 2);
  EXPECT_EQ(samples.at(0, 0, 2), 1.0f);
  EXPECT_EQ(samples.at(1, 0, 2), 0.0f);
  EXPECT_EQ(samples.at(2, 0, 2), 0.0f);
  EXPECT_EQ(nonZeroPixels(samples, 2), 1);
  EXPECT_EQ(invalidateNonFinitePixels(samples, 2), 0);  // already invalid: nothing more to mark
}

}  // namespace
}  // namespace arena
