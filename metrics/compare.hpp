#pragma once
// `arena compare`: differences between two runs per scene x denoiser, with tolerance verdicts.
// A metric regresses when it moved in its worse direction by more than its tolerance (relative to
// the baseline's value) *and* the move is resolved at the chosen confidence: the paired bootstrap
// interval of (candidate - baseline) over the same frames and tiles (metrics/statistics.hpp) lies
// entirely on the worse side of zero. A rerun with another input seed moves every number a little;
// that noise is not a regression. A gate judges many rows at once (scenes x denoisers x metrics),
// and at 95% each, a few of a hundred resolve by chance: measured, a change of --input-seed alone
// failed 12 of 15 comparisons of a 144-row gate (docs/statistics.md). So by default the rows'
// tests are corrected together (Holm): a row regresses only when it stays resolved among all the
// rows the gate judged, so that noise alone fails the gate about 1 - confidence of the time, where
// the rows' intervals hold their level (docs/statistics.md: on light_switch's relMSE they do not).
// Named with --metric, the figures ranked around scripted events and camera cuts are judged the
// same way, a row per event (metrics/ghosting_intervals.hpp, eventFigureChange). The command exits
// 1 on a regression and on anything it cannot compare (a pair or metric the baseline had and the
// candidate lacks, no scene in common), so it can gate a merge in CI.
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "metrics/run_results.hpp"
#include "metrics/statistics.hpp"

namespace arena {

// compareRuns' Error for a gated metric the caller named that neither run computed: a mistake in
// the options, not in the runs (the gate's judgement lets it through, metrics/gate.hpp).
class UnmeasuredMetric : public Error {
 public:
  using Error::Error;
};

struct Tolerance {
  // A name from metricCatalog() (aliases: flip = ldrFlip) or an event figure
  // (gatedEventFigureNames(): ghosting.lagEnergy, cut.recovery1, ...).
  std::string metric;
  double relative = 0.02;
  // Skipped where neither run computed it (the defaults: FLIP may be switched off; a history,
  // whose runs may differ in what they computed). Otherwise, when no pair both runs ran has it,
  // compareRuns is an error: a gate on a metric nobody measured would pass having checked nothing.
  bool optional = false;
};

struct ComparisonRow {
  std::string scene, label, metric;
  double baseline = kUndefined, candidate = kUndefined;
  double change = kUndefined;  // (candidate - baseline) / |baseline|
  Interval changeCi;           // the paired interval of the change, same scale (the row's own)
  double tolerance = 0;
  // "ok", "improved", "regressed", "unresolved" (beyond tolerance, within noise), "unverified"
  // (worse beyond tolerance with no interval to judge it: no tiles in a run directory, too few
  // frames; fails the gate, as passing it would judge from no data), "not judged" (beyond
  // tolerance, either way, on a run read from results.db, which keeps no tiles by design, or on an
  // event figure no interval can judge, its changed region within fewer than 4 effective tiles,
  // or resolved on kFewSummarisedFrames or fewer frames after the warm-up (fewFrames below):
  // the gate's verdict is unknown; `arena history` counts and lists these apart, and they do not
  // fail it), "missing" (the candidate lacks what the baseline had: fails the gate), "failed" (the
  // candidate's pair failed), "new" (only the candidate has it, or only its pair ran; a candidate
  // pair that failed is "failed" whether or not the baseline had it), "absent" (neither run has a
  // summary of it: the note gives both reasons; does not fail the gate on its own), "nothing
  // compared" (one row, scene "*": no figure was measured by both runs, so the gate fails rather
  // than pass on nothing).
  std::string verdict;
  std::string note;
  // The candidate's label where it differs from the baseline's (`label`): a pair matched by what it
  // ran, the denoiser and its parameters ("svgf" against a sweep's "svgf[sigmaL=4]").
  std::string candidateLabel;
  // Matched because `--match` asked (the labels name different configurations, "svgf ->
  // svgf[sigmaL=8]"), not because both ran the same.
  bool matchedByRequest = false;
  // The two-sided p-value of "no change" (PairedChange::pValue); NaN without an interval, and on
  // few frames.
  double pValue = kUndefined;
  // The paired interval rests on kFewSummarisedFrames or fewer frames after the warm-up
  // (statistics.hpp): too narrow to judge by, so a resolved change is "not judged".
  bool fewFrames = false;
};

// How the gate counts the rows it judges together (`--correction`): Holm's step-down correction
// over every row with an interval (the default), or none (each row alone at the confidence).
enum class Correction { Holm, None };
// The most replicates a row's p-value is drawn from under Holm (4 m / alpha for m rows): 2 /
// (kMaxGateReplicates + 1) is the smallest p-value it can show, so a gate of more than about
// alpha kMaxGateReplicates / 2 rows (2,500 at 95%) can resolve nothing under the correction.
constexpr int kMaxGateReplicates = 100000;
// The most rows a gate corrected with Holm at `confidence` can resolve any of: beyond, its smallest
// threshold (1 - confidence) / m lies below the smallest p-value kMaxGateReplicates can show.
inline size_t holmResolvableRows(double confidence) {
  return size_t((1 - confidence) * (kMaxGateReplicates + 1) / 2);
}
// "holm" or "none".
Correction parseCorrection(const std::string& text);
const char* correctionName(Correction c);

// The tolerances a gate applies: `tolerances` checked (a registered metric, finite and
// non-negative; the alias flip read as ldrFlip), or when empty the defaults: every metric gated
// by default, at `relative` (optional).
std::vector<Tolerance> gateTolerances(std::vector<Tolerance> tolerances, double relative = 0.02);
// Defaults when `tolerances` is empty: relMse, ldrFlip, hdrFlip, ssim, tRmae at 2% (no event
// figure).
// A row "regressed" or "improved" by its own interval that does not survive `correction` at
// level 1 - cfg.confidence reads "unresolved", its note saying so.
// `matches` pairs a baseline label with a candidate label on every scene (`--match`: the same
// denoiser with another parameter, a renamed contender), checked by checkLabelMatches.
// Errors: UnmeasuredMetric for a metric the caller named that neither run computed (a mistake in
// the options), an Error naming the run for results it refuses to judge (damaged tiles, a summary
// that disagrees with them).
std::vector<ComparisonRow> compareRuns(const RunResults& baseline, const RunResults& candidate,
                                       std::vector<Tolerance> tolerances,
                                       const BootstrapConfig& cfg = {},
                                       Correction correction = Correction::Holm,
                                       const std::map<std::string, std::string>& matches = {});
// `--match BASELINE=CANDIDATE` assignments read and checked: each label one a run has (the
// baseline's first, the candidate's second), each once, and the candidate's not also a baseline
// label (its own pair would be compared with it by label); Errors name the assignment.
std::map<std::string, std::string> checkLabelMatches(const std::vector<std::string>& assignments,
                                                     const RunResults& baseline,
                                                     const RunResults& candidate);
// `--denoisers` names with each --match partner of a name added: a matched pair is one contender,
// and naming either of its labels keeps both.
std::vector<std::string> withMatchedLabels(std::vector<std::string> names,
                                           const std::map<std::string, std::string>& matches);
// Labels as one line for a message: "a, b, c" (a set: sorted, each once).
std::string labelList(const std::set<std::string>& labels);
// One `--match` assignment split at its first '=' outside brackets (a label may hold '=' itself,
// svgf[sigmaL=8]) into (baseline label, candidate label); an Error names it when it is not two.
std::pair<std::string, std::string> splitLabelMatch(const std::string& assignment);
// The label of `labels` that `typed` names: itself, or the one that differs from it only in how a
// number is written ("svgf[sigmaL=8.0]" for "svgf[sigmaL=8]", as a run writes it): the same name,
// the same keys in any order, each value the same text, number or float. Empty when none,
// or when more than one would.
std::string labelAsWritten(const std::set<std::string>& labels, const std::string& typed);
// What two runs' settings differ in, one line each ("settings.warmup: 8 vs 2",
// "scenes.cornell_static.width: 16 vs 32"): every field under "settings" except the shard, and the
// resolution and frame count of each scene both runs have. Empty when they match. `gated`: the
// gate's tolerances (the rule for lag after an unsettled event counts where they judge lag).
std::vector<std::string> settingsDifferences(const RunResults& baseline,
                                             const RunResults& candidate,
                                             const std::vector<Tolerance>& gated = {});
// The scenes both runs measured against references of other sample counts (a refinement between
// them): "scenes.light_switch.referenceSpp: [64,64] vs [256,64]". Part of each change there is the
// reference's, not the denoiser's; `compare` warns of it. Empty when they match or are not
// recorded.
std::vector<std::string> referenceDifferences(const RunResults& baseline,
                                              const RunResults& candidate);
// Every leaf where two documents differ, as "PATH.key: a vs b" (a missing side reads "absent").
std::vector<std::string> jsonDifferences(const nlohmann::json& a, const nlohmann::json& b,
                                         const std::string& path);
// "2%" -> 0.02, "0.02" -> 0.02; negative, NaN or infinite values are errors.
double parseTolerance(const std::string& text);
// The gate of `--metric` (`metrics`, empty: the defaults) and `--tolerance`: one value for every
// metric ("2%"), and/or per metric, comma-separated ("2%,ghosting.lagEnergy=10%"; a metric's own
// must be one the gate judges). Errors name the item.
std::vector<Tolerance> parseGate(const std::vector<std::string>& metrics,
                                 const std::string& toleranceText);
// "95%" or "0.95" -> 0.95; must lie in (0, 1).
double parseConfidence(const std::string& text);
// Whether a row fails the gate: "regressed", "unverified", "missing", "failed", "nothing
// compared", and history's "not comparable" (runs under other settings, which compare refuses). The
// one place the rule lives: the JSON rows carry it as `fails`, which the report's and the
// dashboard's pages read.
bool failsGate(const ComparisonRow& row);
// The rows as JSON, each with its verdict and `fails` (failsGate).
nlohmann::json comparisonJson(const std::vector<ComparisonRow>& rows);
// True when the gate must fail: some row fails it.
bool anyRegression(const std::vector<ComparisonRow>& rows);
// What the gate decided, for a CI step to tell apart: Regressed (a row "regressed", "missing" or
// "failed": the candidate is worse or lost something; exit 1), CouldNotJudge (no such row, but a
// row the gate fails for want of data: "unverified", "nothing compared", "not comparable"; exit 2,
// as for input the gate refuses), Pass (exit 0).
enum class GateOutcome { Pass, Regressed, CouldNotJudge };
GateOutcome gateOutcome(const std::vector<ComparisonRow>& rows);
const char* gateOutcomeName(GateOutcome outcome);  // "pass", "regressed", "could not judge"
int gateExitCode(GateOutcome outcome);             // 0, 1, 2
// Keeps the pairs of `baseline` and `candidate` whose label or denoiser is among `names` (`arena
// compare --denoisers`): a contender one run lacks is then `missing` or `new`, as without the
// option; a name neither run has is an Error listing the labels they have. A label typed otherwise
// than the runs wrote it names theirs (labelAsWritten); naming either label of a `matches` pair
// keeps both.
void keepContenders(RunResults& baseline, RunResults& candidate, std::vector<std::string> names,
                    const std::map<std::string, std::string>& matches = {});
// Whether `a` and `b` are one run read twice (a copy, a directory and the database it appended
// to): the same name, creation time and build commit, and the same pairs with the same means of
// every summary. Two runs made in the same second under one name differ in their numbers.
bool sameRunRecord(const RunResults& a, const RunResults& b);
// Whether `p` is one of `names` (its label or its denoiser's name).
bool isContender(const PairResult& p, const std::vector<std::string>& names);

}  // namespace arena
