#include "denoisers/common/history_clamp.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

void clampToBox(float* v, const float* lo, const float* hi, int channels) {
  for (int c = 0; c < channels; ++c) v[c] = std::clamp(v[c], lo[c], std::max(lo[c], hi[c]));
}

void clipToBox(float* v, const float* target, const float* lo, const float* hi, int channels) {
  // Points v + t (target - v), t in [0, 1]: per channel the interval of t inside [lo, hi],
  // intersected over the channels; the smallest such t moves the history the least.
  float tEnter = 0.0f, tLeave = 1.0f;
  for (int c = 0; c < channels; ++c) {
    const float d = target[c] - v[c];
    if (std::abs(d) < 1e-20f) {
      if (v[c] < lo[c] || v[c] > hi[c]) tEnter = 2.0f;  // this channel never enters
      continue;
    }
    float t0 = (lo[c] - v[c]) / d, t1 = (hi[c] - v[c]) / d;
    if (t0 > t1) std::swap(t0, t1);
    tEnter = std::max(tEnter, t0);
    tLeave = std::min(tLeave, t1);
  }
  const float t = tEnter <= tLeave ? tEnter : std::min(tEnter, 1.0f);
  for (int c = 0; c < channels; ++c) v[c] += t * (target[c] - v[c]);
  clampToBox(v, lo, hi, channels);  // rounding, or a target outside the box
}

double clampHistory(const Image& history, const Image& current, const GBufferView* g,
                    const HistoryClampSettings& settings, Image& out, RowTapCounter& taps) {
  const int w = current.width(), h = current.height(), channels = current.channels();
  if (!history.sameShape(current) || !out.sameShape(current) || channels > 4)
    throw Error("history clamp: history, current and output must match (at most 4 channels)");
  const int r = settings.radius;
  if (gpu::recording()) {  // the box of the current signal around the history's texel
    using namespace gpu_buffers;
    const double box = double((2 * r + 1) * (2 * r + 1));
    gpu::dispatch(w, h);
    gpu::read(kRadiance, w, h, box);
    if (g && g->meshId) gpu::read(kMeshId, w, h, box);
    gpu::read(kRadianceHistory, w, h, 1);
    gpu::write(kRadiance, w, h);
  }
  parallelRows(h, [&](int y) {
    int64_t fetched = 0;
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      float v[4], target[4], lo[4], hi[4];
      for (int c = 0; c < channels; ++c) {
        v[c] = history.plane(c)[p];
        target[c] = current.plane(c)[p];
      }
      if (g && g->isSky(p)) {
        for (int c = 0; c < channels; ++c) out.plane(c)[p] = v[c];
        continue;
      }
      float sum[4] = {0, 0, 0, 0}, sumSq[4] = {0, 0, 0, 0};
      int count = 0;
      for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx) {
          const int qx = x + dx, qy = y + dy;
          if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
          const size_t q = size_t(qy) * size_t(w) + size_t(qx);
          if (g && g->isSky(q)) continue;
          for (int c = 0; c < channels; ++c) {
            float s = current.plane(c)[q];
            sum[c] += s;
            sumSq[c] += s * s;
          }
          ++count;
        }
      }
      fetched += count;
      for (int c = 0; c < channels; ++c) {
        const float mean = sum[c] / float(count);
        const float sigma = std::sqrt(std::max(0.0f, sumSq[c] / float(count) - mean * mean));
        lo[c] = mean - settings.gamma * sigma;
        hi[c] = mean + settings.gamma * sigma;
      }
      if (settings.mode == HistoryClampMode::Clamp) {
        clampToBox(v, lo, hi, channels);
      } else {
        clipToBox(v, target, lo, hi, channels);
      }
      for (int c = 0; c < channels; ++c) out.plane(c)[p] = v[c];
    }
    taps.set(y, fetched);
  });
  return taps.perPixel(current.pixelCount());
}

}  // namespace arena
