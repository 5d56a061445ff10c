#pragma once
// 64-bit FNV-1a, used for cache keys (scene file + every setting that changes pixels). Not
// cryptographic; collisions only matter between a user's own cache entries.
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace arena {

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
