#pragma once
// A metric's sequence summary as a results document holds it (results schema: summary.<metric>):
// {"mean", "median", ...} when frames after the warm-up define it, {"frames": 0, "absent": "<why>"}
// when none does (a sequence no longer than the warm-up, a metric undefined on every frame). Every
// reader of a summary (the CLI printouts, compare, report, history) goes through summaryMean, so an
// absent summary is shown with its reason, never read as a number (nlohmann's type_error.302).
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace arena {

struct SummaryMean {
  double mean = 0;     // valid when present()
  std::string absent;  // why there is no mean; empty when there is one
  bool computed = true;  // false: the run did not compute the metric at all (e.g. FLIP off)
  bool present() const { return absent.empty(); }
};

// pair.summary.<metric>.mean, or why there is none: the pair has no summary (a failed pair), the
// run did not compute the metric, the summary's own "absent" reason, or a mean that is not a
// finite number.
SummaryMean summaryMean(const nlohmann::json& pair, const std::string& metric);

// The absent summaries of a run's ok pairs, one line per scene, metric and reason:
// "<scene>: <metric> absent in N pair(s): <reason>". `metrics` empty: every metric the pairs'
// summaries name. For printouts that show means and must say why one is missing.
std::vector<std::string> absentSummaryLines(const nlohmann::json& results,
                                            const std::vector<std::string>& metrics = {});

}  // namespace arena
