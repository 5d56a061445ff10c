#pragma once
// Atomic writes: write beside the target under a temporary name, then rename(2). An interrupted
// run never leaves a half-written file under the final name that a later run would trust.
#include <filesystem>
#include <functional>
#include <string>

namespace arena {

// Calls write(tmpPath) and renames tmpPath to `path` if it returns normally; removes tmpPath if it
// throws (the exception propagates).
void writeAtomically(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path& tmpPath)>& write);

void writeTextAtomically(const std::filesystem::path& path, const std::string& text);
std::string readText(const std::filesystem::path& path);

}  // namespace arena
