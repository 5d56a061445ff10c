#pragma once
// The regression gate's judgement of a candidate run against a baseline, made once for the three
// commands that show it: `arena compare` (its exit code), `arena report --baseline` (the regression
// view) and `arena history` (each run against the one before). compareRuns gives the rows; around
// them the gate refuses what it cannot judge (the same run on both sides, runs measured under other
// settings, data compareRuns refuses) and warns of what the rows alone do not show (other
// references, a candidate older than its baseline, more rows than the correction can resolve).
// Each command used to assemble this itself, and their rules had begun to drift apart.
#include <map>
#include <string>
#include <vector>

#include "metrics/compare.hpp"
#include "metrics/run_results.hpp"
#include "metrics/statistics.hpp"

namespace arena {

// `arena compare`'s options, which `report --baseline` and `history` take too.
struct Gate {
  std::vector<Tolerance> tolerances;         // --metric, --tolerance (empty: compare's defaults)
  BootstrapConfig bootstrap;                 // --confidence
  Correction correction = Correction::Holm;  // --correction
  std::vector<std::string> contenders;       // --denoisers: only these (empty: every pair)
  // --match BASELINE=CANDIDATE assignments as typed: the commands resolve them against the runs
  // (checkLabelMatches; a history per comparison) and give judgeRuns the pairs of labels.
  std::vector<std::string> matches;
  bool allowSettingsMismatch = false;        // --allow-settings-mismatch: warn instead of refusing
};

// Why the gate cannot judge two runs (it exits 2, "could not judge", rather than pass or fail).
enum class GateRefusal {
  None,
  SameRun,        // one run read twice: every change zero by construction (sameRunRecord)
  OtherSettings,  // measured under other settings, and --allow-settings-mismatch not given
  Data,           // compareRuns refused the data (refusalDetail says why)
};

struct GateJudgement {
  // compareRuns' rows. Under a refusal, empty unless judgeRuns was asked for them anyway (a page
  // shows what moved beside why the gate would not judge it); always empty under GateRefusal::Data
  // (compareRuns gave none).
  std::vector<ComparisonRow> rows;
  GateOutcome outcome = GateOutcome::Pass;  // CouldNotJudge under any refusal
  GateRefusal refusal = GateRefusal::None;
  std::string refusalDetail;  // GateRefusal::Data: compareRuns' message
  // Facts the rows do not show; gateWarnings says them.
  std::vector<std::string> settingsDiffer;  // settingsDifferences (refused, or allowed: a warning)
  std::vector<std::string> referencesDiffer;    // referenceDifferences, where the settings agree
  std::vector<std::string> unrecordedSettings;  // "baseline", "candidate": records no settings
  bool candidateOlder = false;    // created before its baseline: the arguments swapped?
  size_t rowsJudgedTogether = 0;  // rows with an interval: the family the correction judges
  bool beyondCorrection = false;  // Holm over more rows than it can resolve any of
  size_t resolvableRows = 0;      // holmResolvableRows at the gate's confidence
  std::string baselineCreated, candidateCreated, runName;  // for the messages
};

// The gate on `candidate` against `baseline`: `gate.contenders` kept (keepContenders), `matches`
// (checkLabelMatches of gate.matches, or history's own per comparison) pairing relabelled
// contenders. Mistakes in the options (a name no run has; a metric neither run measured where the
// caller named it, UnmeasuredMetric) are Errors, as before any judgement; what the gate cannot
// judge is a refusal. A run that records no settings (an older record) is compared, and said
// (gateWarnings): its settings cannot be checked; its scenes' sizes and contents are.
// `rowsWhenRefused`: compute the rows even where the gate refuses the runs for their settings or as
// one run (they cost a bootstrap each).
GateJudgement judgeRuns(const RunResults& baseline, const RunResults& candidate, const Gate& gate,
                        const std::map<std::string, std::string>& matches,
                        bool rowsWhenRefused = false);

// The names the messages give the two runs (paths for compare, "run 3" for a history).
struct GateSides {
  std::string baseline = "the baseline", candidate = "the candidate";
};
// Why the gate refused the runs, in a sentence; empty when it judged them. `multiLine`: a list's
// items one to an indented line (a terminal) rather than "; "-separated (a page, a JSON note).
std::string refusalText(const GateJudgement& j, const GateSides& sides, bool multiLine);
// What the reader of the verdict should know besides its rows (the same rule for every command),
// one message each, with its kind (a history says each once, not at every comparison).
enum class GateWarning {
  SettingsAllowed,     // settings differ, and --allow-settings-mismatch compared them
  SettingsUnrecorded,  // a run records no settings: not checked
  OtherReferences,     // the scenes were measured against other references
  CandidateOlder,      // created before its baseline: the arguments swapped?
  BeyondCorrection,    // more rows than the correction can resolve any of
  FewFrames,           // intervals on 7 or fewer frames after the warm-up: too narrow to judge by
};
struct GateNotice {
  GateWarning kind;
  std::string text;
};
std::vector<GateNotice> gateWarnings(const GateJudgement& j, const GateSides& sides,
                                     bool multiLine);
// The warnings' texts alone.
std::vector<std::string> gateWarningTexts(const GateJudgement& j, const GateSides& sides,
                                          bool multiLine);

}  // namespace arena
