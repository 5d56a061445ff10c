#include "denoisers/common/temporal_accumulation.hpp"

#include "core/error.hpp"

namespace arena {

void updateHistoryLength(const Reprojection& reprojection, const Image& previousHistoryLength,
                         float maxHistory, Image& historyLength) {
  const int w = historyLength.width();
  const float* previous = previousHistoryLength.plane(0);
  float* length = historyLength.plane(0);
  parallelRows(historyLength.height(), [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      const bool ok = reprojection.valid(i);
      length[i] = nextHistoryLength(ok, ok ? reprojection.sample(i, previous) : 0.0f, maxHistory);
    }
  });
}

void accumulateTemporally(const Reprojection& reprojection, const Image& current,
                          const Image& history, const Image& historyLength,
                          const AccumulationAlpha& alpha, Image& accumulated) {
  if (!current.sameShape(history) || !current.sameShape(accumulated))
    throw Error("temporal accumulation: signal, history and output must have the same shape");
  blendWithHistory(
      reprojection, current.channels(), [&](size_t i, int c) { return current.plane(c)[i]; },
      history, historyLength, alpha, accumulated);
}

}  // namespace arena
