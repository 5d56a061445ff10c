#pragma once
// Atomic writes: write beside the target under a temporary name, then rename(2). An interrupted
// run never leaves a half-written file under the final name that a later run would trust. Every
// I/O error names the path and the operating system's reason (strerror).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace arena {

// Calls write(tmpPath) and renames tmpPath to `path` if it returns normally; removes tmpPath if it
// throws (the exception propagates, as an Error naming `path`).
void writeAtomically(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path& tmpPath)>& write);
// The temporary name writeAtomically uses for `path` (unique per process and call).
std::filesystem::path temporaryPathFor(const std::filesystem::path& path);
// Removes temporaries of writes that were killed: names made by temporaryPathFor whose process is
// gone and which are older than `minAgeSeconds` (a write on another host sharing the directory
// finishes within seconds). Returns how many were removed; a read-only directory removes none.
int removeStaleTemporaries(const std::filesystem::path& dir, double minAgeSeconds = 600);

void writeTextAtomically(const std::filesystem::path& path, const std::string& text);
// Writes `bytes` to `path` directly (used on temporaries); errors name the path and the reason.
void writeFileBytes(const std::filesystem::path& path, const std::string& bytes);

// The whole file. Refuses what is not a regular file (/dev/zero, a directory, a FIFO) and files
// above `maxBytes`, naming the path and the limit.
constexpr uintmax_t kMaxReadBytes = uintmax_t(512) << 20;
std::string readText(const std::filesystem::path& path, uintmax_t maxBytes = kMaxReadBytes);

// "path: what: strerror(errno)".
std::string osError(const std::filesystem::path& path, const std::string& what, int errnoValue);

// The name of the folder `dir` names, a trailing slash or "." included ("runs/today/" -> "today").
std::string folderName(const std::filesystem::path& dir);

}  // namespace arena
