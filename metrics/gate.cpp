#include "metrics/gate.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <utility>

#include "core/error.hpp"

namespace arena {

namespace {

// Items as a message's tail: one to an indented line, or "; "-separated after a space.
std::string itemList(const std::vector<std::string>& items, bool multiLine) {
  std::string text;
  for (const std::string& item : items)
    text += multiLine ? "\n  " + item : (text.empty() ? " " : "; ") + item;
  return text;
}

}  // namespace

GateJudgement judgeRuns(const RunResults& baselineRun, const RunResults& candidateRun,
                        const Gate& gate, const std::map<std::string, std::string>& matches,
                        bool rowsWhenRefused) {
  GateJudgement j;
  j.runName = baselineRun.name;
  j.baselineCreated = baselineRun.created;
  j.candidateCreated = candidateRun.created;
  // The same run on both sides (a CI step that copied the candidate into the baseline) would pass
  // every row by construction.
  if (sameRunRecord(baselineRun, candidateRun)) j.refusal = GateRefusal::SameRun;
  // --denoisers: copies cut to the contenders named (a history's loop, which cut its runs once,
  // copies nothing: a run's tiles may be megabytes).
  std::optional<RunResults> keptBaseline, keptCandidate;
  if (!gate.contenders.empty()) {
    keptBaseline = baselineRun;
    keptCandidate = candidateRun;
    keepContenders(*keptBaseline, *keptCandidate, gate.contenders, matches);
  }
  const RunResults& baseline = keptBaseline ? *keptBaseline : baselineRun;
  const RunResults& candidate = keptCandidate ? *keptCandidate : candidateRun;
  const std::vector<Tolerance> tolerances = gateTolerances(gate.tolerances);
  // Numbers measured under other settings differ for that reason alone: refused unless asked. A
  // run that records none (older than the record) cannot have them checked: compared, and said;
  // the scenes' sizes, lengths and contents, which are not settings, are checked all the same.
  if (baseline.settings.measurement().empty()) j.unrecordedSettings.push_back("baseline");
  if (candidate.settings.measurement().empty()) j.unrecordedSettings.push_back("candidate");
  j.settingsDiffer = settingsDifferences(baseline, candidate, tolerances);
  if (!j.unrecordedSettings.empty())
    std::erase_if(j.settingsDiffer,
                  [](const std::string& d) { return d.rfind("settings.", 0) == 0; });
  if (!j.settingsDiffer.empty() && !gate.allowSettingsMismatch && j.refusal == GateRefusal::None)
    j.refusal = GateRefusal::OtherSettings;
  // (Runs of other settings render other references anyway: said with the settings.)
  if (j.settingsDiffer.empty()) j.referencesDiffer = referenceDifferences(baseline, candidate);
  // A candidate older than its baseline: the arguments are likely swapped, which turns every
  // regression into an improvement.
  j.candidateOlder = !baseline.created.empty() && !candidate.created.empty() &&
                     candidate.created < baseline.created;
  if (j.refusal != GateRefusal::None && !rowsWhenRefused) {
    j.outcome = GateOutcome::CouldNotJudge;
    return j;
  }
  try {
    j.rows = compareRuns(baseline, candidate, tolerances, gate.bootstrap, gate.correction, matches);
  } catch (const UnmeasuredMetric&) {
    throw;  // a mistake in the options (--metric), said as such by every command
  } catch (const Error& e) {
    // Results it refuses to judge (damaged tiles, a summary that disagrees with them): what `arena
    // compare` refuses (exit 2), and a history marks not comparable.
    if (j.refusal == GateRefusal::None) {
      j.refusal = GateRefusal::Data;
      j.refusalDetail = e.what();
    }
    j.rows.clear();
  }
  j.rowsJudgedTogether =
      size_t(std::count_if(j.rows.begin(), j.rows.end(),
                           [](const ComparisonRow& r) { return std::isfinite(r.pValue); }));
  j.resolvableRows = holmResolvableRows(gate.bootstrap.confidence);
  j.beyondCorrection =
      gate.correction == Correction::Holm && j.rowsJudgedTogether > j.resolvableRows;
  j.outcome = j.refusal != GateRefusal::None ? GateOutcome::CouldNotJudge : gateOutcome(j.rows);
  return j;
}

std::string refusalText(const GateJudgement& j, const GateSides& sides, bool multiLine) {
  switch (j.refusal) {
    case GateRefusal::None:
      return "";
    case GateRefusal::SameRun:
      return sides.baseline + " and " + sides.candidate + " hold the same run (name " + j.runName +
             ", created " + j.baselineCreated +
             "): every change would be zero by construction, and the gate would pass having "
             "checked nothing (was the candidate copied into the baseline?)";
    case GateRefusal::OtherSettings:
      return sides.baseline + " and " + sides.candidate +
             " were run with different settings (baseline vs candidate):" +
             itemList(j.settingsDiffer, multiLine) + (multiLine ? "\n" : "; ") +
             "their numbers are not comparable; pass --allow-settings-mismatch to compare anyway";
    case GateRefusal::Data:
      return sides.baseline + " and " + sides.candidate +
             ": arena compare refuses to judge them: " + j.refusalDetail;
  }
  return "";
}

std::vector<GateNotice> gateWarnings(const GateJudgement& j, const GateSides& sides,
                                     bool multiLine) {
  std::vector<GateNotice> out;
  if (!j.settingsDiffer.empty() && j.refusal != GateRefusal::OtherSettings)
    out.push_back({GateWarning::SettingsAllowed,
                   "comparing runs with different settings (baseline vs candidate):" +
                       itemList(j.settingsDiffer, multiLine)});
  if (!j.unrecordedSettings.empty()) {
    const bool both = j.unrecordedSettings.size() == 2;
    out.push_back(
        {GateWarning::SettingsUnrecorded,
         (both ? sides.baseline + " and " + sides.candidate + " record"
               : (j.unrecordedSettings[0] == "baseline" ? sides.baseline : sides.candidate) +
                     " records") +
             " no settings (a run older than the record): whether the runs were measured under "
             "the same settings (warm-up, samples, FLIP, ...) is not checked; the scenes' sizes, "
             "lengths and contents are"});
  }
  if (!j.referencesDiffer.empty())
    out.push_back(
        {GateWarning::OtherReferences,
         "the runs measured these scenes against other references (refined between them, or a "
         "capture's references rendered again?); part of each change there is the reference's, not "
         "the denoiser's (run both on one cache state to compare the denoisers alone):" +
             itemList(j.referencesDiffer, multiLine)});
  if (j.candidateOlder)
    out.push_back(
        {GateWarning::CandidateOlder,
         sides.candidate + " (created " + j.candidateCreated + ") is older than " + sides.baseline +
             " (created " + j.baselineCreated +
             "): are the two swapped? (the baseline is the earlier run: arena compare BASELINE "
             "CANDIDATE, arena report CANDIDATE --baseline BASELINE)"});
  if (j.beyondCorrection)
    out.push_back(
        {GateWarning::BeyondCorrection,
         std::to_string(j.rowsJudgedTogether) + " rows judged together: more than " +
             std::to_string(j.resolvableRows) +
             ", beyond which the correction can resolve no row at this confidence (its "
             "smallest threshold lies below what its replicates can show); narrow the gate "
             "with --metric or --denoisers, or judge each row alone with --correction none"});
  std::set<std::string> fewScenes;
  bool summariesOnly = false;  // a row of runs read from results.db (no interval to be narrow)
  for (const ComparisonRow& r : j.rows)
    if (r.fewFrames) {
      fewScenes.insert(r.scene);
      summariesOnly |= !r.changeCi.valid();
    }
  if (!fewScenes.empty()) {
    std::string scenes;
    for (const std::string& scene : fewScenes) scenes += (scenes.empty() ? "" : ", ") + scene;
    out.push_back(
        {GateWarning::FewFrames,
         "the runs share " + std::to_string(kFewSummarisedFrames) +
             " or fewer frames after the warm-up on " +
             (fewScenes.size() == 1 ? "scene " : "scenes ") + scenes +
             (summariesOnly
                  ? ": too few for a change within its tolerance there to be told from noise, "
                    "and results.db keeps no tiles to tell it, so the gate cannot pass the runs "
                    "(could not judge, exit 2, unless a row fails it); run "
                  : ": too few for the intervals to hold their level (noise alone fails such a "
                    "gate), so a summary metric's change resolved there is not judged and the "
                    "gate cannot pass the runs (could not judge, exit 2, unless a row fails it); "
                    "run ") +
             std::to_string(kFewSummarisedFrames + 1) +
             " or more frames after the warm-up to gate them"});
  }
  return out;
}

std::vector<std::string> gateWarningTexts(const GateJudgement& j, const GateSides& sides,
                                          bool multiLine) {
  std::vector<std::string> texts;
  for (GateNotice& n : gateWarnings(j, sides, multiLine)) texts.push_back(std::move(n.text));
  return texts;
}

}  // namespace arena
