#include "metrics/run_results.hpp"

#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "core/env_info.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "metrics/metric_registry.hpp"
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
    // An absent field is said so ("got null" read as if the file held a null there).
    if (!obj.contains(key))
      throw Error(file + ": " + path + "." + key + ": expected " + expected +
                  ", got nothing (the field is absent)");
    const json& v = obj.at(key);
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

  // Optional members that must have their type where present (what the run writes of them).
  void optionalText(const json& obj, const std::string& path, const char* key) const {
    if (obj.contains(key)) member(obj, path, key, &json::is_string, "a string");
  }
  void optionalFinite(const json& obj, const std::string& path, const char* key) const {
    if (obj.contains(key) && (!obj.at(key).is_number() || !std::isfinite(obj.at(key).get<double>())))
      fail(path + "." + key, "a finite number", obj.at(key));
  }
  void optionalCount(const json& obj, const std::string& path, const char* key) const {
    if (obj.contains(key)) integer(obj, path, key);
  }
  void optionalFlag(const json& obj, const std::string& path, const char* key) const {
    if (obj.contains(key)) member(obj, path, key, &json::is_boolean, "true or false");
  }
  // An array each of whose elements `element` accepts (`expected` says what it wants).
  const json& arrayOf(const json& obj, const std::string& path, const char* key, bool (*element)(const json&),
                      const char* expected) const {
    const json& a = member(obj, path, key, &json::is_array, "an array");
    for (size_t i = 0; i < a.size(); ++i)
      if (!element(a[i])) fail(path + "." + key + "[" + std::to_string(i) + "]", expected, a[i]);
    return a;
  }
  static bool isString(const json& j) { return j.is_string(); }
  static bool isObject(const json& j) { return j.is_object(); }
  static bool isCount(const json& j) { return j.is_number_integer() && j.get<int64_t>() >= 0; }
  static bool isFlag(const json& j) { return j.is_boolean(); }
  static bool isNumberOrNull(const json& j) { return j.is_number() || j.is_null(); }
  // A rejection of every member of `obj` not in `known`.
  void onlyKnown(const json& obj, const std::string& path, const std::set<std::string>& known) const {
    for (auto it = obj.begin(); it != obj.end(); ++it)
      if (!known.count(it.key())) fail(path + "." + it.key(), "no such field", it.value());
  }

  // pair.timing: how long the pair's frames took (metrics/evaluator.cpp timingSummary, the clock
  // and, on the CPU, the GPU cost model's prediction).
  void timing(const json& t, const std::string& path) const {
    for (const char* k : {"msMedian", "msP5", "msP95", "msMean", "msPerMegapixel", "tapsPerPixel", "msWallMedian"})
      optionalFinite(t, path, k);
    for (const char* k : {"clock", "msSource", "device", "absent"}) optionalText(t, path, k);
    if (t.contains("passes")) arrayOf(t, path, "passes", isObject, "an object (a pass's name and time)");
    if (t.contains("gpuPredicted")) {
      const json& g = member(t, path, "gpuPredicted", &json::is_object, "an object");
      if (g.contains("devices")) {
        const json& devices = arrayOf(g, path + ".gpuPredicted", "devices", isObject, "an object (one device)");
        for (size_t d = 0; d < devices.size(); ++d) {
          const std::string at = path + ".gpuPredicted.devices[" + std::to_string(d) + "]";
          optionalText(devices[d], at, "device");
          for (const char* k : {"msMedian", "msP5", "msP95"}) optionalFinite(devices[d], at, k);
        }
      }
    }
  }

  // pair.ghosting / pair.cuts: one entry per event or cut, matched by its frame.
  void events(const json& p, const std::string& path, const char* key) const {
    const json& list = arrayOf(p, path, key, isObject, "an object (one event's figures)");
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string at = path + "." + key + "[" + std::to_string(i) + "]";
      member(list[i], at, "eventFrame", &json::is_number_integer, "an integer");
      for (const char* k : {"kind", "what"}) optionalText(list[i], at, k);
      for (const char* k : {"ci95", "ci95Absent", "tiles"})
        if (list[i].contains(k)) member(list[i], at, k, &json::is_object, "an object");
    }
  }

  // scenes.<scene>: the sequence's facts, its floors and events (harness/run_matrix.cpp, metrics/
  // evaluator.cpp EvaluationScene::describe), its reference verdict (harness/reference_quality.cpp)
  // and, for a capture, its validation.
  void scene(const json& sc, const std::string& path) const {
    static const std::set<std::string> known = {"purpose",
                                                "sequence",
                                                "hash",
                                                "width",
                                                "height",
                                                "frames",
                                                "maxBounces",
                                                "events",
                                                "referenceSpp",
                                                "referenceCapped",
                                                "referenceEstimatedRelMse",
                                                "chosenFrames",
                                                "images",
                                                "referenceRelMse",
                                                "noisyRelMse",
                                                "exposure",
                                                "exposurePerFrame",
                                                "floors",
                                                "nonFiniteInputs",
                                                "warnings",
                                                "hasReference",
                                                "source",
                                                "capture",
                                                "validation",
                                                "derivedLayers",
                                                "layers",
                                                "assets",
                                                "referenceQuality",
                                                "content",
                                                "notRun"};
    onlyKnown(sc, path, known);
    for (const char* k : {"purpose", "sequence", "hash", "images", "source", "capture"}) optionalText(sc, path, k);
    if (sc.contains("content")) {
      member(sc, path, "content", &json::is_object, "an object");
      onlyKnown(sc["content"], path + ".content", {"inputs", "references"});
      for (const char* k : {"inputs", "references"})
        optionalText(sc["content"], path + ".content", k);
    }
    for (const char* k : {"width", "height", "frames", "maxBounces"}) optionalCount(sc, path, k);
    optionalFinite(sc, path, "exposure");
    optionalFlag(sc, path, "hasReference");
    for (const char* k : {"warnings", "derivedLayers", "layers"})
      if (sc.contains(k)) arrayOf(sc, path, k, isString, "a string");
    for (const char* k : {"referenceSpp", "chosenFrames"})
      if (sc.contains(k)) arrayOf(sc, path, k, isCount, "a non-negative integer");
    if (sc.contains("referenceCapped")) arrayOf(sc, path, "referenceCapped", isFlag, "true or false");
    for (const char* k : {"referenceEstimatedRelMse", "referenceRelMse", "noisyRelMse", "exposurePerFrame"})
      if (sc.contains(k)) arrayOf(sc, path, k, isNumberOrNull, "a number (or null)");
    if (sc.contains(
            "notRun")) {  // a capture's denoisers it lacks the inputs for, under --denoisers all
      const json& notRun =
          arrayOf(sc, path, "notRun", isObject, "an object (a denoiser not run, and why)");
      for (size_t i = 0; i < notRun.size(); ++i) {
        const std::string at = path + ".notRun[" + std::to_string(i) + "]";
        onlyKnown(notRun[i], at, {"label", "reason"});
        text(notRun[i], at, "label");
        text(notRun[i], at, "reason");
      }
    }
    if (sc.contains("events")) {
      const json& events = arrayOf(sc, path, "events", isObject, "an object (one scripted event)");
      for (size_t i = 0; i < events.size(); ++i) {
        const std::string at = path + ".events[" + std::to_string(i) + "]";
        onlyKnown(events[i], at, {"frame", "kind", "what"});
        member(events[i], at, "frame", &json::is_number_integer, "an integer");
        text(events[i], at, "kind");
        optionalText(events[i], at, "what");
      }
    }
    if (sc.contains("floors")) {
      const json& floors = member(sc, path, "floors", &json::is_object, "an object (metric -> floor)");
      for (auto it = floors.begin(); it != floors.end(); ++it)
        if (it.key() == "source" ? !it.value().is_string() : !isNumberOrNull(it.value()))
          fail(path + ".floors." + it.key(), it.key() == "source" ? "a string" : "a number (or null)", it.value());
    }
    if (sc.contains("nonFiniteInputs")) {
      const json& counts = member(sc, path, "nonFiniteInputs", &json::is_object, "an object (layer -> count)");
      for (auto it = counts.begin(); it != counts.end(); ++it)
        if (!isCount(it.value())) fail(path + ".nonFiniteInputs." + it.key(), "a non-negative integer", it.value());
    }
    if (sc.contains("referenceQuality")) {
      const std::string at = path + ".referenceQuality";
      const json& q = member(sc, path, "referenceQuality", &json::is_object, "an object");
      onlyKnown(q, at,
                {"floor", "bestCorrectedRelMse", "bestLabel", "ratio", "goal", "meets",
                 "cappedReferences", "references", "verdict", "segments", "segmentsMeet"});
      // The ratio between the scene's events: {from, to, ratio} each.
      if (q.contains("segments")) {
        arrayOf(q, at, "segments", isObject, "an object (from, to, ratio)");
        for (size_t k = 0; k < q["segments"].size(); ++k) {
          const json& s = q["segments"][k];
          const std::string sat = at + ".segments[" + std::to_string(k) + "]";
          onlyKnown(s, sat, {"from", "to", "ratio"});
          for (const char* f : {"from", "to"}) optionalCount(s, sat, f);
          optionalFinite(s, sat, "ratio");
        }
      }
      text(q, at, "verdict");
      for (const char* k : {"floor", "bestCorrectedRelMse", "ratio", "goal"}) optionalFinite(q, at, k);
      optionalText(q, at, "bestLabel");
      optionalFlag(q, at, "meets");
      optionalFlag(q, at, "segmentsMeet");
      for (const char* k : {"cappedReferences", "references"}) optionalCount(q, at, k);
    }
    if (sc.contains("assets")) {
      const std::string at = path + ".assets";
      const json& a = member(sc, path, "assets", &json::is_object, "an object");
      onlyKnown(a, at, {"credits", "warnings"});
      if (a.contains("credits")) arrayOf(a, at, "credits", isObject, "an object (one asset's credit)");
      if (a.contains("warnings")) arrayOf(a, at, "warnings", isString, "a string");
    }
    if (sc.contains("validation")) member(sc, path, "validation", &json::is_object, "an object (the capture's checks)");
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
    if (s.contains("ci95")) {
      const std::optional<Interval> ci = Interval::fromJson(s.at("ci95"));
      if (!ci) {
        const json& v = s.at("ci95");
        if (v.is_array() && v.size() == 2 && v[0].is_number() && v[1].is_number())
          throw Error(file + ": " + path +
                      ".ci95: expected [low, high] with low <= high (or null), got " + v.dump() +
                      ": its ends are swapped (the results were edited or damaged)");
        fail(path + ".ci95", "[low, high] (or null)", v);
      }
      m.ci95 = *ci;
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
      if (!p.contains("error"))
        throw Error(file + ": " + path +
                    ".error: expected a string (the failure), got nothing (the field is absent)");
      return r;
    }
    member(p, path, "params", &json::is_object, "an object");
    member(p, path, "summary", &json::is_object, "an object");
    // The numbers readers take as numbers (printouts, compare, report, history).
    const json& frames = member(p, path, "frames", &json::is_array, "an array of per-frame metrics");
    // One record per frame, in order: a frame listed twice or out of order is an edit the charts
    // would draw as data (a bad-input trial).
    long long previous = -1;
    for (size_t f = 0; f < frames.size(); ++f) {
      const std::string at = path + ".frames[" + std::to_string(f) + "]";
      if (!frames[f].is_object()) fail(at, "an object", frames[f]);
      const json& frame = member(frames[f], at, "frame", &json::is_number_integer, "an integer");
      if (frame.get<long long>() <= previous)
        fail(at + ".frame",
             (previous < 0 ? std::string("a frame number of 0 or more")
                           : "a frame after " + std::to_string(previous)) +
                 " (one record per frame, in order), not " + frame.dump(),
             frame);
      previous = frame.get<long long>();
    }

    if (p.contains("timing")) timing(member(p, path, "timing", &json::is_object, "an object"), path + ".timing");
    for (const char* k : {"ghosting", "cuts"})
      if (p.contains(k)) events(p, path, k);
    if (p.contains("images")) {
      const json& images = member(p, path, "images", &json::is_object, "an object");
      optionalText(images, path + ".images", "dir");
      optionalFlag(images, path + ".images", "all");
    }
    if (p.contains("warnings")) arrayOf(p, path, "warnings", isString, "a string");
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

bool PairResult::keepsHistory() const {
  const json& k = part("keepsHistory");
  return k.is_boolean() ? k.get<bool>() : denoiser != "passthrough";
}

const json& PairResult::timing() const {
  static const json none = json::object();
  return part("timing").is_object() ? part("timing") : none;
}

std::string PairResult::clock() const {
  return timing().value("clock", "cpu");
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
  if (j.contains("created")) {
    r.created = read.text(j, "$", "created");
    if (!isUtcTimestamp(r.created))
      throw Error(file +
                  ": $.created: expected a UTC time as 2026-11-28T21:15:00Z (runs are ordered by "
                  "it), got \"" +
                  r.created + "\"");
  }
  r.environment = read.member(j, "$", "environment", &json::is_object, "an object");
  r.settings = RunSettings::fromJson(read.member(j, "$", "settings", &json::is_object, "an object"), file);
  r.scenes = read.member(j, "$", "scenes", &json::is_object, "an object");
  for (auto& [name, scene] : r.scenes.items()) {
    if (!scene.is_object()) read.fail("$.scenes." + name, "an object", scene);
    read.scene(scene, "$.scenes." + name);
  }
  const json& pairs = read.member(j, "$", "pairs", &json::is_array, "an array of pairs");
  r.pairs.reserve(pairs.size());
  std::map<std::string, size_t> pairIndex;  // scene + label -> its index: one pair each
  for (size_t i = 0; i < pairs.size(); ++i) {
    const std::string at = "$.pairs[" + std::to_string(i) + "]";
    r.pairs.push_back(read.pair(pairs[i], at));
    const auto [it, fresh] =
        pairIndex.emplace(r.pairs.back().scene + "\n" + r.pairs.back().label, i);
    if (!fresh)
      read.fail(at,
                "a pair of its own (" + r.pairs.back().label + " on " + r.pairs.back().scene +
                    " is already $.pairs[" + std::to_string(it->second) +
                    "]; every reader would keep one of the two)",
                pairs[i]);
  }
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

std::map<std::string, std::string> contenderOrigins(const RunResults& results) {
  std::map<std::string, std::string> out;
  for (const PairResult& p : results.pairs)
    if (p.detail.contains("origin") && p.detail["origin"].is_string())
      out.emplace(p.label, p.detail["origin"].get<std::string>());
  return out;
}

// The origins' prefixes are the loaders' (denoisers/external/plugin_denoiser.cpp, loader.cpp); a
// capture's stored output is its outputs folder's path (harness/pair_run.cpp).
std::string contenderKind(const std::string& origin) {
  if (origin.empty()) return "";
  if (origin.rfind("plugin ", 0) == 0) return "plugin";
  if (origin.rfind("isolated plugin ", 0) == 0) return "isolated plugin";
  if (origin.rfind("external process ", 0) == 0) return "external";
  return "stored output";
}

std::vector<AbsentSummary> absentSummaries(const RunResults& results,
                                           const std::vector<std::string>& metrics) {
  std::map<std::tuple<std::string, std::string, std::string>, int> count;
  for (const PairResult& p : results.pairs) {
    if (!p.ok()) continue;
    std::vector<std::string> names = metrics;
    if (names.empty())
      for (const auto& [metric, s] : p.summary) names.push_back(metric);
    // A scene without a reference (a capture may have none) computes no metric that needs one:
    // said so, not as a metric this run left out.
    const bool noReference = results.scenes.is_object() && results.scenes.contains(p.scene) &&
                             results.scenes[p.scene].is_object() &&
                             results.scenes[p.scene].value("hasReference", true) == false;
    for (const std::string& m : names)
      if (const SummaryMean s = p.mean(m); !s.present()) {
        const MetricDefinition* d = findMetric(m);
        const bool needsReference = d && d->needsReference && !p.summary.count(m);
        ++count[{p.scene, m,
                 noReference && needsReference
                     ? "the scene has no reference (" + m +
                           " needs one; the metrics that need none are measured)"
                     : s.absent}];
      }
  }
  std::vector<AbsentSummary> out;
  for (const auto& [key, n] : count) {
    const auto& [scene, metric, why] = key;
    out.push_back({scene, metric, why, n});
  }
  return out;
}

std::string absentSummaryText(const AbsentSummary& a) {
  return a.scene + ": " + a.metric + " absent in " + std::to_string(a.pairs) + " pair(s): " + a.why;
}

std::vector<std::string> absentSummaryLines(const RunResults& results,
                                            const std::vector<std::string>& metrics) {
  std::vector<std::string> lines;
  for (const AbsentSummary& a : absentSummaries(results, metrics))
    lines.push_back(absentSummaryText(a));
  return lines;
}

}  // namespace arena
