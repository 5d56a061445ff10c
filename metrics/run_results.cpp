#include "metrics/run_results.hpp"

#include <cmath>
#include <set>
#include <tuple>

#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "metrics/results.hpp"

namespace arena {

using nlohmann::json;

namespace {

const std::set<std::string> kSummaryKeys = {"mean", "median", "p5", "p95", "frames", "ci95", "nonFinite", "absent"};
// A pair's keys the model types; the others are its `detail`.
const std::set<std::string> kTypedPairKeys = {"scene", "denoiser", "label", "status", "error", "params", "summary"};

// The reader of one results document: every mismatch is an Error naming the file, the JSON path,
// what was expected and what was there.
struct ShapeReader {
  const std::string& file;

  [[noreturn]] void fail(const std::string& path, const std::string& expected, const json& got) const {
    throw Error(file + ": " + path + ": expected " + expected + ", got " + jsonTypeName(got));
  }
  const json& member(const json& obj, const std::string& path, const char* key,
                     bool (json::*is)() const noexcept, const char* expected) const {
    static const json missing;
    const json& v = obj.contains(key) ? obj.at(key) : missing;
    if (!(v.*is)()) fail(path + "." + key, expected, v);
    return v;
  }
  std::string text(const json& obj, const std::string& path, const char* key) const {
    return member(obj, path, key, &json::is_string, "a string").get<std::string>();
  }
  // A number, or null (a value no frame defined, written as null): NaN then. Absent: NaN.
  double number(const json& obj, const std::string& path, const char* key) const {
    if (!obj.contains(key) || obj.at(key).is_null()) return kUndefined;
    if (!obj.at(key).is_number()) fail(path + "." + key, "a number (or null)", obj.at(key));
    return obj.at(key).get<double>();
  }
  int integer(const json& obj, const std::string& path, const char* key) const {
    if (!obj.contains(key)) return 0;
    const json& v = obj.at(key);
    if (!v.is_number_integer() || v.get<int64_t>() < 0 || v.get<int64_t>() > int64_t(1) << 30)
      fail(path + "." + key, "a non-negative integer", v);
    return v.get<int>();
  }

  MetricSummary summary(const json& s, const std::string& path) const {
    if (!s.is_object()) fail(path, "an object", s);
    MetricSummary m;
    m.frames = integer(s, path, "frames");
    m.nonFinite = integer(s, path, "nonFinite");
    if (s.contains("absent")) {
      m.absent = text(s, path, "absent");
      if (m.absent.empty()) fail(path + ".absent", "the reason the summary is absent", s.at("absent"));
    }
    m.mean = number(s, path, "mean");
    m.median = number(s, path, "median");
    m.p5 = number(s, path, "p5");
    m.p95 = number(s, path, "p95");
    if (s.contains("ci95") && !s.at("ci95").is_null()) {
      const json& ci = s.at("ci95");
      if (!ci.is_array() || ci.size() != 2 || !ci[0].is_number() || !ci[1].is_number())
        fail(path + ".ci95", "[low, high] (or null)", ci);
      m.ci95 = {ci[0].get<double>(), ci[1].get<double>()};
    }
    for (auto it = s.begin(); it != s.end(); ++it)
      if (!kSummaryKeys.count(it.key()))
        fail(path + "." + it.key(), "no such field (a summary holds mean, median, p5, p95, frames, ci95, nonFinite, absent)",
             it.value());
    return m;
  }

  PairResult pair(const json& p, const std::string& path) const {
    if (!p.is_object()) fail(path, "an object", p);
    PairResult r;
    r.scene = text(p, path, "scene");
    r.denoiser = text(p, path, "denoiser");
    r.label = text(p, path, "label");
    r.status = text(p, path, "status");
    if (p.contains("error")) r.error = text(p, path, "error");
    if (p.contains("params")) r.params = member(p, path, "params", &json::is_object, "an object");
    if (p.contains("summary"))
      for (auto& [metric, s] : member(p, path, "summary", &json::is_object, "an object").items())
        r.summary.emplace(metric, summary(s, path + ".summary." + metric));
    for (auto it = p.begin(); it != p.end(); ++it)
      if (!kTypedPairKeys.count(it.key())) r.detail[it.key()] = it.value();
    if (!r.ok()) {
      if (!p.contains("error")) fail(path + ".error", "a string (the failure)", json());
      return r;
    }
    member(p, path, "params", &json::is_object, "an object");
    member(p, path, "summary", &json::is_object, "an object");
    // The numbers readers take as numbers (printouts, compare, report, history).
    const json& frames = member(p, path, "frames", &json::is_array, "an array of per-frame metrics");
    for (size_t f = 0; f < frames.size(); ++f) {
      const std::string at = path + ".frames[" + std::to_string(f) + "]";
      if (!frames[f].is_object()) fail(at, "an object", frames[f]);
      member(frames[f], at, "frame", &json::is_number_integer, "an integer");
    }
    if (p.contains("timing")) {
      const json& t = member(p, path, "timing", &json::is_object, "an object");
      for (const char* k : {"msMedian", "msP5", "msP95", "msMean"}) number(t, path + ".timing", k);
    }
    return r;
  }
};

const std::set<std::string> kRunKeys = {"kind", "schema", "name", "created", "environment", "settings",
                                        "scenes", "pairs", "statistics", "metrics", "sweep"};

}  // namespace

json MetricSummary::toJson() const {
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  if (!present()) {
    json j = {{"frames", frames}, {"absent", absent}};
    if (nonFinite > 0) j["nonFinite"] = nonFinite;
    return j;
  }
  return {{"mean", num(mean)},     {"median", num(median)}, {"p5", num(p5)},
          {"p95", num(p95)},       {"frames", frames},      {"ci95", ci95.toJson()}};
}

SummaryMean PairResult::mean(const std::string& metric) const {
  if (!ok()) return {0, "the pair has no summary (" + status + ": " + error + ")"};
  auto it = summary.find(metric);
  if (it == summary.end()) return {0, metric + " was not computed in this run", false};
  const MetricSummary& s = it->second;
  if (!s.present()) return {0, s.absent};
  if (!std::isfinite(s.mean)) return {0, metric + "'s mean is not a finite number"};
  return {s.mean, ""};
}

const json& PairResult::part(const std::string& key) const {
  static const json none;
  return detail.contains(key) ? detail.at(key) : none;
}

RunResults RunResults::fromJson(const json& j, const std::string& file) {
  if (!j.is_object() || !j.contains("kind") || j.at("kind") != "arena-run")
    throw Error(file + ": not an arena results file");
  if (!j.contains("schema") || j.at("schema") != kResultsSchemaVersion)
    throw Error(file + ": results schema version " + (j.contains("schema") ? j.at("schema").dump() : "none") +
                ", this arena reads version " + std::to_string(kResultsSchemaVersion) + " (re-run with this version)");
  const ShapeReader read{file};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!kRunKeys.count(it.key()))
      read.fail("$." + it.key(), "no such field (a results file holds name, created, environment, settings, "
                                 "scenes, pairs, statistics, metrics, sweep)",
                it.value());
  RunResults r;
  r.name = read.text(j, "$", "name");
  if (j.contains("created")) r.created = read.text(j, "$", "created");
  r.environment = read.member(j, "$", "environment", &json::is_object, "an object");
  r.settings = RunSettings::fromJson(read.member(j, "$", "settings", &json::is_object, "an object"), file);
  r.scenes = read.member(j, "$", "scenes", &json::is_object, "an object");
  for (auto& [name, scene] : r.scenes.items())
    if (!scene.is_object()) read.fail("$.scenes." + name, "an object", scene);
  const json& pairs = read.member(j, "$", "pairs", &json::is_array, "an array of pairs");
  r.pairs.reserve(pairs.size());
  for (size_t i = 0; i < pairs.size(); ++i) r.pairs.push_back(read.pair(pairs[i], "$.pairs[" + std::to_string(i) + "]"));
  if (j.contains("statistics"))
    r.statistics = RunStatistics::fromJson(read.member(j, "$", "statistics", &json::is_object, "an object"), file);
  if (j.contains("metrics")) r.metrics = read.member(j, "$", "metrics", &json::is_array, "an array");
  if (j.contains("sweep")) r.sweep = read.member(j, "$", "sweep", &json::is_object, "an object");
  return r;
}

json RunResults::toJson() const {
  json j = {{"kind", "arena-run"}, {"schema", kResultsSchemaVersion}, {"name", name},
            {"environment", environment}, {"settings", settings.toJson()}, {"scenes", scenes}};
  if (!created.empty()) j["created"] = created;
  json ps = json::array();
  for (const PairResult& p : pairs) {
    json o = p.detail;
    o["scene"] = p.scene;
    o["denoiser"] = p.denoiser;
    o["label"] = p.label;
    o["status"] = p.status;
    if (!p.ok() || !p.error.empty()) o["error"] = p.error;
    o["params"] = p.params;
    if (p.ok() || !p.summary.empty()) {
      json s = json::object();
      for (const auto& [metric, m] : p.summary) s[metric] = m.toJson();
      o["summary"] = s;
    }
    ps.push_back(std::move(o));
  }
  j["pairs"] = std::move(ps);
  if (statistics) j["statistics"] = statistics->toJson();
  if (!metrics.is_null()) j["metrics"] = metrics;
  if (!sweep.is_null()) j["sweep"] = sweep;
  return j;
}

const PairResult* RunResults::find(const std::string& scene, const std::string& label) const {
  for (const PairResult& p : pairs)
    if (p.scene == scene && p.label == label) return &p;
  return nullptr;
}

std::vector<std::string> absentSummaryLines(const RunResults& results, const std::vector<std::string>& metrics) {
  std::map<std::tuple<std::string, std::string, std::string>, int> count;
  for (const PairResult& p : results.pairs) {
    if (!p.ok()) continue;
    std::vector<std::string> names = metrics;
    if (names.empty())
      for (const auto& [metric, s] : p.summary) names.push_back(metric);
    for (const std::string& m : names)
      if (const SummaryMean s = p.mean(m); !s.present()) ++count[{p.scene, m, s.absent}];
  }
  std::vector<std::string> lines;
  for (const auto& [key, n] : count) {
    const auto& [scene, metric, why] = key;
    lines.push_back(scene + ": " + metric + " absent in " + std::to_string(n) + " pair(s): " + why);
  }
  return lines;
}

}  // namespace arena
