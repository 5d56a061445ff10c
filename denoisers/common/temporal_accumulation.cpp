#include "denoisers/common/temporal_accumulation.hpp"

#include "core/error.hpp"
#include "denoisers/common/gpu_traffic.hpp"

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
      length[i] = nextHistoryLength(
          ok, ok ? HistoryTaps(reprojection.record(i), reprojection.width()).apply(previous) : 0.0f,
          maxHistory);
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

void accumulateWithHistoryLength(const Reprojection& reprojection,
                                 const Image& previousHistoryLength, float maxHistory,
                                 const Image& current, const Image& history,
                                 const AccumulationAlpha& alpha, Image& historyLength,
                                 Image& accumulated) {
  if (!current.sameShape(history) || !current.sameShape(accumulated))
    throw Error("temporal accumulation: signal, history and output must have the same shape");
  const int w = current.width(), channels = current.channels();
  recordAccumulationTraffic(reprojection, w, current.height(), false);
  const float* previous = previousHistoryLength.plane(0);
  float* length = historyLength.plane(0);
  parallelRows(current.height(), [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      if (!reprojection.valid(i)) {  // disocclusion: the history is discarded
        length[i] = nextHistoryLength(false, 0.0f, maxHistory);
        for (int c = 0; c < channels; ++c) accumulated.plane(c)[i] = current.plane(c)[i];
        continue;
      }
      const HistoryTaps taps(reprojection.record(i), reprojection.width());
      const float h = nextHistoryLength(true, taps.apply(previous), maxHistory);
      length[i] = h;
      const float a = alpha.blend(i, h);
      for (int c = 0; c < channels; ++c)
        accumulated.plane(c)[i] =
            a * current.plane(c)[i] + (1.0f - a) * taps.apply(history.plane(c));
    }
  });
}

void recordAccumulationTraffic(const Reprojection& reprojection, int width, int height,
                               bool moments) {
  if (!gpu::recording()) return;
  using namespace gpu_buffers;
  const double taps = reprojection.readTapsPerPixel();
  gpu::dispatch(width, height);
  gpu::read({kRecord, kSignal}, width, height, 1);
  gpu::read({kHistoryLengthHistory, kRadianceHistory}, width, height, taps);
  if (moments) gpu::read(kMomentsHistory, width, height, taps);
  gpu::write({kHistoryLength, kRadiance}, width, height);
  if (moments) gpu::write(kMoments, width, height);
}

}  // namespace arena
