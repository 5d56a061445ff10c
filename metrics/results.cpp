#include "metrics/results.hpp"

#include <sqlite3.h>

#include <cmath>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "metrics/statistics.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

const std::vector<MetricInfo>& metricCatalog() {
  static const std::vector<MetricInfo> metrics = {
      {"relMse", true, "relative MSE vs the reference, eps 0.01 (raw)"},
      {"relMseCorrected", true, "relMSE minus the reference's own noise term"},
      {"mse", true, "MSE, linear"},
      {"rmse", true, "RMSE, linear"},
      {"psnr", false, "PSNR of the display image, dB (capped at 100)"},
      {"ssim", false, "SSIM of display luminance (11x11 Gaussian, sigma 1.5)"},
      {"ldrFlip", true, "mean LDR-FLIP of the display image, 67 ppd"},
      {"hdrFlip", true, "mean HDR-FLIP of the linear image, 67 ppd"},
      {"tRmae", true, "temporal relative MAE vs the reference's frame difference (no /3)"},
      {"tPsnr", false, "temporal PSNR of display frame differences, dB"},
      {"warpedFlicker", true, "motion-compensated flicker of the error e = d - r"},
      {"effectiveSpp", false, "samples plain accumulation would need for the same relMSE"},
      {"ms", true, "wall time of the denoiser per frame (both signals), ms"},
  };
  return metrics;
}

const MetricInfo* findMetric(const std::string& name) {
  for (const MetricInfo& m : metricCatalog())
    if (name == m.name) return &m;
  return nullptr;
}

json loadResults(const fs::path& runDir) {
  fs::path file = runDir / "results.json";
  if (!fs::exists(runDir)) throw Error(runDir.string() + ": no such run directory");
  if (!fs::exists(file)) throw Error(runDir.string() + ": not a run (no results.json); create one with `arena run`");
  json j = parseJsonFile(file.string());
  if (!j.is_object() || j.value("kind", "") != "arena-run")
    throw Error(file.string() + ": not an arena results file");
  int schema = j.value("schema", 0);
  if (schema != kResultsSchemaVersion)
    throw Error(file.string() + ": results schema version " + std::to_string(schema) + ", this arena reads version " +
                std::to_string(kResultsSchemaVersion) + " (re-run with this version)");
  return j;
}

void saveResults(const fs::path& runDir, const json& results) {
  fs::create_directories(runDir);
  writeTextAtomically(runDir / "results.json", results.dump(1));
}

namespace {

struct Db {
  sqlite3* db = nullptr;
  explicit Db(const fs::path& p) {
    if (sqlite3_open(p.c_str(), &db) != SQLITE_OK) throw Error(p.string() + ": cannot open SQLite database");
  }
  ~Db() { sqlite3_close(db); }
  void exec(const std::string& sql) {
    char* err = nullptr;
    if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
      std::string msg = err ? err : "?";
      sqlite3_free(err);
      throw Error("SQLite: " + msg);
    }
  }
};

struct Statement {
  sqlite3_stmt* s = nullptr;
  Statement(sqlite3* db, const char* sql) {
    if (sqlite3_prepare_v2(db, sql, -1, &s, nullptr) != SQLITE_OK) throw Error(std::string("SQLite: ") + sqlite3_errmsg(db));
  }
  ~Statement() { sqlite3_finalize(s); }
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
    if (sqlite3_step(s) != SQLITE_DONE) throw Error(std::string("SQLite: ") + sqlite3_errmsg(sqlite3_db_handle(s)));
    sqlite3_reset(s);
    sqlite3_clear_bindings(s);
  }
};

}  // namespace

namespace {

int userVersion(sqlite3* db) {
  sqlite3_stmt* s = nullptr;
  int v = -1;
  if (sqlite3_prepare_v2(db, "PRAGMA user_version", -1, &s, nullptr) == SQLITE_OK && sqlite3_step(s) == SQLITE_ROW)
    v = sqlite3_column_int(s, 0);
  sqlite3_finalize(s);
  return v;
}

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

double ciBound(const json& summary, int i) {
  if (!summary.contains("ci95") || !summary["ci95"].is_array()) return kUndefined;
  return summary["ci95"][size_t(i)].get<double>();
}

}  // namespace

void appendToDatabase(const fs::path& dbPath, const json& r) {
  Db db(dbPath);
  // The database's schema follows the results schema; one of another version is never mixed in.
  const int version = userVersion(db.db);
  if (version != kResultsSchemaVersion && (version != 0 || hasTable(db.db, "runs")))
    throw Error(dbPath.string() + ": a results database of schema version " + std::to_string(version) +
                ", this arena writes version " + std::to_string(kResultsSchemaVersion) +
                "; move it away or write the run elsewhere");
  db.exec("PRAGMA user_version = " + std::to_string(kResultsSchemaVersion));
  db.exec(R"(CREATE TABLE IF NOT EXISTS runs (id INTEGER PRIMARY KEY, name TEXT, created TEXT, git_commit TEXT,
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
               value REAL, ci_lo REAL, ci_hi REAL, tied_with TEXT);)");
  db.exec("BEGIN");
  Statement run(db.db, "INSERT INTO runs (name, created, git_commit, schema, environment, settings) VALUES (?,?,?,?,?,?)");
  run.text(1, r.value("name", "")).text(2, r.value("created", ""))
      .text(3, r["environment"].value("git_commit", "")).integer(4, r.value("schema", 0))
      .text(5, r["environment"].dump()).text(6, r["settings"].dump())
      .step();
  const long long runId = sqlite3_last_insert_rowid(db.db);
  Statement pair(db.db, "INSERT INTO pairs VALUES (?,?,?,?,?,?,?)");
  Statement frame(db.db, "INSERT INTO frame_metrics VALUES (?,?,?,?,?,?)");
  Statement summary(db.db, "INSERT INTO summaries VALUES (?,?,?,?,?,?,?,?,?,?,?,?)");
  for (const json& p : r["pairs"]) {
    const std::string scene = p["scene"], label = p["label"];
    pair.integer(1, runId).text(2, scene).text(3, p["denoiser"]).text(4, label).text(5, p["params"].dump())
        .text(6, p["status"]).text(7, p.value("error", "")).step();
    if (p["status"] != "ok") continue;
    for (const json& f : p["frames"])
      for (auto it = f.begin(); it != f.end(); ++it)
        if (it.key() != "frame" && it.value().is_number())
          frame.integer(1, runId).text(2, scene).text(3, label).integer(4, f["frame"].get<int>()).text(5, it.key())
              .real(6, it.value().get<double>()).step();
    for (auto it = p["summary"].begin(); it != p["summary"].end(); ++it) {
      const json& v = it.value();
      auto real = [&](const char* k) { return v.contains(k) && v[k].is_number() ? v[k].get<double>() : kUndefined; };
      summary.integer(1, runId).text(2, scene).text(3, label).text(4, it.key()).real(5, real("mean"))
          .real(6, real("median")).real(7, real("p5")).real(8, real("p95")).real(9, ciBound(v, 0))
          .real(10, ciBound(v, 1)).integer(11, v.value("frames", 0)).text(12, v.value("absent", "")).step();
    }
  }
  if (r.contains("statistics")) {
    Statement paired(db.db, "INSERT INTO paired VALUES (?,?,?,?,?,?,?,?,?)");
    Statement rank(db.db, "INSERT INTO rankings VALUES (?,?,?,?,?,?,?,?,?)");
    auto addRanking = [&](const std::string& scene, const std::string& metric, const json& ranking, const char* value) {
      for (const json& m : ranking)
        rank.integer(1, runId).text(2, scene).text(3, metric).text(4, m["label"]).integer(5, m["rank"])
            .real(6, m[value]).real(7, ciBound(m, 0)).real(8, ciBound(m, 1)).text(9, m["tiedWith"].dump()).step();
    };
    auto addScene = [&](const std::string& scene, const json& s) {
      addRanking(scene, s["metric"], s["ranking"], "mean");
      for (const json& x : s["pairs"])
        paired.integer(1, runId).text(2, scene).text(3, s["metric"]).text(4, x["a"]).text(5, x["b"]).real(6, x["diff"])
            .real(7, ciBound(x, 0)).real(8, ciBound(x, 1)).integer(9, x["resolved"].get<bool>()).step();
    };
    for (auto it = r["statistics"]["scenes"].begin(); it != r["statistics"]["scenes"].end(); ++it) {
      addScene(it.key(), it.value());
      for (auto m = it.value()["byMetric"].begin(); m != it.value()["byMetric"].end(); ++m) addScene(it.key(), m.value());
    }
    if (r["statistics"].contains("overall"))
      addRanking("*", r["statistics"]["rankedOn"], r["statistics"]["overall"]["ranking"], "score");
  }
  db.exec("COMMIT");
}

}  // namespace arena
