#pragma once
// The scratch folder of a libFuzzer target (and the writer of its inputs' files) that writes each input to files before the code under
// test reads them: one per process (libFuzzer's -jobs run several), on tmpfs when there is one.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
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

// Writes a fuzz input's bytes to `file` (read back with core/atomic_file.hpp's readText).
inline void writeBytes(const std::filesystem::path& file, const std::string& bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  if (!out) throw std::runtime_error("fuzz: cannot write " + file.string());
}

}  // namespace arena::fuzz
