#include "core/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <iostream>
#include <map>
#include <mutex>
#include <regex>

#include "core/error.hpp"

namespace arena {

namespace fs = std::filesystem;

std::string osError(const fs::path& path, const std::string& what, int errnoValue) {
  return path.string() + ": " + what + ": " + std::strerror(errnoValue);
}

namespace {

// This machine's name as it can stand in a file name ([A-Za-z0-9-], at most 32 characters).
// Written into temporaries so that a later process on the same machine knows a dead process id
// there means a dead writer, whatever the file's age.
const std::string& hostTag() {
  static const std::string tag = [] {
    char name[256] = {};
    std::string out;
    if (gethostname(name, sizeof name - 1) == 0)
      for (const char* c = name; *c && out.size() < 32; ++c)
        if (std::isalnum(static_cast<unsigned char>(*c)) || *c == '-') out += *c;
    return out.empty() ? std::string("host") : out;
  }();
  return tag;
}

}  // namespace

fs::path temporaryPathFor(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  // The extension stays last so format libraries that look at it (OpenCV) still recognise it.
  return path.parent_path() / (path.stem().string() + ".tmp" + std::to_string(getpid()) + "@" +
                               hostTag() + "_" + std::to_string(counter++) +
                               path.extension().string());
}

void writeAtomically(const fs::path& path, const std::function<void(const fs::path&)>& write) {
  if (path.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
    if (ec) throw Error(path.parent_path().string() + ": cannot create directory: " + ec.message());
  }
  const fs::path tmp = temporaryPathFor(path);
  try {
    write(tmp);
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      throw Error(osError(path, "cannot rename " + tmp.string() + " to it", errno));
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    try {
      throw;
    } catch (const Error& e) {  // name the final path, not only the temporary
      if (std::string(e.what()).rfind(path.string() + ":", 0) == 0) throw;
      throw Error(path.string() + ": " + e.what());
    } catch (
        const std::exception& e) {  // a library's own exception (OpenEXR's Iex, std::bad_alloc)
      throw Error(path.string() + ": cannot write: " + e.what());
    }
  }
}

// A temporary is "<stem>.tmp<pid>@<host>_<n><ext>". One whose process is gone is removed at any
// age when it was written on this machine; from another machine sharing the directory (or with an
// older name without the machine) a process id says nothing, so only `minAgeSeconds` of age does.
int removeStaleTemporaries(const fs::path& dir, double minAgeSeconds, bool folders) {
  // SQLite's journal of a temporary database ends in ".db-journal". Names without "@host" are
  // those of older versions: their machine is unknown.
  static const std::regex pattern(R"(.+\.tmp([0-9]+)(@([A-Za-z0-9-]+))?_[0-9]+(\.[A-Za-z0-9-]+)?)");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return 0;
  int removed = 0;
  const auto now = fs::file_time_type::clock::now();
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator();
       it.increment(ec)) {
    std::smatch m;
    const std::string name = it->path().filename().string();
    const bool folder = it->is_directory(ec) && !it->is_symlink(ec);
    if (!std::regex_match(name, m, pattern) || !(it->is_regular_file(ec) || (folders && folder)))
      continue;
    const long pid = std::stol(m[1].str());
    const bool alive = pid == getpid() || (pid > 0 && pid < (1L << 30) &&
                                           (kill(pid_t(pid), 0) == 0 || errno != ESRCH));
    if (alive) continue;
    // Written on this machine by a process that is gone: stale at any age (a killed render
    // rerun at once must not keep it). From another machine sharing the directory (or an older
    // name without the machine), a process id says nothing here: only its age does.
    const bool thisMachine = m[3].matched && m[3].str() == hostTag();
    // A folder goes, with what it holds, only when this machine's killed write made it: a folder
    // of a name like ours without the machine (someone's "shots.tmp2019_1") is never guessed at.
    if (folder && !thisMachine) continue;
    auto written = fs::last_write_time(it->path(), ec);
    if (ec || (!thisMachine && std::chrono::duration<double>(now - written).count() < minAgeSeconds))
      continue;
    std::error_code removeError;
    if (folder ? fs::remove_all(it->path(), removeError) > 0 : fs::remove(it->path(), removeError))
      ++removed;
  }
  return removed;
}

int removeStaleTemporariesBelow(const fs::path& dir, double minAgeSeconds) {
  int removed = removeStaleTemporaries(dir, minAgeSeconds);
  std::error_code ec;
  for (auto it =
           fs::recursive_directory_iterator(dir, fs::directory_options::skip_permission_denied, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec))
    if (it->is_directory(ec) && !it->is_symlink(ec))
      removed += removeStaleTemporaries(it->path(), minAgeSeconds);
  return removed;
}

void writeFileBytes(const fs::path& path, const std::string& bytes) {
  int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw Error(osError(path, "cannot create file", errno));
  size_t done = 0;
  while (done < bytes.size()) {
    ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      int err = n < 0 ? errno : EIO;
      ::close(fd);
      throw Error(osError(path, "cannot write " + std::to_string(bytes.size()) + " bytes", err));
    }
    done += size_t(n);
  }
  if (::close(fd) != 0) throw Error(osError(path, "cannot write (close)", errno));
}

void writeTextAtomically(const fs::path& path, const std::string& text) {
  writeAtomically(path, [&](const fs::path& tmp) { writeFileBytes(tmp, text); });
}

std::string readText(const fs::path& path, uintmax_t maxBytes) {
  // Non-blocking open: opening a FIFO for reading waits for a writer, forever; a regular file
  // ignores the flag, and anything else is refused below.
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) throw Error(osError(path, "cannot open file", errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    int err = errno;
    ::close(fd);
    throw Error(osError(path, "cannot stat file", err));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    throw Error(path.string() +
                ": not a regular file (a device, directory or pipe cannot be read as a document)");
  }
  if (uintmax_t(st.st_size) > maxBytes) {
    ::close(fd);
    throw Error(path.string() + ": file is " + std::to_string(st.st_size) +
                " bytes, more than the " + std::to_string(maxBytes) +
                "-byte limit for files arena reads whole");
  }
  std::string text(size_t(st.st_size), '\0');
  size_t done = 0;
  while (done < text.size()) {
    ssize_t n = ::read(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      int err = errno;
      ::close(fd);
      throw Error(osError(path, "cannot read file", err));
    }
    if (n == 0) break;  // shrank while reading
    done += size_t(n);
  }
  text.resize(done);
  ::close(fd);
  return text;
}

std::string folderName(const std::filesystem::path& dir) {
  if (dir.empty()) throw Error("an empty directory name; expected a directory (e.g. runs/today)");
  std::filesystem::path p = std::filesystem::absolute(dir).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  return p.filename().string();
}

namespace {

// The directories this process has locked: canonical path -> its lock file and how many holders.
struct HeldLock {
  int fd = -1;
  int holders = 0;
  DirectoryLock::Mode mode = DirectoryLock::Mode::Shared;
};
std::mutex heldMutex;
std::map<std::string, HeldLock>& heldLocks() {
  static std::map<std::string, HeldLock> held;
  return held;
}

// What the holder wrote into the lock file: "pid N: purpose" (empty when unreadable).
std::string holderOf(int fd) {
  char buf[256];
  const ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
  if (n <= 0) return "";
  std::string text(buf, size_t(n));
  while (!text.empty() && (text.back() == '\n' || text.back() == '\0')) text.pop_back();
  return text;
}

void recordHolder(int fd, const std::string& purpose) {
  const std::string text = "pid " + std::to_string(getpid()) + ": " + purpose + "\n";
  if (ftruncate(fd, 0) == 0 && pwrite(fd, text.data(), text.size(), 0) < 0) {
    // Only the messages of other processes read it: a lock without its note still locks.
  }
}

}  // namespace

DirectoryLock::DirectoryLock(const fs::path& dir, Mode mode, IfHeld ifHeld,
                             const std::string& purpose, bool createFile) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error(dir.string() + ": cannot create directory: " + ec.message());
  const std::string key = fs::weakly_canonical(fs::absolute(dir), ec).string();
  std::lock_guard<std::mutex> guard(heldMutex);
  HeldLock& held = heldLocks()[key];
  const bool fresh = held.fd < 0;
  if (fresh) {
    const fs::path file = dir / ".arena.lock";
    held.fd = ::open(file.c_str(), O_RDWR | (createFile ? O_CREAT : 0) | O_CLOEXEC, 0644);
    // A directory this process may not write (a shared cache on a read-only mount): flock works
    // on a read-only descriptor of an existing lock file; with none, a reader goes on unlocked
    // (nothing can rewrite what it reads through this process's rights either).
    if (held.fd < 0 && (errno == EACCES || errno == EROFS || errno == EPERM))
      held.fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (held.fd < 0) {
      const int err = errno;
      heldLocks().erase(key);
      if (mode == Mode::Shared && (err == ENOENT || err == EACCES || err == EROFS || err == EPERM))
        return;
      throw Error(osError(file, "cannot open the directory's lock file", err));
    }
  }
  if (fresh || (mode == Mode::Exclusive && held.mode == Mode::Shared)) {
    const int op = mode == Mode::Exclusive ? LOCK_EX : LOCK_SH;
    const bool locked = flock(held.fd, op | LOCK_NB) == 0;
    if (!locked && errno != EWOULDBLOCK && !createFile && fresh && mode == Mode::Shared) {
      // A file system without flock: a reader goes on unlocked rather than blame a writer.
      ::close(held.fd);
      heldLocks().erase(key);
      return;
    }
    if (!locked) {
      const std::string holder = holderOf(held.fd);
      const std::string who =
          holder.empty() ? "another arena process" : "another arena process (" + holder + ")";
      if (ifHeld == IfHeld::Refuse) {
        if (fresh) {
          ::close(held.fd);
          heldLocks().erase(key);
        }
        throw Error(dir.string() + ": " + who +
                    " is using it; wait for it to finish or choose another directory");
      }
      std::cerr << "arena: waiting for " << who << " to finish with " << dir.string() << std::endl;
      while (flock(held.fd, op) != 0)
        if (errno != EINTR) {
          const int err = errno;
          if (fresh) {
            ::close(held.fd);
            heldLocks().erase(key);
          }
          throw Error(osError(dir, "cannot lock", err));
        }
    }
    held.mode = fresh ? mode : Mode::Exclusive;
    // Only a writer notes itself (readers leave the directory untouched, read-only ones too).
    if (mode == Mode::Exclusive) recordHolder(held.fd, purpose);
  }
  ++held.holders;
  key_ = key;
}

DirectoryLock::DirectoryLock(DirectoryLock&& other) noexcept : key_(std::move(other.key_)) {
  other.key_.clear();
}

DirectoryLock::~DirectoryLock() {
  if (key_.empty()) return;
  std::lock_guard<std::mutex> guard(heldMutex);
  const auto it = heldLocks().find(key_);
  if (it == heldLocks().end() || --it->second.holders > 0) return;
  ::close(it->second.fd);  // releases the flock
  heldLocks().erase(it);
}

fs::path resolvedPath(const fs::path& path) {
  std::error_code ec;
  fs::path r = fs::weakly_canonical(fs::absolute(path, ec), ec).lexically_normal();
  return r.has_filename() ? r : r.parent_path();  // "dir/" as "dir"
}

bool liesIn(const fs::path& inner, const fs::path& outer) {
  return std::mismatch(outer.begin(), outer.end(), inner.begin(), inner.end()).first == outer.end();
}

}  // namespace arena
