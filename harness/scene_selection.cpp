#include "harness/scene_selection.hpp"

#include <filesystem>
#include <sstream>

#include "core/error.hpp"

namespace arena::cli {

namespace fs = std::filesystem;

RenderSettings RenderOptions::settings() const {
  RenderSettings s = RenderSettings::fromPreset(preset);
  if (!resolution.empty()) {
    int w = 0, h = 0;
    char x = 0;
    std::istringstream in(resolution);
    if (!(in >> w >> x >> h) || x != 'x' || w < 1 || h < 1 || !in.eof())
      throw Error("--resolution: expected WIDTHxHEIGHT with positive integers, got '" + resolution + "'");
    s.width = w;
    s.height = h;
  }
  if (frames < 0) throw Error("--frames: expected a positive count");
  if (frames > 0) s.frames = frames;
  if (referenceSpp < 0) throw Error("--ref-spp: expected a positive count");
  if (referenceSpp > 0) {
    s.referenceSpp = referenceSpp;
    s.referenceMinSpp = std::min(s.referenceMinSpp, referenceSpp);
  }
  if (referenceRelError >= 0) s.referenceRelError = referenceRelError;
  if (maxBounces < 0) throw Error("--max-bounces: expected a positive count");
  s.maxBounces = maxBounces;
  if (inputSeed < 0 || inputSeed > 0xffffffffll)
    throw Error("--input-seed " + std::to_string(inputSeed) + ": expected 0 to 4294967295");
  s.inputSeed = uint32_t(inputSeed);
  s.referenceSampler = referenceSampler;
  if (lowresFactor < 0 || lowresFactor == 1)
    throw Error("--lowres-factor " + std::to_string(lowresFactor) + ": expected 0 (none) or a block size >= 2");
  if (lowresSpp < 1 || lowresSpp > 4096)
    throw Error("--lowres-spp " + std::to_string(lowresSpp) + ": expected a count in [1, 4096]");
  s.lowresFactor = lowresFactor;
  s.lowresSpp = lowresSpp;
  return s;
}

void addRenderOptions(CLI::App* cmd, RenderOptions& o) {
  cmd->add_option("--preset", o.preset, "quick (default; the scene's resolution) or paper (1280x720, 4096 spp)")
      ->check(CLI::IsMember({"quick", "paper"}));
  cmd->add_option("--resolution", o.resolution, "Override the resolution, WIDTHxHEIGHT");
  cmd->add_option("--frames", o.frames, "Override the frame count");
  cmd->add_option("--ref-spp", o.referenceSpp, "Maximum samples per pixel of the references");
  cmd->add_option("--ref-rel-error", o.referenceRelError,
                  "Adaptive stopping: stop a reference when its estimated relative error is below this (0: off)");
  cmd->add_option("--max-bounces", o.maxBounces, "Override the scene's maximum path length");
  cmd->add_option("--input-seed", o.inputSeed,
                  "Another noise realisation of the 1-spp input (0: the scene's seed); references are unchanged")
      ->default_val(0);
  cmd->add_option("--ref-sampler", o.referenceSampler,
                  "References' sampler: sobol (Owen-scrambled, default) or independent (1-spp frames: always independent)")
      ->check(CLI::IsMember({"sobol", "independent"}));
  cmd->add_option("--lowres-factor", o.lowresFactor,
                  "Also render a low-resolution, many-sample buffer per frame, one texel per FxF block "
                  "(CAPCOM 2023 disocclusion rays; 0: none)");
  cmd->add_option("--lowres-spp", o.lowresSpp, "Paths per low-resolution texel (default 16)");
  cmd->add_option("--cache", o.cacheDir, "Sequence cache directory")->default_val("cache");
  cmd->add_option("--scenes-dir", o.scenesDir, "Directory of scene files");
}

std::vector<Scene> selectScenes(const std::string& list, const std::string& scenesDir) {
  std::vector<Scene> out;
  if (list == "all") {
    for (const std::string& f : listSceneFiles(scenesDir)) out.push_back(loadScene(f));
    return out;
  }
  std::stringstream in(list);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (item.empty()) continue;
    fs::path p = item;
    if (p.extension() != ".json") p = fs::path(scenesDir) / (item + ".json");
    if (!fs::exists(p)) throw Error("scene '" + item + "' not found (looked for " + p.string() + "; see `arena scenes`)");
    out.push_back(loadScene(p.string()));
  }
  if (out.empty()) throw Error("no scenes selected");
  return out;
}

}  // namespace arena::cli
