#pragma once
// Planar float images: one contiguous plane per channel, so loops over pixels vectorise and a
// single channel can be handed to a filter without copying (pbrt/OIDN name channels by meaning;
// the names live in core/sequence_format.hpp).
#include <cstddef>
#include <new>
#include <span>
#include <vector>

namespace arena {

// Storage of every plane: cache-line (64-byte) aligned, so a row of 16-float lanes never straddles
// two lines and a filter's speed does not depend on where the allocator happened to put its
// images (with glibc's heap it varied by 25% between two instances of the same denoiser: the
// C plugin of eaw measured 1.26x the built-in on identical code until this).
template <class T>
struct CacheLineAllocator {
  using value_type = T;
  static constexpr std::align_val_t kAlignment{64};
  CacheLineAllocator() = default;
  template <class U>
  CacheLineAllocator(const CacheLineAllocator<U>&) noexcept {}
  T* allocate(size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), kAlignment)); }
  void deallocate(T* p, size_t) noexcept { ::operator delete(p, kAlignment); }
  template <class U>
  bool operator==(const CacheLineAllocator<U>&) const noexcept {
    return true;
  }
};
using PlaneStorage = std::vector<float, CacheLineAllocator<float>>;

// An image owns its planes, or borrows them (Image::borrow): a view of planes somebody else
// allocated, laid out the same way, so code written against Image reads them in place -- the C
// plugin adapter (examples/plugins) hands the harness's planes to a built-in this way, zero copy.
// Copying either kind gives an owning copy; moving a borrowed image moves the view. Assigning to
// a borrowed image rebinds it (it does not write into the borrowed planes).
class Image {
 public:
  Image() = default;
  Image(int width, int height, int channels, float fill = 0.0f);
  // `channels` planes of width x height floats at data, data + w*h, ...; the caller keeps them
  // alive (and unmoved) for the image's life.
  static Image borrow(float* data, int width, int height, int channels);
  Image(const Image& other);
  Image(Image&& other) noexcept;
  Image& operator=(const Image& other);
  Image& operator=(Image&& other) noexcept;
  ~Image() = default;

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  size_t pixelCount() const { return size_t(width_) * size_t(height_); }
  bool empty() const { return pixelCount() == 0 || channels_ == 0; }
  bool borrowed() const { return borrowed_; }
  bool sameShape(const Image& other) const {
    return width_ == other.width_ && height_ == other.height_ && channels_ == other.channels_;
  }

  float* plane(int c) { return base_ + size_t(c) * pixelCount(); }
  const float* plane(int c) const { return base_ + size_t(c) * pixelCount(); }
  std::span<float> planeSpan(int c) { return {plane(c), pixelCount()}; }
  std::span<const float> planeSpan(int c) const { return {plane(c), pixelCount()}; }

  float& at(int x, int y, int c = 0) { return plane(c)[size_t(y) * width_ + x]; }
  float at(int x, int y, int c = 0) const { return plane(c)[size_t(y) * width_ + x]; }
  // Clamp-to-edge access, used by filters whose footprint leaves the image.
  float atClamped(int x, int y, int c = 0) const;

  // Every plane, one after the other (channels x pixelCount values).
  std::span<float> raw() { return {base_, pixelCount() * size_t(channels_)}; }
  std::span<const float> raw() const { return {base_, pixelCount() * size_t(channels_)}; }
  void fill(float value);

 private:
  int width_ = 0, height_ = 0, channels_ = 0;
  bool borrowed_ = false;
  PlaneStorage data_;      // empty when borrowed
  float* base_ = nullptr;  // data_.data(), or the borrowed planes
};

// The pixels of two images are equal (same shape, same values; NaN differs from itself).
bool samePixels(const Image& a, const Image& b);

// Rec.709 luminance of a planar RGB image (channels 0..2).
Image luminance(const Image& rgb);
// The sum of an RGB image's Rec.709 luminance over its pixels whose luminance is finite (a NaN
// pixel is left out, not allowed to make the sum NaN): what a brightness comparison reads.
double finiteLuminanceSum(const Image& rgb);
// Of one pixel, or of several at once (F: float or a lane type of core/fast_math.hpp).
template <class F>
inline F luminance(F r, F g, F b) {
  return 0.2126f * r + 0.7152f * g + 0.0722f * b;
}

}  // namespace arena
