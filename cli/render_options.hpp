#pragma once
// The options every rendering command shares (preset, overrides, cache location) and their CLI11
// declarations; RenderOptions::settings() turns them into the library's RenderSettings.
#include <CLI/CLI.hpp>
#include <string>

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
  // CAPCOM 2023 low-resolution buffer (0: none; -1, unset: the run decides, resolveAutoLowres).
  int lowresFactor = -1, lowresSpp = 16;
  std::string cacheDir = "cache";
  std::string scenesDir = defaultScenesDir();
  RenderSettings settings() const;  // an unset lowresFactor gives 0 here
  bool lowresAuto() const { return lowresFactor < 0; }
};
void addRenderOptions(CLI::App* cmd, RenderOptions& options);

// A CLI check: a finite number in [lo, hi] (CLI::Range lets "nan" through).
CLI::Validator finiteRange(double lo, double hi);
// A file an option writes when the work is done (--json): refused before the work when it is a
// folder, or a folder on its path is a file (a benchmark's minutes were lost to a late error).
CLI::Validator writableFile();
// A CLI check for --lowres-factor: 0 (no buffer) or a block size in [2, max] (1 would be the frame
// itself, which no buffer needs to repeat).
CLI::Validator lowresFactorCheck(int max);

}  // namespace arena::cli
