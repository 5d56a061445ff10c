#include "denoisers/common/mip_chain.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

namespace {
enum GuideChannel : int { kGuideDepth = 0, kGuideNormalX = 1, kGuideCount = 4, kGuideChannels = 5 };
}

void MipChain::setup(int width, int height, int levels, int channels) {
  values_.clear();
  guides_.clear();
  int w = width, h = height;
  for (int l = 1; l <= levels; ++l) {
    w = (w + 1) / 2;
    h = (h + 1) / 2;
    values_.emplace_back(w, h, channels);
    guides_.emplace_back(w, h, kGuideChannels);
  }
}

namespace {

// What building one level moves on a GPU: one dispatch of the level's size, 2x2 children per
// texel (the finest level's children read the G-buffer, coarser ones the level guide above).
void recordLevelTraffic(bool fromBase, int fineW, int fineH, int w, int h, int channels,
                        bool meshId) {
  namespace gb = gpu_buffers;
  gpu::dispatch(w, h);
  gpu::read(fromBase ? gb::kRadiance : gb::kMip, fineW, fineH, 4);
  if (channels > 4) gpu::read(gb::kMipExtra, fineW, fineH, 4);
  if (fromBase) {
    gpu::read(gb::kDepth, fineW, fineH, 4);
    gpu::read(gb::kNormal, fineW, fineH, 4);
    if (meshId) gpu::read(gb::kMeshId, fineW, fineH, 4);
  } else {
    gpu::read(gb::kMipGuide, fineW, fineH, 4);
  }
  gpu::write(gb::kMip, w, h);
  if (channels > 4) gpu::write(gb::kMipExtra, w, h);
  gpu::write(gb::kMipGuide, w, h);
}

}  // namespace

void MipChain::priceLevelsBeyond(int levels) const {
  if (!gpu::recording() || values_.empty()) return;
  int w = values_.back().width(), h = values_.back().height();
  for (int l = int(values_.size()); l < levels; ++l) {
    const int fineW = w, fineH = h;
    w = (w + 1) / 2;
    h = (h + 1) / 2;
    recordLevelTraffic(false, fineW, fineH, w, h, values_.back().channels(), false);
    gpu::skippedHere();
  }
}

void MipChain::build(const Image& signal, const GBufferView& g) {
  if (signal.width() != g.width || signal.height() != g.height)
    throw Error("mip chain: signal and G-buffer sizes differ");
  if (!values_.empty() && signal.channels() != values_[0].channels())
    throw Error("mip chain: channel count differs from setup()");
  base_ = &signal;
  for (size_t l = 0; l < values_.size(); ++l) {
    Image& dst = values_[l];
    Image& dstGuide = guides_[l];
    const int fineW = l == 0 ? g.width : values_[l - 1].width();
    const int fineH = l == 0 ? g.height : values_[l - 1].height();
    const Image* fineValues = l == 0 ? &signal : &values_[l - 1];
    const Image* fineGuide = l == 0 ? nullptr : &guides_[l - 1];
    if (gpu::recording())
      recordLevelTraffic(l == 0, fineW, fineH, dst.width(), dst.height(), signal.channels(),
                         g.meshId != nullptr);
    parallelRows(dst.height(), [&](int y) {
      for (int x = 0; x < dst.width(); ++x) {
        const size_t c = size_t(y) * size_t(dst.width()) + size_t(x);
        float sum[8] = {0}, depth = 0, normal[3] = {0, 0, 0}, count = 0;
        for (int k = 0; k < 4; ++k) {
          const int fx = 2 * x + k % 2, fy = 2 * y + k / 2;
          if (fx >= fineW || fy >= fineH) continue;
          const size_t f = size_t(fy) * size_t(fineW) + size_t(fx);
          // Children weigh by how many full-resolution pixels they stand for.
          float weight;
          if (l == 0) {
            if (g.isSky(f)) continue;
            weight = 1.0f;
            depth += g.depth[f];
            for (size_t a = 0; a < 3; ++a) normal[a] += g.normal[a][f];
          } else {
            weight = fineGuide->plane(kGuideCount)[f];
            if (weight <= 0.0f) continue;
            depth += weight * fineGuide->plane(kGuideDepth)[f];
            for (int a = 0; a < 3; ++a)
              normal[a] += weight * fineGuide->plane(kGuideNormalX + a)[f];
          }
          for (int ch = 0; ch < dst.channels(); ++ch) sum[ch] += weight * fineValues->plane(ch)[f];
          count += weight;
        }
        const float inverse = count > 0.0f ? 1.0f / count : 0.0f;
        for (int ch = 0; ch < dst.channels(); ++ch) dst.plane(ch)[c] = sum[ch] * inverse;
        dstGuide.plane(kGuideDepth)[c] = depth * inverse;
        const float length =
            std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
        for (int a = 0; a < 3; ++a)
          dstGuide.plane(kGuideNormalX + a)[c] = length > 0 ? normal[a] / length : 0.0f;
        dstGuide.plane(kGuideCount)[c] = count;
      }
    });
  }
}

void MipChain::upsample(int maxLevel, const Image* perPixelLevel, const GBufferView& g,
                        const MipUpsampleSettings& settings, Image& out) const {
  if (!base_) throw Error("mip chain: upsample() before build()");
  if (maxLevel < 0 || maxLevel > levels()) throw Error("mip chain: level out of range");
  if (!out.sameShape(*base_) || &out == base_)
    throw Error("mip chain: output must match the signal, not alias it");
  const int w = g.width, channels = out.channels();
  if (gpu::recording()) {  // 2x2 coarse texels of the finest level used, against the pixel's guides
    namespace gb = gpu_buffers;
    gpu::dispatch(w, g.height);
    gpu::read(gb::kDepth, w, g.height, 1);
    gpu::read(gb::kNormal, w, g.height, 1);
    if (g.meshId) gpu::read(gb::kMeshId, w, g.height, 1);
    if (perPixelLevel) gpu::read(gb::kRoughness, w, g.height, 1);  // the level is roughness-driven
    const Image& coarse = maxLevel == 0 ? *base_ : level(maxLevel);
    gpu::read(maxLevel == 0 ? gb::kRadiance : gb::kMip, coarse.width(), coarse.height(), 4);
    if (channels > 4) gpu::read(gb::kMipExtra, coarse.width(), coarse.height(), 4);
    if (maxLevel > 0) gpu::read(gb::kMipGuide, coarse.width(), coarse.height(), 4);
    gpu::write(gb::kRadiance, w, g.height);
    if (channels > 4) gpu::write(gb::kSecondMoments, w, g.height);
  }
  parallelRows(g.height, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      int level = maxLevel;
      if (perPixelLevel)
        level = std::clamp(int(std::lround(perPixelLevel->plane(0)[p])), 0, maxLevel);
      if (level == 0 || g.isSky(p)) {
        for (int ch = 0; ch < channels; ++ch) out.plane(ch)[p] = base_->plane(ch)[p];
        continue;
      }
      const Image& values = values_[size_t(level - 1)];
      const Image& guide = guides_[size_t(level - 1)];
      const int cw = values.width(), ch_ = values.height();
      const float scale = 1.0f / float(1 << level);
      // Continuous coarse coordinates of the pixel centre; bilinear taps around them.
      const float fx = (float(x) + 0.5f) * scale - 0.5f, fy = (float(y) + 0.5f) * scale - 0.5f;
      const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
      const float tx = fx - float(x0), ty = fy - float(y0);
      const float bilinear[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
      float sum[8] = {0}, weightSum = 0;
      for (int k = 0; k < 4; ++k) {
        const int cx = std::clamp(x0 + k % 2, 0, cw - 1), cy = std::clamp(y0 + k / 2, 0, ch_ - 1);
        const size_t c = size_t(cy) * size_t(cw) + size_t(cx);
        if (guide.plane(kGuideCount)[c] <= 0.0f) continue;
        const float dz = std::abs(g.depth[p] - guide.plane(kGuideDepth)[c]) /
                         (settings.sigmaZ * std::abs(g.depth[p]) + 1e-20f);
        float cosine = 0;
        for (int a = 0; a < 3; ++a)
          cosine += g.normal[size_t(a)][p] * guide.plane(kGuideNormalX + a)[c];
        cosine = std::min(cosine, 1.0f);
        if (cosine <= 1e-30f) continue;
        const float weight = (bilinear[k] + 1e-4f) *
                             expNonPositive(-dz + settings.normalPower * logPositive(cosine));
        for (int ch = 0; ch < channels; ++ch) sum[ch] += weight * values.plane(ch)[c];
        weightSum += weight;
      }
      if (weightSum < 1e-12f) {
        for (int ch = 0; ch < channels; ++ch) out.plane(ch)[p] = base_->plane(ch)[p];
        continue;
      }
      for (int ch = 0; ch < channels; ++ch) out.plane(ch)[p] = sum[ch] / weightSum;
    }
  });
}

}  // namespace arena
