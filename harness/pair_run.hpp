#pragma once
// One pair of a run: a denoiser over a prepared scene (harness/scene_data.hpp), or the stored
// output of a denoiser that ran elsewhere (a capture's `file:` contender). Each output frame goes
// to the evaluation (metrics/evaluator.hpp), which measures it; the pair adds what only the run
// knows -- its timing (CPU clock, a capture's recorded clock, the predicted GPU cost), the
// non-finite inputs it was handed, the images it keeps -- and returns the pair's record.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "harness/denoise_run.hpp"
#include "harness/scene_data.hpp"

namespace arena {

struct RunConfig;

// An output frame as the evaluation received it: what evaluatePairAgain hands it once more.
struct KeptFrame {
  int frame = 0;
  Image color;
  FrameFacts facts;
};

// `imageDir` receives the chosen frames' images, or every frame's (and its EXR) with `keepAll`.
// With `kept`, every output frame is also kept there (the study's refinement evaluates them again).
// A screening (which needs `kept`) measures only the linear errors (metrics/evaluator.hpp) and writes
// no frame images: the caller decides on them, then measures the kept frames in full with
// evaluatePairAgain, which writes the images. Outputs' EXRs (`keepAll`) are written here either way.
nlohmann::json runPair(const RunConfig& config, const SceneData& scene, const DenoiserRequest& request,
                       const std::filesystem::path& imageDir, bool keepAll, std::vector<KeptFrame>* kept = nullptr,
                       EvaluationScope scope = EvaluationScope::Full);

// The record `pair` that runPair returned, with its measurements taken again from its kept output
// frames against `scene` as it is now (the study's refined references): the same values as running
// the denoiser again would give, which is deterministic, without running it. What only the run
// knew -- its timing, the non-finite inputs it was handed -- stays; the chosen frames' images are
// written again (their error maps changed), a pair's EXRs are not (its outputs did not). A
// screening writes no images (`imageDir` unused).
nlohmann::json evaluatePairAgain(const RunConfig& config, const SceneData& scene, const nlohmann::json& pair,
                                 const std::vector<KeptFrame>& kept, const std::filesystem::path& imageDir,
                                 bool keepAll, EvaluationScope scope = EvaluationScope::Full);

// The warnings of the run itself, which the evaluation does not know, from what `pair` records: its
// reported times that outlast their calls (timing.implausibleFrames), the oracle layers it read,
// the non-finite inputs it was handed, an external process that exited badly after its last frame
// (processEnds). They come first in the pair's warnings; the run prints them.
std::vector<std::string> runWarnings(const nlohmann::json& pair, int frames);

// The bias^2 / variance split of a pair's error over the scene's input seeds: the denoiser runs on
// every seed's sequence from a reset history; the evaluation splits the K outputs per frame.
nlohmann::json biasVarianceOf(const RunConfig& config, const SceneData& scene, const std::vector<SeedSequence>& seeds,
                              const DenoiserRequest& request);

}  // namespace arena
