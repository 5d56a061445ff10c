#include "core/display.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace arena {

float acesFilmic(float x) {
  x = std::max(x, 0.0f);
  // The curve reaches 1 at x = 7.24 (and tends to a / c = 1.03 > 1, clamped); beyond 8 it is 1,
  // said before x * x overflows (near 1.2e19) and inf / inf made a bright pixel NaN. NaN stays NaN.
  if (x >= 8.0f) return 1.0f;
  const float a = 2.51f, b = 0.03f, c = 2.43f, d = 0.59f, e = 0.14f;
  return std::clamp((x * (a * x + b)) / (x * (c * x + d) + e), 0.0f, 1.0f);
}

float srgbEncode(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

DisplayTransform DisplayTransform::fromReference(const Image& ref) {
  double sum = 0;
  for (size_t i = 0; i < ref.pixelCount(); ++i)
    sum += luminance(ref.plane(0)[i], ref.plane(1)[i], ref.plane(2)[i]);
  double mean = sum / double(std::max<size_t>(1, ref.pixelCount()));
  DisplayTransform t;
  t.exposure = mean > 1e-6 ? float(0.18 / mean) : 1.0f;
  return t;
}

float DisplayTransform::apply(float linear) const {
  return srgbEncode(acesFilmic(linear * exposure));
}

Image DisplayTransform::apply(const Image& rgb) const {
  Image out(rgb.width(), rgb.height(), rgb.channels());
  for (size_t i = 0; i < rgb.raw().size(); ++i) out.raw()[i] = apply(rgb.raw()[i]);
  return out;
}

ExposureMode exposureModeFromName(const std::string& name) {
  if (name == "per-frame") return ExposureMode::PerFrame;
  if (name == "first") return ExposureMode::First;
  throw Error(
      "exposure '" + name +
      "': expected per-frame (each frame's own reference) or first (the first reference's)");
}

const char* exposureModeName(ExposureMode mode) {
  return mode == ExposureMode::PerFrame ? "per-frame" : "first";
}

std::vector<DisplayTransform> displayTransforms(const std::vector<const Image*>& references,
                                                ExposureMode mode) {
  std::vector<DisplayTransform> out;
  for (const Image* r : references)
    out.push_back(mode == ExposureMode::First && !out.empty()
                      ? out.front()
                      : DisplayTransform::fromReference(*r));
  return out;
}

}  // namespace arena
