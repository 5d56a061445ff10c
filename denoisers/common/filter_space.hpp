#pragma once
// The space a denoiser filters in (CAPCOM RE ENGINE 2023, "Auto Exposure Ghosting" / "Removing
// Reinhard Curves", seed 004 slides 24-27): their earlier denoiser filtered a Reinhard-compressed
// signal, y = c / (1 + L(c)), which tames fireflies but is non-linear, so an average of compressed
// values is not the compressed average and the history's brightness lags behind exposure and
// light changes; linear filtering is their fix. The pair below is the ablation: compress before
// filtering, expand after, c = y / (1 - L(y)).
#include <algorithm>

#include "core/image.hpp"

namespace arena {

// The space a filter works in: linear, or Reinhard-compressed y = c / (1 + L(c)) (CAPCOM).
enum class FilterSpace { Linear, Reinhard };

// out = in / (1 + max(L(in), 0)) per pixel (3 channels; out may alias in).
inline void reinhardCompress(const Image& in, Image& out) {
  for (size_t i = 0; i < in.pixelCount(); ++i) {
    const float l = luminance(in.plane(0)[i], in.plane(1)[i], in.plane(2)[i]);
    const float scale = 1.0f / (1.0f + std::max(l, 0.0f));
    for (int c = 0; c < 3; ++c) out.plane(c)[i] = in.plane(c)[i] * scale;
  }
}

// The inverse: out = in / max(1 - L(in), 1e-6) (out may alias in).
inline void reinhardExpand(const Image& in, Image& out) {
  for (size_t i = 0; i < in.pixelCount(); ++i) {
    const float l = luminance(in.plane(0)[i], in.plane(1)[i], in.plane(2)[i]);
    const float scale = 1.0f / std::max(1.0f - l, 1e-6f);
    for (int c = 0; c < 3; ++c) out.plane(c)[i] = in.plane(c)[i] * scale;
  }
}

}  // namespace arena
