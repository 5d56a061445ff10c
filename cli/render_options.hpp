#pragma once
// The options every rendering command shares (preset, overrides, cache location) and their CLI11
// declarations; RenderOptions::settings() turns them into the library's RenderSettings.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
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
// A JSON file `writer` (a bench, "bench gpu-model") writes when its work is done (--json),
// refused before the work (a benchmark's minutes were lost to a late error): an empty name, "-"
// (standard output is not written here), a folder, a device, pipe or socket, a path through a
// file, a folder in which no file can be created, and an existing file that the writer did not
// write (no `"arenaBench": writer` in it: a run's results.json and /dev/full were replaced).
CLI::Validator writableFile(const std::string& writer);
// Writes `out` atomically to `path` with the mark writableFile looks for.
void writeMarkedJson(const std::string& path, const std::string& writer, nlohmann::json out);
// A CLI check for --lowres-factor: 0 (no buffer) or a block size in [2, max] (1 would be the frame
// itself, which no buffer needs to repeat).
CLI::Validator lowresFactorCheck(int max);

}  // namespace arena::cli
