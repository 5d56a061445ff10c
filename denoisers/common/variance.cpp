#include "denoisers/common/variance.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "denoisers/common/edge_stopping.hpp"

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

  parallelRows(h, [&](int y) {
    int64_t fetched = 0;
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      if (g.isSky(p)) {
        out[p] = 0.0f;
        continue;
      }
      if (length[p] >= settings.minHistory) {
        out[p] = std::max(0.0f, mu2[p] - mu1[p] * mu1[p]);  // SVGF §4.2
        continue;
      }
      // Spatial estimate: bilateral 7x7 average of the moments (Falcor SVGFFilterMoments).
      const float lp = lum(p);
      const float depthScale = settings.phiDepth * std::max(std::abs(dzdx[p]), std::abs(dzdy[p]));
      // Double sums: mu2 - mu1^2 cancels catastrophically on a flat signal, and 49 float sums
      // would leave a rounding "variance" the luminance term then trusts.
      double m1 = 0, m2 = 0, weightSum = 0;
      const int r = settings.radius;
      for (int dy = -r; dy <= r; ++dy) {
        for (int dx = -r; dx <= r; ++dx) {
          const int qx = x + dx, qy = y + dy;
          if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
          const size_t q = size_t(qy) * size_t(w) + size_t(qx);
          if (g.isSky(q)) continue;
          ++fetched;
          float weight = 1.0f;
          if (q != p) {
            const float offset = std::sqrt(float(dx * dx + dy * dy));
            // Falcor's 1e-8 floor on the depth scale; 1e-30 guards 0/0.
            const float wz =
                std::abs(g.depth[p] - g.depth[q]) / (std::max(depthScale, 1e-8f) * offset + 1e-30f);
            const float wl = std::abs(lp - lum(q)) / std::max(settings.phiColor, 1e-30f);
            weight = std::exp(-wl - wz) * cosinePowerWeight(g.normalDot(p, q), settings.phiNormal);
          }
          m1 += weight * mu1[q];
          m2 += weight * mu2[q];
          weightSum += weight;
        }
      }
      m1 /= weightSum;  // the centre always counts
      m2 /= weightSum;
      float v = float(std::max(0.0, m2 - m1 * m1));
      if (settings.boostYoungHistory) v *= settings.minHistory / std::max(length[p], 1.0f);
      out[p] = v;
    }
    taps.set(y, fetched);
  });
  return taps.perPixel(moments.pixelCount());
}

}  // namespace arena
