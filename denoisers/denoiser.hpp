#pragma once
// The one interface every denoiser implements (OIDN's filter: set up, then execute per frame).
// A denoiser filters one *signal* -- demodulated diffuse or specular radiance -- frame by frame and
// keeps its own history; the harness runs one instance per signal and remodulates
// (albedo * diffuse + specAlbedo * specular + emission).
#include <chrono>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/camera.hpp"
#include "core/exr_io.hpp"
#include "core/image.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/params.hpp"

namespace arena {

// Color: the remodulated colour, for denoisers that declare SignalMode::Color (external ones).
enum class SignalKind { Diffuse, Specular, Color };
// "diffuse" / "specular" / "color": also the frame layer's name.
const char* signalName(SignalKind kind);

// What one instance filters. Demodulated: one instance per diffuse and specular signal, and the
// harness remodulates. Color: one instance on the frame's colour; its output is the final image.
enum class SignalMode { Demodulated, Color };

// Per-frame state shared by every denoiser (NRD's CommonSettings).
struct FrameContext {
  int frameIndex = 0;
  int width = 0, height = 0;
  CameraState camera, previousCamera;
  bool reset = false;  // history must be discarded (first frame, camera cut)
};

// Inputs by name. `signal` is the noisy demodulated RGB signal to filter; `frame` holds the
// sequence's layers for this frame (depth, normal, position, motion, meshId, roughness,
// specHitDist, albedo, ... -- see core/sequence.hpp); `gradients` the A-SVGF gradient samples
// (nullptr on frame 0 or when the denoiser does not ask for them).
// The sequence's optional low-resolution, many-sample buffer (core/sequence.hpp lowresLayers():
// texel (i, j) shades full-resolution pixel lowresAnchor(i, factor, width), ...).
struct LowresInputs {
  const LayerSet& layers;
  int factor = 0, spp = 0;
};

struct DenoiserInputs {
  const Image& signal;
  const LayerSet& frame;
  const LayerSet* gradients = nullptr;
  const LowresInputs* lowres = nullptr;  // when the denoiser wants it and the sequence has it
};

// Wall time and neighbour fetches of one pass in the last frame.
struct PassStats {
  std::string name;
  double milliseconds = 0;
  double tapsPerPixel = 0;  // neighbour fetches per pixel (the talk's "fetch / pixel")
  // Paths per full-resolution pixel this pass read from the low-resolution buffer (texels read x
  // their spp / pixels): the disocclusion rays a denoiser is charged for beyond the 1-spp frame.
  double raysPerPixel = 0;
  // What a GPU implementation of the pass would move (common/gpu_traffic.hpp), counted by the
  // shared blocks while the pass ran; empty for a pass a GPU does not dispatch (a history swap).
  PassTraffic traffic;
};

class Denoiser {
 public:
  virtual ~Denoiser() = default;
  // Layers of the sequence frame this denoiser reads; the harness checks them before running.
  virtual std::vector<std::string> requiredChannels() const = 0;
  virtual bool needsGradients() const { return false; }
  // Reads the sequence's low-resolution buffer when it has one (DenoiserInputs::lowres).
  virtual bool wantsLowres() const { return false; }
  // Cannot run without that buffer (implies wantsLowres): a run rendering none is refused up front.
  virtual bool needsLowres() const { return false; }
  // Allocates every buffer (history included) for this resolution; not timed.
  virtual void setup(int width, int height) = 0;
  // Clears the history (camera cut).
  virtual void reset() = 0;
  // Filters ctx.frameIndex's signal into `output` (already allocated: width x height x 3).
  virtual void denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) = 0;

  // The compute time of the last frame as the denoiser measured it itself (an external process
  // reports its own); nullopt means the harness's wall clock around denoise() is its time.
  virtual std::optional<double> reportedMilliseconds() const { return std::nullopt; }

  const std::vector<PassStats>& lastPasses() const { return passes_; }
  void clearPassStats() { passes_.clear(); }

 protected:
  // Times one pass: `ScopedPass pass(this, "atrous 1", 25);` records wall time on destruction,
  // and the GPU traffic the shared blocks report while it lives.
  class ScopedPass {
   public:
    ScopedPass(Denoiser* owner, std::string name, double tapsPerPixel)
        : owner_(owner), name_(std::move(name)), taps_(tapsPerPixel), scope_(&traffic_),
          start_(std::chrono::steady_clock::now()) {}
    ~ScopedPass() {
      double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start_).count();
      owner_->passes_.push_back({name_, ms, taps_, rays_, std::move(traffic_)});
    }
    void setTaps(double taps) { taps_ = taps; }
    void setRays(double raysPerPixel) { rays_ = raysPerPixel; }
    ScopedPass(const ScopedPass&) = delete;
    ScopedPass& operator=(const ScopedPass&) = delete;

   private:
    Denoiser* owner_;
    std::string name_;
    double taps_;
    double rays_ = 0;
    PassTraffic traffic_;
    TrafficScope scope_;
    std::chrono::steady_clock::time_point start_;
  };

  std::vector<PassStats> passes_;
};

// The registry: a name -> factory + typed parameter schema.
struct DenoiserInfo {
  std::string name;
  std::string description;  // one line: what it is and its source
  ParamSchema schema;
  std::function<std::unique_ptr<Denoiser>(const ParamSet&, SignalKind)> create;
  SignalMode signals = SignalMode::Demodulated;
  std::string origin;  // where it came from: empty for built-ins, else the manifest or library
  // Its output is its input signal unchanged (passthrough): on a capture of the colour alone it
  // runs on the colour, the same image its remodulated signals give where the parts exist.
  bool identity = false;
  // false: each frame is filtered alone, with no state carried between frames (passthrough, a
  // spatial filter). An event's lag and a cut's jump are then nothing it can show: the run records
  // it (pairs[].keepsHistory false) and the report marks none of those figures best for it.
  bool keepsHistory = true;
};

class DenoiserRegistry {
 public:
  static const DenoiserRegistry& instance();
  // Throws an Error listing the registered names when `name` is unknown.
  const DenoiserInfo& find(const std::string& name) const;
  bool has(const std::string& name) const;
  std::vector<std::string> names() const;  // in registration order
  void add(DenoiserInfo info);
  // Resolves one `--denoisers` entry: a registered name, "ext:MANIFEST" (a manifest file, a
  // directory holding manifest.json, or a name searched on ARENA_DENOISER_PATH) or
  // "plugin:LIBRARY". External ones are loaded once and registered under their own name, which
  // is returned (denoisers/external/loader.cpp).
  static std::string resolve(const std::string& entry);

 private:
  std::deque<DenoiserInfo> infos_;  // a deque: references stay valid as external ones are added
};

}  // namespace arena
