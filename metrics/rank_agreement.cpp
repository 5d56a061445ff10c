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

std::map<std::string, Ranked> rankingOf(const json& scene) {
  std::map<std::string, Ranked> out;
  for (const json& m : scene.at("ranking"))
    out[m.at("label").get<std::string>()] = {m.at("rank").get<int>(),
                                             m.value("mean", json()).is_number() ? m["mean"].get<double>() : std::nan("")};
  return out;
}

// value(a) - value(b) when the pair is resolved, keyed "a|b" in both orders (b|a: the negation).
std::map<std::string, double> resolvedDifferences(const json& scene) {
  std::map<std::string, double> out;
  for (const json& p : scene.value("pairs", json::array())) {
    if (!p.value("resolved", false) || !p.value("diff", json()).is_number()) continue;
    const std::string a = p.at("a").get<std::string>(), b = p.at("b").get<std::string>();
    out[a + "|" + b] = p["diff"].get<double>();
    out[b + "|" + a] = -p["diff"].get<double>();
  }
  return out;
}

}  // namespace

std::vector<SceneRankAgreement> compareRankings(const json& statisticsA, const json& statisticsB) {
  const json& scenesA = statisticsA.at("scenes");
  const json& scenesB = statisticsB.at("scenes");
  std::vector<SceneRankAgreement> out;
  for (auto it = scenesA.begin(); it != scenesA.end(); ++it) {
    if (!scenesB.contains(it.key())) continue;
    const json &a = it.value(), &b = scenesB[it.key()];
    SceneRankAgreement s;
    s.scene = it.key();
    s.metric = a.value("metric", "");
    if (b.value("metric", "") != s.metric)
      throw Error("statistics.scenes." + s.scene + ": ranked on '" + s.metric + "' in one run and '" +
                  b.value("metric", "") + "' in the other (expected one metric)");
    const MetricDefinition* definition = findMetric(s.metric);
    if (!definition)
      throw Error("statistics.scenes." + s.scene + ".metric: '" + s.metric + "' is no registered metric");
    const bool lowerIsBetter = definition->lowerIsBetter();
    const std::map<std::string, Ranked> rankedA = rankingOf(a), rankedB = rankingOf(b);
    for (const json& m : a.at("ranking")) {
      const std::string label = m.at("label").get<std::string>();
      if (rankedB.count(label)) s.methods.push_back(label);
      else s.onlyInOne.push_back(label);
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
