#pragma once
// FLIP image difference evaluator (NVIDIA), implemented from the published definitions:
//   [1] Andersson, Nilsson, Akenine-Möller, Oskarsson, Åström, Fairchild,
//       "FLIP: A Difference Evaluator for Alternating Images", HPG 2020 (LDR-FLIP).
//   [2] Andersson, Nilsson, Shirley, Akenine-Möller,
//       "Visualizing Errors in Rendered High Dynamic Range Images", Eurographics 2021 short
//       paper (HDR-FLIP).
// FLIP approximates the difference a viewer perceives when flipping between the two images at a
// given viewing distance (pixels per degree of visual angle); 67 ppd corresponds to a 0.7 m wide
// 4K monitor seen from 0.7 m, the papers' default.
#include <cstddef>
#include <memory>
#include <optional>
#include <vector>

#include "core/image.hpp"

namespace arena {

struct FlipResult {
  double mean = 0;  // mean of the per-pixel FLIP map, in [0, 1]
  Image map;        // width x height x 1, per-pixel FLIP value in [0, 1]
};

// LDR-FLIP: inputs are display-referred sRGB-encoded RGB images in [0,1] (exactly 3 planar
// channels). Values outside [0,1] are clamped (a display cannot show them); NaN counts as 0.
// Throws arena::Error when either image is empty, the shapes differ, an image does not have 3
// channels, or pixelsPerDegree is not a positive finite number.
FlipResult ldrFlip(const Image& reference, const Image& test, double pixelsPerDegree = 67.0);

// HDR-FLIP: inputs are linear (scene-referred) HDR RGB, 3 planar channels. The exposure range is
// derived from the reference, each exposure is tonemapped with the ACES fit used by FLIP, and the
// result is the per-pixel maximum of LDR-FLIP over the exposures. Same errors as ldrFlip.
FlipResult hdrFlip(const Image& reference, const Image& test, double pixelsPerDegree = 67.0);

// What a comparison checks of a reference's image.
struct FlipImageShape {
  int width = 0, height = 0, channels = 0;
  bool empty() const { return size_t(width) * size_t(height) == 0 || channels == 0; }  // as Image's
  static FlipImageShape of(const Image& image);
};

// A reference prepared once for FLIP against any number of test images: its filtered colour and
// feature planes (LDR-FLIP of `display`; HDR-FLIP of `linear` at each of its exposures) are kept,
// so each comparison filters only the test image, half the work of ldrFlip / hdrFlip, with the
// same values. Either image may be null (that comparison then throws); neither is read after the
// constructor. Comparisons are const and may run concurrently.
class FlipReference {
 public:
  FlipReference(const Image* display, const Image* linear, double pixelsPerDegree = 67.0);
  FlipResult ldr(const Image& test) const;  // ldrFlip(*display, test)
  FlipResult hdr(const Image& test) const;  // hdrFlip(*linear, test)
  size_t bytes() const;                     // of the filtered planes it keeps

 private:
  struct Filtered;
  std::optional<FlipImageShape> display_, linear_;
  double pixelsPerDegree_;
  std::shared_ptr<const Filtered> filtered_;
};

}  // namespace arena
