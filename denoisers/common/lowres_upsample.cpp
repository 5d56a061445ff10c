#include "denoisers/common/lowres_upsample.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "core/error.hpp"
#include "core/sequence.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

void LowresUpsampler::setup(int width, int height, int factor) {
  width_ = width;
  height_ = height;
  factor_ = factor;
  read_.assign(size_t(lowresSize(width, std::max(factor, 1))) *
                   size_t(lowresSize(height, std::max(factor, 1))),
               0);
}

namespace {

// The two texels whose anchors bracket pixel coordinate x along one axis, and x's bilinear
// position between them (0: all on the first).
struct Bracket {
  int i0, i1;
  float t;
};
Bracket bracket(int x, int factor, int size, int texels) {
  int i0 = std::clamp(int(std::floor(float(x - factor / 2) / float(factor))), 0, texels - 1);
  if (i0 + 1 >= texels) return {i0, i0, 0.0f};
  const int a0 = lowresAnchor(i0, factor, size), a1 = lowresAnchor(i0 + 1, factor, size);
  return {i0, i0 + 1, std::clamp(float(x - a0) / float(std::max(a1 - a0, 1)), 0.0f, 1.0f)};
}

}  // namespace

size_t LowresUpsampler::reconstruct(const LowresBuffer& buffer, const GBufferView& g,
                                    const Image* moments, const Image& need,
                                    const LowresUpsampleSettings& s, Image& out,
                                    Image& confidence) {
  const int f = buffer.factor, w = g.width, h = g.height;
  const int lw = lowresSize(w, f), lh = lowresSize(h, f);
  if (f != factor_ || w != width_ || h != height_)
    throw Error("low-resolution upsampler: set up for factor " + std::to_string(factor_) + " at " +
                std::to_string(width_) + "x" + std::to_string(height_) + ", given factor " +
                std::to_string(f) + " at " + std::to_string(w) + "x" + std::to_string(h));
  if (buffer.color.width() != lw || buffer.color.height() != lh)
    throw Error("low-resolution buffer: " + std::to_string(buffer.color.width()) + "x" +
                std::to_string(buffer.color.height()) + ", expected " + std::to_string(lw) + "x" +
                std::to_string(lh) + " for factor " + std::to_string(f) + " at " +
                std::to_string(w) + "x" + std::to_string(h));
  std::fill(read_.begin(), read_.end(), 0);
  if (gpu::recording()) {  // the bracketing 2x2 low-resolution texels against full-res guides
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    gpu::read(kLowres, lw, lh, 4);
    if (buffer.direction) gpu::read(kLowresDirection, lw, lh, 4);
    for (const GpuBuffer& b : {kDepth, kNormal, kMeshId, kPosition}) gpu::read(b, w, h, 1);
    if (moments) gpu::read(kSecondMoments, w, h, 1);
    gpu::read(kHistoryLength, w, h, 1);  // `need`: where the history is short
    gpu::write(kRadiance, w, h);
    gpu::write(kConfidence, w, h);
  }
  const SurfaceWeights geometry(s.weights, SurfaceGuide{g});
  const bool directional = s.directional && buffer.direction != nullptr;
  const bool clampToMoments = s.momentClamp && moments != nullptr;
  constexpr float kLuma[3] = {0.2126f, 0.7152f, 0.0722f};
  parallelRows(h, [&](int y) {
    const Bracket by = bracket(y, f, h, lh);
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      confidence.plane(0)[p] = 0.0f;
      if (need.plane(0)[p] <= 0.0f || g.isSky(p)) continue;
      const Bracket bx = bracket(x, f, w, lw);
      float sum[3] = {0, 0, 0}, weightSum = 0;
      auto gather = [&](int tx, int ty, float spatial) {
        const int ax = lowresAnchor(tx, f, w), ay = lowresAnchor(ty, f, h);
        const size_t a = size_t(ay) * size_t(w) + size_t(ax);
        const float wt = spatial * (a == p ? 1.0f : geometry(p, a));
        if (wt <= 0.0f) return 0.0f;
        const size_t texel = size_t(ty) * size_t(lw) + size_t(tx);
        std::atomic_ref<unsigned char>(read_[texel]).store(1, std::memory_order_relaxed);
        float gain = 1.0f;
        if (directional) {
          const Image& d = *buffer.direction;
          float dp = 0, da = 0;
          for (int c = 0; c < 3; ++c) {
            const float dc = d.plane(c)[texel];
            dp += dc * g.normal[c][p];
            da += dc * g.normal[c][a];
          }
          gain = std::min(std::max(0.0f, 1.0f + 2.0f * dp) / std::max(0.05f, 1.0f + 2.0f * da),
                          s.maxDirectionalGain);
        }
        for (int c = 0; c < 3; ++c) sum[c] += wt * gain * buffer.color.plane(c)[texel];
        weightSum += wt;
        return wt;
      };
      float share = 0;
      for (int k = 0; k < 4; ++k) {
        const int tx = k % 2 ? bx.i1 : bx.i0, ty = k / 2 ? by.i1 : by.i0;
        const float bilinear = (k % 2 ? bx.t : 1.0f - bx.t) * (k / 2 ? by.t : 1.0f - by.t);
        if ((k % 2 && bx.i1 == bx.i0) || (k / 2 && by.i1 == by.i0)) continue;  // edge: one texel
        share += gather(tx, ty, bilinear > 0 ? bilinear : 0.0f);
      }
      if (weightSum < 1e-4f) {
        // No bracketing texel shows p's surface (a thin object between anchors): the 4x4 texels
        // around, geometry weight only, trusted half as much (ours).
        sum[0] = sum[1] = sum[2] = 0;
        weightSum = 0;
        float best = 0;
        for (int ty = std::max(by.i0 - 1, 0); ty <= std::min(by.i0 + 2, lh - 1); ++ty)
          for (int tx = std::max(bx.i0 - 1, 0); tx <= std::min(bx.i0 + 2, lw - 1); ++tx)
            best = std::max(best, gather(tx, ty, 1.0f));
        share = 0.5f * best;
      }
      if (weightSum < 1e-6f) continue;
      float v[3];
      for (int c = 0; c < 3; ++c) v[c] = sum[c] / weightSum;
      if (clampToMoments) {
        float lMean = 0, lSigma = 0;
        for (int c = 0; c < 3; ++c) {
          const float mu = moments->plane(c)[p];
          lMean += kLuma[c] * mu;
          lSigma += kLuma[c] * std::sqrt(std::max(0.0f, moments->plane(c + 3)[p] - mu * mu));
        }
        const float l = luminance(v[0], v[1], v[2]);
        const float lo = std::max(0.0f, lMean - s.clampGamma * lSigma),
                    hi = lMean + s.clampGamma * lSigma;
        const float clamped = std::clamp(l, lo, hi);
        if (l > 0.0f)
          for (float& c : v) c *= clamped / l;
      }
      for (int c = 0; c < 3; ++c) out.plane(c)[p] = v[c];
      confidence.plane(0)[p] = std::min(share, 1.0f);
    }
  });
  size_t texels = 0;
  for (unsigned char r : read_) texels += r;
  raysPerPixel_ = double(texels) * double(buffer.spp) / double(size_t(w) * size_t(h));
  return texels;
}

}  // namespace arena
