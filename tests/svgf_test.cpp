// Issue 15, item 5: the colour of a young history. Falcor's SVGFFilterMoments replaces, while
// h < 4, not only the variance but also the colour by the 7x7 bilateral mean (same weights); the
// SVGF paper estimates only the variance spatially. `youngColor=spatial` is Falcor's,
// `youngColor=accumulated` (default, measured below) the paper's. Here (the block against its
// per-pixel definition is in denoisers_common_test.cpp): the denoiser's frame-0 output, and the
// relMSE on freshly disoccluded pixels (h <= 2) of camera_pan_occluder and moving_object at 96x54
// (24 frames, 64-spp references), frames >= 4.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "denoisers/svgf.hpp"
#include "harness/denoise_run.hpp"
#include "metrics/error.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using Params = std::map<std::string, std::string>;

Image noiseImage(int w, int h, int channels, uint32_t seed, float scale) {
  Image image(w, h, channels);
  for (int c = 0; c < channels; ++c)
    for (size_t i = 0; i < image.pixelCount(); ++i)
      image.plane(c)[i] = scale * test::hashUniform(seed, uint32_t(i), uint32_t(c));
  return image;
}

// Frame 0 (every pixel young) without à-trous: the output is the colour entering the à-trous.
// With `spatial` it is the 7x7 bilateral mean (the spread of i.i.d. noise drops well below the
// input's); with `accumulated` it is the input itself.
TEST(FidelitySvgf, YoungColourOptionDecidesWhatTheAtrousStartsFrom) {
  const int w = 32, h = 24;
  const LayerSet frame = test::planeFrame(w, h);
  const Image signal = noiseImage(w, h, 3, 11, 2.0f);
  auto spread = [&](const Image& image) {
    double sum = 0, sumSquares = 0;
    for (float v : image.raw()) {
      sum += v;
      sumSquares += double(v) * v;
    }
    const double n = double(image.raw().size());
    return std::sqrt(std::max(0.0, sumSquares / n - (sum / n) * (sum / n)));
  };
  for (const std::string name : {"svgf", "asvgf", "slgf"}) {
    for (const std::string mode : {"spatial", "accumulated"}) {
      auto denoiser = test::createDenoiser(
          name, {{"iterations", "0"}, {"feedbackTap", "0"}, {"youngColor", mode}});
      denoiser->setup(w, h);
      Image output(w, h, 3);
      denoiser->denoise(test::stillCameraContext(0, w, h), {signal, frame, nullptr}, output);
      if (mode == "accumulated") {
        EXPECT_TRUE(samePixels(output, signal)) << name;
      } else {
        // Uniform noise: a 49-tap mean of near-equal weights has ~1/7 of the spread.
        EXPECT_LT(spread(output), 0.25 * spread(signal)) << name;
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// relMSE on freshly disoccluded pixels

constexpr int kWidth = 96, kHeight = 54, kFrames = 24, kReferenceSpp = 64, kWarmup = 4;

struct Rendered {
  Sequence sequence;
  std::vector<LayerSet> frames, references;
};

const Rendered& rendered(const std::string& scene) {
  static std::map<std::string, std::unique_ptr<Rendered>> cache;
  auto it = cache.find(scene);
  if (it != cache.end()) return *it->second;
  static const fs::path dir = test::freshDir("fidelity_svgf_cache");
  const fs::path seq =
      renderSequence(test::shippedScene(scene),
                     test::tinySettings(kWidth, kHeight, kFrames, kReferenceSpp), dir, nullptr);
  auto r = std::make_unique<Rendered>(Rendered{Sequence::open(seq), {}, {}});
  for (int t = 0; t < kFrames; ++t) {
    r->frames.push_back(r->sequence.frame(t));
    r->references.push_back(r->sequence.reference(t));
  }
  return *cache.emplace(scene, std::move(r)).first->second;
}

// The history length SVGF's reprojection gives every pixel of every frame (it depends on the
// G-buffer only, not on the signal or on youngColor).
std::vector<Image> historyLengths(const Rendered& r) {
  auto denoiser = test::createDenoiser("svgf", {{"iterations", "0"}, {"feedbackTap", "0"}});
  auto* svgf = dynamic_cast<Svgf*>(denoiser.get());
  denoiser->setup(kWidth, kHeight);
  std::vector<Image> lengths;
  Image output(kWidth, kHeight, 3);
  for (int t = 0; t < kFrames; ++t) {
    FrameContext ctx;
    ctx.frameIndex = t;
    ctx.width = kWidth;
    ctx.height = kHeight;
    ctx.camera = r.sequence.info().cameras[size_t(t)];
    ctx.previousCamera = r.sequence.info().cameras[size_t(std::max(t - 1, 0))];
    ctx.reset = t == 0;
    const LayerSet& frame = r.frames[size_t(t)];
    denoiser->denoise(ctx, {frame.get("diffuse"), frame, nullptr}, output);
    lengths.push_back(svgf->lastHistoryLength());
  }
  return lengths;
}

struct MaskedError {
  double relMse[3] = {0, 0, 0};  // colour, diffuse, specular, pooled over the masked pixels
  long pixels = 0;
};

// relMSE (metrics.md) over the pixels of frames >= kWarmup whose h <= maxLength.
MaskedError disoccludedError(const std::string& scene, const std::string& name,
                             const Params& params, float maxLength) {
  const Rendered& r = rendered(scene);
  const std::vector<Image> lengths = historyLengths(r);
  MaskedError out;
  double sums[3] = {0, 0, 0};
  DenoiseRun run({name, params, name}, r.sequence);
  run.run([&](int t) -> const LayerSet& { return r.frames[size_t(t)]; },
          [&](const DenoisedFrame& f) {
            if (f.frame < kWarmup) return;
            const Image& length = lengths[size_t(f.frame)];
            Image mask(kWidth, kHeight, 1);
            long count = 0;
            for (size_t i = 0; i < mask.pixelCount(); ++i) {
              const bool fresh = length.plane(0)[i] <= maxLength &&
                                 r.frames[size_t(f.frame)].get("meshId").plane(0)[i] >= 0.0f;
              mask.plane(0)[i] = fresh ? 1.0f : 0.0f;
              count += fresh;
            }
            if (count == 0) return;
            const LayerSet& reference = r.references[size_t(f.frame)];
            const Image* denoised[3] = {&f.color, &f.diffuse, &f.specular};
            const char* layer[3] = {"color", "diffuse", "specular"};
            for (int k = 0; k < 3; ++k)
              sums[k] += double(count) *
                         linearError(*denoised[k], reference.get(layer[k]), nullptr, &mask).relMse;
            out.pixels += count;
          });
  for (int k = 0; k < 3; ++k) out.relMse[k] = sums[k] / double(std::max(out.pixels, 1L));
  return out;
}

// The young colour was chosen (accumulated, the paper) under the native footprint policy, where
// Falcor's spatial mean raised the disoccluded pixels' relMSE on both scenes. Under the default
// policy (scaled, issue 15 item 1: at 54 lines one or two à-trous iterations are left) it still
// does on moving_object (0.0114 accumulated vs 0.0289 spatial, svgf h <= 2) but halves it on
// camera_pan_occluder (0.0050 vs 0.0022): pinned per policy, so either change is seen.
TEST(FidelitySvgf, DisoccludedPixelErrorWithAndWithoutTheYoungColour) {
  for (const std::string policy : {"native", "scaled"}) {
    for (const std::string scene : {"camera_pan_occluder", "moving_object"}) {
      for (const std::string name : {"svgf", "asvgf", "slgf"}) {
        for (float maxLength : {2.0f, 3.0f}) {
          const MaskedError spatial = disoccludedError(
              scene, name, {{"youngColor", "spatial"}, {"footprint", policy}}, maxLength);
          const MaskedError accumulated = disoccludedError(
              scene, name, {{"youngColor", "accumulated"}, {"footprint", policy}}, maxLength);
          std::printf(
              "%s %s %s h<=%.0f pixels %ld relMSE colour/diffuse/specular: spatial %.4f %.4f "
              "%.4f, accumulated %.4f %.4f %.4f\n",
              policy.c_str(), scene.c_str(), name.c_str(), double(maxLength), spatial.pixels,
              spatial.relMse[0], spatial.relMse[1], spatial.relMse[2], accumulated.relMse[0],
              accumulated.relMse[1], accumulated.relMse[2]);
          EXPECT_EQ(spatial.pixels, accumulated.pixels);
          EXPECT_GT(spatial.pixels, 100);
          if (policy == "scaled" && scene == "camera_pan_occluder")
            EXPECT_LT(spatial.relMse[0], 0.75 * accumulated.relMse[0]) << name;
          else
            EXPECT_LT(accumulated.relMse[0], spatial.relMse[0]) << policy << " " << scene;
        }
      }
    }
  }
}

}  // namespace
}  // namespace arena
