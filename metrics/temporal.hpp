#pragma once
// Temporal flicker (../shared/docs/metrics.md, "Temporal flicker"): frame-difference metrics for
// static cameras and the motion-compensated warped flicker for moving ones.
#include "core/consistency.hpp"
#include "core/exr_io.hpp"
#include "core/image.hpp"

namespace arena {

// tRMAE = mean over pixels and channels of |Dd_t - Dr_t| / (|Dr_t| + eps), Dx_t = x_t - x_{t-1}.
// Noisebase's form without its extra division by 3.
double temporalRelativeMae(const Image& d, const Image& dPrev, const Image& r, const Image& rPrev,
                           double eps = 0.01);
// tPSNR = 10 log10(1 / MSE(Dd_t, Dr_t)) on display images (capped like PSNR).
double temporalPsnr(const Image& dDisplay, const Image& dPrevDisplay, const Image& rDisplay,
                    const Image& rPrevDisplay);

struct WarpedFlicker {
  double value = 0;          // sqrt(mean over valid p of (e_t(p) - e_{t-1}(warp_t(p)))^2)
  double validFraction = 0;  // share of pixels whose 2x2 warp taps were all consistent
};
// e = d - r (linear). The G-buffers need depth, normal, meshId (both frames) and motion (current).
// A pixel is valid when all four bilinear taps of its motion-compensated position pass the
// consistency test the denoisers use (core/consistency.hpp).
WarpedFlicker warpedFlicker(const Image& error, const Image& errorPrev, const LayerSet& gbuffer,
                            const LayerSet& gbufferPrev, const ConsistencyThresholds& thresholds = {});

}  // namespace arena
