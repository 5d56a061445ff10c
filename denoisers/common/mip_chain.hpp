#pragma once
// Mip chain with edge-aware bilateral upsampling (the CEDEC 2021 talk p. "4.1.3 Mipmap & Down
// Sampling": each level halves the resolution, so level l averages 2^l x 2^l pixels -- "Mip1:2x2,
// Mip2:4x4 ... Mip4:16x16" -- and "フル解像度の GBuffer を利用するなどした Upsampling" must bring
// it back without bleeding across edges; ReBLUR 2020 rebuilt young history from a 4-level chain).
// Downsampling averages the non-sky children (value, depth, normal); upsampling takes the 2x2
// coarse texels around a full-resolution pixel with bilinear weights times a depth and a normal
// weight against that pixel's own full-resolution depth and normal.
#include <vector>

#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"

namespace arena {

struct MipUpsampleSettings {
  // exp(-|z(p) - z(c)| / (sigmaZ z(p))): a coarse texel 10 % off in depth weighs 1/e (ours).
  float sigmaZ = 0.1f;
  // max(0, n(p).n(c))^normalPower (ours).
  float normalPower = 16.0f;
};

class MipChain {
 public:
  // Allocates levels 1..levels for a width x height image of `channels` channels.
  void setup(int width, int height, int levels, int channels = 3);
  int levels() const { return int(values_.size()); }
  // Level l (1-based) from level l-1, level 0 being `signal` with the G-buffer's depth/normal.
  void build(const Image& signal, const GBufferView& gbuffer);
  // out(p) = bilateral upsample of level `level` (0 = the signal given to build(), copied), or of
  // level round(perPixelLevel(p)) clamped to [0, level] when perPixelLevel is given. Sky pixels
  // pass through; a pixel whose coarse texels all weigh 0 keeps its own value.
  void upsample(int level, const Image* perPixelLevel, const GBufferView& gbuffer,
                const MipUpsampleSettings& settings, Image& out) const;
  const Image& level(int l) const { return values_[size_t(l - 1)]; }
  // For the GPU prediction, after build(): levels levels()+1 .. `levels`, which a 1080p frame
  // builds where a scaled depth gives this resolution fewer (scaledMipLevel), recorded as that
  // frame's dispatches would move them (this chain's coarsest size halved on; the 1080p scaling
  // multiplies their texels like every pass's) and counted (gpu::skippedHere). Nothing is built.
  void priceLevelsBeyond(int levels) const;

 private:
  const Image* base_ = nullptr;
  std::vector<Image> values_, guides_;  // guides: depth, normal xyz, child count
};

}  // namespace arena
