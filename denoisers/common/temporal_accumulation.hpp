#pragma once
// Temporal accumulation: an exponential moving average of the signal with its reprojected history
// (SVGF eq. in §4.1: C'_i = alpha C_i + (1 - alpha) C'_{i-1}), the history length h counting
// consecutive successful reprojections, and alpha = max(alphaMin, 1/h) so a young history is a
// plain running mean (Falcor; NRD ReLAX uses the same form).
#include <algorithm>

#include "core/image.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/reprojection.hpp"

namespace arena {

// h = reprojected h + 1, capped at maxHistory; h = 1 on disocclusion (the history is discarded).
inline float nextHistoryLength(bool reprojected, float reprojectedLength, float maxHistory) {
  return reprojected ? std::min(reprojectedLength + 1.0f, maxHistory) : 1.0f;
}

// alpha = max(alphaMin, 1/h). alphaMin may be per pixel: A-SVGF's adaptive alpha
// (Schied 2018 eq. 15, alpha_i = (1 - lambda) alpha + lambda) enters here.
inline float blendAlpha(float historyLength, float alphaMin) {
  return std::max(alphaMin, 1.0f / std::max(historyLength, 1.0f));
}

// historyLength (1 channel) = nextHistoryLength of the resampled previousHistoryLength.
void updateHistoryLength(const Reprojection& reprojection, const Image& previousHistoryLength,
                         float maxHistory, Image& historyLength);

// The lower bound of alpha: one value everywhere, raised per pixel by an optional image. A-SVGF
// (gradient.shortenHistory=false, the paper literally) passes its alpha_i = (1 - lambda) alpha +
// lambda (>= alpha) there; the same image can raise the moments' floor, max(momentsAlpha, alpha_i).
// `antilag` is Q2RTX's order instead (asvgf_temporal): a per-pixel lambda that first shortens the
// history, h = min(h_prev (1 - lambda)^10 + 1, max) (accumulateColorAndMoments only), and then
// pulls alpha towards 1, alpha = lerp(max(alphaMin, 1/h), 1, lambda).
struct AccumulationAlpha {
  float alphaMin = 0.2f;            // SVGF paper 0.2; Falcor 0.05
  const Image* perPixel = nullptr;  // plane 0: per-pixel floor; alpha = max(alphaMin, it, 1/h)
  const Image* antilag = nullptr;   // plane 0: Q2RTX's lambda (see above)
  float at(size_t i) const {
    return perPixel ? std::max(alphaMin, perPixel->plane(0)[i]) : alphaMin;
  }
  // The blend weight of pixel i with history length h.
  float blend(size_t i, float h) const {
    const float a = blendAlpha(h, at(i));
    if (!antilag) return a;
    const float lambda = antilag->plane(0)[i];
    return a + lambda * (1.0f - a);
  }
};

// Q2RTX's history shortening, (1 - lambda)^10, by squarings (F: float or a lane type).
template <class F>
inline F antilagHistoryScale(F lambda) {
  const F keep = 1.0f - lambda, k2 = keep * keep, k4 = k2 * k2, k8 = k4 * k4;
  return k8 * k2;
}

// The EMA itself, for any number of channels: out(c) = current(i, c) on disocclusion, else
// alpha current(i, c) + (1 - alpha) history(c) with alpha = blendAlpha(h, alpha.at(i)).
// `current(i, c)` is a callable so derived signals (luminance moments) need no scratch image.
template <class CurrentValue>
void blendWithHistory(const Reprojection& reprojection, int channels, CurrentValue&& current,
                      const Image& history, const Image& historyLength,
                      const AccumulationAlpha& alpha, Image& out) {
  const int w = out.width();
  const float* length = historyLength.plane(0);
  parallelRows(out.height(), [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      if (!reprojection.valid(i)) {
        for (int c = 0; c < channels; ++c) out.plane(c)[i] = current(i, c);
        continue;
      }
      // The taps are decoded once and read for every channel.
      const HistoryTaps taps(reprojection.record(i), reprojection.width());
      const float a = alpha.blend(i, length[i]);
      for (int c = 0; c < channels; ++c)
        out.plane(c)[i] = a * current(i, c) + (1.0f - a) * taps.apply(history.plane(c));
    }
  });
}

// Colour accumulation: accumulated = EMA(current, reprojected history); all images planar and of
// equal size, `historyLength` already updated for this frame.
void accumulateTemporally(const Reprojection& reprojection, const Image& current,
                          const Image& history, const Image& historyLength,
                          const AccumulationAlpha& alpha, Image& accumulated);

// updateHistoryLength then accumulateTemporally in one sweep that decodes each pixel's history
// taps once; the results are exactly those of the two calls.
void accumulateWithHistoryLength(const Reprojection& reprojection,
                                 const Image& previousHistoryLength, float maxHistory,
                                 const Image& current, const Image& history,
                                 const AccumulationAlpha& alpha, Image& historyLength,
                                 Image& accumulated);

// What one accumulation sweep would move on a GPU (gpu_traffic.hpp): the reprojection record,
// the signal, and each history (colour, h, and with `moments` the luminance moments) through the
// consistent taps; h, colour (and moments) written.
void recordAccumulationTraffic(const Reprojection& reprojection, int width, int height,
                               bool moments);

}  // namespace arena
