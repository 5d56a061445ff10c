#pragma once
// The run matrix: scenes x denoisers. Renders missing sequences, runs every pair, computes every
// metric of ../shared/docs/metrics.md per frame, summarises after warm-up, and writes
// <out>/results.json, appends <out>/results.db, and keeps images of chosen frames for the report.
// A failing pair is recorded with its error and does not lose the others.
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "harness/denoise_run.hpp"
#include "tracer/render.hpp"

namespace arena {

struct RunConfig {
  std::string name;
  std::filesystem::path out, cache = "cache";
  RenderSettings render;
  std::vector<Scene> scenes;
  std::vector<DenoiserRequest> denoisers;
  bool baselines = true;          // add passthrough (noisy input) and temporal for context
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
  // false: return the results without writing results.json/results.db (a pass the caller may
  // redo; it commits what it keeps with commitResults).
  bool commit = true;
  ProgressFn progress;
};

// Returns the results document (also written to disk). Check `failedPairs(results)`.
nlohmann::json runMatrix(const RunConfig& config);
std::vector<std::string> failedPairs(const nlohmann::json& results);
// "i/n" -> (i, n), 0 <= i < n.
std::pair<int, int> parseShard(const std::string& text);
// The run `results` with the scenes of `part` (a run of the same configuration on some of its
// scenes) in place of its own: their scene entries and pairs are replaced where they stand, then
// the statistics and reference quality (cfg.warmup, cfg.referenceNotes) are recomputed over the
// whole, and the result is committed to cfg.out when cfg.commit. The study's second pass.
nlohmann::json replaceScenes(nlohmann::json results, const nlohmann::json& part, const RunConfig& cfg);
// Combines shard runs into one run directory (results.json, results.db, images).
nlohmann::json mergeRuns(const std::vector<std::filesystem::path>& runs, const std::filesystem::path& out);

}  // namespace arena
