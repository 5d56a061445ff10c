#pragma once
// Temporal luminance rejection against a stabilised one-frame result (CAPCOM RE ENGINE 2023,
// "Temporal Luminance Rejection", seed 004 slide 29: "安定化した1フレームの結果は、履歴を修正する
// ために使用されます" -- the stabilised one-frame result corrects the history). The one-frame
// result is a spatially filtered current frame, lightly accumulated over a frame or two so it is
// stable yet reacts within a frame to a light switch; where the history's luminance strays from it
// by more than tau (relative to the larger of the two), the history is pulled towards it in
// proportion, rho = clamp((d - tau) / tau, 0, 1), and its length shortened by the same share.
#include <algorithm>
#include <cmath>

#include "core/image.hpp"

namespace arena {

// Corrects `history` (3 channels) towards `stabilised` in place and returns rho in [0, 1]; the
// caller shortens the history length h to max(1, h (1 - rho)).
inline float rejectHistoryLuminance(float* history, const float* stabilised, float tau) {
  const float lh = luminance(history[0], history[1], history[2]);
  const float ls = luminance(stabilised[0], stabilised[1], stabilised[2]);
  const float d = std::abs(lh - ls) / std::max({lh, ls, 1e-6f});
  const float rho = std::clamp((d - tau) / std::max(tau, 1e-6f), 0.0f, 1.0f);
  for (int c = 0; c < 3; ++c) history[c] += rho * (stabilised[c] - history[c]);
  return rho;
}

// The noise-normalised form (issue 34, item 2): the gap in units of its own standard error,
// z = |L(history) - L(stabilised)| / standardError, rho = clamp((z - k) / k, 0, 1) -- full
// rejection at 2k standard errors. A gap below 1 % of the larger luminance never fires (a
// noise-free region must not fire on rounding); a zero standard error with a larger gap fires
// fully. The relative form above fires on noise wherever the one-frame value is a mean of a few
// sparse samples (CAPCOM's own caveat, slide 24: rejection from a one-frame buffer clamps noise).
inline float rejectHistoryLuminanceSigma(float* history, const float* stabilised,
                                         float standardError, float k) {
  const float lh = luminance(history[0], history[1], history[2]);
  const float ls = luminance(stabilised[0], stabilised[1], stabilised[2]);
  const float gap = std::abs(lh - ls);
  if (gap <= 0.01f * std::max(lh, ls)) return 0.0f;
  const float z = gap / std::max(standardError, 1e-30f);
  const float rho = std::clamp((z - k) / std::max(k, 1e-6f), 0.0f, 1.0f);
  for (int c = 0; c < 3; ++c) history[c] += rho * (stabilised[c] - history[c]);
  return rho;
}

}  // namespace arena
