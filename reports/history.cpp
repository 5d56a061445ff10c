#include "reports/history.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "metrics/results.hpp"
#include "metrics/summary_value.hpp"
#include "reports/report.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// A results database opened read-only; rows come back as JSON objects keyed by column name, so
// columns a newer schema adds (e.g. interval bounds) are read when present and not required.
class ReadOnlyDatabase {
 public:
  explicit ReadOnlyDatabase(const fs::path& file) : file_(file) {
    if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      sqlite3_close(db_);
      throw Error(file.string() + ": cannot open as an SQLite database");
    }
  }
  ~ReadOnlyDatabase() { sqlite3_close(db_); }
  ReadOnlyDatabase(const ReadOnlyDatabase&) = delete;
  ReadOnlyDatabase& operator=(const ReadOnlyDatabase&) = delete;

  std::vector<json> rows(const std::string& sql) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &st, nullptr) != SQLITE_OK)
      throw Error(file_.string() + ": not an arena results database (" + sqlite3_errmsg(db_) +
                  "); expected the tables runs, pairs and summaries that `arena run` writes");
    std::vector<json> out;
    int rc;
    while ((rc = sqlite3_step(st)) == SQLITE_ROW) {
      json row = json::object();
      for (int c = 0; c < sqlite3_column_count(st); ++c) {
        const std::string name = sqlite3_column_name(st, c);
        switch (sqlite3_column_type(st, c)) {
          case SQLITE_INTEGER:
            row[name] = sqlite3_column_int64(st, c);
            break;
          case SQLITE_FLOAT:
            row[name] = sqlite3_column_double(st, c);
            break;
          case SQLITE_TEXT:
            row[name] = std::string(reinterpret_cast<const char*>(sqlite3_column_text(st, c)));
            break;
          default:
            row[name] = nullptr;
        }
      }
      out.push_back(std::move(row));
    }
    sqlite3_finalize(st);
    if (rc != SQLITE_DONE) throw Error(file_.string() + ": " + sqlite3_errmsg(db_));
    return out;
  }

 private:
  fs::path file_;
  sqlite3* db_ = nullptr;
};

// A summary column pair that holds the 95% interval, whatever a schema calls it (ci95_lo/ci95_hi,
// ci_lo/ci_hi): the first column names containing "ci" and ending in lo / hi.
json intervalOf(const json& row) {
  json lo, hi;
  for (auto it = row.begin(); it != row.end(); ++it) {
    const std::string& k = it.key();
    if (k.find("ci") == std::string::npos || !it.value().is_number()) continue;
    if (k.size() > 2 && k.compare(k.size() - 2, 2, "lo") == 0 && lo.is_null()) lo = it.value();
    if (k.size() > 2 && k.compare(k.size() - 2, 2, "hi") == 0 && hi.is_null()) hi = it.value();
  }
  if (lo.is_null() || hi.is_null()) return nullptr;
  return {lo, hi};
}

std::vector<json> runsFromDatabase(const fs::path& file) {
  ReadOnlyDatabase db(file);
  std::map<long long, json> runs;
  std::vector<long long> order;
  for (json& r : db.rows("SELECT * FROM runs ORDER BY id")) {
    const long long id = r["id"];
    json environment = json::object();
    if (r["environment"].is_string())
      environment = json::parse(r["environment"].get<std::string>(), nullptr, false);
    if (environment.is_discarded() || !environment.is_object()) environment = json::object();
    if (r["git_commit"].is_string() && !r["git_commit"].get<std::string>().empty())
      environment["git_commit"] = r["git_commit"];
    runs[id] = {{"kind", "arena-run"},
                {"schema", r["schema"]},
                {"name", r.value("name", json("")).is_string() ? r["name"] : json("")},
                {"created", r["created"].is_string() ? r["created"] : json("")},
                {"environment", environment},
                {"source", file.string() + "#" + std::to_string(id)},
                {"pairs", json::array()}};
    order.push_back(id);
  }
  std::map<std::pair<long long, std::string>, size_t> pairIndex;  // (run, scene\nlabel) -> index
  for (const json& p : db.rows("SELECT * FROM pairs")) {
    const long long id = p["run_id"];
    if (!runs.count(id)) continue;
    json& pairs = runs[id]["pairs"];
    pairIndex[{id, p["scene"].get<std::string>() + "\n" + p["label"].get<std::string>()}] =
        pairs.size();
    json pair = {{"scene", p["scene"]},
                 {"denoiser", p["denoiser"]},
                 {"label", p["label"]},
                 {"status", p["status"]},
                 {"summary", json::object()}};
    if (p["error"].is_string() && !p["error"].get<std::string>().empty())
      pair["error"] = p["error"];
    pairs.push_back(pair);
  }
  for (const json& s : db.rows("SELECT * FROM summaries")) {
    const long long id = s["run_id"];
    auto it =
        pairIndex.find({id, s["scene"].get<std::string>() + "\n" + s["label"].get<std::string>()});
    if (it == pairIndex.end()) continue;
    json summary = json::object();
    for (const char* k : {"mean", "median", "p5", "p95"})
      if (s.contains(k) && s[k].is_number()) summary[k] = s[k];
    if (json ci = intervalOf(s); !ci.is_null()) summary["ci95"] = ci;
    // An absent summary keeps its reason (summaries.absent), so the dashboard can say it.
    if (s.contains("absent") && s["absent"].is_string() && !s["absent"].get<std::string>().empty())
      summary["absent"] = s["absent"];
    runs[id]["pairs"][it->second]["summary"][s["metric"].get<std::string>()] = summary;
  }
  std::vector<json> out;
  for (long long id : order) out.push_back(std::move(runs[id]));
  return out;
}

}  // namespace

std::vector<json> loadHistory(const std::vector<fs::path>& inputs) {
  if (inputs.empty()) throw Error("history: give run directories or results.db files");
  std::vector<json> runs;
  for (const fs::path& in : inputs) {
    if (fs::is_directory(in)) {
      json r = loadResults(in);
      r["source"] = in.string();
      runs.push_back(std::move(r));
    } else if (fs::is_regular_file(in)) {
      for (json& r : runsFromDatabase(in)) runs.push_back(std::move(r));
    } else {
      throw Error("history: " + in.string() +
                  ": no such run directory or results database (expected a directory with "
                  "results.json, or a results.db file)");
    }
  }
  std::stable_sort(runs.begin(), runs.end(), [](const json& a, const json& b) {
    return a.value("created", "") < b.value("created", "");
  });
  return runs;
}

json historyData(const std::vector<json>& runs, const std::vector<Tolerance>& tolerances) {
  json runList = json::array();
  for (const json& r : runs)
    runList.push_back({{"name", r.value("name", "")},
                       {"created", r.value("created", "")},
                       {"commit", r.value("environment", json::object()).value("git_commit", "")},
                       {"source", r.value("source", "")}});
  // Values per scene x label x metric, one slot per run (null where the run lacks it).
  json series = json::object();
  std::vector<std::string> metrics;
  json absent = json::array();  // {run, line}: the summaries a run has no mean for, and why
  for (size_t i = 0; i < runs.size(); ++i) {
    for (const std::string& line : absentSummaryLines(runs[i]))
      absent.push_back({{"run", i}, {"line", line}});
    for (const json& p : runs[i]["pairs"]) {
      if (p.value("status", "") != "ok" || !p.contains("summary")) continue;
      for (auto it = p["summary"].begin(); it != p["summary"].end(); ++it) {
        const SummaryMean mean = summaryMean(p, it.key());
        if (!mean.present()) continue;
        if (std::find(metrics.begin(), metrics.end(), it.key()) == metrics.end())
          metrics.push_back(it.key());
        json& s = series[p["scene"].get<std::string>()][p["label"].get<std::string>()][it.key()];
        if (s.is_null()) s = {{"value", json(runs.size(), nullptr)}};
        s["value"][i] = mean.mean;
        if (it.value().contains("ci95") && it.value()["ci95"].is_array()) {
          if (!s.contains("ci95")) s["ci95"] = json(runs.size(), nullptr);
          s["ci95"][i] = it.value()["ci95"];
        }
      }
    }
  }
  // The gate: exactly what `arena compare previous current` decides, run by run. `changes` keeps
  // every verdict other than "ok" (improved, beyond tolerance but not resolved, ...) with `fails`:
  // whether compare's own rule makes the gate fail on it.
  json changes = json::array();
  json gated = json::object();
  size_t failing = 0;
  for (size_t i = 1; i < runs.size(); ++i)
    for (const ComparisonRow& row : compareRuns(runs[i - 1], runs[i], tolerances)) {
      if (row.tolerance > 0) gated[row.metric] = row.tolerance;
      if (row.verdict == "ok") continue;
      json change = comparisonJson({row})[0];
      change["run"] = i;
      change["fails"] = anyRegression({row});
      failing += change["fails"].get<bool>();
      changes.push_back(change);
    }
  json metricList = json::array();
  for (const MetricDefinition* m : metricCatalog())
    if (std::find(metrics.begin(), metrics.end(), m->name) != metrics.end())
      metricList.push_back({{"name", m->name},
                            {"lowerIsBetter", m->lowerIsBetter()},
                            {"meaning", m->description},
                            {"tolerance", gated.contains(m->name) ? gated[m->name] : json(nullptr)}});
  return {{"generator", "arena history"}, {"runs", runList},
          {"metrics", metricList},        {"series", series},
          {"changes", changes},           {"failing", failing},
          {"absent", absent}};
}

HistorySummary writeHistory(const HistoryOptions& o) {
  if (o.out.empty()) throw Error("history: --out is required");
  const fs::path web = o.webDir.empty() ? ReportOptions::defaultWebDir() : o.webDir;
  const fs::path modules =
      o.nodeModulesDir.empty() ? ReportOptions::defaultNodeModulesDir() : o.nodeModulesDir;
  const std::vector<PageFile> files = {{"history.html", "index.html"},
                                       {"style.css", "style.css"},
                                       {"shared.js", "shared.js"},
                                       {"history.js", "history.js"}};
  checkPageAssets(web, modules, files);
  const json data = historyData(loadHistory(o.inputs), o.tolerances);
  copyPageAssets(web, modules, files, o.out);
  writeTextAtomically(o.out / "history-data.js",
                      "// Generated by `arena history`; read by history.js.\n"
                      "window.ARENA_HISTORY = " +
                          data.dump() + ";\n");
  HistorySummary summary{o.out / "index.html", data["runs"].size(), data["failing"].get<size_t>(), {}};
  for (const json& a : data["absent"])
    summary.absentSummaries.push_back(data["runs"][a["run"].get<size_t>()]["name"].get<std::string>() +
                                      ": " + a["line"].get<std::string>());
  return summary;
}

}  // namespace arena
