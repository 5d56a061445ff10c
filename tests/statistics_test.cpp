// Uncertainty (metrics/statistics.hpp): tile sums, the crossed block bootstrap's coverage on
// synthetic data with a known difference, ranks with ties, the per-scene normalised overall
// ranking, absent summaries, the statistical regression gate and shard completeness.
#include "metrics/statistics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <random>

#include "core/error.hpp"
#include "core/exr_io.hpp"
#include "core/sequence.hpp"
#include "harness/run_matrix.hpp"
#include "harness/scene_selection.hpp"
#include "metrics/compare.hpp"
#include "metrics/error.hpp"
#include "metrics/results.hpp"
#include "metrics/run_statistics.hpp"
#include "metrics/summary.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

Image noiseImage(int w, int h, uint32_t seed, float scale) {
  Image img(w, h, 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        img.at(x, y, c) = 0.5f + scale * (test::hashUniform(seed, uint32_t(y * w + x), c) - 0.5f);
  return img;
}

TEST(Tiles, TileSumsAddUpToTheFrameValue) {
  const Image d = noiseImage(37, 23, 1, 0.4f), r = noiseImage(37, 23, 2, 0.1f),
              var = noiseImage(37, 23, 3, 0.01f);
  ErrorTiles t;
  const ErrorStats e = linearError(d, r, &var, nullptr, kRelMseEpsilon, &t);
  ASSERT_EQ(t.relMse.sum.size(), 16u);
  EXPECT_DOUBLE_EQ(t.relMse.totalCount(), 37.0 * 23 * 3);
  EXPECT_NEAR(t.relMse.totalSum() / t.relMse.totalCount(), e.relMse, 1e-12);
  EXPECT_NEAR(t.relMseCorrected.totalSum() / t.relMseCorrected.totalCount(), e.relMseCorrected,
              1e-12);
  EXPECT_NEAR(t.mse.totalSum() / t.mse.totalCount(), e.mse, 1e-12);
  TileSums s;
  const double v = ssim(d, r, &s);
  EXPECT_NEAR(s.totalSum() / s.totalCount(), v, 1e-12);
  // Every tile holds data and tiles partition the image.
  for (double c : t.mse.count) EXPECT_GT(c, 0);
}

MetricTiles syntheticSeries(int frames, int tiles, double offset, std::mt19937_64& rng,
                            const std::vector<double>& shared) {
  std::normal_distribution<double> noise(0.0, 1.0);
  MetricTiles m;
  for (int f = 0; f < frames; ++f) {
    TileSums t;
    for (int k = 0; k < tiles; ++k) {
      t.sum.push_back(shared[size_t(f * tiles + k)] + offset + 0.3 * noise(rng));
      t.count.push_back(1.0);
    }
    m.add(f, std::move(t));
  }
  return m;
}

// Content shared by the methods: a slow AR(1) drift over frames (rho 0.7) plus a fixed effect per
// tile; each method adds its own independent noise per frame and tile.
std::vector<double> sharedContent(int frames, int tiles, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<double> tileEffect(static_cast<size_t>(tiles)), out;
  for (double& e : tileEffect) e = 2.0 + 0.5 * n(rng);
  double drift = 0;
  for (int f = 0; f < frames; ++f) {
    drift = 0.7 * drift + 0.3 * n(rng);
    for (int k = 0; k < tiles; ++k) out.push_back(tileEffect[size_t(k)] + drift);
  }
  return out;
}

// Trial set: 200 independent sequences of 28 frames x 16 tiles; method B = method A + 0.15 in
// expectation, each with its own noise (sd 0.3 per cell). The 95% paired interval must cover the
// true difference in at least 93% of the trials.
TEST(Bootstrap, PairedIntervalCoversAKnownDifference) {
  std::mt19937_64 rng(2026);
  const double delta = 0.15;
  int covered = 0, resolved = 0;
  double halfWidth = 0;
  BootstrapConfig cfg;
  cfg.replicates = 400;
  for (int trial = 0; trial < 200; ++trial) {
    const auto shared = sharedContent(28, 16, rng);
    const MetricTiles a = syntheticSeries(28, 16, 0.0, rng, shared);
    const MetricTiles b = syntheticSeries(28, 16, delta, rng, shared);
    const PairedDifference d = pairedDifference(b, a, "trial" + std::to_string(trial), cfg);
    ASSERT_TRUE(d.ci.valid());
    covered += d.ci.lo <= delta && delta <= d.ci.hi;
    halfWidth += (d.ci.hi - d.ci.lo) / 2 / 200;
    resolved += d.resolved();
  }
  // The ideal half-width: 1.96 x the difference's standard error, sqrt(2) 0.3 / sqrt(28 x 16).
  std::cout << "coverage " << covered << "/200, resolved " << resolved << "/200, mean half-width "
            << halfWidth << " (ideal " << 1.96 * std::sqrt(2.0) * 0.3 / std::sqrt(28.0 * 16)
            << ")\n";
  EXPECT_GE(covered, 186);   // 93%
  EXPECT_GE(resolved, 150);  // the difference is 0.5 noise sd: mostly resolved, not always
}

TEST(Bootstrap, IdenticalMethodsAreTiedAndAClearWinnerIsResolved) {
  std::mt19937_64 rng(7);
  const auto shared = sharedContent(20, 16, rng);
  const MetricTiles a = syntheticSeries(20, 16, 0.0, rng, shared);
  const MetricTiles worse = syntheticSeries(20, 16, 1.0, rng, shared);
  SceneRanking r = rankScene("relMse", true, {{"a", &a}, {"copy", &a}, {"worse", &worse}}, "scene");
  ASSERT_EQ(r.ranking.size(), 3u);
  EXPECT_EQ(r.ranking[0].rank, 1);
  EXPECT_EQ(r.ranking[1].rank, 1);
  EXPECT_EQ(r.ranking[2].label, "worse");
  EXPECT_EQ(r.ranking[2].rank, 3);
  EXPECT_EQ(r.ranking[0].tiedWith.size(), 1u);
  EXPECT_EQ(r.resolvedPairs, 2);
  ASSERT_TRUE(r.ranking[0].ci.valid());
  EXPECT_LE(r.ranking[0].ci.lo, r.ranking[0].value);
  EXPECT_GE(r.ranking[0].ci.hi, r.ranking[0].value);
  // Reruns are identical (fixed seed per scene).
  SceneRanking again =
      rankScene("relMse", true, {{"a", &a}, {"copy", &a}, {"worse", &worse}}, "scene");
  EXPECT_EQ(again.ranking[0].ci.lo, r.ranking[0].ci.lo);
}

TEST(Bootstrap, AWidenedIntervalOfBMinusAIsTheNegatedIntervalOfAMinusB) {
  // An even count of replicates (the event figures draw 1000): the widening's centre must not
  // depend on which way the difference is taken.
  std::mt19937_64 rng(5);
  std::lognormal_distribution<double> skewed(0.0, 1.0);
  std::vector<double> d(1000);
  for (double& x : d) x = skewed(rng);
  std::vector<double> negated(d.size());
  for (size_t i = 0; i < d.size(); ++i) negated[i] = -d[i];
  for (double widen : {1.0, 1.3}) {
    const Interval forward = widenedInterval(d, 0.95, widen);
    const Interval backward = widenedInterval(negated, 0.95, widen);
    ASSERT_TRUE(forward.valid() && backward.valid());
    EXPECT_NEAR(forward.lo, -backward.hi, 1e-12 * std::abs(forward.lo)) << widen;
    EXPECT_NEAR(forward.hi, -backward.lo, 1e-12 * std::abs(forward.hi)) << widen;
  }
  // Widened about the median: the two middle values' mean where there are two.
  const Interval w = widenedInterval(
      {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19}, 0.5, 2.0);
  const Interval plain = percentileInterval(
      {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19}, 0.5);
  EXPECT_DOUBLE_EQ(w.lo, 9.5 - 2 * (9.5 - plain.lo));
  EXPECT_DOUBLE_EQ(w.hi, 9.5 + 2 * (plain.hi - 9.5));
}

// Blocks of frames wrap from the last frame to the first (a circular block bootstrap), so every
// frame is drawn equally often and the replicates' mean is the sample's: blocks that stopped at
// the end drew the first and last frames a third as often as the rest (block length 3 of 16), and
// on a filter still converging (a decaying error) the replicates' mean sat 2.9% below the point
// estimate, the interval with it.
TEST(Bootstrap, EveryFrameIsDrawnEquallyOften) {
  const int frames = 16;
  const ResamplingPlan plan(frames, 16, "converging", BootstrapConfig{});
  ASSERT_EQ(plan.blockLength(), 3);
  std::vector<double> drawn(frames, 0.0);
  for (int b = 0; b < plan.replicates(); ++b)
    for (int row : plan.frameRows(b)) drawn[size_t(row)] += 1;
  const double expected = double(plan.replicates());  // n draws of n frames per replicate
  for (int t = 0; t < frames; ++t) EXPECT_NEAR(drawn[size_t(t)] / expected, 1.0, 0.08) << t;
  // A decaying error: the replicates' mean is the point estimate, within their own noise.
  MetricTiles m;
  for (int t = 0; t < frames; ++t) {
    TileSums ts;
    for (int k = 0; k < 16; ++k) ts.sum.push_back(0.1 + std::exp(-t / 3.0)), ts.count.push_back(1);
    m.add(t, std::move(ts));
  }
  const std::vector<double> reps = replicateValues(m, plan);
  double mean = 0;
  for (double v : reps) mean += v / double(reps.size());
  EXPECT_NEAR(mean / m.mean(), 1.0, 0.01) << mean << " against " << m.mean();
}

// A p-value and an interval of one widened set of replicates agree: the event figures' changes
// were tested on the plain replicates while their interval was widened, so a corrected gate read
// "[-0.14%, +7.43%] p 0.030" and let more noise through than its level.
TEST(Bootstrap, AWidenedIntervalHoldingZeroHasAPValueAboveItsLevel) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<double> d(1000);
  for (double& x : d) x = 2.2 + noise(rng);  // plain: p about 0.03, interval clear of 0
  const double widen = 1.3;
  ASSERT_LT(changePValue(d), 0.05);
  ASSERT_GT(percentileInterval(d, 0.95).lo, 0.0);
  const Interval w = widenedInterval(d, 0.95, widen);
  ASSERT_TRUE(w.containsZero());
  const std::vector<double> widened = widenedReplicates(d, widen);
  EXPECT_GE(changePValue(widened), 0.05);
  // The same interval, from the widened replicates' own percentiles.
  const Interval again = percentileInterval(widened, 0.95);
  EXPECT_NEAR(again.lo, w.lo, 1e-12);
  EXPECT_NEAR(again.hi, w.hi, 1e-12);
  EXPECT_EQ(widenedReplicates(d, 1.0), d);
}

// Two outputs alike but for rounding on 14 of 16 tiles (float32 tile sums one part in 10^9 apart,
// every one the same way) and really different on 2: about one bootstrap replicate in eight draws
// neither real tile, so an interval's end lies at that replicate's rounding, whose sign decided
// "resolved" (a sweep's edge.id read "better" at [-1.07e-3, -1.28e-11]). Rounding is no
// difference: the end is 0, a tie, in the paired difference, the relative change, its p-value and
// the scene's ranking; a difference on every tile is still resolved.
TEST(Bootstrap, ADifferenceOfRoundingAloneIsATie) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> content(0.02, 0.06);
  MetricTiles a, b, far;
  for (int f = 0; f < 12; ++f) {
    TileSums ta, tb, tf;
    for (int k = 0; k < 16; ++k) {
      const double v = content(rng);
      ta.sum.push_back(v), ta.count.push_back(1);
      tb.sum.push_back(k < 2 ? 0.8 * v : v * (1 - 1e-9)), tb.count.push_back(1);
      tf.sum.push_back(0.8 * v), tf.count.push_back(1);
    }
    a.add(f, std::move(ta));
    b.add(f, std::move(tb));
    far.add(f, std::move(tf));
  }
  const PairedDifference d = pairedDifference(b, a, "rounding");
  ASSERT_TRUE(d.ci.valid());
  EXPECT_LT(d.ci.lo, 0);
  EXPECT_EQ(d.ci.hi, 0) << "the end a replicate of rounding alone gives";
  EXPECT_FALSE(d.resolved());
  const PairedChange c = pairedRelativeChange(b, a, "rounding");
  EXPECT_TRUE(c.ci.containsZero()) << c.ci.lo << " " << c.ci.hi;
  EXPECT_GT(c.pValue, 0.05);
  const SceneRanking r = rankScene("relMse", true, {{"a", &a}, {"b", &b}}, "scene");
  EXPECT_EQ(r.resolvedPairs, 0);
  EXPECT_TRUE(pairedDifference(far, a, "rounding").resolved());
  EXPECT_TRUE(pairedRelativeChange(far, a, "rounding").ci.hi < 0);
  // The shared rule (event figures' changes use it too): within a millionth of the larger is none;
  // near 0, a floor (log ratios).
  EXPECT_EQ(replicateDifferences({1.0, 1.0, 0.0, 1e-9}, {1.0 - 1e-9, 0.999, 1e-9, 0.0}),
            (std::vector<double>{0.0, 1.0 - 0.999, -1e-9, 1e-9}));
  EXPECT_EQ(replicateDifferences({1e-9}, {0.0}, kRoundingResolution), std::vector<double>{0.0});
}

MetricTiles constantSeries(double value, int frames = 12) {
  MetricTiles m;
  std::mt19937_64 rng(uint64_t(value * 1e6));
  std::normal_distribution<double> n(0.0, 0.01 * value);
  for (int f = 0; f < frames; ++f) {
    TileSums t;
    for (int k = 0; k < 16; ++k) t.sum.push_back(value + n(rng)), t.count.push_back(1);
    m.add(f, std::move(t));
  }
  return m;
}

// One scene 1000x the scale of the other must not decide the overall ranking: method x is 2x
// better than y on the small scene and 1.1x worse on the large one; by the mean relMSE y would win,
// by the geometric mean of ratios x does.
TEST(Bootstrap, OverallRankingIsPerSceneNormalised) {
  const MetricTiles xs = constantSeries(0.001), ys = constantSeries(0.002),
                    ts = constantSeries(0.004);
  const MetricTiles xl = constantSeries(1.1), yl = constantSeries(1.0), tl = constantSeries(2.0);
  SceneRanking small =
      rankScene("relMse", true, {{"x", &xs}, {"y", &ys}, {"temporal", &ts}}, "small");
  SceneRanking large =
      rankScene("relMse", true, {{"x", &xl}, {"y", &yl}, {"temporal", &tl}}, "large");
  OverallRanking o = rankOverall({&small, &large}, std::vector<std::string>{"temporal"}, true);
  ASSERT_EQ(o.ranking.size(), 3u);
  EXPECT_EQ(o.ranking[0].label, "x");
  EXPECT_NEAR(o.ranking[0].value, std::sqrt(0.25 * 0.55), 0.01);
  EXPECT_EQ(o.baseline, "temporal");
  EXPECT_NE(o.normalisation.find("geometric mean"), std::string::npos);
  // Every pair is kept, on the log scale its ties are read from: diff = log(score_a / score_b),
  // resolved exactly where the ranking does not tie them; through JSON and back unchanged.
  ASSERT_EQ(o.pairs.size(), 3u);
  for (const SceneRanking::Pair& p : o.pairs) {
    const auto score = [&](const std::string& label) {
      for (const RankedMethod& m : o.ranking)
        if (m.label == label) return m;
      return RankedMethod{};
    };
    const RankedMethod a = score(p.a), b = score(p.b);
    EXPECT_NEAR(p.d.diff, std::log(a.value / b.value), 1e-9) << p.a << " " << p.b;
    EXPECT_TRUE(p.d.ci.lo <= p.d.diff && p.d.diff <= p.d.ci.hi) << p.a << " " << p.b;
    const bool tied = std::find(a.tiedWith.begin(), a.tiedWith.end(), p.b) != a.tiedWith.end();
    EXPECT_EQ(p.d.resolved(), !tied) << p.a << " " << p.b;
  }
  RunStatistics st;
  st.overall = o;
  const RunStatistics back = RunStatistics::fromJson(st.toJson(), "r.json");
  ASSERT_EQ(back.overall->pairs.size(), 3u);
  EXPECT_EQ(back.overall->toJson(), o.toJson());
  // Results written before the pairs were stored read without them.
  json old = st.toJson();
  old["overall"].erase("pairs");
  EXPECT_TRUE(RunStatistics::fromJson(old, "r.json").overall->pairs.empty());
}

// A method missing from a scene is named, whichever scene it misses (the first included), and is
// not scored; with one method left there is no overall score (1 with interval [1, 1] against
// itself would read as a result).
TEST(Bootstrap, OverallRankingNamesWhatItLeavesOut) {
  const MetricTiles x1 = constantSeries(0.001), t1 = constantSeries(0.004);
  const MetricTiles x2 = constantSeries(0.002), y2 = constantSeries(0.003),
                    t2 = constantSeries(0.005);
  SceneRanking first = rankScene("relMse", true, {{"x", &x1}, {"temporal", &t1}}, "first");
  SceneRanking second =
      rankScene("relMse", true, {{"x", &x2}, {"y", &y2}, {"temporal", &t2}}, "second");
  for (const auto& order : {std::vector<const SceneRanking*>{&first, &second},
                            std::vector<const SceneRanking*>{&second, &first}}) {
    const OverallRanking o = rankOverall(order, std::vector<std::string>{"temporal"}, true);
    ASSERT_EQ(o.ranking.size(), 2u);
    EXPECT_EQ(o.excluded, "y: not run on first");
  }
  SceneRanking alone = rankScene("relMse", true, {{"x", &x1}}, "first");
  const OverallRanking one = rankOverall({&alone}, std::vector<std::string>{"temporal"}, true);
  EXPECT_TRUE(one.ranking.empty());
  EXPECT_TRUE(one.baseline.empty());
  EXPECT_NE(one.excluded.find("x: the only method"), std::string::npos) << one.excluded;
  SceneRanking onlyX = rankScene("relMse", true, {{"x", &x2}, {"y", &y2}}, "second");
  const OverallRanking leftOne =
      rankOverall({&first, &onlyX}, std::vector<std::string>{"temporal"}, true);
  EXPECT_TRUE(leftOne.ranking.empty());
  EXPECT_NE(leftOne.excluded.find("temporal: not run on second"), std::string::npos)
      << leftOne.excluded;
  EXPECT_NE(leftOne.excluded.find("x: the only method"), std::string::npos) << leftOne.excluded;
  // A method measured nowhere on two scenes: the first scene names it with its reason, the other
  // is counted; a method whose value is 0 on a scene has no logarithm.
  const MetricTiles empty, zero = constantSeries(0.0);
  SceneRanking a = rankScene("relMse", true, {{"x", &x1}, {"t", &t1}, {"e", &empty}}, "first");
  SceneRanking b = rankScene("relMse", true, {{"x", &x2}, {"t", &t2}, {"e", &empty}}, "second");
  SceneRanking c = rankScene("relMse", true, {{"x", &zero}, {"t", &t2}}, "third");
  const OverallRanking reasons = rankOverall({&a, &b, &c}, std::vector<std::string>{"t"}, true);
  EXPECT_NE(
      reasons.excluded.find("e: not ranked on first (no relMse data) and on 2 other scenes; "),
      std::string::npos)
      << reasons.excluded;
  EXPECT_NE(reasons.excluded.find("x: value <= 0 on third"), std::string::npos) << reasons.excluded;
}

TEST(Bootstrap, TileDataSurvivesJson) {
  std::mt19937_64 rng(3);
  const auto shared = sharedContent(9, 16, rng);
  MetricTiles m = syntheticSeries(9, 16, 0.0, rng, shared);
  m.transform = FrameTransform::Psnr;
  const MetricTiles back = MetricTiles::fromJson(json::parse(m.toJson().dump()));
  EXPECT_EQ(back.frames, m.frames);
  EXPECT_EQ(back.transform, FrameTransform::Psnr);
  EXPECT_NEAR(back.rows[3].sum[5], m.rows[3].sum[5], 1e-6 * std::abs(m.rows[3].sum[5]));
  json bad = m.toJson();
  bad["sum"] = "AAAA";
  EXPECT_THROW(MetricTiles::fromJson(bad), Error);
}

TEST(Summaries, NoDataIsAbsentNeverPerfect) {
  PairSeries few(4, 8);  // fewer frames than the warm-up
  for (int t = 0; t < 4; ++t) few.record("relMse", t, 0.01, {}, FrameTransform::Mean);
  json s = few.summaries("scene");
  EXPECT_FALSE(s["relMse"].contains("mean"));
  EXPECT_NE(s["relMse"]["absent"].get<std::string>().find("warm-up"), std::string::npos);

  PairSeries nan(12, 2);
  for (int t = 0; t < 12; ++t) nan.record("ssim", t, t == 7 ? NAN : 0.9, {}, FrameTransform::Mean);
  s = nan.summaries("scene");
  EXPECT_FALSE(s["ssim"].contains("mean"));
  EXPECT_EQ(s["ssim"]["nonFinite"], 1);
  // Said as the metric's failure, where: the images a metric reads are checked finite before.
  EXPECT_EQ(
      s["ssim"]["absent"],
      "its value is not finite (NaN or Inf) on 1 of 10 frames after the warm-up, first frame 7 "
      "(the images it reads are checked finite before: the metric's own arithmetic failed "
      "there, e.g. a division by 0 or an overflow)");

  PairSeries fine(12, 2);
  for (int t = 0; t < 12; ++t) fine.record("ms", t, 10.0 + t % 3, {}, FrameTransform::Mean);
  s = fine.summaries("scene");
  ASSERT_TRUE(s["ms"]["ci95"].is_array());
  EXPECT_LE(s["ms"]["ci95"][0].get<double>(), s["ms"]["mean"].get<double>());
  EXPECT_GE(s["ms"]["ci95"][1].get<double>(), s["ms"]["mean"].get<double>());

  // One frame after the warm-up of a value per frame: a mean, and no interval (it read [v, v], a
  // certainty from nothing that varied).
  PairSeries one(3, 2);
  for (int t = 0; t < 3; ++t) one.record("ms", t, 10.0 + t, {}, FrameTransform::Mean);
  s = one.summaries("scene");
  EXPECT_DOUBLE_EQ(s["ms"]["mean"].get<double>(), 12.0);
  EXPECT_TRUE(s["ms"]["ci95"].is_null()) << s["ms"];
}

// A results document with one scene and the given labels' relMSE tile data.
json syntheticJson(const std::map<std::string, MetricTiles>& methods, const std::string& scene = "s") {
  json r = {{"schema", kResultsSchemaVersion}, {"kind", "arena-run"},        {"name", "synthetic"},
            {"environment", json::object()},   {"settings", json::object()}, {"scenes", json::object()},
            {"pairs", json::array()}};
  for (const auto& [label, m] : methods)
    r["pairs"].push_back({{"scene", scene},
                          {"label", label},
                          {"denoiser", label},
                          {"status", "ok"},
                          {"params", json::object()},
                          {"frames", json::array()},
                          {"summary", {{"relMse", {{"mean", m.mean()}}}}},
                          {"tiles", {{"relMse", m.toJson()}}}});
  return r;
}
RunResults syntheticRun(const std::map<std::string, MetricTiles>& methods, const std::string& scene = "s") {
  return test::typed(syntheticJson(methods, scene));
}

// Without `temporal` (--no-baselines) the scores are relative to a sweep's first grid point, else
// to the run's first contender: not to whichever label sorts first. The order is the same either
// way; the scores' scale is named after a contender the user chose.
TEST(Bootstrap, WithoutTemporalTheOverallBaselineIsTheSweepsFirstPointOrTheFirstContender) {
  std::mt19937_64 rng(5);
  json run = json::object();
  for (const char* scene : {"s1", "s2"}) {
    const auto shared = sharedContent(12, 16, rng);
    json part = syntheticJson({{"b[x=1]", syntheticSeries(12, 16, 0.0, rng, shared)},
                               {"a[x=2]", syntheticSeries(12, 16, 0.1, rng, shared)}},
                              scene);
    std::reverse(part["pairs"].begin(), part["pairs"].end());  // "b[x=1]" ran first
    if (run.empty())
      run = part;
    else
      for (const json& p : part["pairs"]) run["pairs"].push_back(p);
  }
  ASSERT_EQ(run["pairs"][0]["label"], "b[x=1]");
  ASSERT_TRUE(analyseRun(run).overall.has_value());
  EXPECT_EQ(analyseRun(run).overall->baseline, "b[x=1]");
  json merged = run;  // shards merged in another order: the plan's order decides
  std::reverse(merged["pairs"].begin(), merged["pairs"].end());
  merged["settings"]["plan"] = {{"labels", {"b[x=1]", "a[x=2]"}}};
  EXPECT_EQ(analyseRun(merged).overall->baseline, "b[x=1]");
  run["sweep"] = {{"labels", {"a[x=2]", "b[x=1]"}}};
  EXPECT_EQ(analyseRun(run).overall->baseline, "a[x=2]");
  const RunStatistics st = analyseRun(run);
  const OverallRanking preferred =
      rankOverall({&st.scenes.at("s1").ranking, &st.scenes.at("s2").ranking},
                  {"temporal", "nobody", "b[x=1]"}, true);
  EXPECT_EQ(preferred.baseline, "b[x=1]");
}

// A method with a non-finite value on a frame has no mean; ranked on the frames every method
// shares, that frame would vanish from the comparison unnoticed: it is left out of the ranking,
// named, as is a method whose stored tile sums overflowed float.
TEST(Bootstrap, AMethodWithANonFiniteFrameIsLeftOutOfTheRankingNamed) {
  json run = syntheticJson(
      {{"a", constantSeries(0.01)}, {"b", constantSeries(0.02)}, {"c", constantSeries(0.03)}});
  json& b = run["pairs"][1];
  ASSERT_EQ(b["label"], "b");
  b["summary"]["relMse"] = {
      {"frames", 12},
      {"nonFinite", 1},
      {"absent", "1 of 12 frames after the warm-up are not finite (NaN or Inf)"}};
  const RunStatistics st = analyseRun(run);
  const SceneRanking& r = st.scenes.at("s").ranking;
  ASSERT_EQ(r.ranking.size(), 2u);
  for (const RankedMethod& m : r.ranking) EXPECT_NE(m.label, "b");
  EXPECT_NE(r.excluded.find("b: 1 of 12 frames after the warm-up are not finite"),
            std::string::npos)
      << r.excluded;
  ASSERT_TRUE(st.overall.has_value());
  EXPECT_NE(st.overall->excluded.find(
                "b: not ranked on s (1 of 12 frames after the warm-up are not finite"),
            std::string::npos)
      << st.overall->excluded;

  MetricTiles overflowed = constantSeries(0.02);
  overflowed.rows[3].sum[5] = std::numeric_limits<double>::infinity();
  const MetricTiles a = constantSeries(0.01), c = constantSeries(0.03);
  const SceneRanking o = rankScene("relMse", true, {{"a", &a}, {"b", &overflowed}, {"c", &c}}, "s");
  ASSERT_EQ(o.ranking.size(), 2u);
  EXPECT_NE(o.excluded.find("b: a relMse tile sum is not finite"), std::string::npos) << o.excluded;
}

TEST(CompareGate, NoiseIsNotARegressionAndARealWorseningIs) {
  std::mt19937_64 rng(11);
  const auto shared = sharedContent(20, 16, rng);
  const MetricTiles base = syntheticSeries(20, 16, 0.0, rng, shared);
  const MetricTiles rerun = syntheticSeries(20, 16, 0.0, rng, shared);  // another noise realisation
  const MetricTiles worse = syntheticSeries(20, 16, 0.4, rng, shared);  // ~+20%
  const std::vector<Tolerance> tol = {{"relMse", 0.01}};
  auto rows = compareRuns(syntheticRun({{"m", base}}), syntheticRun({{"m", rerun}}), tol);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_NE(rows[0].verdict, "regressed") << rows[0].change;
  EXPECT_FALSE(anyRegression(rows));
  rows = compareRuns(syntheticRun({{"m", base}}), syntheticRun({{"m", worse}}), tol);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].verdict, "regressed");
  EXPECT_GT(rows[0].changeCi.lo, 0.0);
  EXPECT_TRUE(anyRegression(rows));
}

// A gate judges many rows at once: each at 95% alone, noise resolves a few in a hundred, and a
// gate of 60 rows of pure noise (every candidate another realisation of its baseline) failed in
// most trials. Corrected together (Holm, the default), noise fails it in at most about 5% of them,
// while a real worsening among the noise is still caught.
TEST(CompareGate, ManyRowsOfNoiseAreJudgedTogether) {
  std::mt19937_64 rng(41);
  // A realisation's noise persists in each tile over the frames (a denoiser's history carries
  // it), as in a rendered sequence, where the paired intervals were measured to be about right
  // (docs/statistics.md); noise fresh in every frame and tile would leave them wide.
  std::normal_distribution<double> unit(0.0, 1.0);
  const auto realisation = [&](const std::vector<double>& shared, double offset) {
    std::vector<double> persistent(64);
    for (double& v : persistent) v = 0.15 * unit(rng);
    MetricTiles m;
    for (int f = 0; f < 16; ++f) {
      TileSums t;
      for (int k = 0; k < 64; ++k) {
        t.sum.push_back(shared[size_t(f * 64 + k)] + offset + persistent[size_t(k)] +
                        0.3 * unit(rng));
        t.count.push_back(1.0);
      }
      m.add(f, std::move(t));
    }
    return m;
  };
  const std::vector<Tolerance> tol = {{"relMse", 0.001}};
  BootstrapConfig cfg;
  cfg.replicates = 400;
  int failedAlone = 0, failedTogether = 0, caught = 0;
  const int trials = 20, rows = 60;
  for (int trial = 0; trial < trials; ++trial) {
    const auto shared = sharedContent(16, 64, rng);
    std::map<std::string, MetricTiles> base, noise, worse;
    for (int k = 0; k < rows; ++k) {
      const std::string name = "m" + std::to_string(k);
      base[name] = realisation(shared, 0.0);
      noise[name] = realisation(shared, 0.0);
      worse[name] = k == 0 ? realisation(shared, 0.4) : noise[name];  // ~+20%
    }
    const RunResults b = syntheticRun(base, "s" + std::to_string(trial));
    failedAlone += anyRegression(compareRuns(b, syntheticRun(noise, "s" + std::to_string(trial)),
                                             tol, cfg, Correction::None));
    const auto together =
        compareRuns(b, syntheticRun(noise, "s" + std::to_string(trial)), tol, cfg);
    failedTogether += anyRegression(together);
    for (const ComparisonRow& r : together) {
      EXPECT_TRUE(std::isfinite(r.pValue));
      if (r.verdict == "unresolved" && r.changeCi.valid() && !r.changeCi.containsZero()) {
        EXPECT_NE(r.note.find("not among the 60 rows judged together: Holm, p "), std::string::npos)
            << r.note;
      }
    }
    const auto withWorse =
        compareRuns(b, syntheticRun(worse, "s" + std::to_string(trial)), tol, cfg);
    caught += withWorse[0].label == "m0" && withWorse[0].verdict == "regressed";
  }
  std::cout << "gates of " << rows << " rows of noise failed: " << failedAlone << "/" << trials
            << " judged alone, " << failedTogether << "/" << trials
            << " together; a +20% row caught in " << caught << "/" << trials << "\n";
  EXPECT_GE(failedAlone, 6);  // 11 of 20 with this seed: judged alone, noise fails the gate often
  EXPECT_LE(failedTogether, 3);
  EXPECT_EQ(caught, trials);
}

TEST(CompareGate, HolmRejectsInOrderAndStopsAtTheFirstThatStays) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // m = 3 finite: 0.01 <= 0.05/3, then 0.03 > 0.05/2 stops it; 0.04 stays too.
  EXPECT_EQ(holmRejections({0.01, 0.04, 0.03, nan}, 0.05),
            (std::vector<bool>{true, false, false, false}));
  EXPECT_EQ(holmRejections({0.04, 0.001, 0.02}, 0.05), (std::vector<bool>{true, true, true}));
  EXPECT_EQ(holmRejections({0.03, 0.03}, 0.05), (std::vector<bool>{false, false}));
  EXPECT_EQ(holmRejections({0.02, 0.02}, 0.05), (std::vector<bool>{true, true}));  // 0.025, 0.05
  EXPECT_TRUE(holmRejections({}, 0.05).empty());
  EXPECT_EQ(parseCorrection("none"), Correction::None);
  // Beyond 2,500 rows at 95% no p-value of at most 100,000 replicates reaches 0.05 / m.
  EXPECT_EQ(holmResolvableRows(0.95), 2500u);
  EXPECT_LT(2.0 / (kMaxGateReplicates + 1), 0.05 / double(holmResolvableRows(0.95)));
  EXPECT_GT(2.0 / (kMaxGateReplicates + 1), 0.05 / double(holmResolvableRows(0.95) + 1));
  EXPECT_THROW(parseCorrection("bonferroni"), Error);
}

// The p-value counts the replicates on each side of zero; more replicates (in plans of the
// configured size) tell a smaller one, starting from the same first plan.
TEST(CompareGate, APairedChangesPValueCountsItsReplicates) {
  std::mt19937_64 rng(9);
  const auto shared = sharedContent(16, 16, rng);
  const MetricTiles a = syntheticSeries(16, 16, 0.0, rng, shared);
  const MetricTiles far = syntheticSeries(16, 16, 1.0, rng, shared);
  BootstrapConfig cfg;
  cfg.replicates = 200;
  EXPECT_EQ(pairedRelativeChange(a, a, "s", cfg).pValue, 1.0);  // no change
  const PairedChange d = pairedRelativeChange(far, a, "s", cfg);
  EXPECT_NEAR(d.pValue, 2.0 / 201, 1e-12);  // every replicate above zero: the floor of 200
  EXPECT_EQ(pairedChangePValue(far, a, "s", cfg, 200), d.pValue);
  EXPECT_NEAR(pairedChangePValue(far, a, "s", cfg, 1000), 2.0 / 1001, 1e-12);  // five plans
  // A change whose replicates fall on both sides: five plans of their own, not one plan five
  // times (which would give 2 (5 k + 1) / 1001 for the first plan's k).
  const MetricTiles near = syntheticSeries(16, 16, 0.02, rng, shared);
  const PairedChange n = pairedRelativeChange(near, a, "s", cfg);
  const double k = n.pValue * 201 / 2 - 1;  // the first plan's replicates on the far side
  ASSERT_GT(k, 0.5) << n.pValue;
  ASSERT_LT(n.pValue, 1.0);  // not capped: k read back from it
  const double five = pairedChangePValue(near, a, "s", cfg, 1000);
  EXPECT_GT(five, 0.0);
  EXPECT_NE(five, 2 * (5 * k + 1) / 1001);
  EXPECT_TRUE(std::isnan(pairedChangePValue(a, MetricTiles{}, "s", cfg, 200)));
}

// The interval of a relative change is each replicate's own, so it keeps to the metric's range: a
// candidate at 5% of the baseline everywhere is a -95% change with an interval of about -95%. The
// difference's interval divided by the baseline's point value reached -156% for a relMSE on tiles
// of uneven error (a replicate drawing the worst tile often has a baseline well above its mean).
TEST(CompareGate, AChangesIntervalKeepsToTheMetricsRange) {
  std::mt19937_64 rng(3);
  std::exponential_distribution<double> skewed(1.0);
  MetricTiles base, cand;
  for (int f = 0; f < 20; ++f) {
    TileSums b, c;
    for (int k = 0; k < 16; ++k) {
      const double v = std::pow(skewed(rng), 3.0);  // a few tiles hold most of the error
      b.sum.push_back(v);
      c.sum.push_back(0.05 * v);
      b.count.push_back(1.0);
      c.count.push_back(1.0);
    }
    base.add(f, std::move(b));
    cand.add(f, std::move(c));
  }
  const auto rows =
      compareRuns(syntheticRun({{"m", base}}), syntheticRun({{"m", cand}}), {{"relMse", 0.02}});
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].verdict, "improved");
  EXPECT_NEAR(rows[0].change, -0.95, 1e-6);
  EXPECT_GE(rows[0].changeCi.lo, -1.0);
  EXPECT_NEAR(rows[0].changeCi.lo, -0.95, 1e-6);
  EXPECT_NEAR(rows[0].changeCi.hi, -0.95, 1e-6);
  // The sign is the difference's in every replicate: resolved exactly where pairedDifference is.
  EXPECT_EQ(pairedDifference(cand, base, "s").resolved(),
            pairedRelativeChange(cand, base, "s").ci.valid() &&
                !pairedRelativeChange(cand, base, "s").ci.containsZero());
}

// Runs that summarise other frames (compared with --allow-settings-mismatch): the change is taken
// over the frames both have, like its interval, and the row says so. It took each run's own mean,
// and showed +98% with an interval of [+0%, +0%] over the shared frames.
TEST(CompareGate, RunsOfOtherFramesAreComparedOnTheFramesBothHave) {
  std::mt19937_64 rng(7);
  const auto shared = sharedContent(20, 16, rng);
  const MetricTiles base = syntheticSeries(20, 16, 0.0, rng, shared);
  MetricTiles shorter = base.restrictedTo({0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11});
  for (TileSums& t : shorter.rows)
    for (double& v : t.sum) v *= 1.001;  // the same frames, all but unchanged
  const auto rows =
      compareRuns(syntheticRun({{"m", base}}), syntheticRun({{"m", shorter}}), {{"relMse", 0.02}});
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_NEAR(rows[0].change, 0.001, 1e-6);  // the results keep tile sums as float32
  EXPECT_NEAR(rows[0].baseline, base.restrictedTo(shorter.frames).mean(), 1e-6);
  EXPECT_EQ(rows[0].verdict, "ok");
  EXPECT_NE(rows[0].note.find("over the 12 frames both runs summarise (baseline 20, candidate 12)"),
            std::string::npos)
      << rows[0].note;
}

// A baseline written before labels were canonical ("svgf[sigmaL=2.0]") meets the same contender
// under its new label ("svgf[sigmaL=2]"): matched by denoiser and resolved parameters, compared,
// neither missing nor new. Two candidates of those parameters would be ambiguous: no match.
TEST(CompareGate, APairUnderAnOlderLabelIsMatchedByWhatItRan) {
  std::mt19937_64 rng(12);
  const auto shared = sharedContent(20, 16, rng);
  json base = syntheticJson({{"svgf[sigmaL=2.0]", syntheticSeries(20, 16, 0.0, rng, shared)}});
  json cand = syntheticJson({{"svgf[sigmaL=2]", syntheticSeries(20, 16, 0.0, rng, shared)}});
  for (json* r : {&base, &cand}) {
    (*r)["pairs"][0]["denoiser"] = "svgf";
    (*r)["pairs"][0]["params"] = {{"sigmaL", 2.0}};
  }
  const std::vector<Tolerance> tol = {{"relMse", 0.01}};
  auto rows = compareRuns(test::typed(base), test::typed(cand), tol);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].metric, "relMse");
  EXPECT_EQ(rows[0].label, "svgf[sigmaL=2.0]");
  EXPECT_EQ(rows[0].candidateLabel, "svgf[sigmaL=2]");
  EXPECT_FALSE(anyRegression(rows));
  // A value recorded with more digits than the float that ran (before parameters were resolved
  // to it) matches the float's shortest text.
  json digits = base, floatRan = cand;
  digits["pairs"][0]["params"] = {{"sigmaL", 0.30000001}};
  floatRan["pairs"][0]["params"] = {{"sigmaL", 0.3}};
  rows = compareRuns(test::typed(digits), test::typed(floatRan), tol);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].verdict, "ok") << rows[0].note;
  json twice = cand;
  twice["pairs"].push_back(cand["pairs"][0]);
  twice["pairs"][1]["label"] = "svgf[sigmaL=2,x]";
  rows = compareRuns(test::typed(base), test::typed(twice), tol);
  EXPECT_TRUE(std::any_of(rows.begin(), rows.end(),
                          [](const ComparisonRow& r) { return r.verdict == "missing"; }));
}

// --match takes a label's parameters in any order: the run writes them in the schema's order,
// which a user need not know.
TEST(CompareGate, AMatchNamesParametersInAnyOrder) {
  std::mt19937_64 rng(17);
  const auto shared = sharedContent(20, 16, rng);
  json base = syntheticJson({{"svgf", syntheticSeries(20, 16, 0.0, rng, shared)}});
  json cand =
      syntheticJson({{"svgf[iterations=3,sigmaL=8]", syntheticSeries(20, 16, 0.0, rng, shared)}});
  for (json* r : {&base, &cand})
    for (json& p : (*r)["pairs"]) p["denoiser"] = "svgf";
  cand["pairs"][0]["params"] = {{"iterations", 3}, {"sigmaL", 8.0}};
  const RunResults a = test::typed(base), b = test::typed(cand);
  const std::map<std::string, std::string> matches = {{"svgf", "svgf[iterations=3,sigmaL=8]"}};
  EXPECT_EQ(checkLabelMatches({"svgf=svgf[iterations=3,sigmaL=8]"}, a, b), matches);
  EXPECT_EQ(checkLabelMatches({"svgf=svgf[sigmaL=8,iterations=3]"}, a, b), matches);
  EXPECT_EQ(checkLabelMatches({"svgf=svgf[sigmaL=8.0,iterations=3]"}, a, b), matches);
  // Spaces are the writer's layout, and the same match given twice is one.
  EXPECT_EQ(checkLabelMatches({" svgf = svgf[ sigmaL = 8 , iterations=3 ] "}, a, b), matches);
  EXPECT_EQ(checkLabelMatches(
                {"svgf=svgf[sigmaL=8,iterations=3]", "svgf=svgf[sigmaL=8,iterations=3]"}, a, b),
            matches);
  // A value that differs, or a key given twice, is still no label of the run.
  for (const char* wrong : {"svgf=svgf[sigmaL=8,iterations=4]", "svgf=svgf[sigmaL=8,sigmaL=8]"})
    EXPECT_THROW(checkLabelMatches({wrong}, a, b), Error) << wrong;
}

// A sweep's points against a plain run of one of them (`run --param svgf.sigmaL=2`): the point
// that ran the same is compared by what it ran, and naming either label with --denoisers keeps
// both (naming the plain run's read the sweep's "new", and the gate "nothing compared"); the other
// points are missing, and their note suggests no --match (the plain run's label is another
// configuration than theirs, not theirs renamed).
TEST(CompareGate, ASweepsPointMeetsThePlainRunThatRanTheSame) {
  std::mt19937_64 rng(17);
  const auto shared = sharedContent(20, 16, rng);
  json sweep = syntheticJson(
      {{"svgf[edge.normal=true,sigmaL=2]", syntheticSeries(20, 16, 0.0, rng, shared)},
       {"svgf[edge.normal=false,sigmaL=2]", syntheticSeries(20, 16, 0.0, rng, shared)}});
  json plain = syntheticJson({{"svgf[sigmaL=2]", syntheticSeries(20, 16, 0.0, rng, shared)}});
  for (json* r : {&sweep, &plain})
    for (json& p : (*r)["pairs"]) {
      p["denoiser"] = "svgf";
      const bool normal = p["label"] != "svgf[edge.normal=false,sigmaL=2]";
      p["params"] = {{"edge.normal", normal}, {"sigmaL", 2}};
    }
  const RunResults a = test::typed(sweep), b = test::typed(plain);
  for (const std::string name : {"svgf[sigmaL=2]", "svgf[edge.normal=true,sigmaL=2]"}) {
    RunResults keptA = a, keptB = b;
    keepContenders(keptA, keptB, {name});
    ASSERT_EQ(keptA.pairs.size(), 1u) << name;
    EXPECT_EQ(keptA.pairs[0].label, "svgf[edge.normal=true,sigmaL=2]");
    ASSERT_EQ(keptB.pairs.size(), 1u) << name;
    const std::vector<ComparisonRow> rows = compareRuns(keptA, keptB, {{"relMse", 0.02}});
    ASSERT_EQ(rows.size(), 1u) << name;
    EXPECT_EQ(rows[0].candidateLabel, "svgf[sigmaL=2]");
    EXPECT_NE(rows[0].verdict, "new");
  }
  const std::vector<ComparisonRow> rows = compareRuns(a, b, {{"relMse", 0.02}});
  const auto missing = std::find_if(rows.begin(), rows.end(),
                                    [](const ComparisonRow& r) { return r.verdict == "missing"; });
  ASSERT_NE(missing, rows.end());
  EXPECT_EQ(missing->label, "svgf[edge.normal=false,sigmaL=2]");
  EXPECT_EQ(missing->note.find("--match"), std::string::npos) << missing->note;
  // A label list splits at commas outside brackets: a sweep's label holds its own.
  EXPECT_EQ(splitList("svgf[edge.normal=true,sigmaL=2], eaw", "--denoisers", "labels"),
            (std::vector<std::string>{"svgf[edge.normal=true,sigmaL=2]", "eaw"}));
}

// A parameter changed between two runs (a researcher's ablation): the pairs' labels differ, so
// the baseline's is missing and the candidate's new, and the missing row says how to compare
// them; --match compares them, marked as asked for.
TEST(CompareGate, PairsOfOtherLabelsAreComparedWhenAskedTo) {
  std::mt19937_64 rng(13);
  const auto shared = sharedContent(20, 16, rng);
  json base = syntheticJson({{"svgf", syntheticSeries(20, 16, 0.0, rng, shared)},
                             {"eaw", syntheticSeries(20, 16, 0.0, rng, shared)}});
  json cand = syntheticJson({{"svgf[sigmaL=8]", syntheticSeries(20, 16, 0.0, rng, shared)},
                             {"eaw", syntheticSeries(20, 16, 0.0, rng, shared)}});
  for (json* r : {&base, &cand})
    for (json& p : (*r)["pairs"]) {
      p["denoiser"] = p["label"].get<std::string>().substr(0, 4) == "svgf" ? "svgf" : "eaw";
      if (p["label"] == "svgf[sigmaL=8]") p["params"] = {{"sigmaL", 8.0}};
    }
  const RunResults a = test::typed(base), b = test::typed(cand);
  const std::vector<Tolerance> tol = {{"relMse", 0.01}};
  std::vector<ComparisonRow> rows = compareRuns(a, b, tol);
  const auto missing = std::find_if(rows.begin(), rows.end(),
                                    [](const ComparisonRow& r) { return r.verdict == "missing"; });
  ASSERT_NE(missing, rows.end());
  // The option's name alone: `arena history` and `report --baseline` say the same note.
  EXPECT_NE(missing->note.find("the candidate ran svgf as svgf[sigmaL=8]: `--match "
                               "'svgf=svgf[sigmaL=8]'` compares them (arena compare, report "
                               "--baseline, history)"),
            std::string::npos)
      << missing->note;
  const std::map<std::string, std::string> matches =
      checkLabelMatches({"svgf=svgf[sigmaL=8]"}, a, b);
  EXPECT_EQ(matches, (std::map<std::string, std::string>{{"svgf", "svgf[sigmaL=8]"}}));
  rows = compareRuns(a, b, tol, {}, Correction::Holm, matches);
  ASSERT_EQ(rows.size(), 2u);
  for (const ComparisonRow& r : rows) {
    EXPECT_TRUE(r.verdict == "ok" || r.verdict == "unresolved")
        << r.label << " " << r.verdict << " " << r.note;
    EXPECT_TRUE(std::isfinite(r.change)) << r.label;
  }
  for (const ComparisonRow& r : rows) {
    EXPECT_EQ(r.matchedByRequest, r.label == "svgf") << r.label;
    EXPECT_EQ(r.candidateLabel, r.label == "svgf" ? "svgf[sigmaL=8]" : "") << r.label;
  }
  // --denoisers naming one label of the match, typed otherwise, keeps both.
  RunResults keptA = a, keptB = b;
  keepContenders(keptA, keptB, {"svgf[sigmaL=8.0]"}, matches);
  ASSERT_EQ(keptA.pairs.size(), 1u);
  EXPECT_EQ(keptA.pairs[0].label, "svgf");
  ASSERT_EQ(keptB.pairs.size(), 1u);
  EXPECT_EQ(keptB.pairs[0].label, "svgf[sigmaL=8]");
  // Names that keep neither label of a match: the match would be asked for and do nothing.
  RunResults droppedA = a, droppedB = b;
  const std::string dropped =
      test::errorOf([&] { keepContenders(droppedA, droppedB, {"eaw"}, matches); });
  EXPECT_NE(dropped.find("--match svgf=svgf[sigmaL=8]: --denoisers keeps neither label"),
            std::string::npos)
      << dropped;
  // A number typed otherwise than the run wrote it names the same label.
  EXPECT_EQ(checkLabelMatches({"svgf=svgf[sigmaL=8.0]"}, a, b), matches);
  EXPECT_EQ(checkLabelMatches({"svgf=svgf[sigmaL=8e0]"}, a, b), matches);
  EXPECT_EQ(checkLabelMatches({"svgf=svgf[sigmaL=8.0000001]"}, a, b), matches);  // as a float
  // Each assignment names labels the runs have, each once; a label both runs have is compared by
  // it already.
  const auto refused = [&](const std::string& assignment) {
    try {
      checkLabelMatches({assignment}, a, b);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refused("svgf").find("expected BASELINE=CANDIDATE"), std::string::npos);
  EXPECT_NE(
      refused("svgff=eaw").find("the baseline has no pair labelled svgff (its labels: eaw, svgf)"),
      std::string::npos)
      << refused("svgff=eaw");
  EXPECT_NE(
      refused("svgf=svgf[sigmaL=9]").find("the candidate has no pair labelled svgf[sigmaL=9]"),
      std::string::npos);
  EXPECT_NE(refused("svgf=svgf[sigmaL=8.5]").find("the candidate has no pair labelled"),
            std::string::npos);
  EXPECT_NE(refused("svgf=svgf[sigmaZ=8]").find("the candidate has no pair labelled"),
            std::string::npos);
  EXPECT_NE(refused("svgf=eaw").find("the baseline has a pair labelled eaw too"),
            std::string::npos);
  EXPECT_THROW(checkLabelMatches({"svgf=svgf[sigmaL=8]", "svgf=eaw"}, a, b), Error);
  // A label with itself: nothing for the option to do, refused as history refuses it (compare
  // accepted it).
  EXPECT_NE(refused("eaw=eaw").find("matches eaw with itself"), std::string::npos);
  // The candidate's own pair of that label would vanish from the gate (a failed one with it).
  json both = cand;
  both["pairs"].push_back(base["pairs"][0]);
  both["pairs"].back()["label"] = "svgf";
  EXPECT_NE(test::errorOf([&] {
              checkLabelMatches({"svgf=svgf[sigmaL=8]"}, a, test::typed(both));
            }).find("the candidate has a pair labelled svgf too"),
            std::string::npos);
}

// References refined between two runs: said, scene by scene (part of each change there is the
// reference's); equal sample counts, or a scene only one run has, say nothing.
TEST(CompareGate, ReferencesOfOtherSampleCountsAreNamed) {
  json base = syntheticJson({{"a", constantSeries(0.01)}}), cand = base;
  base["scenes"]["s"] = {{"referenceSpp", {64, 64}}};
  cand["scenes"]["s"] = {{"referenceSpp", {256, 64}}};
  cand["scenes"]["other"] = {{"referenceSpp", {8}}};
  EXPECT_EQ(referenceDifferences(test::typed(base), test::typed(cand)),
            std::vector<std::string>{"scenes.s.referenceSpp: [64,64] vs [256,64]"});
  EXPECT_TRUE(referenceDifferences(test::typed(base), test::typed(base)).empty());
}

TEST(CompareGate, FailsOnWhatItCannotCompare) {
  const MetricTiles m = constantSeries(0.01);
  const std::vector<Tolerance> tol = {{"relMse", 0.02}};
  // The candidate lost a denoiser: the gate fails and names it.
  auto rows = compareRuns(syntheticRun({{"a", m}, {"b", m}}), syntheticRun({{"a", m}}), tol);
  EXPECT_TRUE(anyRegression(rows));
  bool named = false;
  for (auto& r : rows) named |= r.label == "b" && r.verdict == "missing";
  EXPECT_TRUE(named);
  // No scene in common: every baseline pair is missing (the gate fails), every candidate pair new,
  // and the gate says it compared nothing.
  rows = compareRuns(syntheticRun({{"a", m}}, "s1"), syntheticRun({{"a", m}}, "s2"), tol);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].verdict, "missing");
  EXPECT_EQ(rows[1].verdict, "new");
  EXPECT_EQ(rows[2].verdict, "nothing compared");
  EXPECT_NE(rows[0].note.find("share no scene"), std::string::npos) << rows[0].note;
  EXPECT_TRUE(anyRegression(rows));
  // A pair that failed in the baseline and runs in the candidate is shown (it does not fail the
  // gate), beside another that both ran.
  json failedBase = syntheticJson({{"a", m}, {"b", m}});
  failedBase["pairs"][0]["status"] = "failed";
  failedBase["pairs"][0]["error"] = "out of memory";
  rows = compareRuns(test::typed(failedBase), syntheticRun({{"a", m}, {"b", m}}), tol);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].verdict, "new");
  EXPECT_EQ(rows[0].note, "failed in the baseline run: out of memory");
  EXPECT_EQ(rows[1].verdict, "ok");
  EXPECT_FALSE(anyRegression(rows));
  // With only that pair, the gate held nothing to anything: it fails, saying so (it passed).
  json onlyFailed = syntheticJson({{"a", m}});
  onlyFailed["pairs"][0]["status"] = "failed";
  onlyFailed["pairs"][0]["error"] = "out of memory";
  rows = compareRuns(test::typed(onlyFailed), syntheticRun({{"a", m}}), tol);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].verdict, "nothing compared");
  EXPECT_EQ(rows[1].scene, "*");
  EXPECT_TRUE(anyRegression(rows));
  // A candidate pair that failed fails the gate, new or not (a new one passed as "new").
  json failedNew = syntheticJson({{"a", m}, {"c", m}});
  failedNew["pairs"][1]["status"] = "failed";
  failedNew["pairs"][1]["error"] = "crashed";
  rows = compareRuns(syntheticRun({{"a", m}}), test::typed(failedNew), tol);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1].label, "c");
  EXPECT_EQ(rows[1].verdict, "failed");
  EXPECT_EQ(rows[1].note, "crashed");
  EXPECT_TRUE(anyRegression(rows));
  // A metric named on the command line that neither run computed is an error, not a pass.
  try {
    compareRuns(syntheticRun({{"a", m}}), syntheticRun({{"a", m}}), {{"msWall", 0.02}});
    FAIL() << "a gate on an uncomputed metric passed";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--metric msWall"), std::string::npos) << e.what();
  }
  // The defaults skip what neither run computed (here all but relMSE).
  EXPECT_FALSE(anyRegression(compareRuns(syntheticRun({{"a", m}}), syntheticRun({{"a", m}}), {})));
  // A tolerance that can never fail is refused.
  EXPECT_THROW(parseTolerance("nan"), Error);
  EXPECT_THROW(parseTolerance("inf"), Error);
  EXPECT_THROW(parseTolerance("-1%"), Error);
  // A bare 2 is 200%, almost certainly meant as 2%: refused, saying both; as a percentage it
  // stands.
  EXPECT_NE(test::errorOf([] {
              parseTolerance("2");
            }).find("--tolerance '2': a bare number is a fraction (2 is 200%); write 2%"),
            std::string::npos)
      << test::errorOf([] { parseTolerance("2"); });
  EXPECT_DOUBLE_EQ(parseTolerance("200%"), 2.0);
  EXPECT_DOUBLE_EQ(parseTolerance("0.5"), 0.5);
  // Decimal only: "0x10%" read as 16% (hexadecimal), unsaid.
  EXPECT_THROW(parseTolerance("0x10%"), Error);
  EXPECT_THROW(parseTolerance("0x10"), Error);
  EXPECT_DOUBLE_EQ(parseTolerance("1e1%"), 0.1);
  // A metric named twice is judged once: twice, its rows were counted double and, judged
  // together (Holm), raised the bar every row must clear (a resolved regression read unresolved).
  const std::vector<Tolerance> once =
      gateTolerances({{"relMse", 0.02}, {"relMse", 0.02}, {"flip", 0.02}, {"ldrFlip", 0.02}});
  ASSERT_EQ(once.size(), 2u);
  EXPECT_EQ(once[0].metric, "relMse");
  EXPECT_EQ(once[1].metric, "ldrFlip");
  EXPECT_EQ(
      compareRuns(syntheticRun({{"a", m}}), syntheticRun({{"a", m}}),
                  {{"relMse", 0.02}, {"relMse", 0.02}})
          .size(),
      compareRuns(syntheticRun({{"a", m}}), syntheticRun({{"a", m}}), {{"relMse", 0.02}}).size());
  EXPECT_THROW(parseConfidence("1.5"), Error);
  EXPECT_DOUBLE_EQ(parseConfidence("90%"), 0.9);
  // A metric the baseline had and the candidate reports absent fails too.
  json cand = syntheticJson({{"a", m}});
  cand["pairs"][0]["summary"]["relMse"] = {{"frames", 0}, {"absent", "no frame after the warm-up"}};
  rows = compareRuns(syntheticRun({{"a", m}}), test::typed(cand), tol);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].verdict, "missing");
  EXPECT_EQ(rows[1].verdict, "nothing compared");
  // Absent in both (every frame inside the warm-up): a row that does not fail on its own, and a
  // gate that compared nothing, which does (it passed with exit 0).
  json base = syntheticJson({{"a", m}});
  base["pairs"][0]["summary"]["relMse"] = {{"frames", 0}, {"absent", "no frame after the warm-up"}};
  rows = compareRuns(test::typed(base), test::typed(cand), tol);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].verdict, "absent");
  EXPECT_FALSE(failsGate(rows[0]));
  EXPECT_EQ(rows[1].verdict, "nothing compared");
  EXPECT_TRUE(anyRegression(rows));
}

// The JSON rows carry the gate's own rule as `fails` (the report's and the dashboard's pages read
// it instead of keeping verdict lists of their own): true exactly for the verdicts that fail.
TEST(CompareGate, JsonRowsSayWhetherTheyFailTheGate) {
  const std::vector<std::pair<std::string, bool>> verdicts = {
      {"ok", false},     {"improved", false},      {"unresolved", false},     {"new", false},
      {"absent", false}, {"regressed", true},      {"unverified", true},      {"missing", true},
      {"failed", true},  {"not comparable", true}, {"nothing compared", true}};
  for (const auto& [verdict, fails] : verdicts) {
    ComparisonRow row;
    // Assigned from strings, not from literals, on which GCC 12 warns falsely (-Wstringop-overflow).
    const std::string scene = "s", label = "a", metric = "relMse";
    row.scene = scene;
    row.label = label;
    row.metric = metric;
    row.verdict = verdict;
    EXPECT_EQ(failsGate(row), fails) << verdict;
    EXPECT_EQ(anyRegression({row}), fails) << verdict;
    EXPECT_EQ(comparisonJson({row})[0]["fails"], fails) << verdict;
  }
  // On real rows: a lost denoiser fails, the one both runs have does not.
  const MetricTiles m = constantSeries(0.01);
  const auto rows =
      compareRuns(syntheticRun({{"a", m}, {"b", m}}), syntheticRun({{"a", m}}), {{"relMse", 0.02}});
  const json table = comparisonJson(rows);
  ASSERT_EQ(table.size(), rows.size());
  size_t failing = 0;
  for (const json& r : table) failing += r["fails"].get<bool>();
  EXPECT_GE(failing, 1u);
  EXPECT_LT(failing, table.size());
}

// A change beyond tolerance that no interval can judge would pass as noise on no data: it fails the
// gate in run directories; results.db keeps no tiles by design, so its runs stay "unresolved".
TEST(CompareGate, AWorseningNoIntervalCanJudgeFailsTheGate) {
  const MetricTiles m = constantSeries(0.01);
  const std::vector<Tolerance> tol = {{"relMse", 0.02}};
  auto withoutTiles = [&](double mean) {
    json cand = syntheticJson({{"a", m}});
    cand["pairs"][0].erase("tiles");
    cand["pairs"][0]["summary"]["relMse"]["mean"] = mean;
    return test::typed(cand);
  };
  auto rows = compareRuns(syntheticRun({{"a", m}}), withoutTiles(0.02), tol);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].verdict, "unverified");
  EXPECT_NE(rows[0].note.find("no tile data"), std::string::npos) << rows[0].note;
  EXPECT_NE(rows[0].note.find("cannot tell this change from noise"), std::string::npos)
      << rows[0].note;
  EXPECT_TRUE(anyRegression(rows));
  // Within tolerance, or better: nothing to judge, nothing fails.
  EXPECT_EQ(compareRuns(syntheticRun({{"a", m}}), withoutTiles(0.0101), tol)[0].verdict, "ok");
  rows = compareRuns(syntheticRun({{"a", m}}), withoutTiles(0.005), tol);
  EXPECT_EQ(rows[0].verdict, "unresolved");
  EXPECT_FALSE(anyRegression(rows));
  // A metric neither run keeps tiles of (ms, referenceRelMse): never judged by tiles, not failed.
  json untiled = syntheticJson({{"a", m}});
  untiled["pairs"][0].erase("tiles");
  rows = compareRuns(test::typed(untiled), withoutTiles(0.02), tol);
  EXPECT_EQ(rows[0].verdict, "unresolved");
  EXPECT_NE(rows[0].note.find("relMse keeps no per-tile data"), std::string::npos) << rows[0].note;
  EXPECT_FALSE(anyRegression(rows));
  // From results.db (no tiles by design): not judged (neither within noise nor failed), either
  // way, and the note says why.
  RunResults fromDb = syntheticRun({{"a", m}});
  fromDb.keepsTiles = false;
  for (const double candidate : {0.02, 0.005}) {
    rows = compareRuns(fromDb, withoutTiles(candidate), tol);
    EXPECT_EQ(rows[0].verdict, "not judged") << candidate;
    EXPECT_NE(
        rows[0].note.find("results.db keeps none): the gate cannot tell this change from noise"),
        std::string::npos)
        << rows[0].note;
    EXPECT_FALSE(anyRegression(rows));
  }
  EXPECT_EQ(compareRuns(fromDb, withoutTiles(0.0101), tol)[0].verdict, "ok");
}

TEST(MergeGate, AnIncompleteShardSetIsAnError) {
  const fs::path root = test::freshDir("merge_gate");
  auto shard = [&](const std::string& name, const std::string& which) {
    json r = syntheticJson({{"a", constantSeries(0.01)}}, name);
    r["settings"]["shard"] = which;
    r["scenes"] = json::object();
    saveResults(root / name, r);
    return root / name;
  };
  const fs::path s0 = shard("s0", "0/3"), s2 = shard("s2", "2/3"), s1 = shard("s1", "1/3"),
                 again = shard("again", "0/3");
  try {
    mergeRuns({s0, s2}, root / "merged");
    FAIL() << "an incomplete shard set merged";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing 1/3"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(root / "merged" / "results.json"));
  EXPECT_THROW(mergeRuns({s0, again, s1, s2}, root / "merged"), Error);
  json merged = mergeRuns({s0, s1, s2}, root / "new" / "merged");  // --out created when missing
  EXPECT_EQ(merged["pairs"].size(), 3u);
  EXPECT_TRUE(merged["statistics"]["scenes"].contains("s1"));
  // Shards that record their run's plan: one that lost a pair is refused, naming it (it merged
  // into a run silently without it).
  const json plan = {
      {"sequences", json::array({{{"name", "p0"}, {"width", 4}, {"height", 4}, {"frames", 8}},
                                 {{"name", "p1"}, {"width", 4}, {"height", 4}, {"frames", 8}}})},
      {"labels", json::array({"a"})}};
  auto planned = [&](const std::string& name, const std::string& which, bool lost) {
    json r = syntheticJson({{"a", constantSeries(0.01)}}, name);
    r["settings"]["shard"] = which;
    r["settings"]["plan"] = plan;
    r["scenes"] = json::object();
    if (lost) r["pairs"] = json::array();
    saveResults(root / ("planned_" + name + (lost ? "_lost" : "")), r);
    return root / ("planned_" + name + (lost ? "_lost" : ""));
  };
  const fs::path p0 = planned("p0", "0/2", false), p1 = planned("p1", "1/2", false),
                 p1lost = planned("p1", "1/2", true);
  EXPECT_EQ(mergeRuns({p0, p1}, root / "planned_merged")["pairs"].size(), 2u);
  const std::string lost = test::errorOf([&] { mergeRuns({p0, p1lost}, root / "planned_lost"); });
  EXPECT_NE(lost.find("1 pair(s) of the run's plan are in no shard (a on p1)"), std::string::npos)
      << lost;
  EXPECT_FALSE(fs::exists(root / "planned_lost"));
}

// End to end on a tiny sequence: every summary has an interval around its mean, the run carries
// its statistics, and the gate tells another input seed (noise) from a worse filter.
const json& pairOfLabel(const json& results, const std::string& label) {
  for (const json& p : results["pairs"])
    if (p["label"] == label) return p;
  throw Error("no pair " + label);
}

TEST(StatisticsEndToEnd, IntervalsRankingsAndAQuietGate) {
  const fs::path cache = test::freshDir("stats_cache");
  auto run = [&](const std::string& name, uint32_t inputSeed,
                 std::map<std::string, std::string> temporal) {
    RunConfig c;
    c.name = name;
    c.out = test::freshDir("stats_" + name);
    c.cache = cache;
    c.render = test::tinySettings(48, 27, 14, 32);
    c.render.inputSeed = inputSeed;
    c.scenes = {test::shippedScene("cornell_static")};
    c.denoisers = {{"svgf", {}, ""}, {"temporal", std::move(temporal), "temporal"}};
    c.baselines = false;
    c.warmup = 4;
    c.flip = "none";
    c.keepFrames = "none";
    return runMatrix(c);
  };
  const json base = run("base", 0, {});
  ASSERT_TRUE(failedPairs(base).empty());
  for (const json& p : base["pairs"])
    for (const char* m : {"relMse", "psnr", "ssim", "tRmae", "ms"}) {
      const json& s = p["summary"][m];
      ASSERT_TRUE(s["ci95"].is_array()) << m;
      EXPECT_LE(s["ci95"][0].get<double>(), s["mean"].get<double>() + 1e-12) << m;
      EXPECT_GE(s["ci95"][1].get<double>(), s["mean"].get<double>() - 1e-12) << m;
    }
  const json& scene = base["statistics"]["scenes"]["cornell_static"];
  EXPECT_EQ(scene["totalPairs"], 1);
  EXPECT_LE(scene["ranking"][0]["mean"].get<double>(), scene["ranking"][1]["mean"].get<double>());
  EXPECT_TRUE(base["scenes"]["cornell_static"]["floors"].contains("ssim"));

  const json reseeded = run("reseeded", 7, {});
  const json worse =
      run("worse", 0, {{"maxHistory", "3"}});  // a running mean of 3 frames: far noisier
  const std::vector<Tolerance> tol = {{"relMse", 0.02}};
  // Another input seed is the same measurement (arena compare does not refuse it); another filter
  // setting is not.
  EXPECT_TRUE(settingsDifferences(test::typed(base), test::typed(reseeded)).empty());
  auto rows = compareRuns(test::typed(base), test::typed(reseeded), tol);
  for (const auto& r : rows) EXPECT_NE(r.verdict, "regressed") << r.label << " " << r.change;
  EXPECT_NE(pairOfLabel(base, "svgf")["summary"]["relMse"]["mean"],
            pairOfLabel(reseeded, "svgf")["summary"]["relMse"]["mean"]);
  rows = compareRuns(test::typed(base), test::typed(worse), tol);
  bool flagged = false;
  for (const auto& r : rows) {
    flagged |= r.label == "temporal" && r.verdict == "regressed";
    if (r.label == "svgf") {
      EXPECT_EQ(r.verdict, "ok");  // unchanged: identical numbers
    }
  }
  EXPECT_TRUE(flagged);
}

}  // namespace
}  // namespace arena

namespace arena {
namespace {

TEST(BiasVarianceSplit, AddsUpToTheMeanRelMseAndSeparatesTheTerms) {
  const Image r = noiseImage(20, 12, 1, 0.2f);
  std::vector<Image> outs;
  for (uint32_t k = 0; k < 4; ++k) {
    Image d = noiseImage(20, 12, 10 + k, 0.3f);  // noise around 0.5
    for (float& v : d.raw()) v += 0.1f;          // plus a constant bias
    outs.push_back(d);
  }
  std::vector<const Image*> ptrs;
  double meanRel = 0;
  for (const Image& d : outs) ptrs.push_back(&d), meanRel += linearError(d, r, nullptr).relMse / 4;
  const BiasVariance bv = biasVariance(ptrs, r, nullptr);
  EXPECT_NEAR(bv.bias2 + bv.variance, meanRel, 1e-9);
  EXPECT_GT(bv.variance, 0);
  // Identical outputs: no variance, all bias.
  const BiasVariance same = biasVariance({&outs[0], &outs[0]}, r, nullptr);
  EXPECT_DOUBLE_EQ(same.variance, 0.0);
  EXPECT_NEAR(same.bias2, linearError(outs[0], r, nullptr).relMse, 1e-12);
  EXPECT_THROW(biasVariance({&outs[0]}, r, nullptr), Error);
}

// Every term has its tiles (the spatial blocks of its interval), and they add up to the term.
TEST(BiasVarianceSplit, EachTermsTilesAddUpToIt) {
  const Image r = noiseImage(20, 12, 1, 0.2f), var = noiseImage(20, 12, 2, 0.001f);
  std::vector<Image> outs;
  for (uint32_t k = 0; k < 3; ++k) outs.push_back(noiseImage(20, 12, 10 + k, 0.3f));
  BiasVarianceTiles tiles;
  const BiasVariance bv =
      biasVariance({&outs[0], &outs[1], &outs[2]}, r, &var, kRelMseEpsilon, &tiles);
  for (const auto& [term, value] :
       {std::pair{&tiles.bias2, bv.bias2}, std::pair{&tiles.bias2Corrected, bv.bias2Corrected},
        std::pair{&tiles.variance, bv.variance}}) {
    ASSERT_EQ(term->sum.size(), 16u);
    EXPECT_NEAR(term->totalSum() / term->totalCount(), value, 1e-9);
  }
  EXPECT_LT(bv.bias2Corrected, bv.bias2);  // the reference's noise term is positive here
}

// End to end: the noisy input is unbiased (its error is all variance); a spatial filter trades
// variance for bias.
TEST(BiasVarianceSplit, ThreeInputSeedsOnATinySequence) {
  RunConfig c;
  c.name = "seeds";
  c.out = test::freshDir("stats_seeds");
  c.cache = test::freshDir("stats_seeds_cache");
  c.render = test::tinySettings(40, 24, 10, 64);
  c.scenes = {test::shippedScene("cornell_static")};
  c.denoisers = {{"eaw", {}, ""}};
  c.warmup = 2;
  c.flip = "none";
  c.keepFrames = "none";
  c.seeds = 3;
  const json r = runMatrix(c);
  ASSERT_TRUE(failedPairs(r).empty());
  auto split = [&](const std::string& label, const char* term) {
    for (const json& p : r["pairs"])
      if (p["label"] == label) return p["biasVariance"]["summary"][term]["mean"].get<double>();
    throw Error("no pair " + label);
  };
  EXPECT_LT(std::abs(split("passthrough", "bias2Corrected")),
            0.1 * split("passthrough", "variance"));
  EXPECT_LT(split("eaw", "variance"), 0.5 * split("passthrough", "variance"));
  EXPECT_GT(split("eaw", "bias2Corrected") / split("eaw", "variance"),
            split("passthrough", "bias2Corrected") / split("passthrough", "variance"));
  // bias2Corrected is bias2 less a non-negative term, frame by frame and tile by tile: resampled
  // with the same plan (frames and tiles), each replicate keeps that order, and so do the
  // intervals' ends (bias2's interval once came from frames alone, far narrower than the others).
  for (const json& p : r["pairs"]) {
    const json& s = p["biasVariance"]["summary"];
    const auto ci = [&](const char* term) { return s[term]["ci95"].get<std::vector<double>>(); };
    ASSERT_EQ(ci("bias2").size(), 2u) << p["label"];
    EXPECT_LE(ci("bias2Corrected")[0], ci("bias2")[0]) << p["label"];
    EXPECT_LE(ci("bias2Corrected")[1], ci("bias2")[1]) << p["label"];
  }
}

}  // namespace
}  // namespace arena

namespace arena {
namespace {

// Rewrites one layer of a cached EXR (keeping its attributes, so the cache still trusts it) with a
// non-finite value at one pixel.
void poison(const fs::path& file, const std::vector<LayerSpec>& specs, const std::string& layer) {
  test::rewriteCachedExr(file, specs, [&](LayerSet& layers) {
    layers.get(layer).at(3, 2, 0) = std::numeric_limits<float>::quiet_NaN();
  });
}

// No fake perfect score from non-finite data: a NaN in a frame's albedo fails the pair naming the
// layer; a NaN in the reference fails the scene naming the file; inputs are counted per channel.
TEST(NonFiniteData, IsNamedAndNeverScored) {
  RunConfig c;
  c.name = "nan";
  c.cache = test::freshDir("stats_nan_cache");
  c.render = test::tinySettings(24, 16, 6, 8);
  c.scenes = {test::shippedScene("cornell_static")};
  c.denoisers = {{"temporal", {}, ""}};
  c.baselines = false;
  c.warmup = 1;
  c.flip = "none";
  c.keepFrames = "none";
  c.out = test::freshDir("stats_nan_ok");
  const fs::path dir = sequenceDir(c.scenes[0], c.render, c.cache);
  ASSERT_TRUE(failedPairs(runMatrix(c)).empty());
  poison(Sequence::framePath(dir, 3), channels::frameLayers(), "albedo");
  c.out = test::freshDir("stats_nan_albedo");
  json r = runMatrix(c);
  ASSERT_EQ(failedPairs(r).size(), 1u);
  EXPECT_NE(failedPairs(r)[0].find("albedo x1"), std::string::npos) << failedPairs(r)[0];
  EXPECT_EQ(r["scenes"]["cornell_static"]["nonFiniteInputs"]["frame 3: albedo.R"], 1);
  poison(Sequence::referencePath(dir, 0), channels::referenceLayers(), "color");
  c.out = test::freshDir("stats_nan_reference");
  r = runMatrix(c);
  ASSERT_EQ(failedPairs(r).size(), 1u);
  EXPECT_NE(failedPairs(r)[0].find("reference has non-finite values"), std::string::npos)
      << failedPairs(r)[0];
}

}  // namespace
}  // namespace arena
