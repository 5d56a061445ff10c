#pragma once
// 3x3 median for fireflies (the CEDEC 2021 talk p. "4.3.3 Firefly Rejection": "Median Filter ...
// を Spatial Accumulation の前処理に入れる。ただしエネルギーが狂うので Temporal Accumulation に
// 再帰させるのはNG" -- use it in the first post-filter pass, never feed it back into a history).
// Per channel, over p and its non-sky neighbours inside the image (a median of what is there);
// sky pixels pass through. A constant image is unchanged.
#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"

namespace arena {

// out must not alias in; gbuffer may be nullptr (no sky). Returns taps read per pixel (<= 9).
// `edgeAware` (needs the gbuffer's meshId and normal): a neighbour of another mesh, or whose
// normal differs from p's by more than ~37 degrees (n.n' < 0.8), counts as missing too, so a thin
// feature one pixel wide keeps its own value instead of the background's (issue 15, item 8).
double median3x3(const Image& in, const GBufferView* gbuffer, Image& out, bool edgeAware = false);

}  // namespace arena
