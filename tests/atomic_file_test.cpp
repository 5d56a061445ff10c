// core/atomic_file: writes are atomic, a failed write names the path and the OS reason, and the
// temporaries of killed writes are cleaned.
#include "core/atomic_file.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>

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
