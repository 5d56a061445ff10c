#pragma once
// `arena history`: a regression dashboard built from many runs (one per commit, say): per scene,
// denoiser and metric, the value against commit with the tolerance band `arena compare` gates
// with, and the runs where `arena compare` against the run before would have failed marked.
// Like the report, it only reads results and opens from disk with no server.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "metrics/compare.hpp"
#include "metrics/gate.hpp"

namespace arena {

// Runs from run directories (results.json) and results databases (results.db, every run it
// holds), ordered by creation time (ties keep the input order). A database run carries what the
// database stores: its pairs' status and summaries (no per-frame data). Anything else is an Error
// naming the path.
// `warnings` (optional): one line per run given twice in one form (a copied directory, a
// database given twice), which is taken once; a run directory and its results.db are one run.
std::vector<RunResults> loadHistory(const std::vector<std::filesystem::path>& inputs,
                                    std::vector<std::string>* warnings = nullptr);

// The dashboard's data: runs [{name, created, commit}], per scene x label x metric the values (and
// intervals where the runs have them) per run, the tolerance of each gated metric, and `changes`:
// every row of the gate's judgement of run i against run i-1 (judgeRuns, metrics/gate.hpp: what
// `arena compare` decides) whose verdict is not "ok", with the run index i and `fails` (failsGate:
// the gate's own rule, not restated here); `failing` counts those rows, `failingComparisons` the
// comparisons (of `comparisons`) with one; `unresolved` the changes beyond the tolerance within
// noise, `notJudged` those the gate could not judge (runs read from results.db keep no tiles),
// `notComparable` the failing comparisons compare refuses (exit 2: other settings, data it
// refuses); `correction` and `confidence` say how the rows were judged; `warnings` the judgements'
// warnings, each said once (gateWarnings: which settings or references differ, once per text; the
// rest once per kind, with how many comparisons it concerns). Empty `gate.tolerances`: compare's
// defaults. A gated metric neither run of a pair computed is skipped for that pair (runs over
// months differ in what they computed); one the caller named that no run computed is an Error.
// `gate` holds compare's options, so the dashboard judges as the gate it stands for
// (--allow-settings-mismatch: runs of other settings compared, and warned of, not "not
// comparable"). `gate.contenders` (--denoisers): only those pairs are gated, and a comparison whose
// earlier run has none of them (before they existed) is not made (counted in
// `notMadeBeforeContenders`). `gate.matches` (--match
// BASELINE=CANDIDATE, repeatable): a contender relabelled on purpose between runs (`--param
// svgf.sigmaL=8` added to the command CI runs) stays one series, and where a run with the first
// label and not the second is followed by one with the second and not the first, the two are
// compared as `arena compare --match` compares them (naming either label in --denoisers keeps
// both). A label no run has, one matched twice, or a match never met is an Error.
nlohmann::json historyData(std::vector<RunResults> runs, const Gate& gate = {});

struct HistoryOptions {
  std::vector<std::filesystem::path> inputs;
  std::filesystem::path out;
  // The gate's options, as `arena compare` takes them. Its --denoisers: runs over months differ
  // in what they ran, so a name no run has is an Error, one some runs lack is not.
  Gate gate;
  std::filesystem::path webDir, nodeModulesDir;  // empty: the report's defaults
};
struct HistorySummary {
  std::filesystem::path index;
  size_t runs = 0, failing = 0;                    // failing: rows that fail the gate
  size_t comparisons = 0, failingComparisons = 0;  // run i against run i - 1; those that fail
  // Comparisons not made: the earlier run has none of the --denoisers contenders (not yet).
  size_t notMadeBeforeContenders = 0;
  size_t unresolved = 0;                           // changes beyond the tolerance within noise
  // Changes in the worse direction beyond the tolerance the gate could not judge: against runs read
  // from results.db (no tiles), resolved on too few frames, and of events no interval can judge.
  size_t notJudged = 0;
  size_t notJudgedFromDatabase = 0;
  size_t notJudgedFewFrames = 0;  // resolved on 7 or fewer frames after the warm-up
  // Of the failing comparisons, those `arena compare` refuses (other settings, data it refuses):
  // it exits 2 there, "could not judge", not the 1 of a regression.
  size_t notComparable = 0;
  std::vector<std::string> warnings;         // runs given twice; comparisons of too many rows
  std::vector<std::string> absentSummaries;  // "<run>: <scene>: <metric> absent in N pair(s): <why>"
  // Each --match assignment and the comparisons (run i against run i - 1) whose pairs it matched.
  std::vector<std::pair<std::string, std::vector<size_t>>> matches;
};
HistorySummary writeHistory(const HistoryOptions& options);

}  // namespace arena
