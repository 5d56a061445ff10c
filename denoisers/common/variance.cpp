#include "denoisers/common/variance.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/error.hpp"
#include "denoisers/common/edge_stopping.hpp"
#include "denoisers/common/fast_math.hpp"

namespace arena {

void accumulateMoments(const Reprojection& reprojection, const Image& signal,
                       const Image& momentsHistory, const Image& historyLength,
                       const AccumulationAlpha& alpha, Image& moments) {
  if (signal.channels() != 3 || momentsHistory.channels() != 2 ||
      !moments.sameShape(momentsHistory))
    throw Error("moments: expected an RGB signal and 2-channel moment images");
  const float* r = signal.plane(0);
  const float* g = signal.plane(1);
  const float* b = signal.plane(2);
  blendWithHistory(
      reprojection, 2,
      [&](size_t i, int c) {
        const float l = luminance(r[i], g[i], b[i]);
        return c == 0 ? l : l * l;
      },
      momentsHistory, historyLength, alpha, moments);
}

void accumulateColorAndMoments(const Reprojection& reprojection, const Image& previousHistoryLength,
                               float maxHistory, const Image& signal, const Image& colorHistory,
                               const Image& momentsHistory, const AccumulationAlpha& colorAlpha,
                               const AccumulationAlpha& momentsAlpha, Image& historyLength,
                               Image& accumulated, Image& moments) {
  if (signal.channels() != 3 || !signal.sameShape(colorHistory) || !signal.sameShape(accumulated) ||
      momentsHistory.channels() != 2 || !moments.sameShape(momentsHistory))
    throw Error("accumulation: expected RGB signal/history/output and 2-channel moment images");
  const int w = signal.width();
  const float* signalPlane[3] = {signal.plane(0), signal.plane(1), signal.plane(2)};
  const float* colorHistoryPlane[3] = {colorHistory.plane(0), colorHistory.plane(1),
                                       colorHistory.plane(2)};
  float* accumulatedPlane[3] = {accumulated.plane(0), accumulated.plane(1), accumulated.plane(2)};
  const float* previousLength = previousHistoryLength.plane(0);
  const float *mu1History = momentsHistory.plane(0), *mu2History = momentsHistory.plane(1);
  float* length = historyLength.plane(0);
  float *mu1 = moments.plane(0), *mu2 = moments.plane(1);
  parallelRows(signal.height(), [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      const float r = signalPlane[0][i], g = signalPlane[1][i], b = signalPlane[2][i];
      const float l = luminance(r, g, b);
      if (!reprojection.valid(i)) {  // disocclusion: the history is discarded
        length[i] = nextHistoryLength(false, 0.0f, maxHistory);
        accumulatedPlane[0][i] = r;
        accumulatedPlane[1][i] = g;
        accumulatedPlane[2][i] = b;
        mu1[i] = l;
        mu2[i] = l * l;
        continue;
      }
      const HistoryTaps taps(reprojection.record(i), reprojection.width());
      const float h = nextHistoryLength(true, taps.apply(previousLength), maxHistory);
      length[i] = h;
      const float a = blendAlpha(h, colorAlpha.at(i));
      for (int c = 0; c < 3; ++c)
        accumulatedPlane[c][i] =
            a * signalPlane[c][i] + (1.0f - a) * taps.apply(colorHistoryPlane[c]);
      const float am = blendAlpha(h, momentsAlpha.at(i));
      mu1[i] = am * l + (1.0f - am) * taps.apply(mu1History);
      mu2[i] = am * (l * l) + (1.0f - am) * taps.apply(mu2History);
    }
  });
}

namespace {

// Per-thread row buffers of the spatial estimate, grown on first use (no allocation per frame).
struct SpatialVarianceScratch {
  std::vector<float> centreLuminance, neighbourLuminance, depthDenominator, weight;
  std::vector<double> m1, m2, weightSum;
  std::vector<int32_t> fetched;
};
SpatialVarianceScratch& spatialScratch(int width) {
  thread_local SpatialVarianceScratch scratch;
  if (scratch.weight.size() < size_t(width)) {
    for (auto* buffer : {&scratch.centreLuminance, &scratch.neighbourLuminance,
                         &scratch.depthDenominator, &scratch.weight})
      buffer->assign(size_t(width), 0.0f);
    for (auto* buffer : {&scratch.m1, &scratch.m2, &scratch.weightSum})
      buffer->assign(size_t(width), 0.0);
    scratch.fetched.assign(size_t(width), 0);
  }
  return scratch;
}

constexpr int32_t kTinyBits = 0x0DA24260, kOneBits = 0x3F800000;  // bits of 1e-30f and 1.0f

// The bilateral weight of one tap (dx, dy) != (0, 0) for x in [xBegin, xEnd), as one vectorised
// sweep: exp(-wl - wz) max(0, n.n')^phiNormal with both exponentials in one (fast_math.hpp);
// 0 for sky neighbours. Normal = false when phiNormal = 0: pow(clamp(n.n', 0, 1), 0) = 1 even
// where n.n' <= 0.
template <bool Normal>
void spatialTapWeights(const float* __restrict z, const float* __restrict zq,
                       const float* __restrict depthDenominator,
                       const float* __restrict centreLuminance, const float* __restrict luminanceQ,
                       const float* __restrict n0, const float* __restrict n1,
                       const float* __restrict n2, const float* __restrict n0q,
                       const float* __restrict n1q, const float* __restrict n2q,
                       const float* __restrict meshIdQ, float offset, float phiColor,
                       float phiNormal, float* __restrict weight, int xBegin, int xEnd) {
  for (int x = xBegin; x < xEnd; ++x) {
    const float wz = std::abs(z[x] - zq[x]) / (depthDenominator[x] * offset + 1e-30f);
    const float wl = std::abs(centreLuminance[x] - luminanceQ[x]) / phiColor;
    float e = wl + wz;
    if constexpr (Normal) {
      const float dot = n0[x] * n0q[x] + n1[x] * n1q[x] + n2[x] * n2q[x];
      const int32_t bits = std::bit_cast<int32_t>(dot);
      const float cosine = std::bit_cast<float>(std::min(std::max(bits, kTinyBits), kOneBits));
      e += selectFloat(bits < kTinyBits, 1e30f, 0.0f) - phiNormal * logPositive(cosine);
    }
    weight[x] = selectFloat(meshIdQ[x] < 0.0f, 0.0f, expNonPositive(-e));
  }
}

}  // namespace

double estimateVariance(const Image& moments, const Image& historyLength, const Image& color,
                        const GBufferView& g, const Image& derivatives,
                        const VarianceSettings& settings, Image& variance, RowTapCounter& taps) {
  const int w = moments.width(), h = moments.height();
  if (!g.depth || !g.normal[0] || !g.meshId)
    throw Error("variance: needs the depth, normal and meshId layers");
  const float* mu1 = moments.plane(0);
  const float* mu2 = moments.plane(1);
  const float* length = historyLength.plane(0);
  const float* dzdx = derivatives.plane(kDepthDx);
  const float* dzdy = derivatives.plane(kDepthDy);
  float* out = variance.plane(0);
  auto lum = [&](size_t i) {
    return luminance(color.plane(0)[i], color.plane(1)[i], color.plane(2)[i]);
  };

  const int r = settings.radius;
  const float phiColor = std::max(settings.phiColor, 1e-30f);
  parallelRows(h, [&](int y) {
    const size_t rowStart = size_t(y) * size_t(w);
    // Temporal estimate where the history is long enough (SVGF §4.2); the span of the others.
    int spanBegin = w, spanEnd = 0;
    for (int x = 0; x < w; ++x) {
      const size_t p = rowStart + size_t(x);
      if (g.isSky(p)) {
        out[p] = 0.0f;
      } else if (length[p] >= settings.minHistory) {
        out[p] = std::max(0.0f, mu2[p] - mu1[p] * mu1[p]);
      } else {
        spanBegin = std::min(spanBegin, x);
        spanEnd = x + 1;
      }
    }
    if (spanBegin >= spanEnd) {
      taps.set(y, 0);
      return;
    }

    // Spatial estimate: bilateral 7x7 average of the moments (Falcor SVGFFilterMoments), one tap
    // at a time across [spanBegin, spanEnd), taps in the order of a per-pixel dy, dx loop so
    // every pixel's sums round as that loop's would. Double sums: mu2 - mu1^2 cancels
    // catastrophically on a flat signal, and 49 float sums would leave a rounding "variance" the
    // luminance term then trusts.
    SpatialVarianceScratch& row = spatialScratch(w);
    for (int x = spanBegin; x < spanEnd; ++x) {
      const size_t p = rowStart + size_t(x);
      row.centreLuminance[size_t(x)] = lum(p);
      const float depthScale = settings.phiDepth * std::max(std::abs(dzdx[p]), std::abs(dzdy[p]));
      row.depthDenominator[size_t(x)] = std::max(depthScale, 1e-8f);  // Falcor's 1e-8 floor
      row.m1[size_t(x)] = row.m2[size_t(x)] = row.weightSum[size_t(x)] = 0.0;
      row.fetched[size_t(x)] = 0;
    }
    float* weight = row.weight.data();
    for (int dy = -r; dy <= r; ++dy) {
      const int qy = y + dy;
      if (qy < 0 || qy >= h) continue;
      const size_t qRow = size_t(qy) * size_t(w);
      float* lq = row.neighbourLuminance.data();
      for (int x = std::max(0, spanBegin - r); x < std::min(w, spanEnd + r); ++x)
        lq[x] = lum(qRow + size_t(x));
      for (int dx = -r; dx <= r; ++dx) {
        const int xBegin = std::max(spanBegin, -dx), xEnd = std::min(spanEnd, w - dx);
        if (xBegin >= xEnd) continue;
        const std::ptrdiff_t shift = std::ptrdiff_t(dy) * w + dx;
        const float* idq = g.meshId + rowStart + shift;
        if (dx == 0 && dy == 0) {
          for (int x = xBegin; x < xEnd; ++x) weight[x] = 1.0f;  // the centre
        } else {
          const float offset = std::sqrt(float(dx * dx + dy * dy));
          const auto tapWeights =
              settings.phiNormal != 0.0f ? &spatialTapWeights<true> : &spatialTapWeights<false>;
          tapWeights(g.depth + rowStart, g.depth + rowStart + shift, row.depthDenominator.data(),
                     row.centreLuminance.data(), lq + dx, g.normal[0] + rowStart,
                     g.normal[1] + rowStart, g.normal[2] + rowStart, g.normal[0] + rowStart + shift,
                     g.normal[1] + rowStart + shift, g.normal[2] + rowStart + shift, idq, offset,
                     phiColor, settings.phiNormal, weight, xBegin, xEnd);
        }
        const float* mu1q = mu1 + rowStart + shift;
        const float* mu2q = mu2 + rowStart + shift;
        double* m1 = row.m1.data();
        double* m2 = row.m2.data();
        double* weightSum = row.weightSum.data();
        int32_t* fetched = row.fetched.data();
        for (int x = xBegin; x < xEnd; ++x) {
          // Sky neighbours are not read: they add exactly +0 (selected on the bits, so a non-finite
          // sky moment cannot leak in and the loop still vectorises).
          const bool sky = idq[x] < 0.0f;
          fetched[x] += sky ? 0 : 1;
          m1[x] += double(selectFloat(sky, 0.0f, weight[x] * mu1q[x]));
          m2[x] += double(selectFloat(sky, 0.0f, weight[x] * mu2q[x]));
          weightSum[x] += double(selectFloat(sky, 0.0f, weight[x]));
        }
      }
    }
    int64_t fetchedInRow = 0;
    for (int x = spanBegin; x < spanEnd; ++x) {
      const size_t p = rowStart + size_t(x);
      if (g.isSky(p) || length[p] >= settings.minHistory) continue;  // decided above
      fetchedInRow += row.fetched[size_t(x)];
      const double m1 = row.m1[size_t(x)] / row.weightSum[size_t(x)];  // the centre always counts
      const double m2 = row.m2[size_t(x)] / row.weightSum[size_t(x)];
      float v = float(std::max(0.0, m2 - m1 * m1));
      if (settings.boostYoungHistory) v *= settings.minHistory / std::max(length[p], 1.0f);
      out[p] = v;
    }
    taps.set(y, fetchedInRow);
  });
  return taps.perPixel(moments.pixelCount());
}

}  // namespace arena
