#include "harness/scene_selection.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "core/error.hpp"
#include "core/sequence.hpp"

namespace arena::cli {

namespace fs = std::filesystem;

std::pair<int, int> parseResolution(const std::string& option, const std::string& text) {
  const std::string expected = option + " '" + text +
                               "': expected WIDTHxHEIGHT, two integers in [1, " +
                               std::to_string(kMaxSceneResolution) + "]";
  size_t x = text.find('x');
  if (x == std::string::npos) throw Error(expected);
  auto side = [&](const std::string& digits) {
    if (digits.empty() || digits.size() > 6 ||
        digits.find_first_not_of("0123456789") != std::string::npos)
      throw Error(expected);
    int v = std::stoi(digits);
    if (v < 1 || v > kMaxSceneResolution) throw Error(expected);
    return v;
  };
  return {side(text.substr(0, x)), side(text.substr(x + 1))};
}

// Unset overrides are 0 (or -1): the CLI checks below reject those values when given explicitly, so
// "0" can never quietly mean "the default".
RenderSettings RenderOptions::settings() const {
  RenderSettings s = RenderSettings::fromPreset(preset);
  if (!resolution.empty())
    std::tie(s.width, s.height) = parseResolution("--resolution", resolution);
  if (frames > 0) s.frames = frames;
  if (referenceSpp > 0) {
    s.referenceSpp = referenceSpp;
    s.referenceMinSpp = std::min(s.referenceMinSpp, referenceSpp);
  }
  if (referenceRelError >= 0) s.referenceRelError = referenceRelError;
  s.maxBounces = maxBounces;
  if (inputSeed < 0 || inputSeed > 0xffffffffll)
    throw Error("--input-seed " + std::to_string(inputSeed) + ": expected 0 to 4294967295");
  s.inputSeed = uint32_t(inputSeed);
  s.referenceSampler = referenceSampler;
  s.referenceTile = referenceTile;
  if (lowresFactor < 0 || lowresFactor == 1)
    throw Error("--lowres-factor " + std::to_string(lowresFactor) + ": expected 0 (none) or a block size >= 2");
  if (lowresSpp < 1 || lowresSpp > 4096)
    throw Error("--lowres-spp " + std::to_string(lowresSpp) + ": expected a count in [1, 4096]");
  s.lowresFactor = lowresFactor;
  s.lowresSpp = lowresSpp;
  return s;
}

CLI::Validator finiteRange(double lo, double hi) {
  const std::string range =
      "[" + CLI::detail::to_string(lo) + ", " + CLI::detail::to_string(hi) + "]";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(text, v) || !std::isfinite(v) || v < lo || v > hi)
          return "value " + text + " is not a finite number in " + range;
        return "";
      },
      "FLOAT in " + range);
}

void requireFitsInMemory(const Scene& scene, const RenderSettings& settings, bool wholeSequence) {
  auto floatsPerPixel = [](const std::vector<LayerSpec>& specs) {
    double n = 0;
    for (const LayerSpec& l : specs) n += l.channels();
    return n;
  };
  const double pixels = double(settings.resolvedWidth(scene)) * settings.resolvedHeight(scene);
  const double frameFloats = floatsPerPixel(channels::frameLayers());
  const double referenceFloats = floatsPerPixel(channels::referenceLayers());
  // Rendering holds a frame, its gradients and a reference with its accumulators (about twice the
  // layers); a run holds every frame of the sequence and its references at once.
  double bytes = 4.0 * pixels * 2.0 *
                 (frameFloats + referenceFloats + floatsPerPixel(channels::gradientLayers()));
  if (wholeSequence)
    bytes += 4.0 * pixels * settings.resolvedFrames(scene) * (frameFloats + referenceFloats);
  const double physical = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGESIZE));
  if (physical > 0 && bytes > physical) {
    char buf[512];
    std::snprintf(
        buf, sizeof buf,
        "%s: %dx%d x %d frames needs about %.1f GiB of memory, more than this machine's %.1f GiB; "
        "lower --resolution or --frames",
        scene.file.c_str(), settings.resolvedWidth(scene), settings.resolvedHeight(scene),
        settings.resolvedFrames(scene), bytes / double(1u << 30), physical / double(1u << 30));
    throw Error(buf);
  }
}

std::vector<std::string> shortSequenceWarnings(const std::vector<Scene>& scenes,
                                               const RenderSettings& settings, int warmup) {
  std::vector<std::string> out;
  for (const Scene& scene : scenes) {
    const int frames = settings.resolvedFrames(scene);
    if (frames <= warmup)
      out.push_back(scene.file + ": the sequence has " + std::to_string(frames) +
                    " frames and the warm-up excludes the first " + std::to_string(warmup) +
                    ": no frame is left to summarise, every summary of this scene will be absent "
                    "(render more frames with --frames or lower --warmup)");
  }
  return out;
}

void addRenderOptions(CLI::App* cmd, RenderOptions& o) {
  cmd->add_option("--preset", o.preset,
                  "quick (the scene's resolution) or paper (1280x720, 4096 spp)")
      ->check(CLI::IsMember({"quick", "paper"}))
      ->default_str("quick");
  cmd->add_option("--resolution", o.resolution, "Override the resolution, WIDTHxHEIGHT")
      ->default_str("the scene's; paper: 1280x720");
  cmd->add_option("--frames", o.frames, "Override the frame count")
      ->check(CLI::Range(1, kMaxSceneFrames))
      ->default_str("the scene's");
  cmd->add_option("--ref-spp", o.referenceSpp, "Maximum samples per pixel of the references")
      ->check(CLI::Range(1, 1 << 20))
      ->default_str("quick: 512, paper: 4096");
  cmd->add_option("--ref-rel-error", o.referenceRelError,
                  "Adaptive stopping: stop a reference when its estimated relative error is below "
                  "this (0: off)")
      ->check(finiteRange(0.0, 1.0))
      ->default_str("quick: 0.01, paper: 0");
  cmd->add_option("--max-bounces", o.maxBounces, "Override the scene's maximum path length")
      ->check(CLI::Range(1, 64))
      ->default_str("the scene's");
  cmd->add_option("--input-seed", o.inputSeed,
                  "Another noise realisation of the 1-spp input (0: the scene's seed); references are unchanged")
      ->default_val(0);
  cmd->add_option("--ref-sampler", o.referenceSampler,
                  "References' sampler: sobol (Owen-scrambled, default) or independent (1-spp frames: always independent)")
      ->check(CLI::IsMember({"sobol", "independent"}));
  cmd->add_option("--ref-tile", o.referenceTile,
                  "Adaptive allocation of reference samples per tile of this many pixels square, "
                  "toward --ref-rel-error (0: one tile, every pixel the same count)")
      ->check(CLI::Range(0, 1024))
      ->default_val(8);
  cmd->add_option("--lowres-factor", o.lowresFactor,
                  "Also render a low-resolution, many-sample buffer per frame, one texel per FxF block "
                  "(CAPCOM 2023 disocclusion rays; 0: none)");
  cmd->add_option("--lowres-spp", o.lowresSpp, "Paths per low-resolution texel (default 16)");
  cmd->add_option("--cache", o.cacheDir, "Sequence cache directory")->default_val("cache");
  cmd->add_option("--scenes-dir", o.scenesDir, "Directory of scene files")
      ->default_str(o.scenesDir);
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
    if (!fs::exists(p))
      throw Error("scene '" + item + "' not found (looked for " + p.string() +
                  "; see `arena scenes`)");
    out.push_back(loadScene(p.string()));
  }
  if (out.empty()) throw Error("no scenes selected");
  // Results, images and caches are keyed by the scene's name (its file stem): two files with one
  // stem would overwrite each other's pairs.
  for (size_t i = 0; i < out.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (out[i].name == out[j].name)
        throw Error("scenes " + out[j].file + " and " + out[i].file + " share the name '" +
                    out[i].name + "' (the file stem); a run needs distinct names");
  return out;
}

}  // namespace arena::cli
