#pragma once
// The Poisson-disk blur's pixel loop (poisson_blur.hpp) written once over a lane type: Lanes8
// (AVX2, poisson_blur.cpp) or Lanes16 (AVX-512, simd_avx512.cpp, chosen at run time). The same
// operations per lane either way, so the same bits. Internal; like atrous_kernel.hpp it touches no
// standard-library template, so nothing of it can be shared between the two translation units.
#include <cstddef>
#include <cstdint>

#include "core/fast_math.hpp"
#include "denoisers/common/poisson_blur.hpp"

namespace arena::poisson_detail {

constexpr int kMaxChannels = 8;

// Everything one blur reads, as whole-image planes.
struct Blur {
  int width, height, channels;
  const float* in[kMaxChannels];
  float* out[kMaxChannels];
  const float* meshId;  // nullptr: no sky
  const float* scale;   // per-pixel radius scale, nullptr: 1
  float radius;
  float taps[kMaxSparseTaps][2];  // in units of the radius
  int tapCount;
  SurfaceWeightSettings weights;
  const float *position[3], *normal[3], *depth, *hitDistance, *roughness;
};

// std::lround per lane (half away from zero), exactly: the fraction after truncation is exact.
template <class F>
inline IntLanes<F> roundToNearestInt(F v) {
  const IntLanes<F> whole = truncateToInt(v);
  const F fraction = v - toFloat(whole);
  return whole + ((fraction >= 0.5f) & 1) - ((fraction <= -0.5f) & 1);
}

// The guides surfaceWeight() reads for the enabled terms (a neighbour's normal only for the normal
// term, its depth never), read through `planeLanes`.
template <class F, class Read>
inline SurfacePoint<F> readSurface(const Blur& b, bool centre, Read&& planeLanes) {
  const SurfaceWeightSettings& s = b.weights;
  SurfacePoint<F> point{};
  const bool normal = s.normal && s.normalPower != 0.0f;
  for (int c = 0; c < 3; ++c) {
    if (s.planeDistance) point.position[c] = planeLanes(b.position[c]);
    if (normal || (centre && s.planeDistance)) point.normal[c] = planeLanes(b.normal[c]);
  }
  if (centre && (s.planeDistance || s.hitDistance)) point.depth = planeLanes(b.depth);
  if (s.hitDistance) point.hitDistance = planeLanes(b.hitDistance);
  if (s.roughness) point.roughness = planeLanes(b.roughness);
  return point;
}

// Row y, a block of lanes at a time; a tap's neighbours are gathered (the disk's offsets scale
// with each pixel's radius), or loaded consecutively where every lane's offset agrees (a uniform
// radius: a converged history, one roughness) -- the same values. Dropped taps -- off the image,
// onto p itself, into the sky -- weigh 0.
// Taps > 0: exactly that many taps, known at compile time (the 8-tap disk, the 24-tap history-fix
// grid: unrolled); 0: b.tapCount. SkipIdle: blocks without a pixel to gather for (radius 0 or
// sky) are copied through without evaluating their taps (a separate instantiation: the check
// slows the dense blur's loop by half, measured).
template <class F, int Taps, bool SkipIdle>
void blurRow(const Blur& b, int y) {
  using I = IntLanes<F>;
  constexpr int kLanes = int(sizeof(F) / sizeof(float));
  const int w = b.width, h = b.height;
  for (int x0 = 0; x0 < w; x0 += kLanes) {
    const size_t p = size_t(y) * size_t(w) + size_t(x0);
    const I x = laneIndex(F{}) + x0;
    const I inRow = x < w;
    const I sky = b.meshId ? inRow & (loadLanes(b.meshId + p, inRow) < 0.0f) : I{};
    const I surfacePixel = inRow & ~sky;
    F sum[kMaxChannels];
    for (int c = 0; c < b.channels; ++c) sum[c] = loadLanes(b.in[c] + p, inRow);
    F weightSum = F{} + 1.0f;  // the centre
    const F radius = b.radius * (b.scale ? loadLanes(b.scale + p, inRow) : F{} + 1.0f);
    if constexpr (SkipIdle) {
      if (!anyLane(surfacePixel & (radius > 0.0f))) {  // nothing to gather: pass through
        for (int c = 0; c < b.channels; ++c) storeLanes(b.out[c] + p, sum[c], inRow);
        continue;
      }
    }

    const SurfaceCentre<F> centre = surfaceCentre(
        b.weights,
        readSurface<F>(b, true, [&](const float* plane) { return loadLanes(plane + p, inRow); }));
    const int tapCount = Taps > 0 ? Taps : b.tapCount;
    for (int t = 0; t < tapCount; ++t) {
      const I dx = roundToNearestInt(b.taps[t][0] * radius);
      const I dy = roundToNearestInt(b.taps[t][1] * radius);
      const I qx = x + dx, qy = y + dy;
      I use = surfacePixel & (qx >= 0) & (qx < w) & (qy >= 0) & (qy < h) & ((dx != 0) | (dy != 0));
      const I q = qy * w + qx;
      const bool uniform = allLanes((dx == dx[0]) & (dy == dy[0]));
      const size_t q0 = p + size_t(std::ptrdiff_t(dy[0]) * w + dx[0]);
      auto neighbour = [&](const float* plane) {
        return uniform ? loadLanes(plane + q0, use) : gatherLanes(plane, q, use);
      };
      if (b.meshId) use &= neighbour(b.meshId) >= 0.0f;
      const F weight = selectFloat(
          use, surfaceWeight(b.weights, centre, readSurface<F>(b, false, neighbour)), F{});
      for (int c = 0; c < b.channels; ++c) sum[c] += weight * neighbour(b.in[c]);
      weightSum += weight;
    }
    const F inverse = 1.0f / weightSum;
    for (int c = 0; c < b.channels; ++c)
      storeLanes(b.out[c] + p, selectFloat(sky, loadLanes(b.in[c] + p, inRow), sum[c] * inverse),
                 inRow);
  }
}

using BlurRowFunction = void (*)(const Blur&, int);
template <class F, bool SkipIdle>
BlurRowFunction selectBlurRow(int tapCount) {
  switch (tapCount) {
    case kPoissonTaps:
      return &blurRow<F, kPoissonTaps, SkipIdle>;
    case kMaxSparseTaps:
      return &blurRow<F, kMaxSparseTaps, SkipIdle>;
  }
  return &blurRow<F, 0, SkipIdle>;
}
template <class F>
BlurRowFunction selectBlurRow(int tapCount, bool skipIdle) {
  return skipIdle ? selectBlurRow<F, true>(tapCount) : selectBlurRow<F, false>(tapCount);
}
// The sixteen-lane row, defined in simd_avx512.cpp; callable only where the CPU has AVX-512.
BlurRowFunction selectBlurRowAvx512(int tapCount, bool skipIdle);

}  // namespace arena::poisson_detail
