// libFuzzer entry point for the asset importers (built with -DARENA_FUZZ=ON and clang); see
// scripts/fuzz.sh asset. The first byte picks the importer (asset_fuzz_target.hpp), the rest is
// the main file, then the side file (MTL, .bin) after "\n#side-file\n"; tests/fuzz/asset_seeds/
// holds one valid input of each kind.
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "tests/fuzz/asset_fuzz_target.hpp"
#include "tests/fuzz/work_dir.hpp"

namespace {

const std::filesystem::path& workDir() {
  static const std::filesystem::path dir = arena::fuzz::makeFuzzWorkDir("arena_asset_fuzz_");
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  arena::fuzz::importAssetBytesOrReject(data, size, workDir());
  return 0;
}
