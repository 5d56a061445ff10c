// libFuzzer entry point for the scene parser (built with -DARENA_FUZZ=ON and clang):
//   mkdir -p /tmp/scene-corpus && build-fuzz/scene_fuzzer -max_total_time=60 /tmp/scene-corpus
//   scenes
// (new inputs go to the first directory; scenes/ only seeds it).
#include <cstddef>
#include <cstdint>

#include "tests/fuzz/scene_fuzz_target.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  arena::fuzz::parseSceneOrReject(std::string(reinterpret_cast<const char*>(data), size));
  return 0;
}
