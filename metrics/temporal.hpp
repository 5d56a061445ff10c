#pragma once
// Temporal flicker (docs/metrics.md, "Temporal flicker"): frame-difference metrics for
// static cameras and the motion-compensated warped flicker for moving ones.
#include "core/consistency.hpp"
#include "core/exr_io.hpp"
#include "core/image.hpp"
#include "metrics/stability.hpp"
#include "metrics/tiles.hpp"

namespace arena {

// tRMAE = mean over pixels and channels of |Dd_t - Dr_t| / (|Dr_t| + eps), Dx_t = x_t - x_{t-1}.
// Noisebase's form without its extra division by 3.
// With `tiles`, the per-tile sums behind the value (metrics/tiles.hpp).
double temporalRelativeMae(const Image& d, const Image& dPrev, const Image& r, const Image& rPrev,
                           double eps = 0.01, TileSums* tiles = nullptr);
// tPSNR = 10 log10(1 / MSE(Dd_t, Dr_t)) on display images (capped like PSNR).
// `tiles` receives the tile sums of the squared difference (the MSE inside the PSNR).
double temporalPsnr(const Image& dDisplay, const Image& dPrevDisplay, const Image& rDisplay,
                    const Image& rPrevDisplay, TileSums* tiles = nullptr);

struct WarpedFlicker {
  double value = 0;          // sqrt(mean over valid p of (e_t(p) - e_{t-1}(warp_t(p)))^2); NaN: no valid p
  double validFraction = 0;  // share of pixels whose 2x2 warp taps were all consistent
};
// e = d - r (linear). The G-buffers need depth, normal, meshId (both frames) and motion (current).
// A pixel is valid when all four bilinear taps of its motion-compensated position pass the
// consistency test the denoisers use (core/consistency.hpp).
// `tiles` receives the tile sums of the squared difference over valid pixels (the mean inside the sqrt).
WarpedFlicker warpedFlicker(const Image& error, const Image& errorPrev, const LayerSet& gbuffer,
                            const LayerSet& gbufferPrev, const ConsistencyThresholds& thresholds = {},
                            TileSums* tiles = nullptr);
// The same along paths traced before (their first lag: the warp from frame t to t - 1).
WarpedFlicker warpedFlicker(const Image& error, const Image& errorPrev, const StabilityPaths& paths,
                            TileSums* tiles = nullptr);

}  // namespace arena
