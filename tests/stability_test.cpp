// Multi-scale temporal stability (metrics/stability.hpp, docs/metrics.md): a hand computation on a
// tiny sequence, the scale behaviour that tells flicker from boiling, motion compensation, and the
// exclusions (disocclusions, camera cuts, the sky).
#include <gtest/gtest.h>

#include <cmath>

#include "metrics/evaluator.hpp"
#include "metrics/stability.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

Image constant(int w, int h, float v) {
  Image i(w, h, 3);
  i.fill(v);
  return i;
}

TEST(Stability, MatchesAHandComputationOverThreeLags) {
  // 8x8 flat frames (one surface, no motion) with constant values: x_t = 1, x_t-1 = 0.5,
  // x_t-2 = 1, x_t-3 = 0. Per pixel and channel D_k = (x_t - x_t-k)^2 / (((x_t + x_t-k) / 2)^2 + eps):
  const double d1 = 0.25 / (0.75 * 0.75 + 0.01), d2 = 0.0, d3 = 1.0 / (0.5 * 0.5 + 0.01);
  const double expected = std::sqrt((d1 + d2 + d3) / 3);  // pooled over lags, pixels and channels
  const Image x0 = constant(8, 8, 1.0f), x1 = constant(8, 8, 0.5f), x2 = constant(8, 8, 1.0f),
              x3 = constant(8, 8, 0.0f);
  const LayerSet g = test::planeFrame(8, 8);
  const StabilityResult r = temporalStability({&x0, {&x1, &x2, &x3}, {&g, &g, &g, &g}, nullptr});
  EXPECT_NEAR(r.fine, expected, 1e-12);
  EXPECT_NEAR(r.coarse, expected, 1e-12);  // 4x4 block means of constant images are the same values
  // The last column and row are never followed: their bilinear taps reach past the border (the
  // consistency test of warped flicker). So 7 x 7 pixels, and of the 2 x 2 blocks only the first.
  EXPECT_DOUBLE_EQ(r.fineTiles.totalCount(), 7.0 * 7 * 3 * 3);  // pixels x channels x lags
  EXPECT_DOUBLE_EQ(r.coarseTiles.totalCount(), 1.0 * 3 * 3);     // blocks x channels x lags
  EXPECT_DOUBLE_EQ(r.validFraction, 49.0 / 64);
  // The twin divides by the reference instead: r = 2 everywhere.
  const Image ref = constant(8, 8, 2.0f);
  const StabilityResult t = temporalStability({&x0, {&x1, &x2, &x3}, {&g, &g, &g, &g}, &ref});
  EXPECT_NEAR(t.fine, std::sqrt((0.25 + 0.0 + 1.0) / 3 / (4.0 + 0.01)), 1e-12);
}

TEST(Stability, WhiteNoiseFlickersButDoesNotBoilAndBlotchesBoil) {
  const int w = 64, h = 64;
  const LayerSet g = test::planeFrame(w, h);
  // Per-pixel noise, independent in every frame: the 4x4 block means average 16 draws.
  auto white = [&](uint32_t frame) {
    Image i(w, h, 3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) i.at(x, y, c) = 0.5f + 0.2f * (test::hashUniform(x + 1000 * y, frame, c) - 0.5f);
    return i;
  };
  // The same amplitude in 4x4 blotches: nothing averages out.
  auto blotchy = [&](uint32_t frame) {
    Image i(w, h, 3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
          i.at(x, y, c) = 0.5f + 0.2f * (test::hashUniform(x / 4 + 1000 * (y / 4), frame, c) - 0.5f);
    return i;
  };
  const Image w0 = white(0), w1 = white(1), w2 = white(2), w3 = white(3);
  const Image b0 = blotchy(0), b1 = blotchy(1), b2 = blotchy(2), b3 = blotchy(3);
  const StabilityResult flicker = temporalStability({&w0, {&w1, &w2, &w3}, {&g, &g, &g, &g}, nullptr});
  const StabilityResult boil = temporalStability({&b0, {&b1, &b2, &b3}, {&g, &g, &g, &g}, nullptr});
  EXPECT_NEAR(flicker.coarse / flicker.fine, 0.25, 0.05);  // a 16-pixel mean has 1/4 the deviation
  // Equal in every block; the fine scale also sees the border blocks the coarse one leaves out.
  EXPECT_NEAR(boil.coarse / boil.fine, 1.0, 0.01);
  EXPECT_NEAR(boil.fine, flicker.fine, 0.1 * flicker.fine);  // the same per-pixel change
}

TEST(Stability, FollowsMotionAndExcludesWhatCannotBeFollowed) {
  // Content sliding one pixel left per frame: x_t(x) = f(x + t), so frame t - k shows pixel x's
  // surface at x + k, and the motion to the previous frame is +1 pixel in x.
  const int w = 24, h = 8;
  auto frameAt = [&](int t) {
    Image i(w, h, 3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) i.at(x, y, c) = 0.2f + 0.1f * float((x + t) % 5) + 0.01f * float(c);
    return i;
  };
  LayerSet g = test::planeFrame(w, h);
  g.get("motion").fill(0.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) g.get("motion").at(x, y, 0) = 1.0f;
  const Image x3 = frameAt(3), x2 = frameAt(2), x1 = frameAt(1), x0 = frameAt(0);
  const StabilityResult followed = temporalStability({&x3, {&x2, &x1, &x0}, {&g, &g, &g, &g}, nullptr});
  EXPECT_EQ(followed.fine, 0.0);  // every followed pixel lands exactly on its own content
  EXPECT_EQ(followed.coarse, 0.0);
  // Pixels whose path leaves the image are left out: lag k loses the last k + 1 columns (and every
  // lag the last row, whose taps reach past the border).
  EXPECT_DOUBLE_EQ(followed.fineTiles.totalCount(), double((w - 2) + (w - 3) + (w - 4)) * (h - 1) * 3);
  // Motion with the wrong sign finds other content: a large change.
  LayerSet flipped = g;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) flipped.get("motion").at(x, y, 0) = -1.0f;
  const StabilityResult wrong = temporalStability({&x3, {&x2, &x1, &x0}, {&flipped, &flipped, &flipped, &flipped}, nullptr});
  EXPECT_GT(wrong.fine, 0.3);
  // Another surface in the previous frame (a disocclusion): nothing to follow, so undefined --
  // never a perfect 0.
  LayerSet other = test::planeFrame(w, h);
  other.get("meshId").fill(1.0f);
  const StabilityResult none = temporalStability({&x3, {&x2}, {&g, &other}, nullptr});
  EXPECT_TRUE(std::isnan(none.fine));
  EXPECT_TRUE(std::isnan(none.coarse));
  EXPECT_EQ(none.validFraction, 0.0);
  // The sky (mesh id -1) has no surface to follow either.
  LayerSet sky = test::planeFrame(w, h);
  sky.get("meshId").fill(-1.0f);
  EXPECT_TRUE(std::isnan(temporalStability({&x3, {&x2}, {&sky, &sky}, nullptr}).fine));
}

TEST(Stability, PathsTracedOnceServeEveryOutputWithTheSameBits) {
  // The evaluation traces a frame's paths once and applies them to every pair's output (they read
  // only the guide layers): the values must be those of tracing them for each output.
  const int w = 24, h = 8;
  LayerSet g = test::planeFrame(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      g.get("motion").at(x, y, 0) = 0.75f, g.get("motion").at(x, y, 1) = 0.25f;
  auto noise = [&](uint32_t frame, uint32_t seed) {
    Image i(w, h, 3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c)
          i.at(x, y, c) = test::hashUniform(x + 100 * y + 10000 * int(seed), frame, c);
    return i;
  };
  const std::vector<const LayerSet*> guides = {&g, &g, &g, &g};
  const StabilityPaths paths = traceStabilityPaths(guides);
  ASSERT_EQ(paths.lags.size(), 3u);
  for (uint32_t seed : {1u, 2u}) {
    const Image x0 = noise(0, seed), x1 = noise(1, seed), x2 = noise(2, seed), x3 = noise(3, seed);
    const Image ref = constant(w, h, 0.5f);
    const std::vector<StabilityInput> signals = {{&x0, {&x1, &x2, &x3}, {}, nullptr},
                                                 {&x0, {&x1, &x2, &x3}, {}, &ref}};
    const std::vector<StabilityResult> once = temporalStability(signals, paths);
    const std::vector<StabilityResult> each = temporalStability(signals, guides);
    for (size_t s = 0; s < signals.size(); ++s) {
      EXPECT_GT(once[s].fine, 0.0);
      EXPECT_EQ(once[s].fine, each[s].fine);
      EXPECT_EQ(once[s].coarse, each[s].coarse);
      EXPECT_EQ(once[s].validFraction, each[s].validFraction);
      EXPECT_EQ(once[s].fineTiles.totalSum(), each[s].fineTiles.totalSum());
      EXPECT_EQ(once[s].coarseTiles.totalCount(), each[s].coarseTiles.totalCount());
    }
  }
  // Paths over one lag cannot serve a signal with three previous frames.
  const Image x0 = noise(0, 1), x1 = noise(1, 1), x2 = noise(2, 1), x3 = noise(3, 1);
  const StabilityPaths one = traceStabilityPaths({&g, &g});
  const std::string lags = test::errorOf([&] {
    temporalStability({{&x0, {&x1, &x2, &x3}, {}, nullptr}}, one);
  });
  EXPECT_NE(lags.find("3 previous frames need paths over as many lags, got 1"), std::string::npos)
      << lags;
  const std::string single = test::errorOf([&] { traceStabilityPaths({&g}); });
  EXPECT_NE(single.find("at least two frames"), std::string::npos) << single;
}

TEST(Stability, TheEvaluationRecordsItWithoutAReferenceAndNotAcrossACut) {
  // Six flat frames with a camera cut at frame 3; outputs alternate 0.4 / 0.6 (pure flicker).
  EvaluationInput in;
  in.name = "cut";
  for (int t = 0; t < 6; ++t) in.frames.push_back(test::planeFrame(8, 8));
  in.events.push_back({3, EventKind::CameraCut, "", -1});
  EvaluationScene scene(std::move(in), {1, {"none"}, ExposureMode::PerFrame});
  PairEvaluation pair(scene);
  for (int t = 0; t < 6; ++t) pair.add(t, constant(8, 8, t % 2 ? 0.6f : 0.4f));
  const nlohmann::json r = pair.finish();
  const auto& frames = r["frames"];
  EXPECT_FALSE(frames[0].contains("stabilityFine"));
  EXPECT_FALSE(frames[3].contains("stabilityFine"));  // the cut: nothing before it is followed
  EXPECT_FALSE(frames[3].contains("errorStabilityFine"));  // and no reference: no twin at all
  // Frame 4 sees only lag 1 (frame 3): (0.6 - 0.4)^2 / (0.5^2 + eps).
  EXPECT_NEAR(frames[4]["stabilityFine"].get<double>(), std::sqrt(0.04 / 0.26), 1e-6);
  // Frame 2 sees lags 1 and 2: one change of 0.2 and none.
  EXPECT_NEAR(frames[2]["stabilityFine"].get<double>(), std::sqrt(0.04 / 0.26 / 2), 1e-6);
  EXPECT_TRUE(r["summary"]["stabilityCoarse"].contains("mean"));
}

}  // namespace
}  // namespace arena
