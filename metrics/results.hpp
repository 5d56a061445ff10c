#pragma once
// The run matrix's results: results.json (schema-versioned) and the SQLite database results.db
// that dashboards query across commits.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace arena {

// 2: summaries carry ci95 or absent; pairs carry tiles; results carry statistics and scene floors.
constexpr int kResultsSchemaVersion = 2;

// Reads <run>/results.json; a missing run or another schema version is an Error saying so.
nlohmann::json loadResults(const std::filesystem::path& runDir);
void saveResults(const std::filesystem::path& runDir, const nlohmann::json& results);
// Appends the run to <run>/results.db (tables runs, pairs, frame_metrics, summaries).
void appendToDatabase(const std::filesystem::path& dbPath, const nlohmann::json& results);

// Metrics every pair reports per frame, with the direction that counts as better.
struct MetricInfo {
  const char* name;
  bool lowerIsBetter;
  const char* meaning;
};
const std::vector<MetricInfo>& metricCatalog();
const MetricInfo* findMetric(const std::string& name);

}  // namespace arena
