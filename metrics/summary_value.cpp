#include "metrics/summary_value.hpp"

#include <cmath>
#include <map>
#include <tuple>

namespace arena {

using nlohmann::json;

SummaryMean summaryMean(const json& pair, const std::string& metric) {
  if (!pair.is_object() || !pair.contains("summary") || !pair["summary"].is_object())
    return {0, "the pair has no summary"};
  const json& summary = pair["summary"];
  if (!summary.contains(metric)) return {0, metric + " was not computed in this run", false};
  const json& s = summary[metric];
  if (!s.is_object()) return {0, metric + "'s summary is not an object"};
  if (s.contains("absent") && s["absent"].is_string()) return {0, s["absent"].get<std::string>()};
  if (!s.contains("mean")) return {0, metric + "'s summary has no mean"};
  if (!s["mean"].is_number() || !std::isfinite(s["mean"].get<double>()))
    return {0, metric + "'s mean is not a finite number"};
  return {s["mean"].get<double>(), ""};
}

std::vector<std::string> absentSummaryLines(const json& results,
                                            const std::vector<std::string>& metrics) {
  std::map<std::tuple<std::string, std::string, std::string>, int> count;
  if (!results.contains("pairs") || !results["pairs"].is_array()) return {};
  for (const json& p : results["pairs"]) {
    if (!p.is_object() || p.value("status", json()) != "ok") continue;
    std::vector<std::string> names = metrics;
    if (names.empty() && p.contains("summary") && p["summary"].is_object())
      for (auto it = p["summary"].begin(); it != p["summary"].end(); ++it) names.push_back(it.key());
    const std::string scene = p.contains("scene") && p["scene"].is_string() ? p["scene"].get<std::string>() : "?";
    for (const std::string& m : names) {
      const SummaryMean s = summaryMean(p, m);
      if (!s.present()) ++count[{scene, m, s.absent}];
    }
  }
  std::vector<std::string> lines;
  for (const auto& [key, n] : count) {
    const auto& [scene, metric, why] = key;
    lines.push_back(scene + ": " + metric + " absent in " + std::to_string(n) + " pair(s): " + why);
  }
  return lines;
}

}  // namespace arena
