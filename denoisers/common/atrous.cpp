#include "denoisers/common/atrous.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "denoisers/common/atrous_kernel.hpp"
#include "denoisers/common/footprint.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/simd.hpp"

namespace arena {

namespace {

using atrous_detail::KernelTap;
using atrous_detail::NormalTerm;

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

int kernelRadius(AtrousKernel kernel) {
  return kernel == AtrousKernel::B3Spline5x5 ? 2 : 1;
}

constexpr int kMaxSquarings = 16;  // sigmaN up to 2^16; above, the log form
// The number of squarings k with sigmaN = 2^k, or -1 when sigmaN is not such a power.
int powerOfTwoExponent(float sigmaN) {
  if (!(sigmaN >= 1.0f) || sigmaN > float(1 << kMaxSquarings)) return -1;
  int k = 0;
  const float m = std::frexp(sigmaN, &k);  // sigmaN = m 2^k, m in [0.5, 1)
  return m == 0.5f ? k - 1 : -1;
}

// Per-thread buffers of whole images (the filtered image's luminance, a zero id plane), grown on
// first use and reused by every later iteration and frame: no allocation per frame.
std::vector<float>& scratchPlane(std::vector<float>& plane, size_t size) {
  if (plane.size() < size) plane.assign(size, 0.0f);
  return plane;
}

// Per-thread row buffers of prefilterVariance3x3.
struct RowScratch {
  std::vector<float> sum, weightSum;
};
RowScratch& rowScratch(int width) {
  thread_local RowScratch scratch;
  if (scratch.sum.size() < size_t(width)) {
    scratch.sum.assign(size_t(width), 0.0f);
    scratch.weightSum.assign(size_t(width), 0.0f);
  }
  return scratch;
}

}  // namespace

int atrousTapCount(AtrousKernel kernel) {
  return int(kernelTaps(kernel).size());
}

int atrousIterationTaps(int iteration, const AtrousSettings& settings) {
  return atrousStep(iteration, settings.footprintScale) == 0 ? 0 : atrousTapCount(settings.kernel);
}

const ParamTable<AtrousSettings>& atrousKernelParams() {
  static const ParamTable<AtrousSettings> table = ParamTable<AtrousSettings>().choice(
      "kernel", &AtrousSettings::kernel, "5x5",
      {{"5x5", AtrousKernel::B3Spline5x5}, {"3x3", AtrousKernel::Compact3x3}},
      "à-trous kernel: 5x5 B3 spline (paper) or the compact 3x3 (AMD/talk)");
  return table;
}

namespace {

// What the iteration would move on a GPU (gpu_traffic.hpp): every buffer the enabled terms read
// at every tap, the centre-only guides once. An iteration skipped here (step 0) is a copy a shader
// would not do, but a 1080p frame runs it where its step there is not 0: it is counted as that
// frame's iteration, every tap (PassTraffic::skippedHere). The pre-spatial pass's carried moments
// are computed from the colour taps in a shader (their squares), so only their output is traffic.
void recordTraffic(const AtrousSettings& settings, const AtrousGuide& guide,
                   atrous_detail::Carry carry, int taps, int w, int h) {
  using namespace gpu_buffers;
  const EdgeStoppingSettings& s = settings.edges;
  const GBufferView& g = guide.gbuffer;
  gpu::dispatch(w, h);
  gpu::read(kRadiance, w, h, taps);
  if (g.meshId) gpu::read(kMeshId, w, h, taps);  // sky taps are never gathered
  if (s.depth) {
    gpu::read(kDepth, w, h, taps);
    gpu::read(kDerivatives, w, h, 1);
  }
  if (s.normal) gpu::read(kNormal, w, h, taps);
  if (s.position) gpu::read(kPosition, w, h, taps);
  if (s.luminance) gpu::read(kFilteredVariance, w, h, 1);  // the centre's
  if (guide.lobes) gpu::read(kLobes, w, h, taps);
  gpu::write(kRadiance, w, h);
  if (carry == atrous_detail::Carry::Variance) {
    gpu::read(kVariance, w, h, taps);
    gpu::write(kVariance, w, h);
  } else if (carry == atrous_detail::Carry::Plain) {
    gpu::write(kSecondMoments, w, h);
  }
}

// One iteration with what it carries (atrous_kernel.hpp's Carry).
void filterIteration(int iteration, const AtrousSettings& settings, const AtrousGuide& guide,
                     float colorSigma, const Image& colorIn, Image& colorOut,
                     atrous_detail::Carry carry, const Image* carryIn, Image* carryOut) {
  const GBufferView& g = guide.gbuffer;
  const int w = colorIn.width(), h = colorIn.height();
  if (colorIn.channels() != 3 || !colorOut.sameShape(colorIn) || g.width != w || g.height != h)
    throw Error("à-trous: colour in/out must be 3-channel images of the G-buffer's size");
  if (iteration < 0 || iteration > 24) throw Error("à-trous: iteration out of range [0, 24]");
  const int step = atrousStep(iteration, settings.footprintScale);
  if (step == 0) {  // footprint.hpp: an iteration scaled below half a pixel is skipped
    if (gpu::recording() && atrousRunsAt1080p(iteration, settings.footprintScale, h)) {
      recordTraffic(settings, guide, carry, atrousTapCount(settings.kernel), w, h);
      gpu::skippedHere();
    }
    parallelCopy(colorIn, colorOut);
    if (carryIn) parallelCopy(*carryIn, *carryOut);
    return;
  }
  if (guide.lobes && (guide.lobes->width() != w || guide.lobes->height() != h ||
                      guide.lobes->channels() != kSpecularLobeChannels))
    throw Error("à-trous: the lobe image must have 4 channels and the G-buffer's size");

  const EdgeStoppingSettings& s = settings.edges;
  // Checks that every enabled term has its guides (throws otherwise); the kernel evaluates its
  // weight() restructured into blocks (see filterBlock).
  const EdgeStopping edges(s, g, guide.derivatives, colorIn, guide.luminanceVariance, colorSigma);
  const size_t pixels = size_t(w) * size_t(h);

  atrous_detail::Iteration it{};
  const std::vector<KernelTap>& taps = kernelTaps(settings.kernel);
  it.width = w;
  it.height = h;
  it.step = step;
  it.radius = kernelRadius(settings.kernel);
  it.taps = taps.data();
  it.tapCount = int(taps.size());
  for (int c = 0; c < 3; ++c) {
    it.color[c] = colorIn.plane(c);
    it.out[c] = colorOut.plane(c);
  }
  if (carryIn) {
    it.carryCount = carryIn->channels();
    for (int c = 0; c < it.carryCount; ++c) {
      it.carryIn[c] = carryIn->plane(c);
      it.carryOut[c] = carryOut->plane(c);
    }
  }
  if (s.depth) {
    it.z = g.depth;
    it.dzdx = guide.derivatives->plane(kDepthDx);
    it.dzdy = guide.derivatives->plane(kDepthDy);
    it.sigmaZ = s.sigmaZ;
    it.depthEpsilon = s.depthEpsilon;
  }
  thread_local std::vector<float> luminancePlane, zeroIds;
  if (s.luminance) {
    // The luminance of every pixel once, not once per tap.
    float* l = scratchPlane(luminancePlane, pixels).data();
    parallelRows(h, [&](int y) {
      const size_t row = size_t(y) * size_t(w);
      for (size_t i = row; i < row + size_t(w); ++i)
        l[i] = luminance(it.color[0][i], it.color[1][i], it.color[2][i]);
    });
    it.luminance = l;
    it.luminanceVariance = guide.luminanceVariance->plane(0);
    it.sigmaL = s.sigmaL;
    it.luminanceEpsilon = s.luminanceEpsilon;
  }
  auto addDistance = [&](const std::array<const float*, 3>& planes, float sigma) {
    atrous_detail::DistanceTerm& term = it.distances[it.distanceCount++];
    for (size_t c = 0; c < 3; ++c) term.planes[c] = planes[c];
    term.inverseSigma = 1.0f / std::max(sigma, 1e-30f);
  };
  if (s.position) addDistance(g.position, s.sigmaX);
  if (s.color) addDistance({it.color[0], it.color[1], it.color[2]}, colorSigma);
  if (s.normal && s.normalForm == NormalWeightForm::GaussianDistance)
    addDistance(g.normal, s.sigmaN);
  NormalTerm normalTerm = NormalTerm::None;
  if (s.normal && s.normalForm == NormalWeightForm::CosinePower && s.sigmaN != 0.0f) {
    it.squarings = powerOfTwoExponent(s.sigmaN);
    normalTerm = it.squarings >= 0 ? NormalTerm::CosinePowerOfTwo : NormalTerm::CosineLog;
    for (size_t c = 0; c < 3; ++c) it.normal[c] = g.normal[c];
    it.sigmaN = s.sigmaN;
  }
  it.meshId = g.meshId ? g.meshId : scratchPlane(zeroIds, pixels).data();
  it.idTerm = s.id;
  if (guide.lobes) {
    for (int c = 0; c < kSpecularLobeChannels; ++c) it.lobes[c] = guide.lobes->plane(c);
    it.lobeBeta = guide.lobeBeta;
  }

  if (gpu::recording()) recordTraffic(settings, guide, carry, it.tapCount, w, h);

  const atrous_detail::FilterRowFunction filterRow =
      simdUsesAvx512()
          ? atrous_detail::selectFilterRowAvx512(s.depth, s.luminance, normalTerm, carry)
          : atrous_detail::selectFilterRow<Lanes8>(s.depth, s.luminance, normalTerm, carry);
  parallelRows(h, [&](int y) { filterRow(it, y); });
}

}  // namespace

void atrousIteration(int iteration, const AtrousSettings& settings, const AtrousGuide& guide,
                     float colorSigma, const Image& colorIn, Image& colorOut,
                     const Image* varianceIn, Image* varianceOut) {
  if ((varianceIn == nullptr) != (varianceOut == nullptr))
    throw Error("à-trous: variance propagation needs both a variance input and output");
  if (varianceIn &&
      (varianceIn->channels() != 1 || !varianceOut->sameShape(*varianceIn) ||
       varianceIn->width() != colorIn.width() || varianceIn->height() != colorIn.height()))
    throw Error("à-trous: the variance in/out must be 1-channel images of the colour's size");
  filterIteration(iteration, settings, guide, colorSigma, colorIn, colorOut,
                  varianceIn ? atrous_detail::Carry::Variance : atrous_detail::Carry::None,
                  varianceIn, varianceOut);
}

void atrousIterationWithMoments(int iteration, const AtrousSettings& settings,
                                const AtrousGuide& guide, float colorSigma, const Image& colorIn,
                                Image& colorOut, const Image& momentsIn, Image& momentsOut) {
  if (momentsIn.channels() < 1 || momentsIn.channels() > 4 || !momentsOut.sameShape(momentsIn) ||
      momentsIn.width() != colorIn.width() || momentsIn.height() != colorIn.height())
    throw Error(
        "à-trous: moments in/out must be equal images of 1 to 4 channels, the colour's size");
  filterIteration(iteration, settings, guide, colorSigma, colorIn, colorOut,
                  atrous_detail::Carry::Plain, &momentsIn, &momentsOut);
}

void prefilterVariance3x3(const Image& variance, const GBufferView& g, Image& filtered) {
  const int w = variance.width(), h = variance.height();
  if (!filtered.sameShape(variance) || variance.channels() != 1)
    throw Error("variance pre-filter: expected two 1-channel images of equal size");
  constexpr float kGauss[3] = {0.25f, 0.5f, 0.25f};
  const float* in = variance.plane(0);
  float* out = filtered.plane(0);
  // Counted as its own dispatch, as the pipelines here time it (Falcor fuses it into the
  // à-trous shader, reading the variance at 9 taps there instead).
  if (gpu::recording()) {
    gpu::dispatch(w, h);
    gpu::read(gpu_buffers::kVariance, w, h, 9);
    if (g.meshId) gpu::read(gpu_buffers::kMeshId, w, h, 9);
    gpu::write(gpu_buffers::kFilteredVariance, w, h);
  }
  // Tap by tap across the row, in the order of a per-pixel loop over dy, then dx, so the sums
  // round exactly as that loop's would; sky and off-image taps add nothing.
  parallelRows(h, [&](int y) {
    RowScratch& row = rowScratch(w);
    float* __restrict sum = row.sum.data();
    float* __restrict weightSum = row.weightSum.data();
    std::fill(sum, sum + w, 0.0f);
    std::fill(weightSum, weightSum + w, 0.0f);
    for (int dy = -1; dy <= 1; ++dy) {
      const int qy = y + dy;
      if (qy < 0 || qy >= h) continue;
      for (int dx = -1; dx <= 1; ++dx) {
        const float k = kGauss[dx + 1] * kGauss[dy + 1];
        const int xBegin = std::max(0, -dx), xEnd = std::min(w, w - dx);
        const float* inQ = in + size_t(qy) * size_t(w) + dx;
        if (g.meshId) {
          const float* idQ = g.meshId + size_t(qy) * size_t(w) + dx;
          for (int x = xBegin; x < xEnd; ++x) {
            const bool sky = idQ[x] < 0.0f;
            sum[x] += selectFloat(sky, 0.0f, k * inQ[x]);
            weightSum[x] += selectFloat(sky, 0.0f, k);
          }
        } else {
          for (int x = xBegin; x < xEnd; ++x) {
            sum[x] += k * inQ[x];
            weightSum[x] += k;
          }
        }
      }
    }
    const size_t rowStart = size_t(y) * size_t(w);
    const float* inRow = in + rowStart;
    const float* id = g.meshId ? g.meshId + rowStart : weightSum;  // weights are never < 0
    float* outRow = out + rowStart;
    for (int x = 0; x < w; ++x) {
      // The centre is always counted for a surface pixel, so the weight sum is positive there.
      outRow[x] = selectFloat(id[x] < 0.0f, inRow[x], sum[x] / weightSum[x]);
    }
  });
}

}  // namespace arena
