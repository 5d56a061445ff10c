#pragma once
// The run matrix: scenes x denoisers. Renders missing sequences, runs every pair, hands every
// output frame to the evaluation stage (metrics/evaluator.hpp), and writes
// <out>/results.json, appends <out>/results.db, and keeps images of chosen frames for the report.
// A failing pair is recorded with its error and does not lose the others.
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "harness/denoise_run.hpp"
#include "metrics/run_results.hpp"
#include "tracer/sequence_cache.hpp"

namespace arena {

struct RunConfig {
  std::string name;
  // The revision of what the run measures (`--revision`: a denoiser's own commit), recorded as
  // environment.revision beside arena's build commit; empty: none.
  std::string revision;
  std::filesystem::path out, cache = "cache";
  RenderSettings render;
  std::vector<Scene> scenes;
  // Captures (core/capture.hpp): sequences rendered elsewhere, validated and scored like scenes.
  std::vector<std::filesystem::path> captures;
  std::vector<DenoiserRequest> denoisers;
  // The denoisers are every one there is (--denoisers all), not a list the user made: on a capture
  // those it lacks the inputs for are not run (scenes.NAME.notRun says why) rather than failed.
  bool everyDenoiser = false;
  bool baselines = true;          // add passthrough (noisy input) and temporal for context
  // --param values for those baselines (e.g. temporal.maxHistory), by denoiser name.
  std::map<std::string, std::map<std::string, std::string>> baselineParams;
  int warmup = 8;                 // metrics.md: summaries over frames t >= W
  std::string flip = "all";       // none | ldr | all (LDR + HDR)
  std::string exposure = "per-frame";  // display exposure (metrics.md): per-frame | first
  std::string keepFrames = "auto";  // auto (all for a single pair, else chosen) | all | chosen | none
  int shardIndex = 0, shardCount = 1;
  // > 1: every scene is also rendered with input seeds 1..K-1 (the references are the same) and each
  // pair reports the bias^2 / variance split of its error over the K outputs.
  int seeds = 1;
  // Per scene, a sentence its reference-quality verdict carries (the study's refinement).
  std::map<std::string, std::string> referenceNotes;
  // false: return the scenes and pairs only, without statistics, verdicts or writing anything (a
  // pass the caller may redo); the caller finishes what it keeps with finishRun.
  bool finish = true;
  // Entries added to the results document before it is committed (a sweep's grid), so results.json
  // and results.db hold them from the one atomic commit.
  nlohmann::json annotations = nlohmann::json::object();
  ProgressFn progress;  // every step: frames rendered, pairs run, warnings as they happen
  // One line per finished scene (its pairs, their time, failures, the ETA) and per decision of the
  // study (what it refines): the progress a log keeps when `progress` is shown only in passing.
  ProgressFn milestone;
  // A decision's line: to `milestone` where there is one, else to `progress`.
  void announce(const std::string& line) const {
    if (milestone) milestone(line);
    else if (progress) progress(line);
  }
  // The low-resolution buffer was left to the run (no --lowres-factor): resolveAutoLowres decides.
  bool lowresAuto = false;
  // Called after a rendered scene's pairs with the results so far (the scene's record and pairs in
  // place, the pairs screened: their linear errors only): may refine the scene's references (the
  // study, harness/study.hpp) and returns true when it did. The scene is then read again, its pairs
  // are screened again from their kept output frames (evaluatePairAgain), and it is called again,
  // up to kMaxRefineRounds times; then the pairs are measured in full. The denoisers run once.
  std::function<bool(const Scene& scene, const nlohmann::json& results)> refineScene;
};
constexpr int kMaxRefineRounds = 3;

// One meaning of reengine's `disocclusionRays=auto` in every command (issue 34, item 6): where the
// buffer is left to the run (config.lowresAuto), the run renders it -- one texel per
// kAutoLowresFactor^2 pixels (CAPCOM 2023's 1/8, denoisers/FIDELITY.md, `reengine`),
// render.lowresSpp paths each -- when any of its built-in denoisers, with its parameters, reads it,
// and not otherwise. An explicit --lowres-factor (0: none) is kept as given.
constexpr int kAutoLowresFactor = 8;
void resolveAutoLowres(RunConfig& config);

// Returns the results document (also written to disk). Check `failedPairs(results)`.
nlohmann::json runMatrix(const RunConfig& config);
// What ends every run: the statistics over all pairs, the reference-quality verdicts
// (cfg.warmup, cfg.referenceNotes), and results.json + results.db committed to cfg.out.
void finishRun(nlohmann::json& results, const RunConfig& cfg);
// Above this many contenders on a scene, finishRun says how many paired comparisons it computes,
// and a sweep of more grid points warns of its cost before it starts (cli: sweep).
inline constexpr size_t kManyContenders = 100;
// A sweep's points whose outputs on a scene are bit-identical (every frame; `outputChecksum`) each
// get a warning naming the others: the grid's change did nothing there (a filter stage skipped at
// this resolution, a parameter another one overrides), and their tie is no measurement. Earlier
// such warnings are replaced (a merge sees every shard's points); the run's printout names them
// after its table (cli: identicalOutputsText), not `say`. A sweep whose scaled footprint skipped
// passes at this resolution gets `sweep.footprintNote`, said to `say` (one note; where the grid
// holds `iterations`, each point skipping passes is warned of instead, each said).
void warnOfIdenticalSweepPoints(nlohmann::json& results, const ProgressFn& say);
// "label on scene: error" for every failed pair; of a committed run, or of the document runMatrix
// returns.
std::vector<std::string> failedPairs(const RunResults& results);
std::vector<std::string> failedPairs(const nlohmann::json& results);
// "i/n" -> (i, n), 0 <= i < n.
std::pair<int, int> parseShard(const std::string& text);
// Combines shard runs into one run directory (results.json, results.db, images).
nlohmann::json mergeRuns(const std::vector<std::filesystem::path>& runs, const std::filesystem::path& out);

}  // namespace arena
