#pragma once
// The à-trous iteration's pixel kernel (atrous.hpp), register-blocked and written once over a
// lane type: Lanes8 (AVX2, the build's baseline, atrous.cpp) or Lanes16 (AVX-512, its own
// translation unit simd_avx512.cpp, chosen at run time when the CPU has it). Both run the same
// IEEE operations lane by lane, so a pixel gets the same bits on either machine (tested).
//
// Internal to atrous.cpp and simd_avx512.cpp. The kernel touches no standard-library template
// (plain arrays, raw pointers): a template instantiated in both translation units would be
// compiled for AVX-512 in one of them and the linker could keep that copy for both.
#include <cstddef>
#include <cstdint>

#include "core/fast_math.hpp"
#include "denoisers/common/specular_lobe.hpp"

namespace arena::atrous_detail {

struct KernelTap {
  int dx, dy;
  float h;
};

// How the normal term enters a tap's weight.
enum class NormalTerm {
  None,              // off, a Gaussian distance (summed with the other distances), or sigmaN = 0
  CosineLog,         // max(0, n.n')^sigmaN as exp(sigmaN log(n.n')) inside the one exp per tap
  CosinePowerOfTwo,  // sigmaN = 2^k: n.n' squared k times (exact powers, no log), times the exp
};

// What is filtered alongside the colour: nothing; SVGF's variance (1 channel, squared weights);
// or up to 4 channels with the colour's own weights (the talk's second moment).
enum class Carry { None, Variance, Plain };

// Squared-distance terms |a(p) - a(q)|^2 / sigma over three planes each: position, colour and the
// Gaussian normal form, in this order (the order EdgeStopping::weight sums them in).
struct DistanceTerm {
  const float* planes[3];
  float inverseSigma;
};

// Everything one iteration reads, as whole-image planes (index y w + x).
struct Iteration {
  int width, height, step, radius;
  const KernelTap* taps;  // centre first
  int tapCount;
  const float* color[3];
  float* out[3];
  // The carried channels (Carry::Variance: carryCount = 1).
  const float* carryIn[4];
  float* carryOut[4];
  int carryCount;
  // Depth, SVGF eq. 3.
  const float *z, *dzdx, *dzdy;
  float sigmaZ, depthEpsilon;
  // Luminance, SVGF eq. 5: the filtered image's luminance and the variance that scales it.
  const float *luminance, *luminanceVariance;
  float sigmaL, luminanceEpsilon;
  DistanceTerm distances[3];
  int distanceCount;
  // Cosine normal term.
  const float* normal[3];
  float sigmaN;
  int squarings;  // CosinePowerOfTwo: sigmaN = 2^squarings
  // Mesh ids (a plane of zeros when the G-buffer has none): never gather from the sky (id < 0);
  // with the id term, never across meshes.
  const float* meshId;
  bool idTerm;
  // Specular-lobe similarity (specular_lobe.hpp): the lobe image's 4 planes; nullptr = off.
  const float* lobes[4];
  float lobeBeta;
};

constexpr int32_t kTinyBits = 0x0DA24260, kOneBits = 0x3F800000;  // bits of 1e-30f and 1.0f
constexpr float kNeverExponent = 1e30f;  // exp(-1e30) is exactly 0 in expNonPositive

// Loads a block of pixels from p; at the image border only the lanes in `mask`.
template <class F, bool Border>
inline F load(const float* p, IntLanes<F> mask) {
  if constexpr (Border)
    return loadLanes(p, mask);
  else
    return loadLanes(p, F{});
}
template <class F, bool Border>
inline void store(float* p, F value, IntLanes<F> mask) {
  if constexpr (Border)
    storeLanes(p, value, mask);
  else
    storeLanes(p, value);
}

// Filters the pixels x0 .. x0 + lanes - 1 of row y: every kernel tap accumulated into sums held in
// registers, the centre's guides read once. `Border`: some taps (or lanes past the row's end)
// fall outside the image; they are masked out and contribute nothing, as the renormalised border
// drops them. The weights are EdgeStopping::weight's w(p, q) up to float rounding (a distance term
// multiplies by 1/sigma once, not per channel; a power-of-two sigmaN squares the cosine instead of
// exp(sigmaN log(cosine)); products are fused into the sums).
template <class F, bool Depth, bool Luminance, NormalTerm Normal, Carry Carried, bool Border>
inline void filterBlock(const Iteration& it, int y, int x0) {
  using I = IntLanes<F>;
  const int w = it.width;
  const size_t p = size_t(y) * size_t(w) + size_t(x0);
  const I x = laneIndex(F{}) + x0;
  const I inRow = x < w;

  // The centre pixel's guides and its (weight h0) contribution.
  const float h0 = it.taps[0].h;
  const F id = load<F, Border>(it.meshId + p, inRow);
  F sum[3];
  for (int c = 0; c < 3; ++c) sum[c] = h0 * load<F, Border>(it.color[c] + p, inRow);
  F weightSum = F{} + h0;
  F carrySum[4] = {};
  if constexpr (Carried == Carry::Variance)
    carrySum[0] = (h0 * h0) * load<F, Border>(it.carryIn[0] + p, inRow);
  if constexpr (Carried == Carry::Plain)
    for (int c = 0; c < 4; ++c)
      if (c < it.carryCount) carrySum[c] = h0 * load<F, Border>(it.carryIn[c] + p, inRow);
  F z{}, dzdx{}, dzdy{}, depthEpsilon{};
  if constexpr (Depth) {
    z = load<F, Border>(it.z + p, inRow);
    dzdx = load<F, Border>(it.dzdx + p, inRow);
    dzdy = load<F, Border>(it.dzdy + p, inRow);
    depthEpsilon = it.depthEpsilon * absFloat(z);
  }
  F centreLuminance{}, inverseDenominator{};
  if constexpr (Luminance) {
    centreLuminance = load<F, Border>(it.luminance + p, inRow);
    const F variance = load<F, Border>(it.luminanceVariance + p, inRow);
    const F deviation = sqrtLanes(selectFloat(variance > 0.0f, variance, F{}));
    inverseDenominator = 1.0f / (it.sigmaL * deviation + it.luminanceEpsilon + 1e-30f);
  }
  F n[3] = {};
  if constexpr (Normal != NormalTerm::None)
    for (int c = 0; c < 3; ++c) n[c] = load<F, Border>(it.normal[c] + p, inRow);
  const bool lobe = it.lobes[0] != nullptr;
  F lobeCentre[4] = {};
  if (lobe)
    for (int c = 0; c < 4; ++c) lobeCentre[c] = load<F, Border>(it.lobes[c] + p, inRow);

  for (int k = 1; k < it.tapCount; ++k) {
    const KernelTap& tap = it.taps[k];
    const int offsetX = tap.dx * it.step, offsetY = tap.dy * it.step;
    if (y + offsetY < 0 || y + offsetY >= it.height) continue;  // the whole row of taps is off
    // q = p + offset; unsigned wrap-around for negative offsets lands on the same index.
    const size_t q = p + size_t(std::ptrdiff_t(offsetY) * w + offsetX);
    I inImage = inRow;
    if constexpr (Border) inImage &= (x + offsetX >= 0) & (x + offsetX < w);

    F e{};
    if constexpr (Depth) {
      const F zq = load<F, Border>(it.z + q, inImage);
      const F expected = fusedMultiplyAdd(dzdx, F{} + it.sigmaZ * float(offsetX),
                                          dzdy * (it.sigmaZ * float(offsetY)));
      e += absFloat(z - zq) / (absFloat(expected) + depthEpsilon + 1e-30f);
    }
    if constexpr (Luminance)
      e += absFloat(centreLuminance - load<F, Border>(it.luminance + q, inImage)) *
           inverseDenominator;
    for (int d = 0; d < it.distanceCount; ++d) {
      const DistanceTerm& term = it.distances[d];
      F distanceSquared{};
      for (int c = 0; c < 3; ++c) {
        const F difference = load<F, Border>(term.planes[c] + p, inRow) -
                             load<F, Border>(term.planes[c] + q, inImage);
        distanceSquared = fusedMultiplyAdd(difference, difference, distanceSquared);
      }
      e += distanceSquared * term.inverseSigma;  // |a(p) - a(q)|^2 / sigma, one multiply
    }
    F cosine{};
    I backFacing{};
    if constexpr (Normal != NormalTerm::None) {
      F dot = n[0] * load<F, Border>(it.normal[0] + q, inImage);
      dot = fusedMultiplyAdd(n[1], load<F, Border>(it.normal[1] + q, inImage), dot);
      dot = fusedMultiplyAdd(n[2], load<F, Border>(it.normal[2] + q, inImage), dot);
      // min(n.n', 1) clamped below at 1e-30 on the bit pattern (see core/fast_math.hpp on why not
      // in floats); n.n' <= 1e-30 gives weight 0.
      const I bits = bitsOf(dot);
      backFacing = bits < kTinyBits;
      cosine = floatFromBits(minInt(maxInt(bits, I{} + kTinyBits), I{} + kOneBits));
      if constexpr (Normal == NormalTerm::CosineLog)
        e += selectFloat(backFacing, F{} + kNeverExponent, F{}) - it.sigmaN * logPositive(cosine);
    }
    if (lobe) {  // s^beta = exp(beta log s), inside the one exp
      F lobeQ[4];
      for (int c = 0; c < 4; ++c) lobeQ[c] = load<F, Border>(it.lobes[c] + q, inImage);
      e -= it.lobeBeta * logLobeSimilarity(lobeCentre[0], lobeCentre[1], lobeCentre[2],
                                           lobeCentre[3], lobeQ[0], lobeQ[1], lobeQ[2], lobeQ[3]);
    }
    {  // never gather from the sky; with the id term, never across meshes
      const F idq = load<F, Border>(it.meshId + q, inImage);
      const I keep = (idq >= 0.0f) & (it.idTerm ? (id == idq) : I{} - 1);
      e = selectFloat(keep, e, F{} + kNeverExponent);
    }

    F weight = expNonPositive(-e);
    if constexpr (Normal == NormalTerm::CosinePowerOfTwo) {
      F power = selectFloat(backFacing, F{}, cosine);
      for (int s = 0; s < it.squarings; ++s) power *= power;
      weight *= power;
    }
    weight = tap.h * weight;
    if constexpr (Border) weight = selectFloat(inImage, weight, F{});  // a dropped tap
    for (int c = 0; c < 3; ++c)
      sum[c] = fusedMultiplyAdd(weight, load<F, Border>(it.color[c] + q, inImage), sum[c]);
    weightSum += weight;
    if constexpr (Carried == Carry::Variance)
      carrySum[0] = fusedMultiplyAdd(weight * weight, load<F, Border>(it.carryIn[0] + q, inImage),
                                     carrySum[0]);
    if constexpr (Carried == Carry::Plain)
      for (int c = 0; c < 4; ++c)
        if (c < it.carryCount)
          carrySum[c] =
              fusedMultiplyAdd(weight, load<F, Border>(it.carryIn[c] + q, inImage), carrySum[c]);
  }

  // Normalise; sky passes through. The centre tap always contributes h0 > 0, so the weight sum
  // is positive.
  const I sky = id < 0.0f;
  const F inverse = 1.0f / weightSum;
  for (int c = 0; c < 3; ++c) {
    const F in = load<F, Border>(it.color[c] + p, inRow);
    store<F, Border>(it.out[c] + p, selectFloat(sky, in, sum[c] * inverse), inRow);
  }
  for (int c = 0; c < 4; ++c) {
    if (Carried == Carry::None || c >= it.carryCount) break;
    const F in = load<F, Border>(it.carryIn[c] + p, inRow);
    const F normalised =
        Carried == Carry::Variance ? carrySum[c] * inverse * inverse : carrySum[c] * inverse;
    store<F, Border>(it.carryOut[c] + p, selectFloat(sky, in, normalised), inRow);
  }
}

// One row in blocks of `lanes` pixels; the blocks whose taps can leave the image take the masked
// path.
template <class F, bool Depth, bool Luminance, NormalTerm Normal, Carry Carried>
void filterRow(const Iteration& it, int y) {
  constexpr int kLanes = int(sizeof(F) / sizeof(float));
  const int reach = it.radius * it.step;
  for (int x0 = 0; x0 < it.width; x0 += kLanes) {
    if (x0 < reach || x0 + kLanes + reach > it.width)
      filterBlock<F, Depth, Luminance, Normal, Carried, true>(it, y, x0);
    else
      filterBlock<F, Depth, Luminance, Normal, Carried, false>(it, y, x0);
  }
}

using FilterRowFunction = void (*)(const Iteration&, int);

// The instantiation for this iteration's terms, chosen once per iteration.
template <class F, bool Depth, bool Luminance, NormalTerm Normal>
FilterRowFunction selectFilterRow(Carry carry) {
  switch (carry) {
    case Carry::None:
      return &filterRow<F, Depth, Luminance, Normal, Carry::None>;
    case Carry::Variance:
      return &filterRow<F, Depth, Luminance, Normal, Carry::Variance>;
    case Carry::Plain:
      break;
  }
  return &filterRow<F, Depth, Luminance, Normal, Carry::Plain>;
}
template <class F, bool Depth, bool Luminance>
FilterRowFunction selectFilterRow(NormalTerm normal, Carry carry) {
  switch (normal) {
    case NormalTerm::None:
      return selectFilterRow<F, Depth, Luminance, NormalTerm::None>(carry);
    case NormalTerm::CosineLog:
      return selectFilterRow<F, Depth, Luminance, NormalTerm::CosineLog>(carry);
    case NormalTerm::CosinePowerOfTwo:
      break;
  }
  return selectFilterRow<F, Depth, Luminance, NormalTerm::CosinePowerOfTwo>(carry);
}
template <class F>
FilterRowFunction selectFilterRow(bool depth, bool luminance, NormalTerm normal, Carry carry) {
  if (depth)
    return luminance ? selectFilterRow<F, true, true>(normal, carry)
                     : selectFilterRow<F, true, false>(normal, carry);
  return luminance ? selectFilterRow<F, false, true>(normal, carry)
                   : selectFilterRow<F, false, false>(normal, carry);
}

// The AVX-512 (Lanes16) instantiation, defined in simd_avx512.cpp; callable only where the CPU
// has AVX-512 F, VL, BW and DQ.
FilterRowFunction selectFilterRowAvx512(bool depth, bool luminance, NormalTerm normal, Carry carry);

}  // namespace arena::atrous_detail
