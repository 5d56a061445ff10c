// core/atomic_file: writes are atomic, a failed write names the path and the OS reason, and the
// temporaries of killed writes are cleaned.
#include "core/atomic_file.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "core/capture.hpp"
#include "core/error.hpp"
#include "metrics/results.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(AtomicFile, TemporariesOfKilledWritesAreCleaned) {
  fs::path dir = test::freshDir("stale_tmp");
  const long deadPid = 999999999;  // above any pid_max: no such process
  auto make = [&](const std::string& name, int ageSeconds) {
    writeTextAtomically(dir / name, "partial");
    fs::last_write_time(dir / name,
                        fs::file_time_type::clock::now() - std::chrono::seconds(ageSeconds));
  };
  const std::string dead = std::to_string(deadPid), self = std::to_string(getpid());
  make("results.tmp" + dead + "_0.json", 3600);     // killed long ago: removed
  make("frame_0003.tmp" + dead + "_12.exr", 3600);  // killed render: removed
  make("results.tmp" + dead + "_1.db-journal",
       3600);                                    // SQLite's journal of a killed append: removed
  make("results.tmp" + dead + "_2.db", 5);       // young: maybe another host's live write, kept
  make("results.tmp" + self + "_3.json", 3600);  // this process: kept
  make("notes.tmp.json", 3600);                  // not our pattern: kept
  EXPECT_EQ(removeStaleTemporaries(dir), 3);
  EXPECT_FALSE(fs::exists(dir / ("results.tmp" + dead + "_0.json")));
  EXPECT_FALSE(fs::exists(dir / ("frame_0003.tmp" + dead + "_12.exr")));
  EXPECT_TRUE(fs::exists(dir / ("results.tmp" + dead + "_2.db")));
  EXPECT_TRUE(fs::exists(dir / ("results.tmp" + self + "_3.json")));
  EXPECT_TRUE(fs::exists(dir / "notes.tmp.json"));
}

// A capture is written in a temporary folder: a killed import's folder (this machine's, its process
// gone) is removed by the next writer in the same place (with folders), never by the file
// cleaners (without); a folder of such a name without the machine is someone's, and stays.
TEST(AtomicFile, TemporaryFoldersOfKilledWritesAreCleanedWhereAsked) {
  const fs::path dir = test::freshDir("stale_tmp_folders");
  const std::string dead = std::to_string(999999999L);
  // temporaryPathFor's name for this machine, with a process that is gone.
  std::string name = temporaryPathFor(dir / "room").filename().string();
  const size_t digits = name.find(".tmp") + 4;
  name.replace(digits, name.find('@') - digits, dead);
  const fs::path killed = dir / name, someones = dir / ("shots.tmp" + dead + "_1");
  for (const fs::path& d : {killed, someones}) {
    fs::create_directories(d / "frames");
    std::ofstream(d / "frames" / "frame_0001.exr") << "partial";
    fs::last_write_time(d, fs::file_time_type::clock::now() - std::chrono::seconds(3600));
  }
  EXPECT_EQ(removeStaleTemporaries(dir), 0);
  EXPECT_TRUE(fs::exists(killed));
  EXPECT_EQ(removeStaleTemporaries(dir, 600, true), 1);
  EXPECT_FALSE(fs::exists(killed));
  EXPECT_TRUE(fs::exists(someones / "frames" / "frame_0001.exr"));
  // What a writer of a new capture there does first.
  fs::create_directories(killed / "frames");
  { CaptureWriter writer(dir / "other"); }
  EXPECT_FALSE(fs::exists(killed));
  EXPECT_TRUE(fs::exists(someones));
}

// Makes writes beyond `bytes` fail with EFBIG (as a full disk fails with ENOSPC) for this scope.
struct FileSizeLimit {
  rlimit saved{};
  explicit FileSizeLimit(rlim_t bytes) {
    signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &saved);
    rlimit l = saved;
    l.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &l);
  }
  ~FileSizeLimit() { setrlimit(RLIMIT_FSIZE, &saved); }
};

// A named pipe where a document belongs is refused at once: a blocking open would wait for a
// writer forever (a scene file, a mesh, a manifest).
// Directory locks between processes: an exclusive holder (a child process here) makes a refusing
// lock fail naming its pid and purpose and a shared one wait until it lets go; a second run into
// the same run directory is refused; locks nest within one process; a killed holder frees it.
TEST(AtomicFile, DirectoryLocksKeepOtherProcessesOutAndNestWithinOne) {
  const fs::path dir = test::freshDir("directory_lock");
  int ready[2], release[2];
  ASSERT_EQ(pipe(ready), 0);
  ASSERT_EQ(pipe(release), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    {
      const DirectoryLock held(dir, DirectoryLock::Mode::Exclusive, DirectoryLock::IfHeld::Refuse,
                               "the child's test");
      char c = 1;
      if (write(ready[1], &c, 1) != 1) _exit(2);
      if (read(release[0], &c, 1) != 1) _exit(3);
    }
    _exit(0);
  }
  char c = 0;
  ASSERT_EQ(read(ready[0], &c, 1), 1);
  const std::string refused = test::errorOf([&] {
    DirectoryLock(dir, DirectoryLock::Mode::Shared, DirectoryLock::IfHeld::Refuse, "reading");
  });
  EXPECT_NE(refused.find(dir.string() + ": another arena process (pid " + std::to_string(child) +
                         ": the child's test) is using it"),
            std::string::npos)
      << refused;
  const std::string runRefused = test::errorOf([&] { (void)checkRunOutputs(dir); });
  EXPECT_NE(runRefused.find("is using it"), std::string::npos) << runRefused;
  // A waiting lock is granted once the holder lets go.
  const auto asked = std::chrono::steady_clock::now();
  std::thread letGo([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    char r = 1;
    EXPECT_EQ(write(release[1], &r, 1), 1);
  });
  {
    const DirectoryLock shared(dir, DirectoryLock::Mode::Shared, DirectoryLock::IfHeld::Wait,
                               "reading");
    EXPECT_GE(std::chrono::steady_clock::now() - asked, std::chrono::milliseconds(250));
    // Nested within this process: granted at once, an exclusive one upgrading the shared one.
    const DirectoryLock again(dir, DirectoryLock::Mode::Shared, DirectoryLock::IfHeld::Refuse,
                              "again");
    const DirectoryLock upgraded(dir, DirectoryLock::Mode::Exclusive, DirectoryLock::IfHeld::Refuse,
                                 "writing");
  }
  letGo.join();
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  // A holder killed while holding it leaves it free.
  const pid_t killed = fork();
  ASSERT_GE(killed, 0);
  if (killed == 0) {
    const DirectoryLock held(dir, DirectoryLock::Mode::Exclusive, DirectoryLock::IfHeld::Refuse,
                             "to be killed");
    char r = 1;
    if (write(ready[1], &r, 1) != 1) _exit(2);
    pause();
    _exit(0);
  }
  ASSERT_EQ(read(ready[0], &c, 1), 1);
  kill(killed, SIGKILL);
  ASSERT_EQ(waitpid(killed, &status, 0), killed);
  EXPECT_NO_THROW(
      DirectoryLock(dir, DirectoryLock::Mode::Exclusive, DirectoryLock::IfHeld::Refuse, "after"));
  for (int fd : {ready[0], ready[1], release[0], release[1]}) close(fd);
}

TEST(AtomicFile, AFifoIsRefusedWithoutWaitingForAWriter) {
  const fs::path fifo = test::freshDir("atomic_fifo") / "scene.json";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string e = test::errorOf([&] { readText(fifo); });
  EXPECT_NE(e.find("scene.json: not a regular file"), std::string::npos) << e;
}

TEST(AtomicFile, WriteErrorsNameThePathAndTheReason) {
  fs::path dir = test::freshDir("write_errors");
  // SQLite reports a failed write as its own I/O error (it keeps no errno for it): that is the
  // reason shown.
  auto expectNamed = [&](const std::function<void()>& write, const std::string& path,
                         const std::string& why = std::strerror(EFBIG)) {
    try {
      FileSizeLimit limit(4096);
      write();
      ADD_FAILURE() << path << ": the write succeeded";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  expectNamed([&] { writeTextAtomically(dir / "big.json", std::string(100000, 'x')); },
              (dir / "big.json").string());
  LayerSet layers;
  Image noise(128, 128, 3);
  for (size_t i = 0; i < noise.raw().size(); ++i) noise.raw()[i] = test::hashUniform(uint32_t(i));
  layers.set("color", noise);
  expectNamed(
      [&] {
        writeExr(dir / "big.exr", layers, {{"color", {"R", "G", "B"}}}, {});
      },
      (dir / "big.exr").string());
  const RunResults r{.environment = std::string(100000, 's')};
  expectNamed([&] { appendToDatabase(dir / "results.db", r); }, (dir / "results.db").string(),
              "SQLite: disk I/O error");
  // Reads: a missing file names the path and the reason.
  try {
    readText(dir / "missing.json");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "missing.json").string() +
                                         ": cannot open file: " + std::strerror(ENOENT)),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace arena
