#include "metrics/rank_agreement.hpp"

#include <cmath>
#include <map>

#include "core/error.hpp"
#include "metrics/metric_registry.hpp"

namespace arena {

using nlohmann::json;

double kendallTauB(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size())
    throw Error("kendallTauB: series of " + std::to_string(x.size()) + " and " + std::to_string(y.size()) +
                " items (expected equal sizes)");
  double concordant = 0, discordant = 0, tiesX = 0, tiesY = 0, pairs = 0;
  for (size_t i = 0; i < x.size(); ++i)
    for (size_t j = i + 1; j < x.size(); ++j) {
      ++pairs;
      const double dx = x[i] - x[j], dy = y[i] - y[j];
      if (dx == 0) ++tiesX;
      if (dy == 0) ++tiesY;
      if (dx * dy > 0) ++concordant;
      if (dx * dy < 0) ++discordant;
    }
  const double denominator = std::sqrt((pairs - tiesX) * (pairs - tiesY));
  return denominator > 0 ? (concordant - discordant) / denominator : std::nan("");
}

std::string SceneRankAgreement::resolvedText() const {
  return std::to_string(resolvedA) + "/" + std::to_string(resolvedB) + "/" +
         std::to_string(resolvedBoth);
}

json SceneRankAgreement::toJson() const {
  json flipsJson = json::array();
  for (const RankFlip& f : flips)
    flipsJson.push_back({{"better", f.better}, {"worse", f.worse}, {"diffA", f.diffA}, {"diffB", f.diffB}});
  auto number = [](double v) { return std::isfinite(v) ? json(v) : json(); };
  return {{"scene", scene},         {"metric", metric},         {"methods", methods},
          {"ranksA", ranksA},       {"ranksB", ranksB},         {"tauRanks", number(tauRanks)},
          {"tauValues", number(tauValues)}, {"resolvedA", resolvedA}, {"resolvedB", resolvedB},
          {"resolvedBoth", resolvedBoth}, {"flips", flipsJson}, {"onlyInOne", onlyInOne}};
}

namespace {

struct Ranked {
  int rank;
  double value;
};

std::map<std::string, Ranked> rankingOf(const SceneRanking& scene) {
  std::map<std::string, Ranked> out;
  for (const RankedMethod& m : scene.ranking) out[m.label] = {m.rank, m.value};
  return out;
}

// value(a) - value(b) when the pair is resolved, keyed "a|b" in both orders (b|a: the negation).
std::map<std::string, double> resolvedDifferences(const SceneRanking& scene) {
  std::map<std::string, double> out;
  for (const SceneRanking::Pair& p : scene.pairs) {
    if (!p.d.resolved() || !std::isfinite(p.d.diff)) continue;
    out[p.a + "|" + p.b] = p.d.diff;
    out[p.b + "|" + p.a] = -p.d.diff;
  }
  return out;
}

}  // namespace

std::vector<SceneRankAgreement> compareRankings(const RunStatistics& statisticsA, const RunStatistics& statisticsB) {
  std::vector<SceneRankAgreement> out;
  for (const auto& [scene, sceneA] : statisticsA.scenes) {
    auto sceneB = statisticsB.scenes.find(scene);
    if (sceneB == statisticsB.scenes.end()) continue;
    const SceneRanking &a = sceneA.ranking, &b = sceneB->second.ranking;
    SceneRankAgreement s;
    s.scene = scene;
    s.metric = a.metric;
    if (b.metric != s.metric)
      throw Error("statistics.scenes." + s.scene + ": ranked on '" + s.metric + "' in one run and '" + b.metric +
                  "' in the other (expected one metric)");
    const MetricDefinition* definition = findMetric(s.metric);
    if (!definition)
      throw Error("statistics.scenes." + s.scene + ".metric: '" + s.metric + "' is no registered metric");
    const bool lowerIsBetter = definition->lowerIsBetter();
    const std::map<std::string, Ranked> rankedA = rankingOf(a), rankedB = rankingOf(b);
    for (const RankedMethod& m : a.ranking) {
      if (rankedB.count(m.label)) s.methods.push_back(m.label);
      else s.onlyInOne.push_back(m.label);
    }
    for (const auto& [label, r] : rankedB)
      if (!rankedA.count(label)) s.onlyInOne.push_back(label);
    if (s.methods.size() < 2)
      throw Error("statistics.scenes." + s.scene + ": " + std::to_string(s.methods.size()) +
                  " method(s) ranked in both runs (expected at least 2 to compare orders)");
    std::vector<double> ra, rb, va, vb;
    for (const std::string& label : s.methods) {
      s.ranksA.push_back(rankedA.at(label).rank);
      s.ranksB.push_back(rankedB.at(label).rank);
      ra.push_back(rankedA.at(label).rank);
      rb.push_back(rankedB.at(label).rank);
      va.push_back(rankedA.at(label).value);
      vb.push_back(rankedB.at(label).value);
    }
    s.tauRanks = kendallTauB(ra, rb);
    s.tauValues = kendallTauB(va, vb);
    const std::map<std::string, double> dA = resolvedDifferences(a), dB = resolvedDifferences(b);
    for (size_t i = 0; i < s.methods.size(); ++i)
      for (size_t j = i + 1; j < s.methods.size(); ++j) {
        const std::string key = s.methods[i] + "|" + s.methods[j];
        const auto inA = dA.find(key), inB = dB.find(key);
        s.resolvedA += inA != dA.end();
        s.resolvedB += inB != dB.end();
        if (inA == dA.end() || inB == dB.end()) continue;
        ++s.resolvedBoth;
        if ((inA->second < 0) != (inB->second < 0)) {
          // Run A's better method first: the lower value where lower is better.
          const bool iBetterInA = lowerIsBetter ? inA->second < 0 : inA->second > 0;
          s.flips.push_back(iBetterInA ? RankFlip{s.methods[i], s.methods[j], inA->second, inB->second}
                                       : RankFlip{s.methods[j], s.methods[i], -inA->second, -inB->second});
        }
      }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace arena
