#pragma once
// Error of a denoised frame against its reference (docs/metrics.md, "Error against the
// reference"). Linear metrics take linear HDR RGB; display metrics take images already passed
// through core/display.hpp's transform (exposure from the reference, ACES, sRGB).
#include "core/image.hpp"
#include "metrics/tiles.hpp"

namespace arena {

constexpr double kRelMseEpsilon = 0.01;  // metrics.md: eps = 0.01 unless stated (Falcor: 1e-3)
constexpr double kPsnrCapDb = 100.0;     // identical images: PSNR is capped here, not infinite

// Optional pixel mask: non-zero = included. nullptr = every pixel (sky included).
struct ErrorStats {
  double relMse = 0;           // mean of (d - r)^2 / (r^2 + eps) over pixels and channels
  double relMseCorrected = 0;  // minus the reference's own noise term (metrics.md, reference quality)
  double mse = 0, rmse = 0;    // linear
};
// With `tiles`, also the per-tile sums behind each value (metrics/tiles.hpp, for the bootstrap).
struct ErrorTiles {
  TileSums relMse, relMseCorrected, mse;
};
ErrorStats linearError(const Image& denoised, const Image& reference, const Image* referenceVariance,
                       const Image* mask = nullptr, double eps = kRelMseEpsilon, ErrorTiles* tiles = nullptr);
// Bias and variance of a method's output over K input seeds against one reference, in relMSE units
// (metrics.md's eps), with unbiased estimators: dbar the mean output over seeds and
// s^2 = sum_k (d_k - dbar)^2 / (K - 1) per pixel and channel,
//   variance = mean over pixels and channels of s^2 / (r^2 + eps)
//   bias2    = mean over pixels and channels of ((dbar - r)^2 - s^2 / K) / (r^2 + eps)
// so bias2 + variance is exactly the seeds' mean relMSE, and each is unbiased for its term.
// bias2Corrected also subtracts the reference's own noise term, which lands in the bias (the
// reference is shared by every seed). A per-frame bias2 near 0 can come out slightly negative.
struct BiasVariance {
  double bias2 = 0, bias2Corrected = 0, variance = 0;
};
struct BiasVarianceTiles {
  TileSums bias2, bias2Corrected, variance;
};
BiasVariance biasVariance(const std::vector<const Image*>& outputs, const Image& reference, const Image* referenceVariance,
                          double eps = kRelMseEpsilon, BiasVarianceTiles* tiles = nullptr);

// The reference's own estimated relMSE: mean of Var(r_hat) / (r_hat^2 + eps).
double referenceRelMse(const Image& reference, const Image& referenceVariance, const Image* mask = nullptr,
                       double eps = kRelMseEpsilon);

double meanSquaredError(const Image& a, const Image& b, TileSums* tiles = nullptr);
double psnrFromMse(double mse);  // 10 log10(1 / mse), capped at kPsnrCapDb
// SSIM (Wang et al. 2004) on display-image luminance: Gaussian window 11x11, sigma 1.5,
// K1 = 0.01, K2 = 0.03, dynamic range 1; mean over the window positions fully inside the image
// (images smaller than the window use clamped borders).
// With `tiles`: the SSIM map's sums per tile (a window belongs to the tile of its centre).
double ssim(const Image& displayA, const Image& displayB, TileSums* tiles = nullptr);

// Rec.709 luminance of every pixel of an RGB image, as a 1-channel image.
Image luminanceOf(const Image& rgb);

}  // namespace arena
