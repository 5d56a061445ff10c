#pragma once
// `arena compare`: differences between two runs per scene x denoiser, with tolerance verdicts.
// A metric regresses when it moved in its worse direction by more than its tolerance (relative to
// the baseline's value); the command exits 1 then, so it can gate a merge in CI.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace arena {

struct Tolerance {
  std::string metric;  // a name from metricCatalog() (aliases: flip = ldrFlip)
  double relative = 0.02;
};

struct ComparisonRow {
  std::string scene, label, metric;
  double baseline = 0, candidate = 0, change = 0;  // change: (candidate - baseline) / |baseline|
  double tolerance = 0;
  std::string verdict;  // "ok", "improved", "regressed", "missing"
};

// Defaults when `tolerances` is empty: relMse, ldrFlip, hdrFlip, ssim, tRmae at 2%.
std::vector<ComparisonRow> compareRuns(const nlohmann::json& baseline, const nlohmann::json& candidate,
                                       std::vector<Tolerance> tolerances);
// "2%" -> 0.02, "0.02" -> 0.02.
double parseTolerance(const std::string& text);
nlohmann::json comparisonJson(const std::vector<ComparisonRow>& rows);
bool anyRegression(const std::vector<ComparisonRow>& rows);

}  // namespace arena
