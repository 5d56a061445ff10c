// ReBLUR (denoisers/reblur.cpp) on tiny rendered sequences (64x36, <= 24 frames, 64-spp
// references): constant in -> constant out at every pass, and the claims of the NRD/GTC 2020
// material asserted on numbers (tenfold below the input, recurrence, hit-point reprojection, the
// sampled hit distance against the mirror oracle).
#include <gtest/gtest.h>

#include "tests/tiny_sequence_fixture.hpp"

namespace arena {
namespace {

using namespace test::tiny_sequence;

// ---------------------------------------------------------------------------------------------
// ReBLUR

TEST(ReblurVariant, ConstantSignalIsConstantAfterEveryPassAndFrame) {
  expectConstantThroughEveryPass<Reblur>("reblur", {});
  expectConstantThroughEveryPass<Reblur>("reblur", {{"historyFix", "mip"}, {"recurrent", "false"}});
}

// At 64x36 the native footprint (NRD's 30-60 px radii) covers the whole image and ReBLUR, with no
// luminance stopping, blurs the room's lighting gradients away (relMSE 0.048 against the noisy
// 0.185 when measured for issue 15); its claims are checked at the footprint it is tuned for,
// radii scaled from 1080 lines (footprint.hpp), as the first version here ran by default.
const std::map<std::string, std::string> kReblurScaled = {{"footprint", "scaled"}};

TEST(ReblurVariant, CornellStaticTenfoldBelowTheNoisyInput) {
  const Loaded& l = loaded("cornell_static", 24);
  const int warmup = 8;
  const double noisy = noisyRelMse(l, "color", warmup);
  const double reblur = meanRelMse(l, denoise(l, "reblur", kReblurScaled), "color", warmup);
  const double native = meanRelMse(l, denoise(l, "reblur"), "color", warmup);
  std::printf("cornell_static relMSE: noisy %.4f, reblur %.5f (scaled), %.5f (native)\n", noisy,
              reblur, native);
  EXPECT_LT(reblur, noisy / 10.0);
}

// Recurrence (GTC 2020) feeds the blurred samples back: it trades bias for variance. Where noise
// dominates -- hard_light's fireflies through a slit -- the error after the same frames is
// clearly lower with it. (On the well-lit static cornell_static at 64x36 the error is bias-
// dominated after warm-up and recurrence *raises* relMSE, 0.0114 vs 0.0080: see the report.)
TEST(ReblurVariant, RecurrenceLowersTheErrorWhereNoiseDominates) {
  const Loaded& l = loaded("hard_light", 16);
  const int warmup = 4;
  const double recurrent = meanRelMse(l, denoise(l, "reblur", kReblurScaled), "color", warmup);
  const double plain = meanRelMse(
      l, denoise(l, "reblur", {{"recurrent", "false"}, {"footprint", "scaled"}}), "color", warmup);
  std::printf("hard_light relMSE: reblur %.5f, reblur[recurrent=false] %.5f\n", recurrent, plain);
  EXPECT_GT(plain, recurrent * 1.2);
}

TEST(ReblurVariant, HitPointReprojectionBeatsSurfaceMotionOnGlossyReflections) {
  const Loaded& l = loaded("glossy_orbit", 24);
  const int warmup = 4;
  const double hitPoint = meanRelMse(l, denoise(l, "reblur"), "specular", warmup);
  const double surface =
      meanRelMse(l, denoise(l, "reblur", {{"hitPoint", "false"}}), "specular", warmup);
  std::printf("glossy_orbit specular relMSE: reblur hit point %.5f, surface motion %.5f\n",
              hitPoint, surface);
  EXPECT_LT(hitPoint, surface);
}

// Issue 15, item 3: what the oracle mirror hit distance was worth. glossy_orbit's specular relMSE
// with the 1-spp sample's hit distance (the default) against the noise-free mirror ray's, for
// ReBLUR (which pre-blurs the sampled distance, as NRD) and the hybrid (which uses it as traced).
TEST(ReblurVariant, SampledHitDistanceAgainstTheMirrorOracleOnGlossyOrbit) {
  const Loaded& l = loaded("glossy_orbit", 24);
  const int warmup = 4;
  for (const char* name : {"reblur", "hybrid"}) {
    const double sampled = meanRelMse(l, denoise(l, name), "specular", warmup);
    const double mirror =
        meanRelMse(l, denoise(l, name, {{"hitDistance", "mirror"}}), "specular", warmup);
    std::printf(
        "glossy_orbit specular relMSE, %s: sampled hit distance %.5f, mirror oracle %.5f "
        "(x%.2f)\n",
        name, sampled, mirror, sampled / mirror);
    EXPECT_LT(sampled, 3.0 * mirror) << name;  // the oracle must not be what makes them work
  }
}

}  // namespace
}  // namespace arena
