// metrics/rank_agreement: Kendall's tau-b by hand, and flips between two runs' rankings.
#include "metrics/rank_agreement.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

TEST(RankAgreement, KendallTauBByHand) {
  EXPECT_DOUBLE_EQ(kendallTauB({1, 2, 3, 4}, {10, 20, 30, 40}), 1.0);
  EXPECT_DOUBLE_EQ(kendallTauB({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0);
  // One swapped neighbour among 4: 5 concordant, 1 discordant of 6 pairs.
  EXPECT_NEAR(kendallTauB({1, 2, 3, 4}, {1, 3, 2, 4}), 4.0 / 6.0, 1e-12);
  // A tie in y: 5 concordant, 0 discordant, 6 pairs of which 1 tied in y: 5 / sqrt(6 * 5).
  EXPECT_NEAR(kendallTauB({1, 2, 3, 4}, {1, 1, 2, 3}), 5.0 / std::sqrt(30.0), 1e-12);
  EXPECT_TRUE(std::isnan(kendallTauB({1, 1, 1}, {1, 2, 3})));  // x all tied
  EXPECT_TRUE(std::isnan(kendallTauB({1}, {1})));
  EXPECT_NE(test::errorOf([] { kendallTauB({1, 2}, {1}); }).find("expected equal sizes"), std::string::npos);
}

// A run's statistics for one scene: labels best first with their ranks and means, and pairs as
// (a, b, value(a) - value(b), resolved). A resolved pair's interval excludes zero, another's holds it.
SceneStatistics sceneStats(const std::vector<std::tuple<std::string, int, double>>& ranking,
                           const std::vector<std::tuple<std::string, std::string, double, bool>>& pairs,
                           const std::string& metric = "relMse") {
  SceneStatistics s;
  s.ranking.metric = metric;
  for (const auto& [label, rank, mean] : ranking) s.ranking.ranking.push_back({label, rank, mean, {}, {}});
  for (const auto& [a, b, diff, resolved] : pairs) {
    const Interval ci = resolved ? Interval{diff - 0.1 * std::abs(diff), diff + 0.1 * std::abs(diff)}
                                 : Interval{diff - 1.0, diff + 1.0};
    s.ranking.pairs.push_back({a, b, {diff, ci}});
    EXPECT_EQ(s.ranking.pairs.back().d.resolved(), resolved) << a << " - " << b;
  }
  return s;
}

TEST(RankAgreement, FlipsArePairsResolvedInBothRunsInOppositeOrders) {
  RunStatistics a, b;
  // A: x < y < z, every pair resolved. B: y < x (resolved: a flip), z tied with x (not resolved).
  a.scenes["s"] = sceneStats({{"x", 1, 1.0}, {"y", 2, 2.0}, {"z", 3, 3.0}, {"onlyA", 4, 9.0}},
                             {{"x", "y", -1.0, true}, {"x", "z", -2.0, true}, {"y", "z", -1.0, true}});
  b.scenes["s"] = sceneStats({{"y", 1, 1.0}, {"x", 2, 1.5}, {"z", 2, 1.6}},
                             {{"y", "x", -0.5, true}, {"x", "z", -0.1, false}, {"y", "z", -0.6, true}});
  b.scenes["other"] = sceneStats({{"x", 1, 1.0}, {"y", 2, 2.0}}, {});
  const std::vector<SceneRankAgreement> r = compareRankings(a, b);
  ASSERT_EQ(r.size(), 1u);  // only the scene both runs rank
  EXPECT_EQ(r[0].methods, (std::vector<std::string>{"x", "y", "z"}));
  EXPECT_EQ(r[0].onlyInOne, (std::vector<std::string>{"onlyA"}));
  EXPECT_EQ(r[0].resolvedA, 3);
  EXPECT_EQ(r[0].resolvedB, 2);
  EXPECT_EQ(r[0].resolvedBoth, 2);
  EXPECT_EQ(r[0].resolvedText(), "3/2/2");  // one column of the bench's table, no padding inside
  ASSERT_EQ(r[0].flips.size(), 1u);
  EXPECT_EQ(r[0].flips[0].better, "x");  // A's order
  EXPECT_EQ(r[0].flips[0].worse, "y");
  EXPECT_DOUBLE_EQ(r[0].flips[0].diffA, -1.0);
  EXPECT_DOUBLE_EQ(r[0].flips[0].diffB, 0.5);
  // Ranks A (1, 2, 3) against B (2, 1, 2): pairs (x,y) discordant, (x,z) tied in B, (y,z) concordant.
  EXPECT_NEAR(r[0].tauRanks, 0.0, 1e-12);
  // Values A (1, 2, 3) against B (1.5, 1, 1.6): (x,y) discordant, (x,z), (y,z) concordant.
  EXPECT_NEAR(r[0].tauValues, 1.0 / 3.0, 1e-12);
  // Where higher is better (SSIM), the better method is the one with the larger value.
  a.scenes["s"].ranking.metric = "ssim";
  b.scenes["s"].ranking.metric = "ssim";
  EXPECT_EQ(compareRankings(a, b)[0].flips[0].better, "y");
}

TEST(RankAgreement, UnlikeRankingsAreErrorsNamingTheScene) {
  RunStatistics a, b;
  a.scenes["s"] = sceneStats({{"x", 1, 1.0}, {"y", 2, 2.0}}, {});
  b.scenes["s"] = sceneStats({{"x", 1, 1.0}, {"y", 2, 2.0}}, {}, "ssim");
  EXPECT_NE(test::errorOf([&] { compareRankings(a, b); }).find("statistics.scenes.s: ranked on 'relMse' in one run and 'ssim'"),
            std::string::npos);
  b.scenes["s"] = sceneStats({{"x", 1, 1.0}, {"w", 2, 2.0}}, {});
  EXPECT_NE(test::errorOf([&] { compareRankings(a, b); }).find("1 method(s) ranked in both runs"), std::string::npos);
  b.scenes["s"] = sceneStats({{"x", 1, 1.0}, {"y", 2, 2.0}}, {}, "noSuchMetric");
  a.scenes["s"].ranking.metric = "noSuchMetric";
  EXPECT_NE(test::errorOf([&] { compareRankings(a, b); }).find("'noSuchMetric' is no registered metric"), std::string::npos);
}

}  // namespace
}  // namespace arena
