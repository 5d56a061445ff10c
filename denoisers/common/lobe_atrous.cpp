#include "denoisers/common/lobe_atrous.hpp"

#include <algorithm>
#include <array>
#include <vector>

#include "core/error.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

namespace {

struct Tap {
  int dx, dy;
  float h;
};

// The kernels of common/atrous.hpp, centre first.
std::vector<Tap> kernelOf(AtrousKernel kernel) {
  std::vector<Tap> taps;
  if (kernel == AtrousKernel::B3Spline5x5) {
    constexpr float h[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
    taps.push_back({0, 0, h[2] * h[2]});
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx)
        if (dx != 0 || dy != 0) taps.push_back({dx, dy, h[dx + 2] * h[dy + 2]});
  } else {
    constexpr float h[3] = {2.0f / 3, 1.0f, 2.0f / 3};
    taps.push_back({0, 0, 1.0f});
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx)
        if (dx != 0 || dy != 0) taps.push_back({dx, dy, h[dx + 1] * h[dy + 1]});
  }
  return taps;
}

struct Scratch {
  std::vector<float> weights, centreLuminance, centreInverse, weightSum;
  std::array<std::vector<float>, 7> sum;
};
Scratch& scratchFor(int width) {
  thread_local Scratch s;
  if (s.weights.size() < size_t(width)) {
    for (auto* b : {&s.weights, &s.centreLuminance, &s.centreInverse, &s.weightSum})
      b->assign(size_t(width), 0.0f);
    for (auto& b : s.sum) b.assign(size_t(width), 0.0f);
  }
  return s;
}

}  // namespace

void lobeAtrousIteration(int iteration, const AtrousSettings& settings, const AtrousGuide& guide,
                         const LobeTerm& lobe, const Image& colorIn, Image& colorOut,
                         const Image* extraIn, Image* extraOut) {
  const GBufferView& g = guide.gbuffer;
  const int w = colorIn.width(), h = colorIn.height();
  if (colorIn.channels() != 3 || !colorOut.sameShape(colorIn) || g.width != w || g.height != h)
    throw Error("lobe à-trous: colour in/out must be 3-channel images of the G-buffer's size");
  if ((extraIn == nullptr) != (extraOut == nullptr) ||
      (extraIn && (!extraOut->sameShape(*extraIn) || extraIn->width() != w ||
                   extraIn->height() != h || extraIn->channels() > 4)))
    throw Error("lobe à-trous: extra in/out must match each other and the colour (<= 4 channels)");
  if (lobe.lobes && (lobe.lobes->width() != w || lobe.lobes->height() != h))
    throw Error("lobe à-trous: lobe image size differs");
  const EdgeStopping edges(settings.edges, g, guide.derivatives, colorIn, guide.luminanceVariance,
                           1.0f);
  static const std::vector<Tap> b3 = kernelOf(AtrousKernel::B3Spline5x5);
  static const std::vector<Tap> compact = kernelOf(AtrousKernel::Compact3x3);
  const std::vector<Tap>& taps = settings.kernel == AtrousKernel::B3Spline5x5 ? b3 : compact;
  const int step = 1 << iteration;
  const int extraChannels = extraIn ? extraIn->channels() : 0;
  const float* lobePlanes[4] = {nullptr, nullptr, nullptr, nullptr};
  if (lobe.lobes)
    for (int c = 0; c < 4; ++c) lobePlanes[c] = lobe.lobes->plane(c);

  parallelRows(h, [&](int y) {
    Scratch& s = scratchFor(w);
    const size_t rowStart = size_t(y) * size_t(w);
    edges.prepareRow(y, s.centreLuminance.data(), s.centreInverse.data());
    std::fill(s.weightSum.begin(), s.weightSum.begin() + w, 0.0f);
    for (int c = 0; c < 3 + extraChannels; ++c)
      std::fill(s.sum[size_t(c)].begin(), s.sum[size_t(c)].begin() + w, 0.0f);
    float* weights = s.weights.data();
    for (const Tap& tap : taps) {
      const int ox = tap.dx * step, oy = tap.dy * step;
      if (y + oy < 0 || y + oy >= h) continue;
      const int xBegin = std::max(0, -ox), xEnd = std::min(w, w - ox);
      if (xBegin >= xEnd) continue;
      edges.rowWeights(y, xBegin, xEnd, ox, oy, s.centreLuminance.data(), s.centreInverse.data(),
                       weights);
      const std::ptrdiff_t shift = std::ptrdiff_t(oy) * w + ox;
      if (g.meshId) {
        const float* idq = g.meshId + rowStart + shift;
        for (int x = xBegin; x < xEnd; ++x) weights[x] = idq[x] < 0.0f ? 0.0f : weights[x];
      }
      if (lobe.lobes && shift != 0) {
        const float *ax = lobePlanes[0] + rowStart, *ay = lobePlanes[1] + rowStart,
                    *az = lobePlanes[2] + rowStart, *al = lobePlanes[3] + rowStart;
        for (int x = xBegin; x < xEnd; ++x) {
          const float e = logLobeSimilarity(ax[x], ay[x], az[x], al[x], ax[x + shift],
                                            ay[x + shift], az[x + shift], al[x + shift]);
          weights[x] *= expNonPositive(lobe.beta * e);
        }
      }
      for (int c = 0; c < 3 + extraChannels; ++c) {
        const float* in = (c < 3 ? colorIn.plane(c) : extraIn->plane(c - 3)) + rowStart + shift;
        float* sum = s.sum[size_t(c)].data();
        for (int x = xBegin; x < xEnd; ++x) sum[x] += tap.h * weights[x] * in[x];
      }
      float* weightSum = s.weightSum.data();
      for (int x = xBegin; x < xEnd; ++x) weightSum[x] += tap.h * weights[x];
    }
    for (int x = 0; x < w; ++x) {
      const size_t p = rowStart + size_t(x);
      const bool sky = g.isSky(p);
      const float inverse = sky ? 0.0f : 1.0f / s.weightSum[size_t(x)];
      for (int c = 0; c < 3; ++c)
        colorOut.plane(c)[p] = sky ? colorIn.plane(c)[p] : s.sum[size_t(c)][size_t(x)] * inverse;
      for (int c = 0; c < extraChannels; ++c)
        extraOut->plane(c)[p] =
            sky ? extraIn->plane(c)[p] : s.sum[size_t(3 + c)][size_t(x)] * inverse;
    }
  });
}

}  // namespace arena
