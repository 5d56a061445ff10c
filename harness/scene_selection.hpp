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
  int lowresFactor = 0, lowresSpp = 16;  // CAPCOM 2023 low-resolution buffer (0: none)
  std::string cacheDir = "cache";
  std::string scenesDir = defaultScenesDir();
  RenderSettings settings() const;
};
void addRenderOptions(CLI::App* cmd, RenderOptions& options);

// "all", or comma-separated scene names (looked up in scenesDir) or paths to .json files.
std::vector<Scene> selectScenes(const std::string& list, const std::string& scenesDir);

}  // namespace arena::cli
