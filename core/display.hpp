#pragma once
// The one display transform used everywhere an image is shown or a display-referred metric (PSNR,
// SSIM, LDR-FLIP, tPSNR) is computed: exposure -> ACES filmic curve (Narkowicz 2016 fit) -> clamp
// to [0, 1] -> sRGB encoding. The exposure comes from the *reference* so every method of a scene is
// shown and measured through the same transform; by default each frame's own reference
// (docs/metrics.md, "Display exposure": an ideal auto-exposure), or the first one's.
#include <string>
#include <vector>

#include "core/image.hpp"

namespace arena {

struct DisplayTransform {
  float exposure = 1.0f;  // linear scale applied before the curve
  // Exposure mapping the reference's mean luminance (over pixels) to 0.18 (middle grey).
  static DisplayTransform fromReference(const Image& referenceRgb);
  float apply(float linear) const;  // one channel
  Image apply(const Image& linearRgb) const;
};

// metrics.md "Display exposure": PerFrame (default) takes each frame's exposure from that frame's
// reference; First uses the first reference's exposure for every frame (the named alternative).
enum class ExposureMode { PerFrame, First };
// "per-frame" | "first"; anything else is an error naming the value.
ExposureMode exposureModeFromName(const std::string& name);
const char* exposureModeName(ExposureMode mode);
// One transform per reference, in order, under `mode`.
std::vector<DisplayTransform> displayTransforms(const std::vector<const Image*>& referencesRgb,
                                                ExposureMode mode);

float acesFilmic(float x);       // Narkowicz 2016, input already exposed
float srgbEncode(float linear);  // IEC 61966-2-1

}  // namespace arena
