#pragma once
// The scratch folder of a libFuzzer target that writes each input to files before the code under
// test reads them: one per process (libFuzzer's -jobs run several), on tmpfs when there is one.
#include <unistd.h>

#include <filesystem>
#include <string>

namespace arena::fuzz {

inline std::filesystem::path makeFuzzWorkDir(const std::string& prefix) {
  std::error_code ec;
  const std::filesystem::path base = std::filesystem::is_directory("/dev/shm", ec)
                                         ? std::filesystem::path("/dev/shm")
                                         : std::filesystem::temp_directory_path();
  std::filesystem::path dir = base / (prefix + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace arena::fuzz
