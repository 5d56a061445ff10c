#pragma once
// Neighbourhood clamping and clipping of a history colour (Karis 2014; Salvi 2016): from the
// mean mu and standard deviation sigma of the current frame around p, the box
// [mu - k sigma, mu + k sigma]. Clamp: per channel. Clip: move the history along the segment
// towards the current value until it enters the box (keeps its hue better than a clamp).
#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

enum class HistoryClampMode { Clamp, Clip };

struct HistoryClampSettings {
  HistoryClampMode mode = HistoryClampMode::Clip;
  int radius = 1;      // 3x3 neighbourhood
  float gamma = 1.0f;  // k: box half-width in standard deviations (typical 1..2)
};

// Per-channel clamp of v into [lo, hi].
void clampToBox(float* v, const float* lo, const float* hi, int channels);
// Moves v towards `target` along the segment until it lies in [lo, hi] in every channel. When
// the target itself is outside the box (no point of the segment is inside), the point of the
// segment nearest the box is taken and then clamped, so the result is always inside.
void clipToBox(float* v, const float* target, const float* lo, const float* hi, int channels);

// out = history clamped/clipped into the box of `current` around each pixel (all images of the
// same shape, at most 4 channels; out may be the history itself). Sky pixels and sky neighbours
// are left out (gbuffer may be nullptr: no sky). Returns the neighbour taps read per pixel;
// `taps` is scratch sized by setup(height), so the call does not allocate.
double clampHistory(const Image& history, const Image& current, const GBufferView* gbuffer,
                    const HistoryClampSettings& settings, Image& out, RowTapCounter& taps);

}  // namespace arena
