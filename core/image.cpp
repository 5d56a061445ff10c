#include "core/image.hpp"

#include <algorithm>

#include "core/error.hpp"

namespace arena {

Image::Image(int width, int height, int channels, float fill)
    : width_(width), height_(height), channels_(channels) {
  if (width < 0 || height < 0 || channels < 0)
    throw Error("Image: negative size " + std::to_string(width) + "x" + std::to_string(height));
  data_.assign(size_t(width) * size_t(height) * size_t(channels), fill);
}

float Image::atClamped(int x, int y, int c) const {
  x = std::clamp(x, 0, width_ - 1);
  y = std::clamp(y, 0, height_ - 1);
  return at(x, y, c);
}

void Image::fill(float value) { std::fill(data_.begin(), data_.end(), value); }

Image luminance(const Image& rgb) {
  if (rgb.channels() < 3) throw Error("luminance: expected an RGB image (3 channels)");
  Image out(rgb.width(), rgb.height(), 1);
  const float* r = rgb.plane(0);
  const float* g = rgb.plane(1);
  const float* b = rgb.plane(2);
  float* l = out.plane(0);
  for (size_t i = 0; i < rgb.pixelCount(); ++i) l[i] = luminance(r[i], g[i], b[i]);
  return out;
}

}  // namespace arena
