#include "metrics/compare.hpp"

#include <cmath>
#include <map>

#include "core/error.hpp"
#include "metrics/results.hpp"

namespace arena {

using nlohmann::json;

double parseTolerance(const std::string& text) {
  try {
    size_t used = 0;
    double v = std::stod(text, &used);
    if (used == text.size() - 1 && text.back() == '%') v /= 100.0;
    else if (used != text.size()) throw Error("");
    if (v < 0) throw Error("");
    return v;
  } catch (...) {
    throw Error("--tolerance '" + text + "': expected a non-negative number or percentage, e.g. 2% or 0.02");
  }
}

std::vector<ComparisonRow> compareRuns(const json& base, const json& cand, std::vector<Tolerance> tolerances) {
  if (tolerances.empty())
    for (const char* m : {"relMse", "ldrFlip", "hdrFlip", "ssim", "tRmae"}) tolerances.push_back({m, 0.02});
  for (Tolerance& t : tolerances) {
    if (t.metric == "flip") t.metric = "ldrFlip";
    if (!findMetric(t.metric)) {
      std::string names;
      for (const MetricInfo& m : metricCatalog()) names += std::string(" ") + m.name;
      throw Error("compare: unknown metric '" + t.metric + "'; known:" + names);
    }
  }
  std::map<std::string, const json*> basePairs;
  for (const json& p : base["pairs"]) basePairs[p["scene"].get<std::string>() + "\n" + p["label"].get<std::string>()] = &p;
  std::vector<ComparisonRow> rows;
  for (const json& p : cand["pairs"]) {
    const std::string scene = p["scene"], label = p["label"];
    auto it = basePairs.find(scene + "\n" + label);
    if (it == basePairs.end()) continue;
    const json& b = *it->second;
    for (const Tolerance& t : tolerances) {
      ComparisonRow row{scene, label, t.metric, 0, 0, 0, t.relative, "ok"};
      const bool bOk = b["status"] == "ok" && b["summary"].contains(t.metric);
      const bool cOk = p["status"] == "ok" && p["summary"].contains(t.metric);
      if (!bOk && !cOk) continue;  // e.g. FLIP switched off in both runs
      if (!cOk) {
        row.verdict = "regressed";  // the candidate lost a result the baseline had (a failed pair)
        rows.push_back(row);
        continue;
      }
      if (!bOk) {
        row.verdict = "missing";
        rows.push_back(row);
        continue;
      }
      row.baseline = b["summary"][t.metric]["mean"];
      row.candidate = p["summary"][t.metric]["mean"];
      row.change = (row.candidate - row.baseline) / std::max(std::abs(row.baseline), 1e-12);
      const bool lowerIsBetter = findMetric(t.metric)->lowerIsBetter;
      const double worse = lowerIsBetter ? row.change : -row.change;
      if (worse > t.relative) row.verdict = "regressed";
      else if (-worse > t.relative) row.verdict = "improved";
      rows.push_back(row);
    }
  }
  return rows;
}

json comparisonJson(const std::vector<ComparisonRow>& rows) {
  json out = json::array();
  for (const ComparisonRow& r : rows)
    out.push_back({{"scene", r.scene}, {"label", r.label}, {"metric", r.metric}, {"baseline", r.baseline},
                   {"candidate", r.candidate}, {"change", r.change}, {"tolerance", r.tolerance}, {"verdict", r.verdict}});
  return out;
}

bool anyRegression(const std::vector<ComparisonRow>& rows) {
  for (const ComparisonRow& r : rows)
    if (r.verdict == "regressed") return true;
  return false;
}

}  // namespace arena
