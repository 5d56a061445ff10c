#pragma once
// Whether two runs of the same scenes rank the methods alike (issue 34, item 7): the quick preset
// against a larger resolution, say. Per scene: Kendall's tau-b between the two rankings (on the
// ranks with ties that statistics gives, and on the point values), and the pairs whose order is
// resolved in both runs but opposite -- a flip no interval explains.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "metrics/run_statistics.hpp"

namespace arena {

// Kendall's tau-b of two paired series (ties in either count as in Kendall 1945: tau-b =
// (concordant - discordant) / sqrt((n0 - ties in x)(n0 - ties in y)), n0 = n(n-1)/2). NaN when
// fewer than 2 items or one series is all ties. Sizes must match.
double kendallTauB(const std::vector<double>& x, const std::vector<double>& y);

struct RankFlip {
  std::string better, worse;  // in run A's order; run B resolves the opposite
  double diffA = 0, diffB = 0;  // value(better) - value(worse) in A and in B (signs differ)
};

struct SceneRankAgreement {
  std::string scene, metric;
  std::vector<std::string> methods;  // in both runs, in A's order (best first)
  std::vector<int> ranksA, ranksB;    // with ties (statistics' ranks)
  double tauRanks = 0, tauValues = 0;
  int resolvedA = 0, resolvedB = 0, resolvedBoth = 0;  // pairs among `methods`
  std::vector<RankFlip> flips;
  std::vector<std::string> onlyInOne;  // methods ranked in one run only (not compared)
  nlohmann::json toJson() const;
  // "A/B/both": the resolved counts as one column of the bench's table.
  std::string resolvedText() const;
};

// The scenes both runs rank (RunStatistics::scenes, each on its ranked metric), in A's order. A
// scene whose rankings use different metrics, or with fewer than two common methods, is an error
// naming it.
std::vector<SceneRankAgreement> compareRankings(const RunStatistics& a, const RunStatistics& b);

}  // namespace arena
