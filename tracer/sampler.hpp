#pragma once
// Counter-based random numbers: every number a pixel uses is a pure function of
// (scene seed, frame, pixel, sample, dimension), so frames are bit-identical at any thread count and
// A-SVGF's gradient samples can re-shade a pixel with the previous frame's exact random numbers.
#include <cstdint>

namespace arena {

inline uint64_t mix64(uint64_t z) {  // splitmix64 finaliser (Steele et al. 2014)
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

class Sampler {
 public:
  Sampler(uint32_t seed, uint32_t frame, uint32_t pixel, uint32_t sample) {
    key_ = mix64(mix64(mix64(uint64_t(seed) + 0x9e3779b97f4a7c15ull) ^ frame) ^
                 ((uint64_t(pixel) << 20) ^ uint64_t(sample)));
  }
  // Uniform in [0, 1) for dimension `dim`.
  float get(uint32_t dim) const {
    uint64_t h = mix64(key_ ^ (uint64_t(dim) * 0x9e3779b97f4a7c15ull));
    return float(h >> 40) * (1.0f / 16777216.0f);
  }
  uint64_t key() const { return key_; }

 private:
  uint64_t key_;
};

}  // namespace arena
