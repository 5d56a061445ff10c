#include "metrics/results.hpp"

#include <sqlite3.h>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"

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
    sqlite3_bind_double(s, i, v);
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

void appendToDatabase(const fs::path& dbPath, const json& r) {
  Db db(dbPath);
  db.exec(R"(CREATE TABLE IF NOT EXISTS runs (id INTEGER PRIMARY KEY, name TEXT, created TEXT, git_commit TEXT,
               schema INTEGER, environment TEXT, settings TEXT);
             CREATE TABLE IF NOT EXISTS pairs (run_id INTEGER, scene TEXT, denoiser TEXT, label TEXT, params TEXT,
               status TEXT, error TEXT);
             CREATE TABLE IF NOT EXISTS frame_metrics (run_id INTEGER, scene TEXT, label TEXT, frame INTEGER,
               metric TEXT, value REAL);
             CREATE TABLE IF NOT EXISTS summaries (run_id INTEGER, scene TEXT, label TEXT, metric TEXT, mean REAL,
               median REAL, p5 REAL, p95 REAL);)");
  db.exec("BEGIN");
  Statement run(db.db, "INSERT INTO runs (name, created, git_commit, schema, environment, settings) VALUES (?,?,?,?,?,?)");
  run.text(1, r.value("name", "")).text(2, r.value("created", ""))
      .text(3, r["environment"].value("git_commit", "")).integer(4, r.value("schema", 0))
      .text(5, r["environment"].dump()).text(6, r["settings"].dump())
      .step();
  const long long runId = sqlite3_last_insert_rowid(db.db);
  Statement pair(db.db, "INSERT INTO pairs VALUES (?,?,?,?,?,?,?)");
  Statement frame(db.db, "INSERT INTO frame_metrics VALUES (?,?,?,?,?,?)");
  Statement summary(db.db, "INSERT INTO summaries VALUES (?,?,?,?,?,?,?,?)");
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
    for (auto it = p["summary"].begin(); it != p["summary"].end(); ++it)
      summary.integer(1, runId).text(2, scene).text(3, label).text(4, it.key()).real(5, it.value()["mean"])
          .real(6, it.value()["median"]).real(7, it.value()["p5"]).real(8, it.value()["p95"]).step();
  }
  db.exec("COMMIT");
}

}  // namespace arena
