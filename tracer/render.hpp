#pragma once
// Turns a scene into a cached sequence (core/sequence.hpp): per frame the noise-free G-buffer, the
// 1-spp signals and A-SVGF gradient samples; per distinct animation state a converged reference
// with the variance of its mean. Writes are atomic, renders resume, and every cached file carries
// the hash of the scene and settings that produced it, so nothing stale or foreign is trusted.
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "core/exr_io.hpp"
#include "tracer/tracer.hpp"

namespace arena {

struct RenderSettings {
  std::string preset = "quick";
  int width = 0, height = 0;   // 0: the scene's own resolution
  int frames = 0;              // 0: the scene's own frame count
  int referenceSpp = 1024;     // maximum samples per pixel of a reference
  int referenceMinSpp = 64;    // adaptive stopping never stops before this
  double referenceRelError = 0;  // > 0: stop when the reference's estimated relMSE <= this^2
  int maxBounces = 0;          // 0: the scene's own
  // 0: the scene's seed. Otherwise the 1-spp frames and gradient samples are another noise
  // realisation of the same sequence (`arena run --seeds K`, compare's noise test); references do
  // not depend on it.
  uint32_t inputSeed = 0;

  // Presets: quick (the scene's resolution, references of 64-512 spp with adaptive stopping) and paper
  // (1280x720, 4096 spp references).
  static RenderSettings fromPreset(const std::string& name);
  // The settings that change pixels, for the cache hash and sequence.json.
  nlohmann::json pixelSettings(const Scene& scene) const;
  int resolvedWidth(const Scene& s) const { return width > 0 ? width : s.width; }
  int resolvedHeight(const Scene& s) const { return height > 0 ? height : s.height; }
  int resolvedFrames(const Scene& s) const { return frames > 0 ? frames : s.frames; }
};

std::string sequenceHash(const Scene& scene, const RenderSettings& settings);
std::filesystem::path sequenceDir(const Scene& scene, const RenderSettings& settings,
                                  const std::filesystem::path& cacheRoot);

// Renders one scene frame by frame, keeping the Embree scenes of the current and previous frame.
class SequenceRenderer {
 public:
  SequenceRenderer(const Scene& scene, const RenderSettings& settings);
  ~SequenceRenderer();

  int width() const { return width_; }
  int height() const { return height_; }
  int frames() const { return frames_; }
  const Scene& scene() const { return scene_; }

  struct FrameResult {
    LayerSet frame;      // core/sequence.hpp channels::frameLayers()
    LayerSet gradients;  // frames >= 1: channels::gradientLayers()
    RayCounts counts;
  };
  FrameResult renderFrame(int t);
  // A reference for the animation state of frame t; `spp` receives the samples used.
  LayerSet renderReference(int t, int& spp, RayCounts& counts);
  uint64_t stateHash(int t) const;
  const FrameScene& frameScene(int t);

 private:
  Scene scene_;  // a copy, with settings (bounces) applied
  RenderSettings settings_;
  // The seed of the 1-spp frame and gradient samples (RenderSettings::inputSeed).
  uint32_t frameSeed() const;
  int width_, height_, frames_;
  EmbreeDevice device_;
  std::vector<MeshData> meshes_;
  std::map<int, std::unique_ptr<FrameScene>> cache_;
};

using ProgressFn = std::function<void(const std::string& line)>;

// Renders (or resumes) the sequence into <cacheRoot>/<scene>-<hash>/ and returns that directory.
std::filesystem::path renderSequence(const Scene& scene, const RenderSettings& settings,
                                     const std::filesystem::path& cacheRoot, const ProgressFn& progress);

}  // namespace arena
