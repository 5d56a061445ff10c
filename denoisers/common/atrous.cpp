#include "denoisers/common/atrous.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <vector>

#include "core/error.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

namespace {

struct KernelTap {
  int dx, dy;
  float h;
};

// The separable kernels as tap lists (centre first, so the centre weight is never skipped).
const std::vector<KernelTap>& kernelTaps(AtrousKernel kernel) {
  static const std::vector<KernelTap> b3 = [] {
    constexpr float h[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
    std::vector<KernelTap> taps{{0, 0, h[2] * h[2]}};
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx)
        if (dx != 0 || dy != 0) taps.push_back({dx, dy, h[dx + 2] * h[dy + 2]});
    return taps;
  }();
  static const std::vector<KernelTap> compact = [] {
    constexpr float h[3] = {2.0f / 3, 1.0f, 2.0f / 3};
    std::vector<KernelTap> taps{{0, 0, 1.0f}};
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if (dx != 0 || dy != 0) taps.push_back({dx, dy, h[dx + 1] * h[dy + 1]});
    return taps;
  }();
  return kernel == AtrousKernel::B3Spline5x5 ? b3 : compact;
}

// Per-thread row buffers, grown on first use and reused by every later row and frame.
struct RowScratch {
  std::vector<float> weights, centreLuminance, centreInverseDenominator, weightSum, varianceSum;
  std::array<std::vector<float>, 3> sum;
};
RowScratch& rowScratch(int width) {
  thread_local RowScratch scratch;
  if (scratch.weights.size() < size_t(width)) {
    for (auto* buffer : {&scratch.weights, &scratch.centreLuminance,
                         &scratch.centreInverseDenominator, &scratch.weightSum,
                         &scratch.varianceSum, &scratch.sum[0], &scratch.sum[1], &scratch.sum[2]})
      buffer->assign(size_t(width), 0.0f);
  }
  return scratch;
}

}  // namespace

int atrousTapCount(AtrousKernel kernel) {
  return int(kernelTaps(kernel).size());
}

void atrousIteration(int iteration, const AtrousSettings& settings, const AtrousGuide& guide,
                     float colorSigma, const Image& colorIn, Image& colorOut,
                     const Image* varianceIn, Image* varianceOut) {
  const GBufferView& g = guide.gbuffer;
  const int w = colorIn.width(), h = colorIn.height();
  if (colorIn.channels() != 3 || !colorOut.sameShape(colorIn) || g.width != w || g.height != h)
    throw Error("à-trous: colour in/out must be 3-channel images of the G-buffer's size");
  if ((varianceIn == nullptr) != (varianceOut == nullptr))
    throw Error("à-trous: variance propagation needs both a variance input and output");
  if (iteration < 0 || iteration > 24) throw Error("à-trous: iteration out of range [0, 24]");

  const EdgeStopping edges(settings.edges, g, guide.derivatives, colorIn, guide.luminanceVariance,
                           colorSigma);
  const std::vector<KernelTap>& taps = kernelTaps(settings.kernel);
  const int step = 1 << iteration;
  const float* varIn = varianceIn ? varianceIn->plane(0) : nullptr;
  float* varOut = varianceOut ? varianceOut->plane(0) : nullptr;

  // Each row sweeps one kernel tap at a time across all its pixels, accumulating into row
  // buffers: the inner loops run over contiguous x and vectorise.
  parallelRows(h, [&](int y) {
    RowScratch& row = rowScratch(w);
    const size_t rowStart = size_t(y) * size_t(w);
    edges.prepareRow(y, row.centreLuminance.data(), row.centreInverseDenominator.data());
    for (auto* buffer : {&row.sum[0], &row.sum[1], &row.sum[2], &row.weightSum, &row.varianceSum})
      std::fill(buffer->begin(), buffer->begin() + w, 0.0f);
    float* weights = row.weights.data();
    for (const KernelTap& tap : taps) {
      const int offsetX = tap.dx * step, offsetY = tap.dy * step;
      if (y + offsetY < 0 || y + offsetY >= h) continue;
      const int xBegin = std::max(0, -offsetX), xEnd = std::min(w, w - offsetX);
      if (xBegin >= xEnd) continue;  // taps outside the image are dropped (renormalised border)
      edges.rowWeights(y, xBegin, xEnd, offsetX, offsetY, row.centreLuminance.data(),
                       row.centreInverseDenominator.data(), weights);
      const std::ptrdiff_t shift = std::ptrdiff_t(offsetY) * w + offsetX;
      if (g.meshId) {  // never gather from the sky
        const float* idq = g.meshId + rowStart + shift;
        for (int x = xBegin; x < xEnd; ++x) weights[x] = idq[x] < 0.0f ? 0.0f : weights[x];
      }
      for (int c = 0; c < 3; ++c) {
        const float* in = colorIn.plane(c) + rowStart + shift;
        float* sum = row.sum[size_t(c)].data();
        for (int x = xBegin; x < xEnd; ++x) sum[x] += tap.h * weights[x] * in[x];
      }
      float* weightSum = row.weightSum.data();
      for (int x = xBegin; x < xEnd; ++x) weightSum[x] += tap.h * weights[x];
      if (varIn) {
        const float* var = varIn + rowStart + shift;
        float* varianceSum = row.varianceSum.data();
        for (int x = xBegin; x < xEnd; ++x) {
          const float weight = tap.h * weights[x];
          varianceSum[x] += weight * weight * var[x];
        }
      }
    }
    for (int x = 0; x < w; ++x) {
      const size_t p = rowStart + size_t(x);
      if (g.isSky(p)) {  // sky passes through
        for (int c = 0; c < 3; ++c) colorOut.plane(c)[p] = colorIn.plane(c)[p];
        if (varOut) varOut[p] = varIn[p];
        continue;
      }
      // The centre tap always contributes h(0) > 0, so the weight sum is positive.
      const float inverse = 1.0f / row.weightSum[size_t(x)];
      for (int c = 0; c < 3; ++c) colorOut.plane(c)[p] = row.sum[size_t(c)][size_t(x)] * inverse;
      if (varOut) varOut[p] = row.varianceSum[size_t(x)] * inverse * inverse;
    }
  });
}

void prefilterVariance3x3(const Image& variance, const GBufferView& g, Image& filtered) {
  const int w = variance.width(), h = variance.height();
  if (!filtered.sameShape(variance) || variance.channels() != 1)
    throw Error("variance pre-filter: expected two 1-channel images of equal size");
  constexpr float kGauss[3] = {0.25f, 0.5f, 0.25f};
  const float* in = variance.plane(0);
  float* out = filtered.plane(0);
  parallelRows(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      if (g.isSky(p)) {
        out[p] = in[p];
        continue;
      }
      float sum = 0, weightSum = 0;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int qx = x + dx, qy = y + dy;
          if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
          const size_t q = size_t(qy) * size_t(w) + size_t(qx);
          if (g.isSky(q)) continue;
          const float k = kGauss[dx + 1] * kGauss[dy + 1];
          sum += k * in[q];
          weightSum += k;
        }
      }
      out[p] = sum / weightSum;  // the centre is always counted
    }
  });
}

}  // namespace arena
