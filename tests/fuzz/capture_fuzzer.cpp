// libFuzzer entry point for the capture importer (built with -DARENA_FUZZ=ON and clang); see
// scripts/fuzz.sh capture. The first byte picks which file of the seed capture the rest replaces
// (capture_fuzz_target.hpp). With ARENA_CAPTURE_SEEDS set to a folder, initialisation writes one
// seed input per file kind there (the seed capture's own files), for scripts/fuzz.sh to start from.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>

#include "tests/fuzz/capture_fuzz_target.hpp"
#include "tests/fuzz/work_dir.hpp"

namespace {

const std::filesystem::path& workDir() {
  static const std::filesystem::path dir = arena::fuzz::makeFuzzWorkDir("arena_capture_fuzz_");
  return dir;
}

const std::filesystem::path& seedCapture() {
  static const std::filesystem::path seed = [] {
    const std::filesystem::path s = workDir() / "seed";
    arena::fuzz::writeSeedCapture(s);
    return s;
  }();
  return seed;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (const char* seeds = std::getenv("ARENA_CAPTURE_SEEDS")) {
    std::filesystem::create_directories(seeds);
    for (int k = 0; k < arena::fuzz::kCaptureFileKinds; ++k) {
      const auto kind = arena::fuzz::CaptureFile(k);
      arena::fuzz::writeBytes(std::filesystem::path(seeds) / ("seed_" + std::to_string(k)),
                              std::string(1, char(k)) +
                                  arena::readText(arena::fuzz::captureFileOf(kind, seedCapture())));
    }
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const auto kind = arena::fuzz::CaptureFile(data[0] % arena::fuzz::kCaptureFileKinds);
  arena::fuzz::openMutatedCapture(seedCapture(), workDir(), kind,
                                  std::string(reinterpret_cast<const char*>(data) + 1, size - 1));
  return 0;
}
