#pragma once
// Reconstruction of a low-resolution, many-sample buffer at full resolution (CAPCOM RE ENGINE
// 2023, "Reconstruction" and "Why it works?", slides 20-21): the light is low-frequency and lives
// in the low-resolution texels (colour and average direction); the full-resolution G-buffer and
// the full-resolution 1-spp moments restore the detail:
//   1. joint-bilateral upsampling: the 2x2 texels around p (bilinear weights over their anchor
//      pixels, core/sequence.hpp lowresAnchor) times a geometry weight between p and each
//      texel's anchor pixel (plane distance + normal, poisson_blur.hpp's SurfaceWeights), so light
//      never crosses a silhouette;
//   2. "upscaled colour/direction + normal = 4K colour (projected with spherical harmonics)": each
//      texel's colour is re-projected to p's normal with the L1 spherical-harmonic irradiance of
//      a radiance distribution with mean direction d (|d| <= 1),
//        E(n) ~ 1 + 2 d.n   (L(w) = (1 + 3 d.w) / 4pi convolved with the clamped cosine),
//      i.e. scaled by max(0, 1 + 2 d.n_p) / max(eps, 1 + 2 d.n_anchor), at most maxDirectionalGain;
//   3. "moment + colour/direction = upscaled colour/direction (moment clamp)": the result's
//      luminance is clamped into the full-resolution moment box mu +- k sigma around p, so
//      shadows the coarse grid misses survive.
// Only pixels whose `need` is > 0 are reconstructed, and the texels they read are counted: the
// disocclusion rays a denoiser pays for.
#include <cstddef>
#include <vector>

#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/poisson_blur.hpp"

namespace arena {

struct LowresUpsampleSettings {
  SurfaceWeightSettings weights;    // plane distance and normal between p and a texel's anchor
  bool directional{};  // step 2 (only where a direction image is given): reengine's parameter
  float maxDirectionalGain = 4.0f;  // (1; inf) ours: bounds the SH ratio at grazing texels
  bool momentClamp{};  // step 3 (only where moments are given): reengine's parameter
  float clampGamma = 2.0f;          // k of the moment box (ours)
};

struct LowresBuffer {
  const Image& color;      // 3 channels, ceil(w / factor) x ceil(h / factor)
  const Image* direction;  // 3 channels, or nullptr (no directional step)
  int factor;
  int spp;
};

class LowresUpsampler {
 public:
  void setup(int width, int height, int factor);
  // out(p) = the reconstruction at every pixel with need(p) > 0 and some texel of non-zero weight;
  // confidence(p) = the geometry weight's share of the bilinear weight there (0 elsewhere, where
  // out(p) is left as it was). Returns the texels read, each counted once.
  // `moments`: 6 channels, the full-resolution neighbourhood mean (RGB) and second moment (RGB),
  // or nullptr (no moment clamp).
  size_t reconstruct(const LowresBuffer& buffer, const GBufferView& gbuffer, const Image* moments,
                     const Image& need, const LowresUpsampleSettings& settings, Image& out,
                     Image& confidence);
  // Paths read per full-resolution pixel in the last reconstruct(): texels x spp / pixels.
  double raysPerPixel() const { return raysPerPixel_; }

 private:
  int width_ = 0, height_ = 0, factor_ = 0;
  std::vector<unsigned char> read_;  // per texel: read this frame
  double raysPerPixel_ = 0;
};

}  // namespace arena
