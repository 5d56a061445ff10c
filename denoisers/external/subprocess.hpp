#pragma once
// A child process with its stdin, stdout and stderr connected to the harness, driven by poll()
// with a deadline on every exchange, so a process that hangs, stops reading or floods stderr can
// never deadlock the harness: writes and reads make progress together, stderr is drained all the
// time (its tail kept for error messages), and a missed deadline is an error, after which the
// caller kills the process. The child runs in its own process group, and nothing it started
// outlives it: kill() ends the group, and when the process ends by itself what it left running in
// its group is ended before the process is reaped (a wrapper script's background job would
// otherwise hold the output open, making an exit look like a hang, and run on after the pair).
#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace arena {

class Subprocess {
 public:
  using Clock = std::chrono::steady_clock;

  // The process closed its output or exited (what() says which; exitStatus() then knows how).
  struct Ended : Error {
    using Error::Error;
  };
  struct TimedOut : Error {
    using Error::Error;
  };

  // Starts argv[0] (searched on PATH unless it holds a '/') in `workingDir`. Throws an Error
  // naming the program when it cannot be started.
  Subprocess(const std::vector<std::string>& argv, const std::filesystem::path& workingDir);
  ~Subprocess();  // closes stdin, gives the process a moment to exit, then kills it
  Subprocess(const Subprocess&) = delete;
  Subprocess& operator=(const Subprocess&) = delete;

  // Each throws Ended or TimedOut. Bytes go unchanged in both directions.
  void write(const void* data, size_t bytes, Clock::time_point deadline);
  std::string readLine(size_t maxBytes, Clock::time_point deadline);  // without the '\n'
  void read(void* data, size_t bytes, Clock::time_point deadline);

  // "exited with status 1", "killed by signal 11 (Segmentation fault)", or "still running"; waits
  // up to `grace` for the process to end first.
  std::string exitStatus(std::chrono::milliseconds grace = std::chrono::milliseconds(500));
  // Closes the process's stdin (the end of its input: a well-behaved process exits) and returns
  // exitStatus(grace).
  std::string endInput(std::chrono::milliseconds grace);
  // The last lines of what the process wrote to stderr (at most ~2 KiB).
  std::string stderrTail();
  // After the process ended: what it wrote to its output beyond what was read (bytes counted up to
  // 16 MiB; `excerpt` holds the first up to 64 of them). 0 when nothing.
  size_t unreadOutput(std::string& excerpt);
  // What a failure's message adds about the process: "; the process exited with status 3" (or
  // "was killed by the harness", after killing one still running after `grace`), then "; the end
  // of its stderr:\n..." or "; its stderr was empty".
  std::string howItEnded(std::chrono::milliseconds grace);
  void kill();

 private:
  // One poll() round: writes from `out` (advancing it), reads stdout into `in` (up to inBytes),
  // drains stderr. Returns the bytes read into `in`.
  size_t pump(const char*& out, size_t& outBytes, char* in, size_t inBytes,
              Clock::time_point deadline, const char* what);
  void drainStderr();
  void closeStdin();
  // Whether the process has ended, without reaping it (while unreaped its number stays taken, so
  // signalling its group reaches what it left behind and no other process's group).
  bool ended();
  // Ends what the ended (or killed) process left in its group, then reaps it.
  void reap();

  pid_t pid_ = -1;
  int stdin_ = -1, stdout_ = -1, stderr_ = -1;
  bool reaped_ = false;
  int status_ = 0;
  std::string stdoutBuffer_;  // read ahead of the current line
  std::string stderrTail_;
};

}  // namespace arena
