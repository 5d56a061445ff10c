#pragma once
// Error of a denoised frame against its reference (../shared/docs/metrics.md, "Error against the
// reference"). Linear metrics take linear HDR RGB; display metrics take images already passed
// through core/display.hpp's transform (exposure from the reference, ACES, sRGB).
#include "core/image.hpp"

namespace arena {

constexpr double kRelMseEpsilon = 0.01;  // metrics.md: eps = 0.01 unless stated (Falcor: 1e-3)
constexpr double kPsnrCapDb = 100.0;     // identical images: PSNR is capped here, not infinite

// Optional pixel mask: non-zero = included. nullptr = every pixel (sky included).
struct ErrorStats {
  double relMse = 0;           // mean of (d - r)^2 / (r^2 + eps) over pixels and channels
  double relMseCorrected = 0;  // minus the reference's own noise term (metrics.md, reference quality)
  double mse = 0, rmse = 0;    // linear
};
ErrorStats linearError(const Image& denoised, const Image& reference, const Image* referenceVariance,
                       const Image* mask = nullptr, double eps = kRelMseEpsilon);
// The reference's own estimated relMSE: mean of Var(r_hat) / (r_hat^2 + eps).
double referenceRelMse(const Image& reference, const Image& referenceVariance, const Image* mask = nullptr,
                       double eps = kRelMseEpsilon);

double meanSquaredError(const Image& a, const Image& b);
double psnrFromMse(double mse);  // 10 log10(1 / mse), capped at kPsnrCapDb
// SSIM (Wang et al. 2004) on display-image luminance: Gaussian window 11x11, sigma 1.5,
// K1 = 0.01, K2 = 0.03, dynamic range 1; mean over the window positions fully inside the image
// (images smaller than the window use clamped borders).
double ssim(const Image& displayA, const Image& displayB);

// Rec.709 luminance of every pixel of an RGB image, as a 1-channel image.
Image luminanceOf(const Image& rgb);

}  // namespace arena
