#include "denoisers/common/simd.hpp"

#include <atomic>
#include <cstdlib>

namespace arena {

namespace {
bool cpuHasAvx512() {
  static const bool has = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                          __builtin_cpu_supports("avx512bw") &&
                          __builtin_cpu_supports("avx512dq") && !std::getenv("ARENA_NO_AVX512");
  return has;
}
std::atomic<bool> allowed{true};
}  // namespace

bool simdUsesAvx512() {
  return allowed && cpuHasAvx512();
}

bool allowAvx512(bool allow) {
  return allowed.exchange(allow);
}

}  // namespace arena
