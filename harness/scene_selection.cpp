#include "harness/scene_selection.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>

#include "core/error.hpp"
#include "core/sequence.hpp"
#include "core/text.hpp"

namespace arena {

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

void requireRenderable(const Scene& scene, const RenderSettings& settings, bool wholeSequence) {
  const int bounces = settings.resolvedMaxBounces(scene);
  if (scene.referenceEstimator == ReferenceEstimator::Bidirectional &&
      bounces > kMaxBidirectionalBounces)
    throw Error(scene.file + ": --max-bounces " + std::to_string(bounces) +
                ": its references are bidirectional, which hold at most " +
                std::to_string(kMaxBidirectionalBounces) + " bounces");
  requireFitsInMemory(scene, settings, wholeSequence);
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

std::string shortSequenceText(int frames, int warmup, bool capture) {
  if (frames > warmup + kFewSummarisedFrames) return "";
  // What the user can change: a scene's frames, a capture's warm-up only (its frames are what it
  // holds); a warm-up of 0 cannot be lowered.
  const std::string remedy =
      capture ? (warmup > 0 ? "lower --warmup; a capture's frames are what it holds"
                            : "a capture's frames are what it holds: capture more")
              : (warmup > 0 ? "render more frames with --frames or lower --warmup"
                            : "render more frames with --frames");
  if (frames > warmup) {
    const int n = frames - warmup;
    return "only " + std::to_string(n) + (n == 1 ? " frame follows" : " frames follow") +
           " the warm-up of " + std::to_string(warmup) +
           ": the intervals resample so few frames that they hardly cover how a method varies "
           "from frame to frame, and differences resolved on them are fragile (" +
           remedy + "; " + std::to_string(kFewSummarisedFrames + 1) + " or more frames after it)";
  }
  return "the sequence has " + std::to_string(frames) +
         " frames and the warm-up excludes the first " + std::to_string(warmup) +
         ": no frame is left to summarise, every summary of this sequence will be absent (" +
         remedy + ")";
}

std::string shortSequenceWarning(const std::string& source, int frames, int warmup, bool capture) {
  if (frames > warmup) return "";  // few frames: said with the results (shortSequenceText)
  return source + ": " + shortSequenceText(frames, warmup, capture);
}

std::string tinyImageWarning(const std::string& source, int width, int height) {
  if (std::min(width, height) >= 16) return "";
  return source + ": " + std::to_string(width) + "x" + std::to_string(height) +
         " is too small to measure much: the statistics' 4x4 tiles hold a few pixels each" +
         (std::min(width, height) < 11 ? ", SSIM's 11x11 window is larger than the image" : "") +
         (height < 16 ? ", and under the default scaled footprint the à-trous filters skip most of "
                        "their iterations"
                      : "") +
         " (a smoke test, not a ranking)";
}

std::vector<std::string> shortSequenceWarnings(const std::vector<Scene>& scenes,
                                               const RenderSettings& settings, int warmup) {
  std::vector<std::string> out;
  for (const Scene& scene : scenes)
    if (std::string w = tinyImageWarning(scene.file, settings.resolvedWidth(scene),
                                         settings.resolvedHeight(scene));
        !w.empty())
      out.push_back(std::move(w));
  for (const Scene& scene : scenes)
    if (std::string w =
            shortSequenceWarning(scene.file, settings.resolvedFrames(scene), warmup, false);
        !w.empty())
      out.push_back(std::move(w));
  return out;
}

std::vector<std::string> splitList(const std::string& list, const std::string& what,
                                   const std::string& expected) {
  // At commas outside brackets: a sweep's label holds its own ("svgf[edge.normal=true,sigmaL=2]").
  std::vector<std::string> out;
  size_t start = 0;
  int depth = 0;
  for (size_t i = 0; i < list.size(); ++i) {
    depth += list[i] == '[' ? 1 : list[i] == ']' && depth > 0 ? -1 : 0;
    if (list[i] == ',' && depth == 0) {
      out.push_back(list.substr(start, i - start));
      start = i + 1;
    }
  }
  out.push_back(list.substr(start));
  // Spaces around an entry are the writer's layout ("[2, 4]"), not part of a name or a value.
  for (std::string& item : out) item = trimmed(item);
  for (const std::string& item : out)
    if (item.empty())
      throw Error(what + " '" + list +
                  "': " + (list.empty() ? "empty" : "an empty entry (a comma too many)") +
                  "; expected " + expected);
  return out;
}

std::vector<Scene> selectScenes(const std::string& list, const std::string& scenesDir,
                                const std::string& what) {
  std::vector<Scene> out;
  if (list == "all") {
    for (const std::string& f : listSceneFiles(scenesDir)) out.push_back(loadScene(f));
    return out;
  }
  for (const std::string& item : splitList(
           list, what, "scene names (`arena scenes`) or .json paths, comma-separated, or 'all'")) {
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
      if (out[i].name == out[j].name &&
          fs::weakly_canonical(out[i].file) == fs::weakly_canonical(out[j].file))
        throw Error(what + " '" + list + "': scene '" + out[i].name + "' is listed twice");
      else if (out[i].name == out[j].name)
        throw Error("scenes " + out[j].file + " and " + out[i].file + " share the name '" +
                    out[i].name + "' (the file stem); a run needs distinct names");
  return out;
}

}  // namespace arena
