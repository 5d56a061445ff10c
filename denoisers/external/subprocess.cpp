#include "denoisers/external/subprocess.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <iterator>
#include <mutex>
#include <thread>

#include "core/text.hpp"

extern char** environ;

namespace arena {

namespace {

constexpr size_t kStderrTailBytes = 2048;
constexpr size_t kMaxUnreadBytes = size_t(64) << 20;
constexpr size_t kChunk = size_t(1) << 16;
constexpr long long kEndedCheckMs = 100;  // how often a wait checks whether the process ended

void setNonBlocking(int fd) {
  fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
}

// The process groups of the external processes alive. A signal that ends arena (Ctrl-C, SIGTERM,
// a closed terminal) ends them first: each runs in a group of its own, which a terminal's Ctrl-C
// does not reach, so a hung one outlived arena (a bad-input trial). Fixed slots of atomics, as a
// signal handler reads them; a process beyond them is only not covered.
constexpr int kGroupSlots = 64;
std::atomic<pid_t> liveGroups[kGroupSlots];
constexpr int kEndingSignals[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};
static_assert(std::atomic<pid_t>::is_always_lock_free, "the signal handler reads the groups");
struct sigaction previousActions[std::size(kEndingSignals)];

void endGroupsAndResignal(int signal) {
  const int savedErrno = errno;  // a previous handler the signal returns to may read it
  for (std::atomic<pid_t>& group : liveGroups)
    if (const pid_t p = group.load(); p > 0) ::kill(-p, SIGKILL);
  // Then the signal as before: blocked while this handler runs, it is delivered on its return
  // under the disposition that was there (the default ends arena).
  for (size_t k = 0; k < std::size(kEndingSignals); ++k)
    if (kEndingSignals[k] == signal) sigaction(signal, &previousActions[k], nullptr);
  raise(signal);
  errno = savedErrno;
}

void registerGroup(pid_t group) {
  static std::once_flag installed;
  std::call_once(installed, [] {
    for (size_t k = 0; k < std::size(kEndingSignals); ++k) {
      sigaction(kEndingSignals[k], nullptr, &previousActions[k]);
      // A signal arena ignores (a background job's SIGINT, nohup's SIGHUP) ends nothing.
      if (!(previousActions[k].sa_flags & SA_SIGINFO) && previousActions[k].sa_handler == SIG_IGN)
        continue;
      struct sigaction action {};
      action.sa_handler = endGroupsAndResignal;
      sigemptyset(&action.sa_mask);
      sigaction(kEndingSignals[k], &action, nullptr);
    }
  });
  for (std::atomic<pid_t>& slot : liveGroups) {
    pid_t empty = 0;
    if (slot.compare_exchange_strong(empty, group)) return;
  }
}

void unregisterGroup(pid_t group) {
  for (std::atomic<pid_t>& slot : liveGroups) {
    pid_t same = group;
    if (slot.compare_exchange_strong(same, 0)) return;
  }
}

std::string describeStatus(int status) {
  if (WIFEXITED(status)) return "exited with status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status))
    return "was killed by signal " + std::to_string(WTERMSIG(status)) + " (" +
           strsignal(WTERMSIG(status)) + ")";
  return "ended (wait status " + std::to_string(status) + ")";
}

}  // namespace

Subprocess::Subprocess(const std::vector<std::string>& argv,
                       const std::filesystem::path& workingDir) {
  if (argv.empty()) throw Error("subprocess: empty command");
  // stdin is a socket so writes can ask for MSG_NOSIGNAL: a process that dies mid-frame gives
  // EPIPE, not a SIGPIPE that would end the harness.
  int in[2], out[2], err[2];
  if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, in) != 0)
    throw Error(std::string("subprocess: socketpair: ") + std::strerror(errno));
  if (pipe2(out, O_CLOEXEC) != 0 || pipe2(err, O_CLOEXEC) != 0)
    throw Error(std::string("subprocess: pipe: ") + std::strerror(errno));
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, in[1], 0);
  posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  posix_spawn_file_actions_adddup2(&actions, err[1], 2);
  posix_spawn_file_actions_addchdir_np(&actions, workingDir.c_str());
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  sigset_t none, all;
  sigemptyset(&none);
  sigfillset(&all);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setsigdefault(&attr, &all);
  posix_spawnattr_setpgroup(&attr, 0);  // its own group: kill() ends its children too
  posix_spawnattr_setflags(&attr,
                           POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETPGROUP);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  // The ending signals wait from the spawn to the group's registration: one in between would end
  // arena and leave the child unnamed to the handler (the child starts with an empty mask).
  sigset_t ending, before;
  sigemptyset(&ending);
  for (const int signal : kEndingSignals) sigaddset(&ending, signal);
  pthread_sigmask(SIG_BLOCK, &ending, &before);
  const int rc = posix_spawnp(&pid_, args[0], &actions, &attr, args.data(), environ);
  if (rc == 0) registerGroup(pid_);
  pthread_sigmask(SIG_SETMASK, &before, nullptr);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attr);
  ::close(in[1]);
  ::close(out[1]);
  ::close(err[1]);
  stdin_ = in[0];
  stdout_ = out[0];
  stderr_ = err[0];
  if (rc != 0) {
    ::close(stdin_);
    ::close(stdout_);
    ::close(stderr_);
    stdin_ = stdout_ = stderr_ = -1;
    reaped_ = true;
    throw Error("cannot start '" + argv[0] + "' in " + workingDir.string() + ": " +
                std::strerror(rc));
  }
  for (int fd : {stdin_, stdout_, stderr_}) setNonBlocking(fd);
}

Subprocess::~Subprocess() {
  closeStdin();
  if (exitStatus(std::chrono::milliseconds(1000)) == "still running") kill();
  for (int fd : {stdout_, stderr_})
    if (fd >= 0) ::close(fd);
}

void Subprocess::closeStdin() {
  if (stdin_ >= 0) ::close(stdin_);
  stdin_ = -1;
}

void Subprocess::drainStderr() {
  char buf[4096];
  while (stderr_ >= 0) {
    const ssize_t n = ::read(stderr_, buf, sizeof buf);
    if (n > 0) {
      stderrTail_.append(buf, size_t(n));
      if (stderrTail_.size() > 2 * kStderrTailBytes)
        stderrTail_.erase(0, stderrTail_.size() - kStderrTailBytes);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n == 0) {  // the process closed stderr (exited)
      ::close(stderr_);
      stderr_ = -1;
    }
    return;  // EAGAIN: nothing more for now
  }
}

size_t Subprocess::pump(const char*& out, size_t& outBytes, char* in, size_t inBytes,
                        Clock::time_point deadline, const char* what) {
  pollfd fds[3];
  nfds_t n = 0;
  int stdinSlot = -1, stdoutSlot = -1, stderrSlot = -1;
  if (outBytes > 0) {
    if (stdin_ < 0) throw Ended(std::string("its input was closed while ") + what);
    stdinSlot = int(n);
    fds[n++] = {stdin_, POLLOUT, 0};
  }
  if (inBytes > 0) {
    stdoutSlot = int(n);
    fds[n++] = {stdout_, POLLIN, 0};
  }
  if (stderr_ >= 0) {
    stderrSlot = int(n);
    fds[n++] = {stderr_, POLLIN, 0};
  }
  const auto now = Clock::now();
  if (now >= deadline) throw TimedOut(std::string("timed out ") + what);
  const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - now).count();
  // In slices, so that a process that ended while something it started holds its output open is
  // noticed: its group is ended, the output closes, and the exit is reported as one, not as a hang.
  const int ready = ::poll(fds, n, int(std::min<long long>(left, kEndedCheckMs)));
  if (ready < 0) {
    if (errno == EINTR) return 0;
    throw Error(std::string("poll: ") + std::strerror(errno));
  }
  if (ready == 0) {
    if (ended() && !reaped_) ::kill(-pid_, SIGKILL);  // ended, not reaped: its group is its own
    return 0;  // the caller asks again; the deadline is checked first
  }
  if (stderrSlot >= 0 && fds[stderrSlot].revents != 0) drainStderr();
  if (stdinSlot >= 0 && fds[stdinSlot].revents != 0) {
    const ssize_t sent =
        ::send(stdin_, out, std::min(outBytes, kChunk), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (sent > 0) {
      out += sent;
      outBytes -= size_t(sent);
    } else if (sent < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      throw Ended(std::string("it stopped reading its input while ") + what);
    }
  }
  if (stdoutSlot >= 0 && fds[stdoutSlot].revents != 0) {
    const ssize_t got = ::read(stdout_, in, inBytes);
    if (got > 0) return size_t(got);
    if (got == 0) throw Ended(std::string("it closed its output while ") + what);
    if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
      throw Ended(std::string("reading its output failed (") + std::strerror(errno) + ") while " +
                  what);
  }
  return 0;
}

void Subprocess::write(const void* data, size_t bytes, Clock::time_point deadline) {
  const char* p = static_cast<const char*>(data);
  char chunk[4096];
  // Whatever the process answers meanwhile is kept for the next read: a process that replies
  // (or complains) before reading everything cannot deadlock against this write.
  while (bytes > 0) {
    const size_t got = pump(p, bytes, chunk, sizeof chunk, deadline, "sending it a frame");
    stdoutBuffer_.append(chunk, got);
    // An answer cannot come before its frame has arrived: what is kept meanwhile is a complaint
    // or a header, not an unbounded stream held in memory until the timeout.
    if (stdoutBuffer_.size() > kMaxUnreadBytes)
      throw Error("wrote more than " + std::to_string(kMaxUnreadBytes >> 20) +
                  " MiB to its output while it was being sent a frame (is it reading its input?)");
  }
}

std::string Subprocess::readLine(size_t maxBytes, Clock::time_point deadline) {
  const char* none = nullptr;
  size_t noBytes = 0;
  char chunk[4096];
  for (size_t scanned = 0;;) {
    const size_t eol = stdoutBuffer_.find('\n', scanned);
    if (eol != std::string::npos) {
      std::string line = stdoutBuffer_.substr(0, eol);
      stdoutBuffer_.erase(0, eol + 1);
      return line;
    }
    scanned = stdoutBuffer_.size();
    if (scanned > maxBytes)
      throw Error("sent a header line longer than " + std::to_string(maxBytes) +
                  " bytes (is it writing raw data where a JSON line belongs?)");
    const size_t got = pump(none, noBytes, chunk, sizeof chunk, deadline, "waiting for its answer");
    stdoutBuffer_.append(chunk, got);
  }
}

void Subprocess::read(void* data, size_t bytes, Clock::time_point deadline) {
  char* p = static_cast<char*>(data);
  const size_t buffered = std::min(bytes, stdoutBuffer_.size());
  std::memcpy(p, stdoutBuffer_.data(), buffered);
  stdoutBuffer_.erase(0, buffered);
  const char* none = nullptr;
  size_t noBytes = 0;
  for (size_t got = buffered; got < bytes;)
    got += pump(none, noBytes, p + got, bytes - got, deadline, "reading its output planes");
}

bool Subprocess::ended() {
  if (reaped_) return true;
  siginfo_t info{};
  while (::waitid(P_PID, id_t(pid_), &info, WEXITED | WNOHANG | WNOWAIT) < 0) {
    if (errno == EINTR) continue;
    reaped_ = true;  // ECHILD: nothing left to reap (status unknown)
    unregisterGroup(pid_);
    return true;
  }
  return info.si_pid == pid_;
}

void Subprocess::reap() {
  if (reaped_) return;
  ::kill(-pid_, SIGKILL);
  unregisterGroup(pid_);  // once reaped, its group's id may name another's
  while (::waitpid(pid_, &status_, 0) < 0 && errno == EINTR) {
  }
  reaped_ = true;
}

std::string Subprocess::exitStatus(std::chrono::milliseconds grace) {
  const auto until = Clock::now() + grace;
  while (!reaped_) {
    if (ended()) {
      reap();
      break;
    }
    if (Clock::now() >= until) return "still running";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return describeStatus(status_);
}

std::string Subprocess::endInput(std::chrono::milliseconds grace) {
  closeStdin();
  return exitStatus(grace);
}

std::string Subprocess::howItEnded(std::chrono::milliseconds grace) {
  std::string status = exitStatus(grace);
  if (status == "still running") {
    kill();
    status = "was killed by the harness";
  }
  const std::string tail = stderrTail();
  return "; the process " + status +
         (tail.empty() ? "; its stderr was empty" : "; the end of its stderr:\n" + tail);
}

std::string Subprocess::stderrTail() {
  drainStderr();
  std::string tail = utf8Excerpt(stderrTail_, kStderrTailBytes, true);
  while (!tail.empty() && (tail.back() == '\n' || tail.back() == ' ')) tail.pop_back();
  return tail;
}

size_t Subprocess::unreadOutput(std::string& excerpt) {
  size_t count = stdoutBuffer_.size();
  excerpt = stdoutBuffer_.substr(0, 64);
  char buf[4096];
  while (stdout_ >= 0 && count < (size_t(16) << 20)) {
    const ssize_t n = ::read(stdout_, buf, sizeof buf);
    if (n > 0) {
      if (excerpt.size() < 64) excerpt.append(buf, std::min(size_t(n), 64 - excerpt.size()));
      count += size_t(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    break;  // the end of its output, or nothing more for now (EAGAIN)
  }
  return count;
}

void Subprocess::kill() {
  if (reaped_) return;
  ::kill(pid_, SIGKILL);
  reap();  // ends the group too
}

}  // namespace arena
