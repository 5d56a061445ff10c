#pragma once
// Branch-light exp and log for filter weights, evaluated tens of times per pixel per pass. The
// library's expf/logf handle errno and every special case; weights only need ~1e-7 relative
// accuracy on a known domain, which a short polynomial gives at a fraction of the cost.
//
// Each function is written once over a "lane" type: a plain float (scalar code, and loops GCC
// vectorises itself), Lanes8 (eight floats in one AVX2 register) or Lanes16 (AVX-512), for the
// filter kernels that work on blocks of pixels. All run the same IEEE operations in the same
// order, so a pixel gets the same bits whichever path filtered it. The build has
// -ffp-contract=off: the compiler never fuses a multiply-add on its own; fusedMultiplyAdd() is
// the explicit one, the same on every path.
#include <immintrin.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace arena {

// Eight float / int32 lanes as GCC vector extensions: + - * / and comparisons act per lane (a
// comparison yields -1 or 0 per lane), a scalar operand is broadcast.
using Lanes8 = float __attribute__((vector_size(32)));
using LaneMask8 = int32_t __attribute__((vector_size(32)));

// The int lanes of a float lane type, and bit casts / conversions between the two.
template <class F>
struct LaneTraits {
  using Int = int32_t;
};
template <>
struct LaneTraits<Lanes8> {
  using Int = LaneMask8;
};
template <class F>
using IntLanes = typename LaneTraits<F>::Int;

inline int32_t bitsOf(float x) {
  return std::bit_cast<int32_t>(x);
}
inline LaneMask8 bitsOf(Lanes8 x) {
  return reinterpret_cast<LaneMask8>(x);
}
inline float floatFromBits(int32_t x) {
  return std::bit_cast<float>(x);
}
inline Lanes8 floatFromBits(LaneMask8 x) {
  return reinterpret_cast<Lanes8>(x);
}
inline int32_t truncateToInt(float x) {
  return int32_t(x);
}
inline LaneMask8 truncateToInt(Lanes8 x) {
  return __builtin_convertvector(x, LaneMask8);
}
inline float toFloat(int32_t x) {
  return float(x);
}
inline Lanes8 toFloat(LaneMask8 x) {
  return __builtin_convertvector(x, Lanes8);
}
inline int32_t minInt(int32_t a, int32_t b) {
  return std::min(a, b);
}
inline LaneMask8 minInt(LaneMask8 a, LaneMask8 b) {
  return a < b ? a : b;
}
inline int32_t maxInt(int32_t a, int32_t b) {
  return std::max(a, b);
}
inline LaneMask8 maxInt(LaneMask8 a, LaneMask8 b) {
  return a > b ? a : b;
}

// GCC (without -fno-trapping-math) vectorises a loop over these only if no floating-point
// operation can become conditional: a float clamp or std::floor ahead of arithmetic defeats it,
// hence the integer-domain clamp and the truncation-based floor below.

// condition ? ifTrue : ifFalse on the bit patterns. GCC does not if-convert a float ?: whose
// operands come out of floating-point arithmetic (either could trap), and then does not vectorise
// the loop; an integer select it does.
inline float selectFloat(bool condition, float ifTrue, float ifFalse) {
  const int32_t mask = -int32_t(condition);
  return std::bit_cast<float>((std::bit_cast<int32_t>(ifTrue) & mask) |
                              (std::bit_cast<int32_t>(ifFalse) & ~mask));
}
// Per lane: mask (-1 or 0, as comparisons give) ? ifTrue : ifFalse.
inline Lanes8 selectFloat(LaneMask8 mask, Lanes8 ifTrue, Lanes8 ifFalse) {
  return floatFromBits((bitsOf(ifTrue) & mask) | (bitsOf(ifFalse) & ~mask));
}
inline float absFloat(float x) {
  return std::abs(x);
}
// x in every lane, bit for bit (-0 stays -0, which 0 + x would not keep).
inline Lanes8 splatLanes(float x) {
  return reinterpret_cast<Lanes8>(_mm256_set1_ps(x));
}
inline float sqrtLanes(float x) {
  return std::sqrt(x);
}
inline Lanes8 absFloat(Lanes8 x) {
  return floatFromBits(bitsOf(x) & 0x7FFFFFFF);
}

// Eight consecutive floats; the masked forms read and write only the lanes whose mask is set (no
// fault on the others, which may lie outside the image).
// (The second argument of the unmasked load only picks the lane type.)
inline Lanes8 loadLanes(const float* p, Lanes8) {
  Lanes8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline Lanes8 loadLanes(const float* p, LaneMask8 mask) {
  return reinterpret_cast<Lanes8>(_mm256_maskload_ps(p, reinterpret_cast<__m256i>(mask)));
}
// Eight int32 values where mask is set, 0 elsewhere.
inline LaneMask8 loadIntLanes(const int32_t* p, LaneMask8 mask) {
  return reinterpret_cast<LaneMask8>(
      _mm256_maskload_epi32(reinterpret_cast<const int*>(p), reinterpret_cast<__m256i>(mask)));
}
inline void storeLanes(float* p, Lanes8 v) {
  std::memcpy(p, &v, sizeof v);
}
inline void storeLanes(float* p, Lanes8 v, LaneMask8 mask) {
  _mm256_maskstore_ps(p, reinterpret_cast<__m256i>(mask), reinterpret_cast<__m256>(v));
}

// a b + c rounded once, per lane. Written out (the build has -ffp-contract=off, so the compiler
// never fuses on its own, which made results depend on how a loop was peeled): every caller gets
// the same rounding on every lane, scalar or vector.
inline float fusedMultiplyAdd(float a, float b, float c) {
  return __builtin_fmaf(a, b, c);
}
inline Lanes8 fusedMultiplyAdd(Lanes8 a, Lanes8 b, Lanes8 c) {
  return reinterpret_cast<Lanes8>(_mm256_fmadd_ps(
      reinterpret_cast<__m256>(a), reinterpret_cast<__m256>(b), reinterpret_cast<__m256>(c)));
}

// Whether every lane of the mask is set.
inline bool allLanes(LaneMask8 mask) {
  return _mm256_movemask_ps(reinterpret_cast<__m256>(mask)) == 0xFF;
}
// Whether any lane of the mask is set.
inline bool anyLane(LaneMask8 mask) {
  return _mm256_movemask_ps(reinterpret_cast<__m256>(mask)) != 0;
}
// base[index] per lane where mask is set, 0 elsewhere (no fault on masked-out lanes).
inline Lanes8 gatherLanes(const float* base, LaneMask8 index, LaneMask8 mask) {
  return reinterpret_cast<Lanes8>(_mm256_mask_i32gather_ps(_mm256_setzero_ps(), base,
                                                           reinterpret_cast<__m256i>(index),
                                                           reinterpret_cast<__m256>(mask), 4));
}
inline LaneMask8 gatherIntLanes(const int32_t* base, LaneMask8 index, LaneMask8 mask) {
  return reinterpret_cast<LaneMask8>(
      _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), base, reinterpret_cast<__m256i>(index),
                                  reinterpret_cast<__m256i>(mask), 4));
}
inline Lanes8 sqrtLanes(Lanes8 x) {
  return reinterpret_cast<Lanes8>(_mm256_sqrt_ps(reinterpret_cast<__m256>(x)));
}
inline Lanes8 floorLanes(Lanes8 x) {
  return reinterpret_cast<Lanes8>(_mm256_floor_ps(reinterpret_cast<__m256>(x)));
}
inline LaneMask8 laneIndex(Lanes8) {
  return LaneMask8{0, 1, 2, 3, 4, 5, 6, 7};
}

#ifdef __AVX512F__
// Sixteen lanes, for the translation unit built for AVX-512 (denoisers/common/simd_avx512.cpp,
// chosen at run time, see denoisers/common/simd.hpp): the same operations, so the same bits per
// lane as Lanes8.
using Lanes16 = float __attribute__((vector_size(64)));
using LaneMask16 = int32_t __attribute__((vector_size(64)));
template <>
struct LaneTraits<Lanes16> {
  using Int = LaneMask16;
};
inline LaneMask16 bitsOf(Lanes16 x) {
  return reinterpret_cast<LaneMask16>(x);
}
inline Lanes16 floatFromBits(LaneMask16 x) {
  return reinterpret_cast<Lanes16>(x);
}
inline LaneMask16 truncateToInt(Lanes16 x) {
  return __builtin_convertvector(x, LaneMask16);
}
inline Lanes16 toFloat(LaneMask16 x) {
  return __builtin_convertvector(x, Lanes16);
}
inline LaneMask16 minInt(LaneMask16 a, LaneMask16 b) {
  return a < b ? a : b;
}
inline LaneMask16 maxInt(LaneMask16 a, LaneMask16 b) {
  return a > b ? a : b;
}
inline Lanes16 selectFloat(LaneMask16 mask, Lanes16 ifTrue, Lanes16 ifFalse) {
  return floatFromBits((bitsOf(ifTrue) & mask) | (bitsOf(ifFalse) & ~mask));
}
inline Lanes16 absFloat(Lanes16 x) {
  return floatFromBits(bitsOf(x) & 0x7FFFFFFF);
}
inline __mmask16 predicate(LaneMask16 mask) {
  return _mm512_movepi32_mask(reinterpret_cast<__m512i>(mask));
}
inline Lanes16 loadLanes(const float* p, Lanes16) {
  return reinterpret_cast<Lanes16>(_mm512_loadu_ps(p));
}
inline Lanes16 loadLanes(const float* p, LaneMask16 mask) {
  return reinterpret_cast<Lanes16>(_mm512_maskz_loadu_ps(predicate(mask), p));
}
inline void storeLanes(float* p, Lanes16 v) {
  _mm512_storeu_ps(p, reinterpret_cast<__m512>(v));
}
inline void storeLanes(float* p, Lanes16 v, LaneMask16 mask) {
  _mm512_mask_storeu_ps(p, predicate(mask), reinterpret_cast<__m512>(v));
}
inline Lanes16 fusedMultiplyAdd(Lanes16 a, Lanes16 b, Lanes16 c) {
  return reinterpret_cast<Lanes16>(_mm512_fmadd_ps(
      reinterpret_cast<__m512>(a), reinterpret_cast<__m512>(b), reinterpret_cast<__m512>(c)));
}
inline Lanes16 gatherLanes(const float* base, LaneMask16 index, LaneMask16 mask) {
  return reinterpret_cast<Lanes16>(_mm512_mask_i32gather_ps(
      _mm512_setzero_ps(), predicate(mask), reinterpret_cast<__m512i>(index), base, 4));
}
inline bool allLanes(LaneMask16 mask) {
  return predicate(mask) == 0xFFFF;
}
inline bool anyLane(LaneMask16 mask) {
  return predicate(mask) != 0;
}
inline Lanes16 sqrtLanes(Lanes16 x) {
  // The maskz form: GCC 12's _mm512_sqrt_ps trips -Wmaybe-uninitialized inside its own header.
  return reinterpret_cast<Lanes16>(_mm512_maskz_sqrt_ps(0xFFFF, reinterpret_cast<__m512>(x)));
}
inline LaneMask16 laneIndex(Lanes16) {
  return LaneMask16{0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
}
#endif

// min / max per lane (either operand when they compare equal or unordered).
template <class F>
inline F minFloat(F a, F b) {
  return selectFloat(b < a, b, a);
}
template <class F>
inline F maxFloat(F a, F b) {
  return selectFloat(a < b, b, a);
}

// e^x for x <= 0 (the sign of x is ignored: e^-|x|; NaN gives 0): 2^(x log2 e) split into
// 2^n (exponent bits, n the nearest integer) times 2^f = e^u, u = f ln 2 in [-0.35, 0.35], a
// Taylor series to degree 6 (truncation error < 1.3e-7; the float product x log2 e adds up to
// about |x| 3e-8 relative). Exactly 1 at x = 0, never above 1, exactly 0 below about -87.4
// (where expf turns denormal).
template <class F>
inline F expNonPositive(F x) {
  using I = IntLanes<F>;
  // -min(|x|, 88.5) on the bit pattern: for a float's magnitude, integer order is value order.
  const I magnitude = minInt(bitsOf(x) & 0x7FFFFFFF, I{} + 0x42B10000);
  const F t = floatFromBits(magnitude) * -1.4426950409f;  // in [-127.7, 0]
  // round(t): t + 128.5 > 0 truncates downwards. (Neither std::round nor std::floor: see above.)
  const I whole = truncateToInt(t + 128.5f) - 128;
  const F u = (t - toFloat(whole)) * 0.6931471806f;
  F p = F{} + 1.0f / 720;
  p = fusedMultiplyAdd(p, u, F{} + 1.0f / 120);
  p = fusedMultiplyAdd(p, u, F{} + 1.0f / 24);
  p = fusedMultiplyAdd(p, u, F{} + 1.0f / 6);
  p = fusedMultiplyAdd(p, u, F{} + 0.5f);
  p = fusedMultiplyAdd(p, u, F{} + 1.0f);
  p = fusedMultiplyAdd(p, u, F{} + 1.0f);
  // 2^whole from the exponent bits; 0 once 2^whole would be denormal.
  const F scale = floatFromBits(I(maxInt(whole + 127, I{}) << 23));
  const F value = p * scale;
  return selectFloat(1.0f < value, F{} + 1.0f, value);  // min(value, 1), if-converted in any loop
}

// ln x for normal positive x: x = m 2^e with m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh(s),
// s = (m - 1) / (m + 1), |s| < 0.172, series to s^9 (error < 1e-8 in ln m).
template <class F>
inline F logPositive(F x) {
  using I = IntLanes<F>;
  const I bits = bitsOf(x);
  const I mantissaBits = bits & 0x007FFFFF;
  // Mantissa above sqrt(2): halve it (m exponent 0x3F000000 instead of 0x3F800000). Sign-bit
  // arithmetic rather than ?: so that GCC if-converts it inside bigger loops too.
  const I high = ((0x003504F3 - mantissaBits) >> 31) & 1;
  const F m = floatFromBits(mantissaBits | (0x3F800000 - (high << 23)));
  const F e = toFloat(((bits >> 23) & 255) - 127 + high);
  const F s = (m - 1.0f) / (m + 1.0f), s2 = s * s;
  const F series =
      s * (2.0f + s2 * (2.0f / 3 + s2 * (2.0f / 5 + s2 * (2.0f / 7 + s2 * (2.0f / 9)))));
  return e * 0.6931471806f + series;
}

}  // namespace arena
