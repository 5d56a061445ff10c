#pragma once
// A scene of a run, prepared once for all its pairs: the cached sequence (or a capture, validated
// first), its evaluation (metrics/evaluator.hpp), the frames whose images the report shows, the
// other input seeds' sequences, and the scene's record in results.json. run_matrix.cpp prepares
// each scene with these and runs its pairs on it (harness/pair_run.hpp).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/sequence.hpp"
#include "metrics/evaluator.hpp"

namespace arena {

struct RunConfig;
struct Scene;

struct SceneData {
  Sequence sequence;
  EvaluationScene evaluation;
  std::vector<int> chosenFrames;  // frames whose images are kept for the report
};

// Another noise realisation of a scene's input, with its frames in memory.
struct SeedSequence {
  uint32_t inputSeed = 0;
  Sequence sequence;
  std::vector<LayerSet> frames;
};

// The sequence in `dir` (a cached render or a capture) opened for its pairs. A capture is
// validated before anything runs on it (metrics/capture_checks.hpp): `validation` receives the
// checks, and a hard failure refuses the scene with the checks' names and numbers.
std::unique_ptr<SceneData> prepareScene(const std::filesystem::path& dir, const EvaluationOptions& options,
                                        nlohmann::json* validation = nullptr);

// The scene rendered with input seeds 1..config.seeds-1 (same references), their frames read.
std::vector<SeedSequence> renderSeedSequences(const Scene& scene, const RunConfig& config);

// One line per capture check that did not pass: "status: name value (detail)".
std::vector<std::string> validationLines(const nlohmann::json& validation);

// What a run records of a scene it prepared (results.json "scenes"): size, events, reference,
// evaluation floors, chosen frames; for a capture its validation and layers, for an asset scene
// its credits. Writes the chosen frames' reference and noisy images unless config.keepFrames is
// "none". `scene` is null for a capture.
nlohmann::json sceneRecord(const RunConfig& config, const SceneData& data, const std::string& purpose,
                           const Scene* scene, const std::filesystem::path& dir, const nlohmann::json& validation);

}  // namespace arena
