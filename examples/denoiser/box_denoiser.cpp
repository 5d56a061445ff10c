// `box`: the worked example of docs/extending.md -- a built-in-style denoiser in one file. A box
// filter over the (2 radius + 1)^2 window that averages only the pixels of the same mesh (a
// crude edge-stopping term); sky pixels (meshId -1) pass through. It is not registered in the
// arena: tests/variants_test.cpp puts it through the same contract tests as every
// registered variant, so the example keeps compiling and keeps the Denoiser contract. Like every
// spatial built-in it takes the footprint policy (denoisers/common/footprint.hpp): its radius is
// in pixels at `footprintHeight` lines, scaled with the image. To make it a built-in, follow
// docs/extending.md: copy it to denoisers/box.cpp and rename exampleBoxInfo() to boxInfo() there
// (the tests build this file under its own name), declare boxInfo() in denoisers/variants.hpp and
// add it to builtinDenoisers() there.
#include <algorithm>
#include <cmath>

#include "denoisers/common/footprint.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/denoiser.hpp"
#include "denoisers/param_table.hpp"

namespace arena {

namespace {

// Set from boxParams() below, which declares each default, range and meaning once.
struct BoxSettings {
  int radius;           // pixels at footprint.referenceHeight lines
  Footprint footprint;  // the shared policy: `footprint`, `footprintHeight`
};

class BoxDenoiser final : public Denoiser {
 public:
  explicit BoxDenoiser(const BoxSettings& settings) : settings_(settings) {}

  // The harness checks these layers are in the sequence before the first frame.
  std::vector<std::string> requiredChannels() const override { return {"meshId"}; }
  // No buffers (the filter keeps no history); the radius in this image's pixels, at least one
  // where the setting is, so that the filter never vanishes (as the first à-trous step).
  void setup(int, int height) override {
    radius_ = radiusAt(height);
    radius1080_ = radiusAt(1080);  // the window a 1080p frame runs, which the GPU count prices
  }
  void reset() override {}

  void denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) override {
    const int r = radius_, w = ctx.width, h = ctx.height;
    const Image& meshId = in.frame.get("meshId");
    const double taps = double((2 * r + 1) * (2 * r + 1));
    ScopedPass pass(this, "box", taps);  // timed; taps per pixel
    // What a GPU would move for this pass (docs/gpu-cost.md): one dispatch of a thread per pixel,
    // each reading the window's signal and mesh ids and writing its output. Without these lines
    // the run has no predicted GPU time for the denoiser (the speed chart's GPU axis). The taps are
    // the 1080p window's, which the prediction prices (a small image's shrunk window would
    // underprice it: gpu-cost.md, section 7).
    const double taps1080 = double((2 * radius1080_ + 1) * (2 * radius1080_ + 1));
    gpu::dispatch(w, h);
    gpu::read({gpu_buffers::kSignal, gpu_buffers::kMeshId}, w, h, taps1080);
    gpu::write(gpu_buffers::kRadiance, w, h);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const float id = meshId.at(x, y);
        float sum[3] = {0, 0, 0}, weight = 0;
        for (int j = std::max(0, y - r); j <= std::min(h - 1, y + r); ++j)
          for (int i = std::max(0, x - r); i <= std::min(w - 1, x + r); ++i) {
            if (meshId.at(i, j) != id || (id < 0 && (i != x || j != y))) continue;  // sky: itself only
            for (int c = 0; c < 3; ++c) sum[c] += in.signal.at(i, j, c);
            weight += 1;
          }
        for (int c = 0; c < 3; ++c) output.at(x, y, c) = sum[c] / weight;  // the centre always counts
      }
  }

 private:
  // The radius in pixels of an image `height` lines high: at least one where the setting is.
  int radiusAt(int height) const {
    const float r = float(settings_.radius) * settings_.footprint.scale(height);
    return settings_.radius == 0 ? 0 : std::max(1, int(std::lround(r)));
  }

  BoxSettings settings_;
  int radius_ = 0;      // this image's pixels (setup)
  int radius1080_ = 0;  // a 1080-line image's
};

const ParamTable<BoxSettings>& boxParams() {
  using S = BoxSettings;
  static const ParamTable<S> table =
      ParamTable<S>()
          .integer("radius", &S::radius, 8, 0, 64,
                   "half-width of the box window, pixels at footprintHeight lines (0: none)")
          .include(footprintParams(), &S::footprint);
  return table;
}

}  // namespace

DenoiserInfo exampleBoxInfo() {
  DenoiserInfo info{"box", "Box filter within each mesh (the worked example of docs/extending.md)",
                    boxParams().schema(), [](const ParamSet& params, SignalKind) {
                      return std::make_unique<BoxDenoiser>(boxParams().settings(params, "box"));
                    }};
  info.keepsHistory = false;  // each frame alone: its event figures (no lag) are by construction
  return info;
}

}  // namespace arena
