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
// `folders`: folders of those names too, with what they hold (a capture written in a temporary
// folder, CaptureWriter), but only those this machine's processes made (the name carries the
// machine); files only otherwise.
int removeStaleTemporaries(const std::filesystem::path& dir, double minAgeSeconds = 600,
                           bool folders = false);
// The same in `dir` and every folder below it (a run's images/, a report's tiles/).
int removeStaleTemporariesBelow(const std::filesystem::path& dir, double minAgeSeconds = 600);

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
// `path` absolute, its links resolved and "dir/" read as "dir": what two paths are compared as.
std::filesystem::path resolvedPath(const std::filesystem::path& path);
// Whether `inner` is `outer` or lies below it (both resolvedPath'd by the caller).
bool liesIn(const std::filesystem::path& inner, const std::filesystem::path& outer);

// An advisory lock on a directory between arena processes (flock(2) on DIR/.arena.lock, released
// when the lock is destroyed or the process dies, so a killed process never leaves it held).
// Shared locks coexist; an exclusive one excludes every other. Within one process a directory is
// locked once: a nested lock of the same directory is granted at once (an exclusive one upgrades
// a shared one). `purpose` ("writing this run") is recorded for the messages other processes give.
class DirectoryLock {
 public:
  enum class Mode { Shared, Exclusive };
  enum class IfHeld { Wait, Refuse };
  // Creates `dir` if needed. Refuse: an Error naming the directory, the holder's process id and
  // purpose when another process holds a conflicting lock. Wait: says so once on stderr, then
  // waits.
  // `createFile` false (a reader of a finished run): no lock file is created where there is
  // none, and a shared lock the file system cannot take goes on unlocked; only a writer's lock
  // held by another process refuses or waits.
  DirectoryLock(const std::filesystem::path& dir, Mode mode, IfHeld ifHeld,
                const std::string& purpose, bool createFile = true);
  ~DirectoryLock();
  DirectoryLock(DirectoryLock&& other) noexcept;
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;
  DirectoryLock& operator=(DirectoryLock&&) = delete;

 private:
  std::string key_;  // the directory's canonical path; empty once moved from
};

}  // namespace arena
