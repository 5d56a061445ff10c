#include "core/image.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace arena {

Image::Image(int width, int height, int channels, float fill)
    : width_(width), height_(height), channels_(channels) {
  if (width < 0 || height < 0 || channels < 0)
    throw Error("Image: negative size " + std::to_string(width) + "x" + std::to_string(height));
  data_.assign(size_t(width) * size_t(height) * size_t(channels), fill);
  base_ = data_.data();
}

Image Image::borrow(float* data, int width, int height, int channels) {
  if (width < 0 || height < 0 || channels < 0)
    throw Error("Image::borrow: negative size " + std::to_string(width) + "x" +
                std::to_string(height));
  if (!data && width * height * channels != 0) throw Error("Image::borrow: no planes to borrow");
  Image view;
  view.width_ = width;
  view.height_ = height;
  view.channels_ = channels;
  view.borrowed_ = true;
  view.base_ = data;
  return view;
}

Image::Image(const Image& other)
    : width_(other.width_),
      height_(other.height_),
      channels_(other.channels_),
      data_(other.raw().begin(), other.raw().end()),
      base_(data_.data()) {}

Image::Image(Image&& other) noexcept
    : width_(other.width_),
      height_(other.height_),
      channels_(other.channels_),
      borrowed_(other.borrowed_),
      data_(std::move(other.data_)),
      base_(other.borrowed_ ? other.base_ : data_.data()) {
  other.width_ = other.height_ = other.channels_ = 0;
  other.borrowed_ = false;
  other.base_ = nullptr;
}

Image& Image::operator=(const Image& other) {
  if (this == &other) return *this;
  data_.assign(other.raw().begin(), other.raw().end());
  width_ = other.width_;
  height_ = other.height_;
  channels_ = other.channels_;
  borrowed_ = false;
  base_ = data_.data();
  return *this;
}

Image& Image::operator=(Image&& other) noexcept {
  if (this == &other) return *this;
  width_ = other.width_;
  height_ = other.height_;
  channels_ = other.channels_;
  borrowed_ = other.borrowed_;
  data_ = std::move(other.data_);
  base_ = borrowed_ ? other.base_ : data_.data();
  other.width_ = other.height_ = other.channels_ = 0;
  other.borrowed_ = false;
  other.data_.clear();
  other.base_ = nullptr;
  return *this;
}

float Image::atClamped(int x, int y, int c) const {
  x = std::clamp(x, 0, width_ - 1);
  y = std::clamp(y, 0, height_ - 1);
  return at(x, y, c);
}

void Image::fill(float value) {
  std::ranges::fill(raw(), value);
}

bool samePixels(const Image& a, const Image& b) {
  return a.sameShape(b) && std::ranges::equal(a.raw(), b.raw());
}

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

double finiteLuminanceSum(const Image& rgb) {
  if (rgb.channels() < 3) throw Error("luminance: expected an RGB image (3 channels)");
  const float *r = rgb.plane(0), *g = rgb.plane(1), *b = rgb.plane(2);
  double sum = 0;
  for (size_t i = 0; i < rgb.pixelCount(); ++i)
    if (const float l = luminance(r[i], g[i], b[i]); std::isfinite(l)) sum += double(l);
  return sum;
}

}  // namespace arena
