#include "denoisers/common/atrous.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "denoisers/common/fast_math.hpp"
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

constexpr int kMaxKernelRadius = 2;
constexpr int kKernelRows = 2 * kMaxKernelRadius + 1;

// Per-thread row buffers, grown on first use and reused by every later row and frame (no
// allocation per frame once the widest image has been seen).
struct RowScratch {
  std::vector<float> centreLuminance, centreInverseDenominator, depthEpsilon, exponent,
      normalFactor, weightSum, varianceSum;
  std::array<std::vector<float>, 3> sum;
  // Luminance of the filtered image on rows y + dy 2^i, dy = -2..2: every tap of a row reads its
  // neighbour luminance from these instead of recomputing it from RGB 25 times per pixel.
  std::array<std::vector<float>, kKernelRows> neighbourLuminance;
};
RowScratch& rowScratch(int width) {
  thread_local RowScratch scratch;
  if (scratch.weightSum.size() < size_t(width)) {
    for (auto* buffer :
         {&scratch.centreLuminance, &scratch.centreInverseDenominator, &scratch.depthEpsilon,
          &scratch.exponent, &scratch.normalFactor, &scratch.weightSum, &scratch.varianceSum,
          &scratch.sum[0], &scratch.sum[1], &scratch.sum[2]})
      buffer->assign(size_t(width), 0.0f);
    for (auto& buffer : scratch.neighbourLuminance) buffer.assign(size_t(width), 0.0f);
  }
  return scratch;
}

// How the normal term enters a tap's weight.
enum class NormalTerm {
  None,              // off, a Gaussian distance (summed with the other distances), or sigmaN = 0
  CosineLog,         // max(0, n.n')^sigmaN as exp(sigmaN log(n.n')) inside the one exp per tap
  CosinePowerOfTwo,  // sigmaN = 2^k: n.n' squared k times (exact powers, no log), times the exp
};

// Squared-distance terms |a(p) - a(q)|^2 / sigma over three planes each: position, colour and the
// Gaussian normal form, in this order (the order EdgeStopping::rowWeights sums them in).
struct DistanceTerm {
  std::array<const float*, 3> planes;
  float inverseSigma;
};

// Everything the exponent of one tap's sweep across a row reads; pointers are to the row's first
// pixel (x = 0), the neighbour q at + shift.
struct TapRow {
  // Depth, SVGF eq. 3.
  const float *z, *dzdx, *dzdy, *depthEpsilon;
  float offsetX, offsetY;  // sigmaZ times the pixel offset
  // Luminance, SVGF eq. 5.
  const float *centreLuminance, *centreInverseDenominator, *luminanceQ;
  // Distances.
  std::array<DistanceTerm, 3> distances;
  std::ptrdiff_t shift;
  // Cosine normal term.
  std::array<const float*, 3> normal;
  float sigmaN;
  // Sky (meshId < 0) and mesh-id term.
  const float* meshId;
  bool idTerm;
};

constexpr int32_t kTinyBits = 0x0DA24260, kOneBits = 0x3F800000;  // bits of 1e-30f and 1.0f
constexpr float kNeverExponent = 1e30f;  // exp(-1e30) is exactly 0 in expNonPositive

// The summed exponent of every enabled exponential term for taps x in [xBegin, xEnd), and the
// clamped cosine for the power-of-two normal term; one branch-free loop that GCC vectorises
// (each term is a template switch, so a disabled term costs nothing). Kept apart from the
// accumulation below: fused, the loop needs more pointers than there are registers and runs
// slower (measured).
template <bool Depth, bool Luminance, int Distances, NormalTerm Normal, bool Mesh>
void tapExponent(const TapRow& t, int xBegin, int xEnd, float* __restrict exponent,
                 float* __restrict normalFactor) {
  const std::ptrdiff_t shift = t.shift;
  const bool idTerm = t.idTerm;
  for (int x = xBegin; x < xEnd; ++x) {
    float e = 0.0f;
    if constexpr (Depth)
      e += std::abs(t.z[x] - t.z[x + shift]) /
           (std::abs(t.dzdx[x] * t.offsetX + t.dzdy[x] * t.offsetY) + t.depthEpsilon[x] + 1e-30f);
    if constexpr (Luminance)
      e += std::abs(t.centreLuminance[x] - t.luminanceQ[x]) * t.centreInverseDenominator[x];
#pragma GCC unroll 3
    for (int d = 0; d < Distances; ++d) {
      const DistanceTerm& term = t.distances[size_t(d)];
      float distanceSquared = 0.0f;
#pragma GCC unroll 3
      for (size_t c = 0; c < 3; ++c) {
        const float difference = term.planes[c][x] - term.planes[c][x + shift];
        distanceSquared += difference * difference;
      }
      e += distanceSquared * term.inverseSigma;  // |a(p) - a(q)|^2 / sigma, one multiply
    }
    if constexpr (Normal != NormalTerm::None) {
      const float dot = t.normal[0][x] * t.normal[0][x + shift] +
                        t.normal[1][x] * t.normal[1][x + shift] +
                        t.normal[2][x] * t.normal[2][x + shift];
      // min(n.n', 1) clamped below at 1e-30 on the bit pattern (see fast_math.hpp on why not in
      // floats); n.n' <= 1e-30 gives weight 0.
      const int32_t bits = std::bit_cast<int32_t>(dot);
      const float cosine = std::bit_cast<float>(std::min(std::max(bits, kTinyBits), kOneBits));
      if constexpr (Normal == NormalTerm::CosineLog)
        e += selectFloat(bits < kTinyBits, kNeverExponent, 0.0f) - t.sigmaN * logPositive(cosine);
      else
        normalFactor[x] = selectFloat(bits < kTinyBits, 0.0f, cosine);
    }
    if constexpr (Mesh) {  // never gather from the sky; with the id term, never across meshes
      const float id = t.meshId[x], idq = t.meshId[x + shift];
      // Both compares unconditionally (& and |, not && and ||): a float compare that only runs on
      // one branch is control flow to the vectoriser.
      const bool keep = (idq >= 0.0f) & (!idTerm | (id == idq));
      e = selectFloat(keep, e, kNeverExponent);
    }
    exponent[x] = e;
  }
}

using TapExponentFunction = void (*)(const TapRow&, int, int, float*, float*);

// The instantiation for this iteration's terms, chosen once per iteration.
template <bool Depth, bool Luminance, int Distances, NormalTerm Normal>
TapExponentFunction selectTapExponent(bool mesh) {
  return mesh ? &tapExponent<Depth, Luminance, Distances, Normal, true>
              : &tapExponent<Depth, Luminance, Distances, Normal, false>;
}
template <bool Depth, bool Luminance, int Distances>
TapExponentFunction selectTapExponent(NormalTerm normal, bool mesh) {
  switch (normal) {
    case NormalTerm::None:
      return selectTapExponent<Depth, Luminance, Distances, NormalTerm::None>(mesh);
    case NormalTerm::CosineLog:
      return selectTapExponent<Depth, Luminance, Distances, NormalTerm::CosineLog>(mesh);
    case NormalTerm::CosinePowerOfTwo:
      break;
  }
  return selectTapExponent<Depth, Luminance, Distances, NormalTerm::CosinePowerOfTwo>(mesh);
}
template <bool Depth, bool Luminance>
TapExponentFunction selectTapExponent(int distances, NormalTerm normal, bool mesh) {
  switch (distances) {
    case 0:
      return selectTapExponent<Depth, Luminance, 0>(normal, mesh);
    case 1:
      return selectTapExponent<Depth, Luminance, 1>(normal, mesh);
    case 2:
      return selectTapExponent<Depth, Luminance, 2>(normal, mesh);
  }
  return selectTapExponent<Depth, Luminance, 3>(normal, mesh);
}
TapExponentFunction selectTapExponent(bool depth, bool luminance, int distances, NormalTerm normal,
                                      bool mesh) {
  if (depth)
    return luminance ? selectTapExponent<true, true>(distances, normal, mesh)
                     : selectTapExponent<true, false>(distances, normal, mesh);
  return luminance ? selectTapExponent<false, true>(distances, normal, mesh)
                   : selectTapExponent<false, false>(distances, normal, mesh);
}

constexpr int kMaxSquarings = 16;  // sigmaN up to 2^16; above, the log form
// The number of squarings k with sigmaN = 2^k, or -1 when sigmaN is not such a power.
int powerOfTwoExponent(float sigmaN) {
  if (!(sigmaN >= 1.0f) || sigmaN > float(1 << kMaxSquarings)) return -1;
  int k = 0;
  const float m = std::frexp(sigmaN, &k);  // sigmaN = m 2^k, m in [0.5, 1)
  return m == 0.5f ? k - 1 : -1;
}

// The tap's weights h w(p, q) = h exp(-exponent) [cosine^(2^Squarings)] accumulated into the row
// sums (Squarings < 0: no cosine factor). Plain restrict pointer parameters: GCC 12 does not
// vectorise this loop when they come out of a struct.
template <bool Variance, int Squarings>
void accumulateTap(const float* __restrict exponent, const float* __restrict cosine, float h,
                   const float* __restrict color0, const float* __restrict color1,
                   const float* __restrict color2, const float* __restrict varianceQ,
                   float* __restrict sum0, float* __restrict sum1, float* __restrict sum2,
                   float* __restrict weightSum, float* __restrict varianceSum, int xBegin,
                   int xEnd) {
  for (int x = xBegin; x < xEnd; ++x) {
    float w = expNonPositive(-exponent[x]);
    if constexpr (Squarings >= 0) {
      float power = cosine[x];
      for (int k = 0; k < Squarings; ++k) power *= power;
      w *= power;
    }
    const float weight = h * w;
    sum0[x] += weight * color0[x];
    sum1[x] += weight * color1[x];
    sum2[x] += weight * color2[x];
    weightSum[x] += weight;
    if constexpr (Variance) varianceSum[x] += weight * weight * varianceQ[x];
  }
}
using AccumulateTapFunction = decltype(&accumulateTap<false, -1>);
template <bool Variance, int... K>
AccumulateTapFunction selectAccumulateTap(int squarings, std::integer_sequence<int, K...>) {
  constexpr AccumulateTapFunction table[] = {&accumulateTap<Variance, K - 1>...};
  return table[squarings + 1];
}
AccumulateTapFunction selectAccumulateTap(bool variance, int squarings) {
  constexpr auto k = std::make_integer_sequence<int, kMaxSquarings + 2>{};  // -1 .. kMaxSquarings
  return variance ? selectAccumulateTap<true>(squarings, k)
                  : selectAccumulateTap<false>(squarings, k);
}

// out = sum / weightSum (variance: varianceSum / weightSum^2), or the input on sky pixels. The
// centre tap always contributes h(0) > 0, so the weight sum is positive.
void normaliseRow(const float* __restrict meshId, const float* __restrict in0,
                  const float* __restrict in1, const float* __restrict in2,
                  const float* __restrict varianceIn, const float* __restrict sum0,
                  const float* __restrict sum1, const float* __restrict sum2,
                  const float* __restrict weightSum, const float* __restrict varianceSum,
                  float* __restrict out0, float* __restrict out1, float* __restrict out2,
                  float* __restrict varianceOut, int width) {
  const float* id = meshId ? meshId : weightSum;  // weights are never < 0: no sky
  for (int x = 0; x < width; ++x) {
    const bool sky = id[x] < 0.0f;
    const float inverse = 1.0f / weightSum[x];
    out0[x] = selectFloat(sky, in0[x], sum0[x] * inverse);
    out1[x] = selectFloat(sky, in1[x], sum1[x] * inverse);
    out2[x] = selectFloat(sky, in2[x], sum2[x] * inverse);
  }
  if (!varianceOut) return;
  for (int x = 0; x < width; ++x) {
    const float inverse = 1.0f / weightSum[x];
    varianceOut[x] = selectFloat(id[x] < 0.0f, varianceIn[x], varianceSum[x] * inverse * inverse);
  }
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

  const EdgeStoppingSettings& s = settings.edges;
  // Checks that every enabled term has its guides (throws otherwise). The loops below evaluate the
  // w(p, q) of its rowWeights(), restructured so each tap is one vectorised sweep; equal up to
  // float rounding (a distance term multiplies by 1/sigma once, not per channel; a power-of-two
  // sigmaN squares the cosine instead of exp(sigmaN log(cosine))).
  const EdgeStopping edges(s, g, guide.derivatives, colorIn, guide.luminanceVariance, colorSigma);
  const std::vector<KernelTap>& taps = kernelTaps(settings.kernel);
  const int step = 1 << iteration;
  const float* varIn = varianceIn ? varianceIn->plane(0) : nullptr;
  float* varOut = varianceOut ? varianceOut->plane(0) : nullptr;
  const std::array<const float*, 3> color = {colorIn.plane(0), colorIn.plane(1), colorIn.plane(2)};

  // Which terms are on, decided once per iteration.
  std::array<DistanceTerm, 3> distances{};
  int distanceCount = 0;
  if (s.position)
    distances[size_t(distanceCount++)] = {g.position, 1.0f / std::max(s.sigmaX, 1e-30f)};
  if (s.color) distances[size_t(distanceCount++)] = {color, 1.0f / std::max(colorSigma, 1e-30f)};
  if (s.normal && s.normalForm == NormalWeightForm::GaussianDistance)
    distances[size_t(distanceCount++)] = {g.normal, 1.0f / std::max(s.sigmaN, 1e-30f)};
  NormalTerm normalTerm = NormalTerm::None;
  int squarings = -1;
  if (s.normal && s.normalForm == NormalWeightForm::CosinePower && s.sigmaN != 0.0f) {
    squarings = powerOfTwoExponent(s.sigmaN);
    normalTerm = squarings >= 0 ? NormalTerm::CosinePowerOfTwo : NormalTerm::CosineLog;
  }
  const bool mesh = g.meshId != nullptr;
  const TapExponentFunction tapExponentRow =
      selectTapExponent(s.depth, s.luminance, distanceCount, normalTerm, mesh);
  const AccumulateTapFunction accumulate = selectAccumulateTap(varIn != nullptr, squarings);

  // Each row sweeps one kernel tap at a time across all its pixels, accumulating into row
  // buffers: the inner loops run over contiguous x and vectorise.
  parallelRows(h, [&](int y) {
    RowScratch& row = rowScratch(w);
    const size_t rowStart = size_t(y) * size_t(w);
    const float* varRow = varIn ? varIn + rowStart : nullptr;

    // Centre terms, once per pixel (not per tap).
    if (s.luminance) {
      const float* variance = guide.luminanceVariance->plane(0) + rowStart;
      float* inverseDenominator = row.centreInverseDenominator.data();
      // std::sqrt keeps a scalar errno branch (the build has math errno on), so this loop does not
      // vectorise; it runs once per pixel, not per tap.
      for (int x = 0; x < w; ++x) inverseDenominator[x] = std::sqrt(std::max(0.0f, variance[x]));
      for (int x = 0; x < w; ++x) {
        const size_t p = rowStart + size_t(x);
        row.centreLuminance[size_t(x)] = luminance(color[0][p], color[1][p], color[2][p]);
        inverseDenominator[x] =
            1.0f / (s.sigmaL * inverseDenominator[x] + s.luminanceEpsilon + 1e-30f);
      }
      for (int j = 0; j < kKernelRows; ++j) {
        const int yq = y + (j - kMaxKernelRadius) * step;
        if (yq < 0 || yq >= h) continue;
        const size_t q0 = size_t(yq) * size_t(w);
        float* l = row.neighbourLuminance[size_t(j)].data();
        for (int x = 0; x < w; ++x)
          l[x] = luminance(color[0][q0 + size_t(x)], color[1][q0 + size_t(x)],
                           color[2][q0 + size_t(x)]);
      }
    }
    if (s.depth) {
      const float* z = g.depth + rowStart;
      for (int x = 0; x < w; ++x) row.depthEpsilon[size_t(x)] = s.depthEpsilon * std::abs(z[x]);
    }

    float* sum0 = row.sum[0].data();
    float* sum1 = row.sum[1].data();
    float* sum2 = row.sum[2].data();
    float* weightSum = row.weightSum.data();
    float* varianceSum = row.varianceSum.data();
    TapRow t{};
    if (s.depth) {
      t.z = g.depth + rowStart;
      t.dzdx = guide.derivatives->plane(kDepthDx) + rowStart;
      t.dzdy = guide.derivatives->plane(kDepthDy) + rowStart;
      t.depthEpsilon = row.depthEpsilon.data();
    }
    t.centreLuminance = row.centreLuminance.data();
    t.centreInverseDenominator = row.centreInverseDenominator.data();
    for (int d = 0; d < distanceCount; ++d) {
      for (size_t c = 0; c < 3; ++c)
        t.distances[size_t(d)].planes[c] = distances[size_t(d)].planes[c] + rowStart;
      t.distances[size_t(d)].inverseSigma = distances[size_t(d)].inverseSigma;
    }
    if (normalTerm != NormalTerm::None)
      for (size_t c = 0; c < 3; ++c) t.normal[c] = g.normal[c] + rowStart;
    t.sigmaN = s.sigmaN;
    if (mesh) t.meshId = g.meshId + rowStart;
    t.idTerm = s.id;

    // The centre tap (always first) has weight 1: it initialises the sums.
    const float h0 = taps.front().h;
    std::fill(weightSum, weightSum + w, h0);
    for (size_t c = 0; c < 3; ++c) {
      const float* in = color[c] + rowStart;
      float* sum = row.sum[c].data();
      for (int x = 0; x < w; ++x) sum[x] = h0 * in[x];
    }
    if (varRow)
      for (int x = 0; x < w; ++x) varianceSum[x] = h0 * h0 * varRow[x];

    for (size_t k = 1; k < taps.size(); ++k) {
      const KernelTap& tap = taps[k];
      const int offsetX = tap.dx * step, offsetY = tap.dy * step;
      if (y + offsetY < 0 || y + offsetY >= h) continue;
      const int xBegin = std::max(0, -offsetX), xEnd = std::min(w, w - offsetX);
      if (xBegin >= xEnd) continue;  // taps outside the image are dropped (renormalised border)
      t.shift = std::ptrdiff_t(offsetY) * w + offsetX;
      t.offsetX = s.sigmaZ * float(offsetX);
      t.offsetY = s.sigmaZ * float(offsetY);
      if (s.luminance)
        t.luminanceQ = row.neighbourLuminance[size_t(tap.dy + kMaxKernelRadius)].data() + offsetX;
      tapExponentRow(t, xBegin, xEnd, row.exponent.data(), row.normalFactor.data());
      const std::ptrdiff_t shift = t.shift;
      accumulate(row.exponent.data(), row.normalFactor.data(), tap.h, color[0] + rowStart + shift,
                 color[1] + rowStart + shift, color[2] + rowStart + shift,
                 varRow ? varRow + shift : nullptr, sum0, sum1, sum2, weightSum, varianceSum,
                 xBegin, xEnd);
    }

    // Normalise; sky passes through.
    normaliseRow(mesh ? g.meshId + rowStart : nullptr, color[0] + rowStart, color[1] + rowStart,
                 color[2] + rowStart, varRow, sum0, sum1, sum2, weightSum, varianceSum,
                 colorOut.plane(0) + rowStart, colorOut.plane(1) + rowStart,
                 colorOut.plane(2) + rowStart, varOut ? varOut + rowStart : nullptr, w);
  });
}

void prefilterVariance3x3(const Image& variance, const GBufferView& g, Image& filtered) {
  const int w = variance.width(), h = variance.height();
  if (!filtered.sameShape(variance) || variance.channels() != 1)
    throw Error("variance pre-filter: expected two 1-channel images of equal size");
  constexpr float kGauss[3] = {0.25f, 0.5f, 0.25f};
  const float* in = variance.plane(0);
  float* out = filtered.plane(0);
  // Tap by tap across the row, in the order of a per-pixel loop over dy, then dx, so the sums
  // round exactly as that loop's would; sky and off-image taps add nothing.
  parallelRows(h, [&](int y) {
    RowScratch& row = rowScratch(w);
    float* __restrict sum = row.sum[0].data();
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
