#pragma once
// Shared CLI options for anything that renders: preset, overrides and the cache location.
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "tracer/render.hpp"
#include "tracer/scene.hpp"

namespace arena::cli {

struct RenderOptions {
  std::string preset = "quick";
  std::string resolution;  // WxH
  int frames = 0;
  int referenceSpp = 0;
  double referenceRelError = -1;
  int maxBounces = 0;
  long long inputSeed = 0;
  std::string referenceSampler = "sobol";
  int referenceTile = 8;                 // adaptive allocation tile (0: one tile, uniform)
  int lowresFactor = 0, lowresSpp = 16;  // CAPCOM 2023 low-resolution buffer (0: none)
  std::string cacheDir = "cache";
  std::string scenesDir = defaultScenesDir();
  RenderSettings settings() const;
};
void addRenderOptions(CLI::App* cmd, RenderOptions& options);

// "WxH" with both sides in [1, kMaxSceneResolution]; errors name `option` and the text.
std::pair<int, int> parseResolution(const std::string& option, const std::string& text);
// A CLI check: a finite number in [lo, hi] (CLI::Range lets "nan" through).
CLI::Validator finiteRange(double lo, double hi);
// Throws, naming the scene file, resolution and frames, when rendering it (or, with
// `wholeSequence`, running denoisers on it: every frame is held in memory) needs more memory than
// the machine has -- a clear error instead of std::bad_alloc halfway through.
void requireFitsInMemory(const Scene& scene, const RenderSettings& settings, bool wholeSequence);

// One line per scene whose sequence (as `settings` render it) has no frame after the warm-up: every
// summary of its pairs will be absent (metrics.md W). Said before any work, so that a --frames or
// --warmup slip costs a second, not a run.
std::vector<std::string> shortSequenceWarnings(const std::vector<Scene>& scenes,
                                               const RenderSettings& settings, int warmup);

// "all", or comma-separated scene names (looked up in scenesDir) or paths to .json files.
std::vector<Scene> selectScenes(const std::string& list, const std::string& scenesDir);

}  // namespace arena::cli
