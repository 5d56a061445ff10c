#pragma once
// The results of one run as a typed model: what results.json holds (schema kResultsSchemaVersion,
// docs/usage.md) and what its readers take -- the printouts, compare, history and benchmarks.
// fromJson checks the document's shape once, naming the JSON path of anything out of place (never
// nlohmann's type_error later); toJson writes the same document back, byte for byte once dumped.
//
// Typed so far: the run's identity and provenance, every pair's identity, status, parameters and
// metric summaries (with their intervals and the reason a summary is absent), and the run's
// statistics (metrics/run_statistics.hpp); the run's settings are the record it wrote, checked field
// by field (metrics/run_settings.hpp). A pair's per-frame values, tile sums, timing, events and
// warnings, and the run's scenes, are still carried as the JSON the run wrote (`PairResult::detail`,
// the json members below); fromJson checks the parts of them that readers take (a scene's size,
// events, floors, verdict and warnings; a pair's timing, event figures, images and warnings).
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "metrics/run_settings.hpp"
#include "metrics/run_statistics.hpp"
#include "metrics/statistics.hpp"

namespace arena {

// pair.summary.<metric>: the summary over the frames after the warm-up (metrics/summary.hpp), or
// why there is none.
struct MetricSummary {
  double mean = kUndefined, median = kUndefined, p5 = kUndefined, p95 = kUndefined;
  int frames = 0;        // frames after the warm-up that define the metric
  Interval ci95;         // the mean's interval; invalid when too few frames gave one
  int nonFinite = 0;     // of `frames`, those whose value was NaN or Inf (the summary is absent then)
  std::string absent;    // why there is no mean; empty when there is one
  bool present() const { return absent.empty(); }
  nlohmann::json toJson() const;
};

// A summary's mean as its readers (printouts, compare, report, history) take it, or why there is
// none: an absent summary is shown with its reason, never read as a number.
struct SummaryMean {
  double mean = 0;       // valid when present()
  std::string absent;    // why there is no mean; empty when there is one
  bool computed = true;  // false: the run did not compute the metric at all (e.g. FLIP off)
  bool present() const { return absent.empty(); }
};

// One scene x denoiser configuration of the run.
struct PairResult {
  std::string scene, denoiser, label;
  std::string status;      // "ok", or how it ended ("failed")
  std::string error;       // the failure; set when status is not "ok"
  nlohmann::json params = nlohmann::json::object();  // parameter -> value as the run applied it
  std::map<std::string, MetricSummary> summary;       // metric -> summary (ok pairs)
  // Everything else the run wrote of the pair, by key: frames (per-frame metrics), tiles, timing,
  // cuts, ghosting, images, sanitizedInputs, warnings.
  nlohmann::json detail = nlohmann::json::object();

  bool ok() const { return status == "ok"; }
  // The summary's mean, or why there is none: a failed pair, a metric the run did not compute, the
  // summary's own reason, or a mean that is not a finite number.
  SummaryMean mean(const std::string& metric) const;
  // detail[key], or an empty JSON value when the pair has no such entry.
  const nlohmann::json& part(const std::string& key) const;
  // The pair's timing object (an empty object when it has none).
  const nlohmann::json& timing() const;
  // Whether its denoiser carries state between frames (keepsHistory false: passthrough, a spatial
  // filter; results written before it was recorded: false for passthrough alone).
  bool keepsHistory() const;
  // The clock its times were taken on: "cpu" (measured here; also where timing says none),
  // "process" (an external process's own report), "capture" (a capture's device), "none".
  std::string clock() const;
};

struct RunResults {
  std::string name, created;
  nlohmann::json environment = nlohmann::json::object();  // compiler, cores, cpu, flags, git_commit
  RunSettings settings;  // how the run measured (compare checks them)
  nlohmann::json scenes = nlohmann::json::object();       // scene -> sequence facts, floors, events
  std::vector<PairResult> pairs;
  std::optional<RunStatistics> statistics;  // rankings, paired differences, the overall score
  nlohmann::json metrics;     // the metric registry as the run had it (null: none)
  nlohmann::json sweep;       // the sweep's grid (null: not a sweep)
  std::string source;         // where it was read from (a run directory, "db#id"); not written
  // false: read from results.db, which keeps no per-tile data by design (the gate cannot resolve a
  // change there, and says so); a run directory's pairs keep theirs. Not written.
  bool keepsTiles = true;

  // `file`: the name errors give (the results.json path).
  static RunResults fromJson(const nlohmann::json& j, const std::string& file);
  nlohmann::json toJson() const;
  // The pair of `scene` labelled `label`, or null.
  const PairResult* find(const std::string& scene, const std::string& label) const;
};

// The absent summaries of a run's ok pairs, one line per scene, metric and reason:
// Where each contender that is not built in came from, by label (a pair's `origin`: an external
// process's manifest, a plugin's library, a capture's stored output); built-ins are not listed.
std::map<std::string, std::string> contenderOrigins(const RunResults& results);
// What kind of contender an origin names, as the report's tables say it: "plugin" (loaded into
// arena), "isolated plugin" (run in `arena serve`), "external" (a process's manifest) or "stored
// output" (a capture's outputs folder).
std::string contenderKind(const std::string& origin);

// The absent summaries, one per scene, metric and reason, with how many pairs have it. `metrics`
// empty: every metric the pairs' summaries name.
struct AbsentSummary {
  std::string scene, metric, why;
  int pairs = 0;
};
std::vector<AbsentSummary> absentSummaries(const RunResults& results,
                                           const std::vector<std::string>& metrics = {});
// One as "<scene>: <metric> absent in N pair(s): <reason>"; all of them so, for printouts that show
// means and must say why one is missing.
std::string absentSummaryText(const AbsentSummary& absent);
std::vector<std::string> absentSummaryLines(const RunResults& results,
                                            const std::vector<std::string>& metrics = {});

}  // namespace arena
