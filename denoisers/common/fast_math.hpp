#pragma once
// Branch-light exp and log for filter weights, evaluated tens of times per pixel per pass. The
// library's expf/logf handle errno and every special case; weights only need ~1e-7 relative
// accuracy on a known domain, which a short polynomial gives at a fraction of the cost.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

namespace arena {

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

// e^x for x <= 0 (the sign of x is ignored: e^-|x|; NaN gives 0): 2^(x log2 e) split into
// 2^integer (exponent bits) times 2^fraction (Taylor series of e^u, u = fraction * ln 2 in
// [0, ln 2), to degree 8: truncation error < 1e-7; the float product x log2 e adds up to about
// |x| 3e-8 relative). Exactly 1 at x = 0, never above 1, exactly 0 below about -87.4 (where expf
// turns denormal).
inline float expNonPositive(float x) {
  // -min(|x|, 88.5) on the bit pattern: for a float's magnitude, integer order is value order.
  const int32_t magnitude = std::min(std::bit_cast<int32_t>(x) & 0x7FFFFFFF, 0x42B10000);
  const float t = std::bit_cast<float>(magnitude) * -1.4426950409f;  // in [-127.7, 0]
  // floor(t): t + 128 >= 0 truncates downwards. Rounding may give one more, leaving u a hair
  // below 0, where the series is as accurate.
  const int32_t whole = int32_t(t + 128.0f) - 128;
  const float u = (t - float(whole)) * 0.6931471806f;
  const float p =
      1.0f +
      u * (1.0f +
           u * (0.5f + u * (1.0f / 6 +
                            u * (1.0f / 24 +
                                 u * (1.0f / 120 + u * (1.0f / 720 + u * (1.0f / 5040 +
                                                                          u * (1.0f / 40320))))))));
  // 2^whole from the exponent bits; 0 once 2^whole would be denormal.
  const float scale = std::bit_cast<float>(int32_t(std::max(whole + 127, 0) << 23));
  const float value = p * scale;
  return selectFloat(1.0f < value, 1.0f, value);  // min(value, 1), if-converted in any loop
}

// ln x for normal positive x: x = m 2^e with m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh(s),
// s = (m - 1) / (m + 1), |s| < 0.172, series to s^9 (error < 1e-8 in ln m).
inline float logPositive(float x) {
  const int32_t bits = std::bit_cast<int32_t>(x);
  const int32_t mantissaBits = bits & 0x007FFFFF;
  // Mantissa above sqrt(2): halve it (m exponent 0x3F000000 instead of 0x3F800000). Sign-bit
  // arithmetic rather than ?: so that GCC if-converts it inside bigger loops too.
  const int32_t high = ((0x003504F3 - mantissaBits) >> 31) & 1;
  const float m = std::bit_cast<float>(mantissaBits | (0x3F800000 - (high << 23)));
  const float e = float(((bits >> 23) & 255) - 127 + high);
  const float s = (m - 1.0f) / (m + 1.0f), s2 = s * s;
  const float series =
      s * (2.0f + s2 * (2.0f / 3 + s2 * (2.0f / 5 + s2 * (2.0f / 7 + s2 * (2.0f / 9)))));
  return e * 0.6931471806f + series;
}

}  // namespace arena
