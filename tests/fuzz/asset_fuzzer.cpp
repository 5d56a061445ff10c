// libFuzzer entry point for the asset importers (built with -DARENA_FUZZ=ON and clang); see
// scripts/fuzz.sh asset. The first byte picks the importer (asset_fuzz_target.hpp), the rest is
// the main file, then the side file (MTL, .bin) after "\n#side-file\n"; tests/fuzz/asset_seeds/
// holds one valid input of each kind.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "tests/fuzz/asset_fuzz_target.hpp"

namespace {

// One directory per process (libFuzzer's -jobs run several): on tmpfs when there is one, since
// every input is written to files before the importers read them.
const std::filesystem::path& workDir() {
  static const std::filesystem::path dir = [] {
    std::error_code ec;
    const std::filesystem::path base =
        std::filesystem::is_directory("/dev/shm", ec) ? std::filesystem::path("/dev/shm")
                                                      : std::filesystem::temp_directory_path();
    std::filesystem::path d = base / ("arena_asset_fuzz_" + std::to_string(getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  arena::fuzz::importAssetBytesOrReject(data, size, workDir());
  return 0;
}
