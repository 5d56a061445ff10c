#pragma once
// 64-bit FNV-1a, used for cache keys (scene file + every setting that changes pixels). Not
// cryptographic; collisions only matter between a user's own cache entries.
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <string_view>

namespace arena {

// A checksum of a block of 32-bit words, to notice damaged data (not to resist an adversary):
// FNV-1a over words rather than bytes, four times faster; hex() as Hasher's. `h` continues an
// earlier block's checksum (a file read in chunks).
inline uint64_t wordChecksum(const void* data, size_t words, uint64_t h = 1469598103934665603ull) {
  const auto* w = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < words; ++i) {
    uint32_t v;
    std::memcpy(&v, w + 4 * i, 4);
    h = (h ^ v) * 1099511628211ull;
  }
  return h;
}
inline std::string checksumHex(uint64_t h) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

class Hasher {
 public:
  Hasher& add(std::string_view bytes) {
    for (unsigned char c : bytes) {
      state_ ^= c;
      state_ *= 1099511628211ull;
    }
    state_ ^= 0xffu;  // separator, so ("ab","c") and ("a","bc") differ
    state_ *= 1099511628211ull;
    return *this;
  }
  uint64_t value() const { return state_; }
  std::string hex() const {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(state_));
    return buf;
  }

 private:
  uint64_t state_ = 1469598103934665603ull;
};

}  // namespace arena
