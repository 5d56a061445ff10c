#include "denoisers/common/variance.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "denoisers/common/edge_stopping.hpp"
#include "denoisers/common/gpu_traffic.hpp"

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
  recordAccumulationTraffic(reprojection, w, signal.height(), true);
  const float* signalPlane[3] = {signal.plane(0), signal.plane(1), signal.plane(2)};
  const float* colorHistoryPlane[3] = {colorHistory.plane(0), colorHistory.plane(1),
                                       colorHistory.plane(2)};
  float* accumulatedPlane[3] = {accumulated.plane(0), accumulated.plane(1), accumulated.plane(2)};
  const float* previousLength = previousHistoryLength.plane(0);
  const float *mu1History = momentsHistory.plane(0), *mu2History = momentsHistory.plane(1);
  float* length = historyLength.plane(0);
  float *mu1 = moments.plane(0), *mu2 = moments.plane(1);
  // Eight pixels at a time; per lane the operations of updateHistoryLength, accumulateTemporally
  // and accumulateMoments (a disoccluded lane restarts from the current value).
  auto alphaFloor = [](const AccumulationAlpha& alpha, size_t i, LaneMask8 inRow) {
    const Lanes8 floor = Lanes8{} + alpha.alphaMin;
    return alpha.perPixel ? maxFloat(floor, loadLanes(alpha.perPixel->plane(0) + i, inRow)) : floor;
  };
  auto blendAlphaLanes = [](const AccumulationAlpha& alpha, Lanes8 h, Lanes8 alphaMin, size_t i,
                            LaneMask8 inRow) {  // AccumulationAlpha::blend()
    const Lanes8 a = maxFloat(alphaMin, 1.0f / maxFloat(h, Lanes8{} + 1.0f));
    if (!alpha.antilag) return a;
    return a + loadLanes(alpha.antilag->plane(0) + i, inRow) * (1.0f - a);
  };
  // Q2RTX shortens the reprojected length before alpha is fixed (temporal_accumulation.hpp).
  const float* antilag = colorAlpha.antilag ? colorAlpha.antilag->plane(0) : nullptr;
  parallelRows(signal.height(), [&](int y) {
    for (int x0 = 0; x0 < w; x0 += 8) {
      const size_t i = size_t(y) * size_t(w) + size_t(x0);
      const int count = std::min(8, w - x0);
      const LaneMask8 inRow = laneIndex(Lanes8{}) < count;
      const HistoryLanes taps = reprojection.lanes(i, count);
      Lanes8 current[3];
      for (int c = 0; c < 3; ++c) current[c] = loadLanes(signalPlane[c] + i, inRow);
      const Lanes8 l = luminance(current[0], current[1], current[2]);
      Lanes8 reprojectedLength = taps.apply(previousLength);
      if (antilag) reprojectedLength *= antilagHistoryScale(loadLanes(antilag + i, inRow));
      const Lanes8 h =
          selectFloat(taps.valid, minFloat(reprojectedLength + 1.0f, Lanes8{} + maxHistory),
                      Lanes8{} + 1.0f);  // nextHistoryLength()
      storeLanes(length + i, h, inRow);
      const Lanes8 a = blendAlphaLanes(colorAlpha, h, alphaFloor(colorAlpha, i, inRow), i, inRow);
      for (int c = 0; c < 3; ++c) {
        const Lanes8 blended = a * current[c] + (1.0f - a) * taps.apply(colorHistoryPlane[c]);
        storeLanes(accumulatedPlane[c] + i, selectFloat(taps.valid, blended, current[c]), inRow);
      }
      const Lanes8 am =
          blendAlphaLanes(momentsAlpha, h, alphaFloor(momentsAlpha, i, inRow), i, inRow);
      const Lanes8 m1 = am * l + (1.0f - am) * taps.apply(mu1History);
      const Lanes8 m2 = am * (l * l) + (1.0f - am) * taps.apply(mu2History);
      storeLanes(mu1 + i, selectFloat(taps.valid, m1, l), inRow);
      storeLanes(mu2 + i, selectFloat(taps.valid, m2, l * l), inRow);
    }
  });
}

namespace {

// Per-thread buffers of the spatial estimate, one entry per young pixel of a row (packed), grown
// on first use (no allocation per frame).
struct SpatialVarianceScratch {
  std::vector<int> young;  // x of the row's young pixels
  // Centre guides, and one tap's neighbour values gathered beside them.
  std::vector<float> z, depthDenominator, centreLuminance, n0, n1, n2;
  std::vector<float> zq, luminanceQ, n0q, n1q, n2q, meshIdQ, mu1q, mu2q, weight;
  std::vector<float> rq, gq, bq;    // the neighbours' colour (youngColorMean only)
  std::vector<float> rowLuminance;  // a neighbour row's luminance, indexed by x (runs)
  std::vector<double> m1, m2, weightSum, sumR, sumG, sumB;
  std::vector<int32_t> fetched;
};
SpatialVarianceScratch& spatialScratch(int width) {
  thread_local SpatialVarianceScratch scratch;
  if (scratch.young.size() < size_t(width)) {
    scratch.young.assign(size_t(width), 0);
    for (auto* buffer :
         {&scratch.z, &scratch.depthDenominator, &scratch.centreLuminance, &scratch.n0, &scratch.n1,
          &scratch.n2, &scratch.zq, &scratch.luminanceQ, &scratch.n0q, &scratch.n1q, &scratch.n2q,
          &scratch.meshIdQ, &scratch.mu1q, &scratch.mu2q, &scratch.weight, &scratch.rq, &scratch.gq,
          &scratch.bq, &scratch.rowLuminance})
      buffer->assign(size_t(width), 0.0f);
    for (auto* buffer : {&scratch.m1, &scratch.m2, &scratch.weightSum, &scratch.sumR, &scratch.sumG,
                         &scratch.sumB})
      buffer->assign(size_t(width), 0.0);
    scratch.fetched.assign(size_t(width), 0);
  }
  return scratch;
}

constexpr int32_t kTinyBits = 0x0DA24260, kOneBits = 0x3F800000;  // bits of 1e-30f and 1.0f

// The bilateral weight of one tap (dx, dy) != (0, 0) for x in [xBegin, xEnd), as one vectorised
// sweep: exp(-wl - wz) max(0, n.n')^phiNormal with both exponentials in one (core/fast_math.hpp);
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
                        const VarianceSettings& settings, Image& variance, RowTapCounter& taps,
                        Image* youngColorMean) {
  const int w = moments.width(), h = moments.height();
  if (!g.depth || !g.normal[0] || !g.meshId)
    throw Error("variance: needs the depth, normal and meshId layers");
  if (youngColorMean && (youngColorMean->channels() != 3 || !youngColorMean->sameShape(color)))
    throw Error("variance: youngColorMean must be an RGB image of the colour's size");
  const float* colorPlane[3] = {color.plane(0), color.plane(1), color.plane(2)};
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
    SpatialVarianceScratch& row = spatialScratch(w);
    // Temporal estimate where the history is long enough (SVGF §4.2); the others are young.
    int count = 0;
    for (int x = 0; x < w; ++x) {
      const size_t p = rowStart + size_t(x);
      if (isYoungPixel(g, length, p, settings)) {
        row.young[size_t(count++)] = x;
      } else {
        out[p] = g.isSky(p) ? 0.0f : std::max(0.0f, mu2[p] - mu1[p] * mu1[p]);
      }
    }
    if (count == 0) {
      taps.set(y, 0);
      return;
    }

    // Spatial estimate: bilateral 7x7 average of the moments (Falcor SVGFFilterMoments). The young
    // pixels are packed (they are sparse after a correction or a disocclusion, dense only on the
    // first frames), and every tap gathers their neighbours beside them, so each sweep below is
    // one vectorised loop over the young pixels, taps in the order of a per-pixel dy, dx loop so
    // every pixel's sums round as that loop's would. Double sums: mu2 - mu1^2 cancels
    // catastrophically on a flat signal, and 49 float sums would leave a rounding "variance" the
    // luminance term then trusts.
    for (int k = 0; k < count; ++k) {
      const size_t p = rowStart + size_t(row.young[size_t(k)]);
      row.z[size_t(k)] = g.depth[p];
      row.centreLuminance[size_t(k)] = lum(p);
      const float depthScale = settings.phiDepth * std::max(std::abs(dzdx[p]), std::abs(dzdy[p]));
      row.depthDenominator[size_t(k)] = std::max(depthScale, 1e-8f);  // Falcor's 1e-8 floor
      row.n0[size_t(k)] = g.normal[0][p];
      row.n1[size_t(k)] = g.normal[1][p];
      row.n2[size_t(k)] = g.normal[2][p];
      row.m1[size_t(k)] = row.m2[size_t(k)] = row.weightSum[size_t(k)] = 0.0;
      row.sumR[size_t(k)] = row.sumG[size_t(k)] = row.sumB[size_t(k)] = 0.0;
      row.fetched[size_t(k)] = 0;
    }
    const auto tapWeights =
        settings.phiNormal != 0.0f ? &spatialTapWeights<true> : &spatialTapWeights<false>;
    // A single run of young pixels (the first frames, a large disocclusion) reads its neighbours
    // in place, the image rows offset by the tap; scattered ones are gathered.
    const int first = row.young[0];
    const bool run = row.young[size_t(count - 1)] - first == count - 1;
    for (int dy = -r; dy <= r; ++dy) {
      const int qy = y + dy;
      if (qy < 0 || qy >= h) continue;
      const size_t qRow = size_t(qy) * size_t(w);
      if (run)  // this row's luminance once, not once per tap
        for (int x = std::max(0, first - r); x < std::min(w, first + count + r); ++x)
          row.rowLuminance[size_t(x)] = lum(qRow + size_t(x));
      for (int dx = -r; dx <= r; ++dx) {
        // The young pixels k in [kBegin, kEnd) whose neighbour lies inside the row; in a gather,
        // a neighbour off the image reads as sky (it then adds exactly +0, as a skipped tap
        // would).
        int kBegin = 0, kEnd = count;
        const float *zq, *luminanceQ, *n0q, *n1q, *n2q, *idq, *mu1q, *mu2q;
        const float *rq = nullptr, *gq = nullptr, *bq = nullptr;
        if (run) {
          kBegin = std::max(0, -dx - first);
          kEnd = std::min(count, w - dx - first);
          if (kBegin >= kEnd) continue;
          // Pointers such that [k] is the neighbour of young pixel k (read for k in range only).
          const std::ptrdiff_t offset = std::ptrdiff_t(first) + dx;
          auto at = [&](const float* plane) { return plane + std::ptrdiff_t(qRow) + offset; };
          zq = at(g.depth);
          luminanceQ = row.rowLuminance.data() + offset;
          n0q = at(g.normal[0]);
          n1q = at(g.normal[1]);
          n2q = at(g.normal[2]);
          idq = at(g.meshId);
          mu1q = at(mu1);
          mu2q = at(mu2);
          if (youngColorMean) {
            rq = at(colorPlane[0]);
            gq = at(colorPlane[1]);
            bq = at(colorPlane[2]);
          }
        } else {
          for (int k = 0; k < count; ++k) {
            const int qx = row.young[size_t(k)] + dx;
            const bool inside = qx >= 0 && qx < w;
            const size_t q = qRow + size_t(std::clamp(qx, 0, w - 1));
            row.zq[size_t(k)] = g.depth[q];
            row.luminanceQ[size_t(k)] = lum(q);
            row.n0q[size_t(k)] = g.normal[0][q];
            row.n1q[size_t(k)] = g.normal[1][q];
            row.n2q[size_t(k)] = g.normal[2][q];
            row.meshIdQ[size_t(k)] = inside ? g.meshId[q] : -1.0f;
            row.mu1q[size_t(k)] = mu1[q];
            row.mu2q[size_t(k)] = mu2[q];
          }
          if (youngColorMean) {
            for (int k = 0; k < count; ++k) {
              const size_t q = qRow + size_t(std::clamp(row.young[size_t(k)] + dx, 0, w - 1));
              row.rq[size_t(k)] = colorPlane[0][q];
              row.gq[size_t(k)] = colorPlane[1][q];
              row.bq[size_t(k)] = colorPlane[2][q];
            }
            rq = row.rq.data();
            gq = row.gq.data();
            bq = row.bq.data();
          }
          zq = row.zq.data();
          luminanceQ = row.luminanceQ.data();
          n0q = row.n0q.data();
          n1q = row.n1q.data();
          n2q = row.n2q.data();
          idq = row.meshIdQ.data();
          mu1q = row.mu1q.data();
          mu2q = row.mu2q.data();
        }
        float* weight = row.weight.data();
        if (dx == 0 && dy == 0) {
          std::fill(weight + kBegin, weight + kEnd, 1.0f);  // the centre
        } else {
          tapWeights(row.z.data(), zq, row.depthDenominator.data(), row.centreLuminance.data(),
                     luminanceQ, row.n0.data(), row.n1.data(), row.n2.data(), n0q, n1q, n2q, idq,
                     std::sqrt(float(dx * dx + dy * dy)), phiColor, settings.phiNormal, weight,
                     kBegin, kEnd);
        }
        double* m1 = row.m1.data();
        double* m2 = row.m2.data();
        double* weightSum = row.weightSum.data();
        int32_t* fetched = row.fetched.data();
        for (int k = kBegin; k < kEnd; ++k) {
          // Sky neighbours are not read: they add exactly +0 (selected on the bits, so a non-finite
          // sky moment cannot leak in and the loop still vectorises).
          const bool sky = idq[k] < 0.0f;
          fetched[k] += sky ? 0 : 1;
          m1[k] += double(selectFloat(sky, 0.0f, weight[k] * mu1q[k]));
          m2[k] += double(selectFloat(sky, 0.0f, weight[k] * mu2q[k]));
          weightSum[k] += double(selectFloat(sky, 0.0f, weight[k]));
        }
        if (youngColorMean) {  // Falcor: the colour under the same weights
          double* sumR = row.sumR.data();
          double* sumG = row.sumG.data();
          double* sumB = row.sumB.data();
          for (int k = kBegin; k < kEnd; ++k) {
            const bool sky = idq[k] < 0.0f;
            sumR[k] += double(selectFloat(sky, 0.0f, weight[k] * rq[k]));
            sumG[k] += double(selectFloat(sky, 0.0f, weight[k] * gq[k]));
            sumB[k] += double(selectFloat(sky, 0.0f, weight[k] * bq[k]));
          }
        }
      }
    }
    int64_t fetchedInRow = 0;
    for (int k = 0; k < count; ++k) {
      const size_t p = rowStart + size_t(row.young[size_t(k)]);
      fetchedInRow += row.fetched[size_t(k)];
      const double m1 = row.m1[size_t(k)] / row.weightSum[size_t(k)];  // the centre always counts
      const double m2 = row.m2[size_t(k)] / row.weightSum[size_t(k)];
      float v = float(std::max(0.0, m2 - m1 * m1));
      if (settings.boostYoungHistory) v *= settings.minHistory / std::max(length[p], 1.0f);
      out[p] = v;
      if (youngColorMean) {
        const double weightSum = row.weightSum[size_t(k)];
        youngColorMean->plane(0)[p] = float(row.sumR[size_t(k)] / weightSum);
        youngColorMean->plane(1)[p] = float(row.sumG[size_t(k)] / weightSum);
        youngColorMean->plane(2)[p] = float(row.sumB[size_t(k)] / weightSum);
      }
    }
    taps.set(y, fetchedInRow);
  });
  const double fetched = taps.perPixel(moments.pixelCount());
  if (gpu::recording()) {  // every pixel its moments and h; young ones the 7x7 bilateral
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    gpu::read(kHistoryLength, w, h, 1);
    gpu::read(kMoments, w, h, 1 + fetched);
    gpu::read(kRadiance, w, h, fetched);
    gpu::read(kDepth, w, h, fetched);
    gpu::read(kNormal, w, h, fetched);
    gpu::read(kMeshId, w, h, 1 + fetched);
    gpu::read(kDerivatives, w, h, 1);
    gpu::write(kVariance, w, h);
    if (youngColorMean) gpu::write(kRadiance, w, h);
  }
  return fetched;
}

void replaceYoungColor(const Image& youngColorMean, const Image& historyLength,
                       const GBufferView& g, const VarianceSettings& settings, Image& color) {
  if (youngColorMean.channels() != 3 || color.channels() != 3 || !youngColorMean.sameShape(color))
    throw Error("variance: replaceYoungColor expects two RGB images of one size");
  const int w = color.width();
  const float* length = historyLength.plane(0);
  parallelRows(color.height(), [&](int y) {
    for (size_t p = size_t(y) * size_t(w); p < size_t(y + 1) * size_t(w); ++p)
      if (isYoungPixel(g, length, p, settings))
        for (int c = 0; c < 3; ++c) color.plane(c)[p] = youngColorMean.plane(c)[p];
  });
}

}  // namespace arena
