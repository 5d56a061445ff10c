#include "reports/history.hpp"

#include <sqlite3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>

#include "core/atomic_file.hpp"
#include "core/env_info.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/text.hpp"
#include "metrics/ghosting_intervals.hpp"
#include "metrics/results.hpp"
#include "reports/report.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// A run as the gate's messages name it: "the run nightly of 2026-12-01T10:00:00Z".
std::string runDescription(const RunResults& r) {
  return "the run " + (r.name.empty() ? std::string("(unnamed)") : r.name) +
         (r.created.empty() ? std::string() : " of " + r.created);
}

// A results database opened read-only; rows come back as JSON objects keyed by column name, so
// columns a newer schema adds (e.g. interval bounds) are read when present and not required.
class ReadOnlyDatabase {
 public:
  explicit ReadOnlyDatabase(const fs::path& file) : file_(file) {
    if (sqlite3_open_v2(file.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      sqlite3_close(db_);
      throw Error(file.string() + ": cannot open as an SQLite database");
    }
    // Another schema's tables could be read as if they were this one's: refused, as `arena run`
    // refuses to append to one (a database of no schema, user_version 0, is not arena's).
    const int version = databaseSchemaVersion(db_);
    if (version != kResultsSchemaVersion) {
      const std::string why = sqlite3_errmsg(db_);
      sqlite3_close(db_);
      throw Error(file.string() + ": " +
                  (version < 0 ? "not an SQLite database (" + why + ")"
                   : version == 0
                       ? std::string("not an arena results database (no schema version)")
                       : "a results database of schema version " + std::to_string(version)) +
                  "; this arena reads version " + std::to_string(kResultsSchemaVersion) +
                  " (the results.db that `arena run` writes)");
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
Interval intervalOf(const json& row) {
  json lo, hi;
  for (auto it = row.begin(); it != row.end(); ++it) {
    const std::string& k = it.key();
    if (k.find("ci") == std::string::npos || !it.value().is_number()) continue;
    if (k.size() > 2 && k.compare(k.size() - 2, 2, "lo") == 0 && lo.is_null()) lo = it.value();
    if (k.size() > 2 && k.compare(k.size() - 2, 2, "hi") == 0 && hi.is_null()) hi = it.value();
  }
  if (lo.is_null() || hi.is_null()) return {};
  return {lo.get<double>(), hi.get<double>()};
}

std::string textOf(const json& row, const char* column) {
  return row.contains(column) && row[column].is_string() ? row[column].get<std::string>() : "";
}

std::vector<RunResults> runsFromDatabase(const fs::path& file) {
  ReadOnlyDatabase db(file);
  std::map<long long, RunResults> runs;
  std::vector<long long> order;
  for (json& r : db.rows("SELECT * FROM runs ORDER BY id")) {
    const long long id = r["id"];
    RunResults& run = runs[id];
    if (r["environment"].is_string())
      run.environment = json::parse(r["environment"].get<std::string>(), nullptr, false);
    if (run.environment.is_discarded() || !run.environment.is_object()) run.environment = json::object();
    if (!textOf(r, "git_commit").empty()) run.environment["git_commit"] = r["git_commit"];
    run.name = textOf(r, "name");
    run.created = textOf(r, "created");
    run.source = file.string() + "#" + std::to_string(id);
    if (!isUtcTimestamp(run.created))
      throw Error(run.source +
                  ": runs.created: expected a UTC time as 2026-11-28T21:15:00Z (runs are "
                  "ordered by it), got \"" +
                  run.created + "\"");
    run.keepsTiles = false;
    // The settings the run recorded (its gate compares them); a database row without them (or
    // with a record of another shape) leaves them unknown, and the history does not judge them.
    // A record that is no JSON at all was damaged: said, not read as "no settings".
    const std::string settingsText = textOf(r, "settings");
    const json settings = json::parse(settingsText, nullptr, false);
    if (!settingsText.empty() && settings.is_discarded())
      throw Error(run.source + ": runs.settings: expected the run's settings as JSON, got " +
                  quotedText(utf8Excerpt(settingsText, 60, false)) +
                  " (the database was edited or damaged)");
    if (settings.is_object()) try {
        run.settings = RunSettings::fromJson(settings, run.source, "$.settings");
      } catch (const Error&) {
      }
    order.push_back(id);
  }
  // Each scene's size and length (the gate compares them); a database written before the table
  // existed has none, and then only the settings are compared.
  if (!db.rows("SELECT name FROM sqlite_master WHERE type = 'table' AND name = 'scenes'").empty())
    for (const json& s : db.rows("SELECT * FROM scenes")) {
      const long long id = s["run_id"];
      if (!runs.count(id)) continue;
      json& facts = runs[id].scenes[textOf(s, "scene")];
      facts = json::object();
      for (const char* k : {"width", "height", "frames"})
        if (s.contains(k) && s[k].is_number_integer()) facts[k] = s[k];
    }
  std::map<std::pair<long long, std::string>, size_t> pairIndex;  // (run, scene\nlabel) -> index
  for (const json& p : db.rows("SELECT * FROM pairs")) {
    const long long id = p["run_id"];
    if (!runs.count(id)) continue;
    std::vector<PairResult>& pairs = runs[id].pairs;
    PairResult pair;
    pair.scene = textOf(p, "scene");
    pair.denoiser = textOf(p, "denoiser");
    pair.label = textOf(p, "label");
    pair.status = textOf(p, "status");
    pair.error = textOf(p, "error");
    if (!pairIndex.emplace(std::pair{id, pair.scene + "\n" + pair.label}, pairs.size()).second)
      throw Error(runs[id].source + ": pairs: " + pair.label + " on " + pair.scene +
                  " is listed twice (the database was edited or damaged)");
    pairs.push_back(std::move(pair));
  }
  for (const json& s : db.rows("SELECT * FROM summaries")) {
    const long long id = s["run_id"];
    auto it = pairIndex.find({id, textOf(s, "scene") + "\n" + textOf(s, "label")});
    if (it == pairIndex.end()) continue;
    MetricSummary summary;
    auto number = [&](const char* k) { return s.contains(k) && s[k].is_number() ? s[k].get<double>() : kUndefined; };
    summary.mean = number("mean");
    summary.median = number("median");
    summary.p5 = number("p5");
    summary.p95 = number("p95");
    if (s.contains("frames") && s["frames"].is_number_integer()) summary.frames = s["frames"].get<int>();
    summary.ci95 = intervalOf(s);
    // Checked as a results.json's summaries are (metrics/run_results): an edited or damaged row
    // names its run, pair and metric rather than reach the dashboard.
    const std::string where = runs[id].source + ": summaries, " + textOf(s, "label") + " on " +
                              textOf(s, "scene") + ", " + textOf(s, "metric");
    if (summary.frames < 0)
      throw Error(where + ": frames " + std::to_string(summary.frames) +
                  ": expected a count of frames (0 or more)");
    if (summary.frames == 0 && (std::isfinite(summary.mean) || summary.ci95.valid()))
      throw Error(where + ": a summary of 0 frames holds a value (" +
                  (std::isfinite(summary.mean) ? "mean " + shortestText(summary.mean)
                                               : "interval [" + shortestText(summary.ci95.lo) +
                                                     ", " + shortestText(summary.ci95.hi) + "]") +
                  "): a run writes none there (the database was edited or damaged)");
    if (summary.ci95.lo > summary.ci95.hi)
      throw Error(where + ": the interval [" + shortestText(summary.ci95.lo) + ", " +
                  shortestText(summary.ci95.hi) +
                  "] has its ends swapped (the database was edited or damaged)");
    // An absent summary keeps its reason (summaries.absent), so the dashboard can say it.
    summary.absent = textOf(s, "absent");
    if (!runs[id].pairs[it->second].summary.emplace(textOf(s, "metric"), summary).second)
      throw Error(where + ": listed twice (the database was edited or damaged)");
  }
  std::vector<RunResults> out;
  if (order.empty()) throw Error(file.string() + ": holds no runs (nothing to chart or gate)");
  for (long long id : order) out.push_back(std::move(runs[id]));
  return out;
}

// One `--match A=B` of a history: the labels as the runs wrote them.
struct LabelMatch {
  std::string assignment, from, to;
};

std::set<std::string> labelsOf(const RunResults& run) {
  std::set<std::string> labels;
  for (const PairResult& p : run.pairs) labels.insert(p.label);
  return labels;
}

// Every label any of the runs has.
std::set<std::string> labelsOf(const std::vector<RunResults>& runs) {
  std::set<std::string> all;
  for (const RunResults& r : runs) {
    const std::set<std::string> labels = labelsOf(r);
    all.insert(labels.begin(), labels.end());
  }
  return all;
}

// A history's --match assignments read: each label as the runs wrote it (a number typed otherwise
// names the same label), one some run has, and each matched once; Errors name the assignment.
std::vector<LabelMatch> historyMatches(const std::vector<std::string>& assignments,
                                       const std::set<std::string>& all) {
  std::vector<LabelMatch> matches;
  std::set<std::string> froms, tos;
  for (const std::string& a : assignments) {
    auto [from, to] = splitLabelMatch(a);
    if (const std::string label = labelAsWritten(all, from); !label.empty()) from = label;
    if (const std::string label = labelAsWritten(all, to); !label.empty()) to = label;
    for (const std::string* label : {&from, &to})
      if (!all.count(*label))
        throw Error("history: --match " + a + ": no run has a pair labelled " + *label +
                    " (their labels: " + labelList(all) + ")");
    if (from == to)
      throw Error("history: --match " + a + ": matches " + from +
                  " with itself; a label is matched with itself already");
    bool again = false;  // the same match given twice: one match
    for (const LabelMatch& m : matches) again = again || (m.from == from && m.to == to);
    if (again) continue;
    if (!froms.insert(from).second)
      throw Error("history: --match " + a + ": " + from + " is matched twice");
    if (!tos.insert(to).second)
      throw Error("history: --match " + a + ": " + to + " is matched twice");
    matches.push_back({a, from, to});
  }
  return matches;
}

// The matches checked against the runs the gate reads (after --denoisers): the labels a chain of
// matches joins (A=B, B=C) are one series, so no run may hold two of them (its two contenders would
// be one point); and each match is met where the gate uses it, a run with its first label followed
// by one with its second. Errors name the assignment and the runs each label is in.
void requireMatchesMet(const std::vector<LabelMatch>& matches, const std::vector<RunResults>& runs,
                       bool filtered) {
  std::vector<std::set<std::string>> byRun;
  for (const RunResults& r : runs) byRun.push_back(labelsOf(r));
  const auto where = [&](const std::string& label) {  // "0, 1" (0 the oldest), or "none"
    std::string list;
    for (size_t i = 0; i < byRun.size(); ++i)
      if (byRun[i].count(label)) list += (list.empty() ? "" : ", ") + std::to_string(i);
    return list.empty() ? std::string("none") : list;
  };
  for (const LabelMatch& m : matches) {
    // The labels joined with this match's, through the others.
    std::set<std::string> joined = {m.from, m.to};
    for (bool grew = true; grew;) {
      grew = false;
      for (const LabelMatch& o : matches)
        if ((joined.count(o.from) || joined.count(o.to)) &&
            !(joined.count(o.from) && joined.count(o.to))) {
          joined.insert({o.from, o.to});
          grew = true;
        }
    }
    // The assignments that join them, as typed, for the message: a clash through a chain (A=B,
    // B=C, and a run with A and C) is the chain's, not A=B's alone.
    std::string chain;
    size_t links = 0;
    for (const LabelMatch& o : matches)
      if (joined.count(o.from)) chain += (links++ ? " and --match " : "--match ") + o.assignment;
    for (size_t i = 0; i < byRun.size(); ++i) {
      std::set<std::string> both;
      for (const std::string& label : joined)
        if (byRun[i].count(label)) both.insert(label);
      if (both.size() > 1)
        throw Error(
            "history: " + chain +
            (links > 1 ? ": together they make " + labelList(joined) + " one series, but" : ":") +
            " run " + std::to_string(i) + " (" + runs[i].source + ") has pairs labelled " +
            labelList(both) +
            ": a run's two contenders cannot be one series (compare that run's pairs by "
            "their labels, or leave it out of the history)");
    }
    if (filtered && where(m.from) == "none" && where(m.to) == "none")
      throw Error("history: --match " + m.assignment +
                  ": --denoisers keeps neither label; name one of them with --denoisers, or "
                  "leave this --match out");
    bool met = false;
    for (size_t i = 1; i < runs.size() && !met; ++i)
      met = byRun[i - 1].count(m.from) && byRun[i].count(m.to);
    if (!met)
      throw Error("history: --match " + m.assignment + ": no run with a pair labelled " + m.from +
                  " is followed by one with " + m.to +
                  " (the history compares each run with the one before; " + m.from +
                  " is in runs " + where(m.from) + ", " + m.to + " in runs " + where(m.to) +
                  ", 0 the oldest)");
  }
}

}  // namespace

std::vector<RunResults> loadHistory(const std::vector<fs::path>& inputs,
                                    std::vector<std::string>* warnings) {
  if (inputs.empty()) throw Error("history: give run directories or results.db files");
  std::vector<RunResults> runs;
  for (const fs::path& in : inputs) {
    if (fs::is_directory(in)) {
      runs.push_back(loadResults(in));
      runs.back().source = in.string();
      if (const std::string note = unfinishedRunNote(in); !note.empty() && warnings)
        warnings->push_back(note +
                            "; the dashboard shows the earlier run's numbers, which are whole");
    } else if (fs::is_regular_file(in)) {
      // A database a run is appending to (its directory's writer holds the lock) is refused, as
      // a run directory being written is: the dashboard would miss the run.
      const DirectoryLock reading(fs::absolute(in).parent_path(), DirectoryLock::Mode::Shared,
                                  DirectoryLock::IfHeld::Refuse, "reading its results.db",
                                  /*createFile=*/false);
      for (RunResults& r : runsFromDatabase(in)) runs.push_back(std::move(r));
    } else {
      throw Error("history: " + in.string() +
                  ": no such run directory or results database (expected a directory with "
                  "results.json, or a results.db file)");
    }
  }
  // The history is in the order the runs were made: a run that does not say when it was made
  // cannot be placed (and would be gated against the wrong neighbour).
  for (const RunResults& r : runs)
    if (r.created.empty())
      throw Error("history: " + r.source +
                  ": the run records no `created` time; the history orders runs by it");
  std::stable_sort(runs.begin(), runs.end(),
                   [](const RunResults& a, const RunResults& b) { return a.created < b.created; });
  const auto sameRun = sameRunRecord;
  // A run given twice (a path twice, a run directory and the results.db it appended to, two copies
  // of a database) would be compared with itself, and the gate pass on it: it is taken once, from
  // its run directory where there is one (the directory keeps the tiles the gate resolves with).
  std::vector<RunResults> distinct;
  for (RunResults& r : runs) {
    auto same = std::find_if(distinct.begin(), distinct.end(),
                             [&](const RunResults& d) { return sameRun(d, r); });
    if (same == distinct.end()) {
      distinct.push_back(std::move(r));
      continue;
    }
    // A run directory and the database it appended to are one run by design; two copies of one
    // kind (a directory copied, a database given twice) are said.
    if (warnings && same->keepsTiles == r.keepsTiles)
      warnings->push_back(r.source + " holds the same run as " + same->source + " (name " + r.name +
                          ", created " + r.created + "): taken once");
    if (!same->keepsTiles && r.keepsTiles) *same = std::move(r);
  }
  // Two runs made in the same second (`created` has one-second resolution) keep the order they
  // were given in, which a shell's `ls` of commit-named folders does not make the commits' order:
  // every change between them would flip its sign. Said.
  for (size_t i = 1; i < distinct.size() && warnings; ++i)
    if (distinct[i].created == distinct[i - 1].created)
      warnings->push_back(distinct[i - 1].source + " and " + distinct[i].source +
                          " were created in the same second (" + distinct[i].created +
                          "): the history keeps them in the order given, so give them in the order "
                          "they were made (or their changes read reversed)");
  return distinct;
}

json historyData(std::vector<RunResults> runs, const Gate& gate) {
  std::vector<Tolerance> tolerances = gate.tolerances;
  std::vector<std::string> contenders = gate.contenders;
  const BootstrapConfig& bootstrap = gate.bootstrap;
  const Correction correction = gate.correction;
  // --match: a contender relabelled on purpose between two runs (a parameter changed in the
  // command CI runs) is one series, and its two labels are compared where one follows the other.
  const std::set<std::string> all = labelsOf(runs);
  const std::vector<LabelMatch> labelMatches = historyMatches(gate.matches, all);
  // --denoisers: only the named contenders' pairs; a name no run has is a mistake.
  if (!contenders.empty()) {
    for (std::string& name : contenders) {
      // A label typed otherwise than the runs wrote it names theirs, as with --match.
      if (const std::string label = labelAsWritten(all, name); !label.empty()) name = label;
      if (std::none_of(runs.begin(), runs.end(), [&](const RunResults& r) {
            return std::any_of(r.pairs.begin(), r.pairs.end(),
                               [&](const PairResult& p) { return isContender(p, {name}); });
          }))
        throw Error(
            "history: --denoisers " + name +
            ": no run has a pair of that label or denoiser (their labels: " + labelList(all) + ")");
    }
    // A matched pair of labels is one contender: naming either keeps both (a chain's all).
    std::map<std::string, std::string> pairs;
    for (const LabelMatch& m : labelMatches) pairs[m.from] = m.to;
    contenders = withMatchedLabels(std::move(contenders), pairs);
    for (RunResults& r : runs)
      std::erase_if(r.pairs, [&](const PairResult& p) { return !isContender(p, contenders); });
  }
  requireMatchesMet(labelMatches, runs, !contenders.empty());
  // Runs over months differ in what they computed: a gated metric is compared where both have it.
  // One the caller named that no run computed at all is a mistake (`--metric ldrFlip` on runs of
  // --flip none), an error as in `arena compare`, not a page of "nothing compared".
  tolerances = gateTolerances(std::move(tolerances));
  for (Tolerance& t : tolerances) {
    // An event figure (--metric ghosting.lagEnergy) is kept with each pair's events in a run
    // directory; results.db ranks them but keeps none per pair.
    const bool event = isGatedEventFigure(t.metric);
    const bool cut = event && t.metric.rfind("cut.", 0) == 0;
    const bool computed = std::any_of(runs.begin(), runs.end(), [&](const RunResults& r) {
      return std::any_of(r.pairs.begin(), r.pairs.end(), [&](const PairResult& p) {
        if (!p.ok()) return false;
        if (!event) return p.mean(t.metric).computed;
        const json& events = p.part(cut ? "cuts" : "ghosting");
        return events.is_array() && !events.empty();
      });
    });
    const bool fromDatabase =
        std::any_of(runs.begin(), runs.end(), [](const RunResults& r) { return !r.keepsTiles; });
    if (!t.optional && !computed)
      throw Error(
          "history: --metric " + t.metric + ": no run computed it (nothing to gate on; " +
          (event ? std::string("an event figure is measured on scenes with scripted events or "
                               "camera cuts, and kept in run directories") +
                       (fromDatabase ? ": results.db keeps none, give `arena history` the run "
                                       "directories (their results.json)"
                                     : "") +
                       ")"
                 : std::string("`arena metrics` says what each metric needs, e.g. FLIP's --flip "
                               "setting)")));
    t.optional = true;
  }
  json runList = json::array();
  for (const RunResults& r : runs)
    runList.push_back({{"name", r.name},
                       {"created", r.created},
                       {"commit", r.environment.value("git_commit", "")},
                       {"revision", r.environment.value("revision", "")},
                       {"source", r.source}});
  // Values per scene x label x metric, one slot per run (null where the run lacks it).
  json series = json::object();
  std::vector<std::string> metrics;
  json absent = json::array();  // {run, line}: the summaries a run has no mean for, and why
  // A contender whose label changed between runs (labels were once written as typed,
  // "svgf[sigmaL=2.0]"; a default named explicitly, "svgf[iterations=5]", is svgf) stays one
  // series, under its first label, as `arena compare` matches it: by denoiser and resolved
  // parameters, where exactly one series of the scene ran that and the run has no pair under that
  // series' label.
  std::map<std::string, std::map<std::string, std::pair<std::string, json>>>
      ran;  // scene -> label -> (denoiser, params)
  // scene -> label -> the series its values last went to (a --match target joins its match's).
  std::map<std::string, std::map<std::string, std::string>> seriesOfLabel;
  auto seriesLabel = [&](const RunResults& run, const PairResult& p) {
    // --match A=B: B's values join A's series in a run without A.
    for (const LabelMatch& m : labelMatches)
      if (m.to == p.label && std::none_of(run.pairs.begin(), run.pairs.end(),
                                          [&](const PairResult& q) { return q.label == m.from; }))
        if (auto it = seriesOfLabel[p.scene].find(m.from); it != seriesOfLabel[p.scene].end())
          return it->second;
    auto& labels = ran[p.scene];
    if (labels.count(p.label) || p.params.empty()) return p.label;
    std::string match;
    int matches = 0;
    for (const auto& [label, what] : labels)
      if (what.first == p.denoiser && what.second == p.params &&
          std::none_of(run.pairs.begin(), run.pairs.end(),
                       [&p, &name = label](const PairResult& q) {
                         return q.scene == p.scene && q.label == name;
                       }))
        match = label, ++matches;
    if (matches != 1) return p.label;
    // Another pair of the run that ran the same (two labels for one contender): no alias, or the
    // two would overwrite each other's value.
    const auto sameRun =
        std::count_if(run.pairs.begin(), run.pairs.end(), [&](const PairResult& q) {
          return q.scene == p.scene && q.denoiser == p.denoiser && q.params == p.params;
        });
    return sameRun == 1 ? match : p.label;
  };
  // Run i's (scene, pair label) -> the series its values went to: the gate's rows name the pair's
  // own label, the page's flags the series.
  std::vector<std::map<std::pair<std::string, std::string>, std::string>> seriesOf(runs.size());
  for (size_t i = 0; i < runs.size(); ++i) {
    for (const std::string& line : absentSummaryLines(runs[i]))
      absent.push_back({{"run", i}, {"line", line}});
    for (const PairResult& p : runs[i].pairs) {
      if (!p.ok()) continue;
      const std::string label = seriesLabel(runs[i], p);
      ran[p.scene].emplace(label, std::make_pair(p.denoiser, p.params));
      seriesOf[i][{p.scene, p.label}] = label;
      seriesOfLabel[p.scene][p.label] = label;
      if (label != p.label) {
        json& aliases = series[p.scene][label]["aliases"];
        if (std::find(aliases.begin(), aliases.end(), p.label) == aliases.end())
          aliases.push_back(p.label);
      }
      // The gated event figures, one series per event ("ghosting@12.lagEnergy", as the gate's
      // rows and results.db name them), with the run's own interval.
      for (const Tolerance& t : tolerances) {
        if (!isGatedEventFigure(t.metric)) continue;
        const size_t dot = t.metric.find('.');
        const std::string kind = t.metric.substr(0, dot), figure = t.metric.substr(dot + 1);
        const json& events = p.part(kind == "cut" ? "cuts" : "ghosting");
        if (!events.is_array()) continue;
        for (const json& e : events) {
          const std::string metric =
              kind + "@" + std::to_string(e.value("eventFrame", -1)) + "." + figure;
          // Without a value (a lag measured after an unsettled event: the worst laggers), a gap
          // in the series, and the reason said beside the summaries' absences.
          const double v = storedFigures(e, kind == "cut").at(figure);
          if (const std::string why = storedFigureAbsence(e, kind == "cut", figure, v);
              !why.empty()) {
            absent.push_back(
                {{"run", i},
                 {"line", p.scene + ": " + metric + " absent for " + label + ": " + why}});
            continue;
          }
          if (std::find(metrics.begin(), metrics.end(), metric) == metrics.end())
            metrics.push_back(metric);
          json& s = series[p.scene][label][metric];
          if (s.is_null()) s = {{"value", json(runs.size(), nullptr)}};
          s["value"][i] = v;
          const json ci = e.value("ci95", json::object()).value(figure, json());
          if (ci.is_array() && ci.size() == 2 && ci[0].is_number() && ci[1].is_number()) {
            if (!s.contains("ci95")) s["ci95"] = json(runs.size(), nullptr);
            s["ci95"][i] = ci;
          }
        }
      }
      for (const auto& [metric, summary] : p.summary) {
        const SummaryMean mean = p.mean(metric);
        if (!mean.present()) continue;
        if (std::find(metrics.begin(), metrics.end(), metric) == metrics.end()) metrics.push_back(metric);
        json& s = series[p.scene][label][metric];
        if (s.is_null()) s = {{"value", json(runs.size(), nullptr)}};
        s["value"][i] = mean.mean;
        if (summary.ci95.valid()) {
          if (!s.contains("ci95")) s["ci95"] = json(runs.size(), nullptr);
          s["ci95"][i] = summary.ci95.toJson();
        }
      }
    }
  }
  // The gate: exactly what `arena compare previous current` decides, run by run. `changes` keeps
  // every verdict other than "ok" (improved, beyond tolerance but not resolved, ...) with `fails`
  // (failsGate: compare's own rule).
  json changes = json::array();
  json gated = json::object();  // the gate's tolerance per metric (0 included), from one run on
  for (const Tolerance& t : tolerances) gated[t.metric] = t.relative;
  size_t notJudgedFewFrames = 0;
  size_t failing = 0, unresolved = 0, notJudged = 0, notJudgedFromDatabase = 0,
         notComparableRuns = 0;
  std::set<size_t> failingRuns;  // the comparisons (run i against run i - 1) that fail
  // A comparison the gate cannot make (other settings, data it refuses): one row for the whole run,
  // which fails the gate there, saying why.
  auto notComparable = [&](size_t run, const std::string& why) {
    ComparisonRow row;
    row.scene = row.label = row.metric = "*";
    row.verdict = "not comparable";
    row.note = why;
    json change = comparisonJson({row})[0];
    change["run"] = run;
    ++failing;
    ++notComparableRuns;
    failingRuns.insert(run);
    changes.push_back(change);
  };
  size_t comparisons = 0;
  // Comparisons not made: their earlier run has none of the --denoisers contenders (before they
  // existed; `arena compare --denoisers` would find nothing to compare there and not judge).
  size_t beforeContenders = 0;
  json matchedAt =
      json::object();  // "A=B" (--match, the runs' labels) -> the comparisons it paired
  json historyWarnings = json::array();
  struct WarningAt {
    size_t index;        // in historyWarnings
    size_t comparisons;  // how many comparisons it concerns
  };
  // Said once per kind (a run that records no settings, rows beyond the correction), or once per
  // distinct text where the text is the news (which settings differ, which references).
  std::map<std::pair<GateWarning, std::string>, WarningAt> warned;
  // Each comparison's gate: the tolerances as read above, the runs already cut to --denoisers and
  // the --match pairs those two runs meet.
  Gate step = gate;
  step.tolerances = tolerances;
  step.contenders.clear();
  step.matches.clear();
  for (size_t i = 1; i < runs.size(); ++i) {
    // Before the contenders named with --denoisers existed (the previous run has none of them),
    // there is nothing of theirs to gate: no comparison, rather than "nothing compared".
    if (!contenders.empty() && runs[i - 1].pairs.empty()) {
      ++beforeContenders;
      continue;
    }
    ++comparisons;
    // The --match pairs this comparison meets: the first label before, the second in its place.
    std::map<std::string, std::string> matched;
    const std::set<std::string> before = labelsOf(runs[i - 1]), now = labelsOf(runs[i]);
    for (const LabelMatch& m : labelMatches)
      if (before.count(m.from) && !before.count(m.to) && now.count(m.to) && !now.count(m.from))
        matched[m.from] = m.to;
    // The judgement `arena compare previous current` makes (metrics/gate.hpp), on the runs as
    // --denoisers left them. What it refuses (other settings, data it refuses) fails the gate
    // there, saying why; the dashboard of the other runs is still built.
    const GateJudgement judged = judgeRuns(runs[i - 1], runs[i], step, matched);
    const GateSides sides{runDescription(runs[i - 1]), runDescription(runs[i])};
    // Its warnings, each once (with how many comparisons it concerns): a history of a hundred
    // runs would otherwise say one thing a hundred times.
    for (GateNotice& notice : gateWarnings(judged, sides, /*multiLine=*/false)) {
      const bool byText = notice.kind == GateWarning::SettingsAllowed ||
                          notice.kind == GateWarning::OtherReferences;
      auto [at, first] = warned.try_emplace({notice.kind, byText ? notice.text : std::string()},
                                            WarningAt{historyWarnings.size(), 0});
      ++at->second.comparisons;
      if (first)
        historyWarnings.push_back("comparing " + sides.candidate +
                                  " with the run before: " + notice.text);
    }
    if (judged.refusal != GateRefusal::None) {
      notComparable(i, refusalText(judged, sides, /*multiLine=*/false));
      continue;
    }
    const std::vector<ComparisonRow>& rows = judged.rows;
    // A comparison the gate cannot pass though no row fails it (runs of too few frames after the
    // warm-up: compare exits 2) fails here too; its warning says why.
    if (judged.outcome != GateOutcome::Pass) failingRuns.insert(i);
    for (const auto& [from, to] : matched) matchedAt[from + "=" + to].push_back(i);
    for (const ComparisonRow& row : rows) {
      if (row.verdict == "ok") continue;
      json change = comparisonJson({row})[0];
      change["run"] = i;
      change["pairLabel"] = row.label;  // the labels compared, where --match paired two
      // The row names the baseline's label (or the candidate's, for a new pair): the series.
      for (const size_t r : {i - 1, i})
        if (auto it = seriesOf[r].find({row.scene, row.label}); it != seriesOf[r].end()) {
          change["label"] = it->second;
          break;
        }
      failing += change["fails"].get<bool>();
      if (change["fails"].get<bool>()) failingRuns.insert(i);
      unresolved += row.verdict == "unresolved";
      // Only a change in the worse direction could fail the gate: an improvement it could not
      // judge is no warning (24 of a trial's 50 "NOT JUDGED" were improvements).
      if (row.verdict == "not judged") {
        const MetricDefinition* m = findMetric(row.metric);  // event figures: lower is better
        // A change of unknown size (no change given: runs from results.db that summarise other
        // frames, or keep no pair's events) may be worse: counted, not passed over.
        const bool worse = !((!m || m->lowerIsBetter() ? row.change : -row.change) <= 0);
        notJudged += worse;
        const bool fromDatabase = !runs[i - 1].keepsTiles || !runs[i].keepsTiles;
        notJudgedFromDatabase += worse && fromDatabase;
        notJudgedFewFrames += worse && !fromDatabase && row.fewFrames;
      }
      changes.push_back(change);
    }
  }
  for (const auto& [key, at] : warned)
    if (at.comparisons > 1)
      historyWarnings[at.index] = historyWarnings[at.index].get<std::string>() + " (and " +
                                  std::to_string(at.comparisons - 1) +
                                  " more comparison(s) of the history)";
  json metricList = json::array();
  for (const MetricDefinition* m : metricCatalog())
    if (std::find(metrics.begin(), metrics.end(), m->name) != metrics.end())
      metricList.push_back({{"name", m->name},
                            {"lowerIsBetter", m->lowerIsBetter()},
                            {"meaning", m->description},
                            {"tolerance", gated.contains(m->name) ? gated[m->name] : json(nullptr)}});
  // Then the event figures, in the order met (events by frame within a scene's pairs).
  for (const std::string& name : metrics)
    if (const std::string figure = gatedEventFigureOf(name); !figure.empty())
      metricList.push_back(
          {{"name", name},
           {"lowerIsBetter", true},
           {"meaning", figure.substr(figure.find('.') + 1) + " of the " +
                           (figure.rfind("cut.", 0) == 0 ? "camera cut" : "scripted event") +
                           " at frame " +
                           name.substr(name.find('@') + 1, name.find('.') - name.find('@') - 1) +
                           " (docs/metrics.md, \"Ghosting and lag\")"},
           {"tolerance", gated.contains(figure) ? gated[figure] : json(nullptr)}});
  return {{"generator", "arena history"},
          {"runs", runList},
          {"metrics", metricList},
          {"series", series},
          {"changes", changes},
          {"failing", failing},
          {"comparisons", comparisons},
          {"notMadeBeforeContenders", beforeContenders},
          {"failingComparisons", failingRuns.size()},
          {"unresolved", unresolved},
          {"notJudged", notJudged},
          {"notJudgedFromDatabase", notJudgedFromDatabase},
          {"notJudgedFewFrames", notJudgedFewFrames},
          {"notComparable", notComparableRuns},
          {"correction", correctionName(correction)},
          {"confidence", bootstrap.confidence},
          {"warnings", historyWarnings},
          {"matches", matchedAt},
          {"absent", absent}};
}

HistorySummary writeHistory(const HistoryOptions& o) {
  requirePageDirectory(o.out, "history");
  // A run's directory holds its own page where `arena report` wrote it in place (index.html,
  // style.css, ...): the dashboard's files have the same names and would replace it.
  if (std::error_code ec; fs::exists(o.out / "results.json", ec))
    throw Error("history: --out " + o.out.string() +
                " holds a run (results.json): the dashboard's index.html would replace the run's "
                "own page there; choose a directory of its own, e.g. report/history");
  if (std::error_code ec; fs::exists(o.out / "data.js", ec))
    throw Error("history: --out " + o.out.string() +
                " holds a run's report (data.js): the dashboard's index.html would replace it; "
                "choose a directory of its own, e.g. report/history");
  const fs::path web = o.webDir.empty() ? ReportOptions::defaultWebDir() : o.webDir;
  const fs::path modules =
      o.nodeModulesDir.empty() ? ReportOptions::defaultNodeModulesDir() : o.nodeModulesDir;
  const std::vector<PageFile> files = {{"history.html", "index.html"},
                                       {"style.css", "style.css"},
                                       {"shared.js", "shared.js"},
                                       {"history.js", "history.js"}};
  checkPageAssets(web, modules, files);
  requireOwnPageFiles(o.out, files, "history-data.js", {}, "history");
  std::vector<std::string> warnings;
  const json data = historyData(loadHistory(o.inputs, &warnings), o.gate);
  copyPageAssets(web, modules, files, o.out);
  writeTextAtomically(o.out / "history-data.js",
                      "// Generated by `arena history`; read by history.js.\n"
                      "window.ARENA_HISTORY = " +
                          jsonText(data) + ";\n");
  HistorySummary summary;
  summary.index = o.out / "index.html";
  summary.runs = data["runs"].size();
  summary.failing = data["failing"].get<size_t>();
  summary.comparisons = data["comparisons"].get<size_t>();
  summary.notMadeBeforeContenders = data["notMadeBeforeContenders"].get<size_t>();
  summary.failingComparisons = data["failingComparisons"].get<size_t>();
  summary.unresolved = data["unresolved"].get<size_t>();
  summary.notJudged = data["notJudged"].get<size_t>();
  summary.notJudgedFromDatabase = data["notJudgedFromDatabase"].get<size_t>();
  summary.notJudgedFewFrames = data["notJudgedFewFrames"].get<size_t>();
  summary.notComparable = data["notComparable"].get<size_t>();
  summary.warnings = std::move(warnings);
  for (const json& w : data["warnings"]) summary.warnings.push_back(w.get<std::string>());
  for (const auto& [assignment, at] : data["matches"].items())
    summary.matches.push_back({assignment, at.get<std::vector<size_t>>()});
  for (const json& a : data["absent"])
    summary.absentSummaries.push_back(data["runs"][a["run"].get<size_t>()]["name"].get<std::string>() +
                                      ": " + a["line"].get<std::string>());
  return summary;
}

}  // namespace arena
