#pragma once
// The run matrix's results: results.json (schema-versioned) and the SQLite database results.db
// that dashboards query across commits.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/atomic_file.hpp"
#include "metrics/metric_registry.hpp"
#include "metrics/run_results.hpp"

struct sqlite3;

namespace arena {

// 2: summaries carry ci95 or absent; pairs carry tiles; results carry statistics and scene floors.
constexpr int kResultsSchemaVersion = 2;

// A results database's schema version (PRAGMA user_version): 0 for a database of no schema, -1
// where it cannot be read (not an SQLite database).
int databaseSchemaVersion(sqlite3* db);

// Reads <run>/results.json into the typed model; a missing run, another schema version or a
// document out of shape is an Error saying so (naming the JSON path).
RunResults loadResults(const std::filesystem::path& runDir);
void saveResults(const std::filesystem::path& runDir, const nlohmann::json& results);
// Appends the run to the database at dbPath (tables runs, pairs, frame_metrics, summaries) in one
// transaction; errors name `nameInErrors` (default: dbPath).
void appendToDatabase(const std::filesystem::path& dbPath, const RunResults& results,
                      const std::string& nameInErrors = "");
// Before any work: the run directory is (made) writable, an existing results.json is an arena run,
// and an existing results.db is an intact SQLite database of this schema -- so a bad output fails
// in a second, naming the file, instead of after every pair has run. Removes stale temporaries.
// The returned lock keeps other arena processes out of the directory until the run is committed:
// a second run into the same --out is refused (two commits would each drop the other's rows).
// When the run fails, a directory it created is removed on release (see RunDirectoryLock).
class RunDirectoryLock {
 public:
  RunDirectoryLock(std::filesystem::path dir, bool created, DirectoryLock lock);
  RunDirectoryLock(RunDirectoryLock&& other) noexcept;
  RunDirectoryLock(const RunDirectoryLock&) = delete;
  RunDirectoryLock& operator=(const RunDirectoryLock&) = delete;
  RunDirectoryLock& operator=(RunDirectoryLock&&) = delete;
  // A directory this lock created, released without results.json (the run failed before its
  // commit), loses what the run wrote (images, temporaries, the lock file) and is removed if that
  // leaves it empty: an error leaves no directory holding only a lock file, or a pair's images
  // without results. One that existed before the run is left as it was found.
  ~RunDirectoryLock();

 private:
  std::filesystem::path dir_;
  bool created_ = false;
  DirectoryLock lock_;
};
[[nodiscard]] RunDirectoryLock checkRunOutputs(const std::filesystem::path& runDir);
// What a run that stopped before its commit (killed, or failed) left in a directory: "DIR: a run
// into this directory stopped before its commit (started T by process P): results.json is still
// the run before it, but that run's images were being replaced" (or, with no earlier run, "...:
// it left no results"); "" when none did. The numbers (results.json, results.db) are
// the earlier run's, whole; its images are not: the report refuses such a directory, compare and
// history warn.
std::string unfinishedRunNote(const std::filesystem::path& runDir);
// Before the first image is replaced or written (a run's, a merge's): marks the directory until
// commitResults, naming the image folders (relative, images/...) the run may write, with those a
// run stopped before it named. Not earlier: a run refused before touching anything leaves the
// directory as it was.
void markRunUnfinished(const std::filesystem::path& runDir,
                       const std::vector<std::filesystem::path>& folders = {});
// The image folders the mark names (under runDir): a run that completes removes those that no
// results file records (a stopped run's), and only those.
std::vector<std::filesystem::path> unfinishedRunFolders(const std::filesystem::path& runDir);
// Writes results.json and appends to results.db as one commit: both are written to temporaries
// (the database as an appended copy) and renamed into place only when both are complete. A
// document RunResults::fromJson refuses is an Error before any file is touched.
void commitResults(const std::filesystem::path& runDir, const nlohmann::json& results);

}  // namespace arena
