#include "metrics/results.hpp"

#include <sqlite3.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include "core/atomic_file.hpp"
#include "core/env_info.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "metrics/statistics.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Written when a run starts replacing images, removed when its results are committed: while it
// lies there, the images are partly the new run's. Its first line says who started it; each
// line after it, "folder images/SCENE[/PAIR]", names an image folder that run (or a run stopped
// before it) may have written.
constexpr const char* kUnfinishedMarker = ".arena.unfinished";
constexpr const char* kFolderLine = "folder ";

// The marker's lines ({} when there is none or it cannot be read).
std::vector<std::string> markerLines(const fs::path& runDir) {
  std::vector<std::string> lines;
  std::error_code ec;
  if (!fs::exists(runDir / kUnfinishedMarker, ec)) return lines;
  try {
    std::istringstream in(readText(runDir / kUnfinishedMarker));
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  } catch (const Error&) {
  }
  return lines;
}

}  // namespace

void markRunUnfinished(const fs::path& runDir, const std::vector<fs::path>& folders) {
  // A stopped run's folders stay named: the run that completes removes those no results record.
  std::set<std::string> named;
  for (const std::string& line : markerLines(runDir))
    if (line.rfind(kFolderLine, 0) == 0) named.insert(line.substr(std::string(kFolderLine).size()));
  for (const fs::path& f : folders) named.insert(f.generic_string());
  std::string text = "started " + utcTimestamp() + " by process " + std::to_string(getpid()) + "\n";
  for (const std::string& f : named) text += kFolderLine + f + "\n";
  writeTextAtomically(runDir / kUnfinishedMarker, text);
}

std::vector<fs::path> unfinishedRunFolders(const fs::path& runDir) {
  std::vector<fs::path> folders;
  for (const std::string& line : markerLines(runDir))
    if (line.rfind(kFolderLine, 0) == 0) {
      const fs::path relative = line.substr(std::string(kFolderLine).size());
      // Only what a run writes: relative, below images/, no "..".
      bool plain = !relative.empty() && !relative.is_absolute() && *relative.begin() == "images";
      for (const fs::path& part : relative) plain = plain && part != "..";
      if (plain) folders.push_back(runDir / relative);
    }
  return folders;
}

std::string unfinishedRunNote(const fs::path& runDir) {
  std::error_code ec;
  if (!fs::exists(runDir / kUnfinishedMarker, ec)) return "";
  const std::vector<std::string> lines = markerLines(runDir);
  std::string started = lines.empty() ? "" : lines.front();
  while (!started.empty() && (started.back() == '\r' || started.back() == ' ')) started.pop_back();
  return runDir.string() + ": a run into this directory stopped before its commit" +
         (started.empty() ? "" : " (" + started + ")") +
         (fs::exists(runDir / "results.json", ec)
              ? ": results.json is still the run before it, but that run's images were being "
                "replaced"
              : ": it left no results (run it again)");
}

RunResults loadResults(const fs::path& runDir) {
  fs::path file = runDir / "results.json";
  if (!fs::exists(runDir)) throw Error(runDir.string() + ": no such run directory");
  if (!fs::is_directory(runDir))
    throw Error(runDir.string() +
                ": a file; expected a run directory (the folder that holds results.json" +
                (runDir.filename() == "results.json" ? ": " + runDir.parent_path().string()
                                                     : std::string()) +
                ")");
  // A run still being written (its writer holds the directory's lock) holds a results.json of an
  // earlier run, or none: refused, naming the writer, rather than judged as if finished.
  const DirectoryLock reading(runDir, DirectoryLock::Mode::Shared, DirectoryLock::IfHeld::Refuse,
                              "reading this run", /*createFile=*/false);
  if (!fs::exists(file)) {
    // A run stopped before its first commit: said so (its mark), rather than "not a run".
    if (const std::string note = unfinishedRunNote(runDir); !note.empty()) throw Error(note);
    throw Error(runDir.string() + ": not a run (no results.json); create one with `arena run`");
  }
  RunResults results = RunResults::fromJson(parseJsonFile(file.string()), file.string());
  results.source = file.string();  // what later errors about its contents name
  return results;
}

void saveResults(const fs::path& runDir, const json& results) {
  std::error_code ec;
  fs::create_directories(runDir, ec);
  if (ec) throw Error(runDir.string() + ": cannot create run directory: " + ec.message());
  // Strings from outside (an external denoiser's messages) are made valid UTF-8 where they enter;
  // should one slip through, a replacement character costs less than the whole run.
  writeTextAtomically(runDir / "results.json", jsonText(results, 1));
}

namespace {

// The tables of results.db, defined once: appends create them, and checkRunOutputs compares an
// existing database's columns against them.
constexpr const char* kDatabaseSchema = R"(
  CREATE TABLE IF NOT EXISTS runs (id INTEGER PRIMARY KEY, name TEXT, created TEXT, git_commit TEXT,
               schema INTEGER, environment TEXT, settings TEXT);
             CREATE TABLE IF NOT EXISTS pairs (run_id INTEGER, scene TEXT, denoiser TEXT, label TEXT, params TEXT,
               status TEXT, error TEXT);
             CREATE TABLE IF NOT EXISTS frame_metrics (run_id INTEGER, scene TEXT, label TEXT, frame INTEGER,
               metric TEXT, value REAL);
             CREATE TABLE IF NOT EXISTS summaries (run_id INTEGER, scene TEXT, label TEXT, metric TEXT, mean REAL,
               median REAL, p5 REAL, p95 REAL, ci_lo REAL, ci_hi REAL, frames INTEGER, absent TEXT);
             CREATE TABLE IF NOT EXISTS paired (run_id INTEGER, scene TEXT, metric TEXT, a TEXT, b TEXT, diff REAL,
               ci_lo REAL, ci_hi REAL, resolved INTEGER);
             CREATE TABLE IF NOT EXISTS rankings (run_id INTEGER, scene TEXT, metric TEXT, label TEXT, rank INTEGER,
               value REAL, ci_lo REAL, ci_hi REAL, tied_with TEXT);
             CREATE TABLE IF NOT EXISTS metrics (run_id INTEGER, name TEXT, unit TEXT, better TEXT,
               needs_reference INTEGER, reads TEXT, transform TEXT, ranked INTEGER, meaning TEXT);
             CREATE TABLE IF NOT EXISTS scenes (run_id INTEGER, scene TEXT, width INTEGER,
               height INTEGER, frames INTEGER);
             CREATE TABLE IF NOT EXISTS gpu_predicted (run_id INTEGER, scene TEXT, label TEXT,
               device TEXT, width INTEGER, height INTEGER, ms_median REAL, ms_mean REAL, ms_p5 REAL,
               ms_p95 REAL, persistent_mib REAL, working_set_mib REAL);)";
// Tables added to the schema after databases were written without them: such a database is still
// this schema (the append creates the table), and its earlier runs simply lack the rows (scenes,
// 2026-12-06: each scene's size and length, which the gate compares, as results.json has them;
// gpu_predicted, 2026-12-07: the cost model's time per device and memory per pair, as
// pairs[].timing.gpuPredicted has them).
const std::set<std::string> kTablesAddedLater = {"scenes", "gpu_predicted"};

// An open database; every error names `name` (the path the user knows) and SQLite's reason, with
// the operating system's reason where SQLite had one (a full disk, a read-only directory).
struct Db {
  sqlite3* db = nullptr;
  std::string name;
  Db(const fs::path& p, const std::string& nameInErrors, int flags) : name(nameInErrors) {
    if (sqlite3_open_v2(p.c_str(), &db, flags, nullptr) != SQLITE_OK)
      fail("cannot open SQLite database");
    sqlite3_extended_result_codes(db, 1);
  }
  ~Db() { sqlite3_close(db); }
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;
  [[noreturn]] void fail(const std::string& what) const {
    std::string msg =
        name + ": " + what + ": SQLite: " + (db ? sqlite3_errmsg(db) : "out of memory");
    if (db && sqlite3_system_errno(db) != 0)
      msg += std::string(" (") + std::strerror(sqlite3_system_errno(db)) + ")";
    throw Error(msg);
  }
  void exec(const std::string& sql) {
    if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr) != SQLITE_OK)
      fail("cannot execute " + sql.substr(0, 40));
  }
  // table -> column names, in order.
  std::map<std::string, std::vector<std::string>> tables() {
    std::map<std::string, std::vector<std::string>> out;
    std::vector<std::string> names;
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db, "SELECT name FROM sqlite_master WHERE type = 'table'", -1, &s,
                           nullptr) != SQLITE_OK)
      fail("cannot read the schema");
    int rc;
    while ((rc = sqlite3_step(s)) == SQLITE_ROW)
      names.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(s, 0)));
    sqlite3_finalize(s);
    if (rc != SQLITE_DONE) fail("cannot read the schema");
    for (const std::string& t : names) {
      std::string sql = "PRAGMA table_info(\"" + t + "\")";
      if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s, nullptr) != SQLITE_OK)
        fail("cannot read table " + t);
      while ((rc = sqlite3_step(s)) == SQLITE_ROW)
        out[t].emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(s, 1)));
      sqlite3_finalize(s);
      if (rc != SQLITE_DONE) fail("cannot read table " + t);
    }
    return out;
  }
};

struct Statement {
  sqlite3_stmt* s = nullptr;
  const Db& db;
  Statement(const Db& database, const char* sql) : db(database) {
    if (sqlite3_prepare_v2(db.db, sql, -1, &s, nullptr) != SQLITE_OK)
      db.fail("cannot prepare an insert");
  }
  ~Statement() { sqlite3_finalize(s); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  Statement& text(int i, const std::string& v) {
    sqlite3_bind_text(s, i, v.c_str(), -1, SQLITE_TRANSIENT);
    return *this;
  }
  Statement& real(int i, double v) {
    if (std::isfinite(v)) sqlite3_bind_double(s, i, v);
    else sqlite3_bind_null(s, i);  // absent, never a fake number
    return *this;
  }
  Statement& integer(int i, long long v) {
    sqlite3_bind_int64(s, i, v);
    return *this;
  }
  void step() {
    if (sqlite3_step(s) != SQLITE_DONE) db.fail("cannot insert a row");
    sqlite3_reset(s);
    sqlite3_clear_bindings(s);
  }
};

}  // namespace

int databaseSchemaVersion(sqlite3* db) {
  sqlite3_stmt* s = nullptr;
  int v = -1;
  if (sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &s, nullptr) == SQLITE_OK && sqlite3_step(s) == SQLITE_ROW)
    v = sqlite3_column_int(s, 0);
  sqlite3_finalize(s);
  return v;
}

namespace {

bool hasTable(sqlite3* db, const char* name) {
  sqlite3_stmt* s = nullptr;
  bool found = false;
  if (sqlite3_prepare_v2(db, "SELECT 1 FROM sqlite_master WHERE type='table' AND name=?", -1, &s, nullptr) == SQLITE_OK) {
    sqlite3_bind_text(s, 1, name, -1, SQLITE_STATIC);
    found = sqlite3_step(s) == SQLITE_ROW;
  }
  sqlite3_finalize(s);
  return found;
}

// The database's schema follows the results schema; one of another version is never mixed in.
void requireSchemaVersion(const Db& db) {
  const int version = databaseSchemaVersion(db.db);
  if (version != kResultsSchemaVersion && (version != 0 || hasTable(db.db, "runs")))
    throw Error(db.name + ": a results database of schema version " + std::to_string(version) +
                ", this arena writes version " + std::to_string(kResultsSchemaVersion) +
                "; move it away or write the run elsewhere");
}

}  // namespace

void appendToDatabase(const fs::path& dbPath, const RunResults& r, const std::string& nameInErrors) {
  Db db(dbPath, nameInErrors.empty() ? dbPath.string() : nameInErrors, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  requireSchemaVersion(db);
  db.exec("PRAGMA user_version = " + std::to_string(kResultsSchemaVersion));
  db.exec(kDatabaseSchema);
  db.exec("BEGIN");
  Statement run(db, "INSERT INTO runs (name, created, git_commit, schema, environment, settings) VALUES (?,?,?,?,?,?)");
  run.text(1, r.name)
      .text(2, r.created)
      .text(3, r.environment.value("git_commit", ""))
      .integer(4, kResultsSchemaVersion)
      .text(5, jsonText(r.environment))
      .text(6, jsonText(r.settings.toJson()))
      .step();
  const long long runId = sqlite3_last_insert_rowid(db.db);
  // The registry as this arena knew it, so a dashboard reads each metric's direction and unit from
  // the database rather than from a list of its own.
  Statement registered(db, "INSERT INTO metrics VALUES (?,?,?,?,?,?,?,?,?)");
  for (const json& m : metricCatalogJson())
    registered.integer(1, runId).text(2, m["name"]).text(3, m["unit"]).text(4, m["better"])
        .integer(5, m["needsReference"].get<bool>()).text(6, m["reads"]).text(7, m["transform"])
        .integer(8, m["ranked"].get<bool>()).text(9, m["meaning"]).step();
  // Each scene's size and length as the run measured it (settingsDifferences compares them).
  Statement sceneRow(db, "INSERT INTO scenes VALUES (?,?,?,?,?)");
  for (auto it = r.scenes.begin(); it != r.scenes.end(); ++it) {
    const json& facts = it.value();
    if (!facts.is_object()) continue;
    sceneRow.integer(1, runId).text(2, it.key());
    int column = 3;
    for (const char* k : {"width", "height", "frames"}) {  // unbound: NULL, not a made-up size
      if (facts.contains(k) && facts[k].is_number_integer())
        sceneRow.integer(column, facts[k].get<long long>());
      ++column;
    }
    sceneRow.step();
  }
  // The cost model's predicted GPU time, one row per pair and device, with the pair's memory.
  Statement gpu(db, "INSERT INTO gpu_predicted VALUES (?,?,?,?,?,?,?,?,?,?,?,?)");
  for (const PairResult& p : r.pairs) {
    const json& g = p.ok() ? p.timing().value("gpuPredicted", json()) : json();
    if (!g.is_object()) continue;
    const json resolution = g.value("resolution", json::array());
    const json memory = g.value("memory", json::object());
    auto number = [](const json& j, const char* k) {
      return j.is_object() && j.contains(k) && j[k].is_number() ? j[k].get<double>() : kUndefined;
    };
    for (const json& d : g.value("devices", json::array())) {
      gpu.integer(1, runId).text(2, p.scene).text(3, p.label).text(4, d.value("device", ""));
      if (resolution.size() == 2 && resolution[0].is_number_integer() &&
          resolution[1].is_number_integer())
        gpu.integer(5, resolution[0].get<long long>()).integer(6, resolution[1].get<long long>());
      gpu.real(7, number(d, "msMedian"))
          .real(8, number(d, "msMean"))
          .real(9, number(d, "msP5"))
          .real(10, number(d, "msP95"))
          .real(11, number(memory, "persistentMiB"))
          .real(12, number(memory, "workingSetMiB"))
          .step();
    }
  }
  Statement pair(db, "INSERT INTO pairs VALUES (?,?,?,?,?,?,?)");
  Statement frame(db, "INSERT INTO frame_metrics VALUES (?,?,?,?,?,?)");
  Statement summary(db, "INSERT INTO summaries VALUES (?,?,?,?,?,?,?,?,?,?,?,?)");
  for (const PairResult& p : r.pairs) {
    pair.integer(1, runId)
        .text(2, p.scene)
        .text(3, p.denoiser)
        .text(4, p.label)
        .text(5, jsonText(p.params))
        .text(6, p.status)
        .text(7, p.error)
        .step();
    if (!p.ok()) continue;
    for (const json& f : p.part("frames"))
      for (auto it = f.begin(); it != f.end(); ++it)
        if (it.key() != "frame" && it.value().is_number())
          frame.integer(1, runId).text(2, p.scene).text(3, p.label).integer(4, f["frame"].get<int>()).text(5, it.key())
              .real(6, it.value().get<double>()).step();
    for (const auto& [metric, v] : p.summary)
      summary.integer(1, runId).text(2, p.scene).text(3, p.label).text(4, metric).real(5, v.mean)
          .real(6, v.median).real(7, v.p5).real(8, v.p95).real(9, v.ci95.lo).real(10, v.ci95.hi)
          .integer(11, v.frames).text(12, v.absent).step();
  }
  if (r.statistics) {
    const RunStatistics& statistics = *r.statistics;
    Statement paired(db, "INSERT INTO paired VALUES (?,?,?,?,?,?,?,?,?)");
    Statement rank(db, "INSERT INTO rankings VALUES (?,?,?,?,?,?,?,?,?)");
    // An event's response: a method that never settled has the window's frame count as its
    // ranking value, by which the ranking orders it last, and any interval bound that reaches
    // that count means "never"; no number of frames, so NULL here, as results.json has null.
    struct Response {
      double window;  // the window's frames from the event: "never"
      bool never;     // the method never settled
    };
    auto addRanking = [&](const std::string& scene, const std::string& metric,
                          const std::vector<RankedMethod>& ranking,
                          const std::map<std::string, Response>& responses = {}) {
      for (const RankedMethod& m : ranking) {
        const auto response = responses.find(m.label);
        const bool known = response != responses.end();
        const auto bound = [&](double v) {
          return known && v >= response->second.window ? kUndefined : v;
        };
        rank.integer(1, runId)
            .text(2, scene)
            .text(3, metric)
            .text(4, m.label)
            .integer(5, m.rank)
            .real(6, known && response->second.never ? kUndefined : m.value)
            .real(7, bound(m.ci.lo))
            .real(8, bound(m.ci.hi))
            .text(9, jsonText(json(m.tiedWith)))
            .step();
      }
    };
    // Of a scene's event at `eventFrame`, each method's response: label -> window, never settled.
    auto responsesAt = [&](const std::string& scene, int eventFrame) {
      std::map<std::string, Response> out;
      for (const PairResult& p : r.pairs)
        if (p.scene == scene && p.ok() && p.part("ghosting").is_array())
          for (const json& g : p.part("ghosting"))
            if (g.value("eventFrame", -1) == eventFrame &&
                g.value("settled", json()).is_boolean() && g.value("windowEnd", json()).is_number())
              out[p.label] = {g["windowEnd"].get<double>() - eventFrame + 1,
                              !g["settled"].get<bool>()};
      return out;
    };
    auto addScene = [&](const std::string& scene, const SceneRanking& s, const std::string& metric,
                        const std::map<std::string, Response>& responses = {}) {
      addRanking(scene, metric, s.ranking, responses);
      for (const SceneRanking::Pair& x : s.pairs)
        paired.integer(1, runId).text(2, scene).text(3, metric).text(4, x.a).text(5, x.b).real(6, x.d.diff)
            .real(7, x.d.ci.lo).real(8, x.d.ci.hi).integer(9, x.d.resolved()).step();
    };
    for (const auto& entry : statistics.scenes) {
      const std::string& name = entry.first;  // read by the lambda below
      const auto& scene = entry.second;
      addScene(name, scene.ranking, scene.ranking.metric);
      for (const auto& [metric, ranking] : scene.byMetric) addScene(name, ranking, ranking.metric);
      // Event-window figures (metrics/ghosting_intervals): metric "ghosting@<frame>.<figure>" or
      // "cut@<frame>.<figure>"; each method's figure and interval are its rankings row.
      scene.forEachEvent([&](const EventStatistics& e, bool cut) {
        for (const auto& [figure, ranking] : e.byFigure)
          addScene(
              name, ranking,
              std::string(cut ? "cut@" : "ghosting@") + std::to_string(e.eventFrame) + "." + figure,
              !cut && figure == "responseFrames" ? responsesAt(name, e.eventFrame)
                                                 : std::map<std::string, Response>{});
      });
    }
    // The overall scores: scene "*", relMSE's and every other metric's that declares one; their
    // pairs' diff is log(score_a / score_b), from which the ranking's ties are read.
    auto addOverall = [&](const std::string& metric, const OverallRanking& overall) {
      addRanking("*", metric, overall.ranking);
      for (const SceneRanking::Pair& x : overall.pairs)
        paired.integer(1, runId)
            .text(2, "*")
            .text(3, metric)
            .text(4, x.a)
            .text(5, x.b)
            .real(6, x.d.diff)
            .real(7, x.d.ci.lo)
            .real(8, x.d.ci.hi)
            .integer(9, x.d.resolved())
            .step();
    };
    if (statistics.overall) addOverall(statistics.rankedOn, *statistics.overall);
    for (const auto& [metric, overall] : statistics.overallByMetric) addOverall(metric, overall);
  }
  db.exec("COMMIT");
}

RunDirectoryLock::RunDirectoryLock(fs::path dir, bool created, DirectoryLock lock)
    : dir_(std::move(dir)), created_(created), lock_(std::move(lock)) {}

RunDirectoryLock::RunDirectoryLock(RunDirectoryLock&& other) noexcept
    : dir_(std::move(other.dir_)),
      created_(std::exchange(other.created_, false)),
      lock_(std::move(other.lock_)) {}

RunDirectoryLock::~RunDirectoryLock() {
  std::error_code ec;
  if (!created_ || fs::exists(dir_ / "results.json", ec)) return;
  // What the run wrote (its images, temporaries and lock file); then the directory, if that was
  // all (a file someone put there during the run stays, and so does the directory).
  fs::remove_all(dir_ / "images", ec);
  removeStaleTemporariesBelow(dir_, 0);
  fs::remove(dir_ / kUnfinishedMarker, ec);  // its images are gone with it
  fs::remove(dir_ / ".arena.lock", ec);
  fs::remove(dir_, ec);  // only when empty
}

RunDirectoryLock checkRunOutputs(const fs::path& runDir) {
  std::error_code ec;
  if (fs::exists(runDir, ec) && !fs::is_directory(runDir, ec))
    throw Error(runDir.string() + ": exists and is not a directory; --out needs a run directory");
  const bool created = !fs::exists(runDir, ec);
  fs::create_directories(runDir, ec);
  if (ec) throw Error(runDir.string() + ": cannot create run directory: " + ec.message());
  if (access(runDir.c_str(), W_OK) != 0)
    throw Error(osError(runDir, "run directory is not writable", errno));
  RunDirectoryLock lock(runDir, created,
                        DirectoryLock(runDir, DirectoryLock::Mode::Exclusive,
                                      DirectoryLock::IfHeld::Refuse, "writing this run"));
  removeStaleTemporariesBelow(runDir);  // images/ too

  const fs::path jsonPath = runDir / "results.json";
  if (fs::exists(jsonPath, ec)) {
    json j;
    try {
      j = parseJsonFile(jsonPath.string());
    } catch (const Error& e) {
      throw Error(std::string(e.what()) +
                  "; refusing to replace it (move it away or choose another --out)");
    }
    if (!j.is_object() || !j.contains("kind") || j.at("kind") != "arena-run")
      throw Error(jsonPath.string() +
                  ": not an arena results file; refusing to replace it (move it away or choose "
                  "another --out)");
  }

  const fs::path dbPath = runDir / "results.db";
  if (!fs::exists(dbPath, ec)) return lock;
  Db expected(":memory:", "schema", SQLITE_OPEN_READWRITE | SQLITE_OPEN_MEMORY);
  expected.exec(kDatabaseSchema);
  Db existing(dbPath, dbPath.string(), SQLITE_OPEN_READONLY);
  // quick_check reads every page: a truncated or garbage file fails here, not after the run.
  sqlite3_stmt* s = nullptr;
  std::string verdict;
  if (sqlite3_prepare_v2(existing.db, "PRAGMA quick_check", -1, &s, nullptr) != SQLITE_OK)
    existing.fail("not a usable SQLite database (garbage or truncated?)");
  int rc = sqlite3_step(s);
  if (rc == SQLITE_ROW) verdict = reinterpret_cast<const char*>(sqlite3_column_text(s, 0));
  sqlite3_finalize(s);
  if (rc != SQLITE_ROW) existing.fail("not a usable SQLite database (garbage or truncated?)");
  if (verdict != "ok") throw Error(dbPath.string() + ": damaged SQLite database: " + verdict);
  requireSchemaVersion(existing);
  auto want = expected.tables(), have = existing.tables();
  auto join = [](const std::vector<std::string>& v) {
    std::string text;
    for (const std::string& c : v) {
      if (!text.empty()) text += ", ";
      text += c;
    }
    return text;
  };
  if (have.empty()) return lock;  // an empty database file: the append creates the tables
  for (auto& [table, columns] : want) {
    auto it = have.find(table);
    if (it == have.end() && kTablesAddedLater.count(table)) continue;
    if (it == have.end() || it->second != columns)
      throw Error(dbPath.string() + ": another schema (table " + table + " has columns (" +
                  (it == have.end() ? std::string("missing") : join(it->second)) +
                  "), this arena writes (" + join(columns) +
                  ")); move it away or choose another --out");
  }
  return lock;
}

void commitResults(const fs::path& runDir, const json& results) {
  const fs::path jsonPath = runDir / "results.json", dbPath = runDir / "results.db";
  // A document its readers would refuse is never written: the model's own check, before any file.
  // Both forms are then written from the model.
  const RunResults run = RunResults::fromJson(results, jsonPath.string());
  const fs::path jsonTmp = temporaryPathFor(jsonPath), dbTmp = temporaryPathFor(dbPath);
  auto removeTemporaries = [&] {
    std::error_code ignored;
    fs::remove(jsonTmp, ignored);
    fs::remove(dbTmp, ignored);
    fs::remove(fs::path(dbTmp.string() + "-journal"), ignored);
  };
  try {
    writeFileBytes(jsonTmp, jsonText(run.toJson(), 1));
    std::error_code ec;
    if (fs::exists(dbPath)) {
      fs::copy_file(dbPath, dbTmp, ec);
      if (ec)
        throw Error(dbPath.string() + ": cannot copy to " + dbTmp.string() + ": " + ec.message());
    }
    appendToDatabase(dbTmp, run, dbPath.string());
    // Both complete: the database first, so results.json never names a run the database lacks.
    if (std::rename(dbTmp.c_str(), dbPath.c_str()) != 0)
      throw Error(osError(dbPath, "cannot replace", errno));
    if (std::rename(jsonTmp.c_str(), jsonPath.c_str()) != 0)
      throw Error(osError(jsonPath, "cannot replace", errno));
  } catch (...) {
    removeTemporaries();
    throw;
  }
  // The directory's images and results are one run's again.
  std::error_code ignored;
  fs::remove(runDir / kUnfinishedMarker, ignored);
}

}  // namespace arena
