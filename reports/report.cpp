#include "reports/report.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/exr_io.hpp"
#include "core/json_reader.hpp"
#include "core/text.hpp"
#include "metrics/compare.hpp"
#include "metrics/error_maps.hpp"
#include "metrics/ghosting_intervals.hpp"
#include "metrics/results.hpp"
#include "reports/image_files.hpp"
#include "reports/pareto.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

fs::path ReportOptions::defaultWebDir() {
  return fs::path(ARENA_SOURCE_DIR) / "reports" / "web";
}
fs::path ReportOptions::defaultNodeModulesDir() {
  return fs::path(ARENA_SOURCE_DIR) / "reports" / "node_modules";
}

const std::vector<std::string>& reportSectionIds() {
  static const std::vector<std::string> ids = {"speed",  "over-time", "ghosting",
                                               "tables", "images",    "regression"};
  return ids;
}

namespace {

// A double NaN: json::value(key, NAN) would return float (NAN is a float) and round every value.
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The page's static files, copied as they are.
// app.js is split by view; shared.js holds the helpers every view uses, once.
const char* const kWebFiles[] = {"index.html",    "style.css",   "shared.js", "speed.js",
                                 "over_time.js",  "ghosting.js", "tables.js", "images.js",
                                 "regression.js", "app.js"};
// Browser (UMD) builds that index.html loads with <script>, from reports/node_modules.
const char* const kVendorFiles[] = {"vega/build/vega.min.js", "vega-lite/build/vega-lite.min.js",
                                    "vega-embed/build/vega-embed.min.js"};

// The error metrics the speed-vs-accuracy chart offers. 1-SSIM turns SSIM (higher is better) into
// an error so every choice reads "lower is better" and the Pareto front is always lower-left.
struct ErrorAxis {
  const char* key;
  const char* title;
  const char* source;   // the per-frame metric it comes from
  bool complement;      // value = 1 - source
  const char* overall;  // the registered metric whose overall score (statistics) is the all-scenes value
};
const ErrorAxis kErrorAxes[] = {
    {"relMse", "relMSE", "relMse", false, "relMse"},
    {"hdrFlip", "HDR-FLIP", "hdrFlip", false, "hdrFlip"},
    {"ldrFlip", "LDR-FLIP", "ldrFlip", false, "ldrFlip"},
    {"dssim", "1 − SSIM", "ssim", true, "dssim"},
    // Flicker against time: what a 60 fps title weighs beside the error.
    {"tRmae", "tRMAE (flicker)", "tRmae", false, "tRmae"}};

// The mean of the reference's own relMSE over frames t >= W (metrics.md's sequence summary), the
// floor below which a method's raw relMSE cannot be ranked.
json noiseFloor(const json& scene, int warmup) {
  if (!scene.contains("referenceRelMse")) return nullptr;
  std::vector<double> v;
  for (const json& x : scene["referenceRelMse"])
    if (x.is_number()) v.push_back(x.get<double>());
  const size_t from = v.size() > size_t(warmup) ? size_t(warmup) : 0;
  if (from >= v.size()) return nullptr;
  double s = 0;
  for (size_t i = from; i < v.size(); ++i) s += v[i];
  std::vector<double> tail(v.begin() + long(from), v.end());
  std::sort(tail.begin(), tail.end());
  const double p95 =
      tail[std::min(tail.size() - 1, size_t(std::ceil(0.95 * double(tail.size())) - 1))];
  return {{"mean", s / double(v.size() - from)}, {"p95", p95}, {"frames", v.size() - from}};
}

// Per-frame metrics as columns (one array per metric, null where a frame lacks it): a third of
// the size of per-frame objects and what the charts want anyway.
json seriesColumns(const json& frames) {
  std::vector<std::string> names;
  for (const json& f : frames)
    for (auto it = f.begin(); it != f.end(); ++it)
      if (it.value().is_number() && std::find(names.begin(), names.end(), it.key()) == names.end())
        names.push_back(it.key());
  json cols = json::object();
  for (const std::string& n : names) {
    json col = json::array();
    for (const json& f : frames) col.push_back(f.contains(n) ? f[n] : json(nullptr));
    cols[n] = col;
  }
  return cols;
}

// The value of an error axis from a pair's summary and its bar: the 95% interval of the mean
// (results schema: summary.<metric>.ci95) when the run has one, else the p5-p95 spread over frames
// (older runs). Null when the pair lacks the metric.
json axisValue(const PairResult& pair, const ErrorAxis& axis) {
  const auto found = pair.summary.find(axis.source);
  if (!pair.ok() || found == pair.summary.end()) return nullptr;
  const MetricSummary& s = found->second;
  double mean = s.mean, p5 = s.p5, p95 = s.p95;
  const bool hasCi = s.ci95.valid();
  double lo = hasCi ? s.ci95.lo : p5, hi = hasCi ? s.ci95.hi : p95;
  if (axis.complement) {  // 1 - x reverses the order: the low end of SSIM is the high one of 1-SSIM
    mean = 1 - mean;
    std::swap(p5, p95), std::swap(lo, hi);
    p5 = 1 - p5, p95 = 1 - p95, lo = 1 - lo, hi = 1 - hi;
  }
  if (!std::isfinite(mean)) return nullptr;
  return {{"error", mean}, {"p5", p5}, {"p95", p95},
          {"lo", lo},      {"hi", hi}, {"interval", hasCi ? "ci95" : "p5-p95"}};
}

double timingOf(const PairResult& pair, const char* key) {
  return pair.timing().value(key, kNaN);
}

// One point per label with its error bars, and the labels on the Pareto front (time x error).
// The Pareto front on the denoiser's own time ("front") and the equal-paths front
// ("frontEqualPaths", issue 34): a method that read extra paths (reengine's disocclusion rays,
// asvgf's gradient samples) costs its time plus their tracing time there, and one whose tracing
// time is unknown is left off it. Such points carry extraPaths: true.
json speedScope(std::vector<json> points, bool needsComplete) {
  std::vector<ParetoPoint> pp, equal;
  for (json& p : points) {
    const bool eligible = !needsComplete || p.value("complete", true);
    const double tracing = p.contains("tracingMs") && p["tracingMs"].is_number() ? p["tracingMs"].get<double>() : 0.0;
    const bool extra = tracing > 0 || (p.contains("extraRaysPerPixel") && p["extraRaysPerPixel"].is_number() &&
                                       p["extraRaysPerPixel"].get<double>() > 0);
    if (extra) p["extraPaths"] = true;
    const double ms = p["ms"].get<double>();
    pp.push_back({eligible ? ms : kNaN, p["error"].get<double>()});
    equal.push_back({eligible && (!extra || tracing > 0) ? ms + tracing : kNaN, p["error"].get<double>()});
  }
  json front = json::array(), frontEqual = json::array();
  for (size_t i : paretoFront(pp)) front.push_back(points[i]["label"]);
  for (size_t i : paretoFront(equal)) frontEqual.push_back(points[i]["label"]);
  return {{"points", points}, {"front", front}, {"frontEqualPaths", frontEqual}};
}

// The time axes the speed chart offers (issue 31 section 4): "cpu", the time measured here;
// "gpu:<device>", the GPU ms the cost model predicts at 1920x1080 on a named device from the
// traffic the passes counted (harness/gpu_cost.hpp); "capture", another device's time recorded in
// a capture. A pair is on an axis only when it has that time; each axis has its own Pareto front.
struct SpeedClock {
  std::string key, title;
  double orderTolerance = 0;  // times less than this apart (relative) are not ordered: the model's
};

std::vector<SpeedClock> speedClocks(const RunResults& results, const std::vector<std::string>& scenes) {
  const json& env = results.environment;
  std::set<std::string> sizes;
  const json& infos = results.scenes;
  for (const std::string& scene : scenes)
    if (infos.contains(scene) && infos[scene].contains("width") && infos[scene].contains("height") &&
        infos[scene].value("source", "") != "capture")
      sizes.insert(std::to_string(infos[scene]["width"].get<int>()) + "x" + std::to_string(infos[scene]["height"].get<int>()));
  std::string where = env.value("cpu", std::string("this machine"));
  if (env.contains("cores")) where += ", " + env["cores"].dump() + " threads";
  for (const std::string& size : sizes) where += ", " + size;
  // Other work on the machine slows what is timed: its load when the run began.
  if (const json load = env.value("loadAverage", json());
      load.is_array() && !load.empty() && load[0].is_number()) {
    char buf[48];
    std::snprintf(buf, sizeof buf, ", load %.2f at the start", load[0].get<double>());
    where += buf;
  }
  std::vector<SpeedClock> clocks = {{"cpu", "CPU ms measured here (" + where + ")"}};
  std::vector<std::string> devices, captureDevices;
  bool processClock = false;
  double orderTolerance = 0;  // as the run's predictions say how to read them
  for (const PairResult& pair : results.pairs) {
    processClock |= pair.ok() && pair.clock() == "process";
    const json& timing = pair.timing();
    if (timing.contains("gpuPredicted") && timing["gpuPredicted"].is_object()) {
      if (const json t = timing["gpuPredicted"].value("orderTolerance", json()); t.is_number())
        orderTolerance = std::max(orderTolerance, t.get<double>());
      for (const json& d : timing["gpuPredicted"].value("devices", json::array())) {
        const std::string name = d.value("device", "");
        if (!name.empty() && std::find(devices.begin(), devices.end(), name) == devices.end()) devices.push_back(name);
      }
    }
    if (pair.clock() == "capture") {
      const std::string d = timing.value("device", "");
      if (std::find(captureDevices.begin(), captureDevices.end(), d) == captureDevices.end()) captureDevices.push_back(d);
    }
  }
  for (const std::string& d : devices)
    clocks.push_back(
        {"gpu:" + d,
         "GPU ms predicted at 1920x1080 on " + d + " (a model: counted traffic, docs/gpu-cost.md)",
         orderTolerance});
  if (processClock)
    clocks.push_back({"process",
                      "ms the external processes reported for their own work (each its own clock, "
                      "CPU or GPU: not measured here)"});
  if (!captureDevices.empty()) {
    std::string list;
    for (const std::string& d : captureDevices) list += (list.empty() ? "" : ", ") + (d.empty() ? "device not named" : d);
    clocks.push_back({"capture", "GPU ms reported by the capture (" + list + ")"});
  }
  return clocks;
}

// A pair's time on a clock: median, p5 and p95; NaN where the pair has no time on it.
struct ClockTime {
  double ms = kNaN, lo = kNaN, hi = kNaN;
};
ClockTime timeOn(const PairResult& pair, const std::string& clock) {
  if (clock == "cpu" || clock == "capture" || clock == "process") {
    if (pair.clock() != clock) return {};
    return {timingOf(pair, "msMedian"), timingOf(pair, "msP5"), timingOf(pair, "msP95")};  // msP5: results schema 2
  }
  const std::string device = clock.substr(4);  // "gpu:<device>"
  const json& timing = pair.timing();
  if (!timing.contains("gpuPredicted") || !timing["gpuPredicted"].is_object()) return {};
  json d;
  for (const json& row : timing["gpuPredicted"].value("devices", json::array()))
    if (row.is_object() && row.value("device", "") == device) d = row;
  if (!d.is_object()) return {};
  auto num = [&](const char* k) { return d.contains(k) && d[k].is_number() ? d[k].get<double>() : kNaN; };
  return {num("msMedian"), num("msP5"), num("msP95")};
}

// A pair's point on the chart: error with its bar, time with its p5-p95 bar, and the parameters.
json speedPoint(const PairResult& pair, const ErrorAxis& axis, const std::string& clock) {
  const ClockTime t = timeOn(pair, clock);
  json v = axisValue(pair, axis);
  if (v.is_null() || !std::isfinite(t.ms)) return nullptr;
  v["label"] = pair.label;
  v["params"] = pair.params;
  v["ms"] = t.ms;
  v["msLo"] = std::isfinite(t.lo) ? json(t.lo) : json(nullptr);
  v["msHi"] = std::isfinite(t.hi) ? json(t.hi) : json(nullptr);
  // Disocclusion rays (reengine), gradient samples (asvgf): the paths a denoiser read beyond the
  // frame's and, on the CPU axis, their equivalent tracing time, drawn as a bar beside its own
  // time: its median, as the time's. The model prices no tracing, so a GPU axis keeps only the
  // "+paths" mark.
  if (const auto found = pair.summary.find("tracingMs");
      clock == "cpu" && found != pair.summary.end() && std::isfinite(found->second.median))
    v["tracingMs"] = found->second.median;
  if (const auto found = pair.summary.find("extraRaysPerPixel");
      found != pair.summary.end() && std::isfinite(found->second.mean))
    v["extraRaysPerPixel"] = found->second.mean;
  if (const json& oracle = pair.part("oracleLayers"); oracle.is_array() && !oracle.empty())
    v["oracleLayers"] = oracle;  // named "(oracle)" on the chart, as in the rankings
  return v;
}

}  // namespace

namespace {

// One clock's charts: per scene and all scenes, per error axis.
json speedView(const RunResults& results, const std::vector<std::string>& scenes, const std::vector<std::string>& labels,
               const std::string& clock) {
  json out = json::object();
  json perScene = json::object();
  std::map<std::string, std::map<std::string, std::map<std::string, json>>> byAxis;
  for (const PairResult& pair : results.pairs)
    for (const ErrorAxis& axis : kErrorAxes) {
      json v = speedPoint(pair, axis, clock);
      if (!v.is_null()) byAxis[axis.key][pair.scene][pair.label] = v;
    }
  for (const std::string& scene : scenes) {
    json axes = json::object();
    for (const ErrorAxis& axis : kErrorAxes) {
      std::vector<json> points;
      for (const std::string& label : labels)
        if (byAxis[axis.key][scene].count(label)) points.push_back(byAxis[axis.key][scene][label]);
      if (!points.empty()) axes[axis.key] = speedScope(points, false);
    }
    perScene[scene] = axes;
  }
  out["scenes"] = perScene;
  // Contenders with no time on this clock (another device's, none recorded, or nothing counted to
  // price): named under the chart with the clock they have, never drawn on this axis.
  json elsewhere = json::array();
  for (const PairResult& pair : results.pairs)
    if (pair.ok() && !std::isfinite(timeOn(pair, clock).ms)) {
      const json& timing = pair.timing();
      std::string source = timing.value("msSource", "");
      if (clock.rfind("gpu:", 0) == 0 && pair.clock() == "cpu")
        source = "no GPU traffic counted (" + source + ")";
      elsewhere.push_back({{"scene", pair.scene}, {"label", pair.label},
                           {"ms", timing.contains("msMedian") ? timing["msMedian"] : json(nullptr)},
                           {"source", source}});
    }
  out["otherClocks"] = elsewhere;
  // All scenes: statistics' overall score on the axis's metric (relMSE: the run's "overall"; the
  // others: "overallByMetric"), with its interval -- the one score the printout shows too, never a
  // second one computed here. A point's time is the label's mean over the scenes it ran on.
  json all = json::object();
  for (const ErrorAxis& axis : kErrorAxes) {
    const OverallRanking* overall = nullptr;
    if (const auto& st = results.statistics; st && axis.overall == st->rankedOn && st->overall) {
      overall = &*st->overall;
    } else if (st) {
      const auto it = st->overallByMetric.find(axis.overall);
      if (it != st->overallByMetric.end()) overall = &it->second;
    }
    if (!overall) continue;
    auto& table = byAxis[axis.key];
    // The scenes the overall score covers: those where a ranked method has a value on this axis (a
    // capture without a reference has none, and is in no one's score). A point is complete when it
    // covers all of them.
    size_t covered = 0;
    for (const std::string& scene : scenes)
      covered +=
          std::any_of(overall->ranking.begin(), overall->ranking.end(),
                      [&](const RankedMethod& r) { return table[scene].count(r.label) > 0; });
    std::vector<json> points;
    for (const RankedMethod& r : overall->ranking) {
      const std::string& label = r.label;
      if (!std::isfinite(r.value)) continue;
      double ms = 0, msLo = 0, msHi = 0, tracing = 0;
      size_t n = 0, nLo = 0, nHi = 0, nTracing = 0;
      json params;
      for (const std::string& scene : scenes) {
        auto it = table[scene].find(label);
        if (it == table[scene].end()) continue;
        const json& v = it->second;
        ms += v["ms"].get<double>();
        if (v["msLo"].is_number()) msLo += v["msLo"].get<double>(), ++nLo;
        if (v["msHi"].is_number()) msHi += v["msHi"].get<double>(), ++nHi;
        if (v.contains("tracingMs")) tracing += v["tracingMs"].get<double>(), ++nTracing;
        params = v["params"];
        ++n;
      }
      if (n == 0) continue;
      const double k = double(n), score = r.value;
      const bool hasCi = r.ci.valid();
      json point = {{"label", label},
                    {"params", params},
                    {"error", score},
                    {"lo", hasCi ? r.ci.lo : score},
                    {"hi", hasCi ? r.ci.hi : score},
                    {"ms", ms / k},
                    {"msLo", nLo == n ? json(msLo / k) : json(nullptr)},
                    {"msHi", nHi == n ? json(msHi / k) : json(nullptr)},
                    {"scenes", n},
                    {"complete", n == covered}};
      if (nTracing == n) point["tracingMs"] = tracing / k;  // the mean like its time's
      if (std::isfinite(r.extraPathsPerPixel)) point["extraRaysPerPixel"] = r.extraPathsPerPixel;
      if (!r.oracleLayers.empty()) point["oracleLayers"] = r.oracleLayers;
      points.push_back(std::move(point));
    }
    if (points.empty()) continue;
    json scope = speedScope(points, true);
    scope["normalisation"] = overall->normalisation;
    scope["baseline"] = overall->baseline;
    scope["sceneCount"] = covered;
    scope["source"] = "statistics";
    all[axis.key] = scope;
  }
  out["all"] = all;
  return out;
}

// Every clock's charts, and the clocks' titles (the page's time-axis selector).
json speedData(const RunResults& results, const std::vector<std::string>& scenes, const std::vector<std::string>& labels) {
  json out = {{"clocks", json::array()}, {"views", json::object()}};
  for (const SpeedClock& c : speedClocks(results, scenes)) {
    out["clocks"].push_back({{"key", c.key}, {"title", c.title}});
    if (c.orderTolerance > 0) out["clocks"].back()["orderTolerance"] = c.orderTolerance;
    out["views"][c.key] = speedView(results, scenes, labels, c.key);
  }
  // The 1080p predictions are priced from the run's own passes: à-trous iterations its footprint
  // skipped at this resolution run at 1080p and are priced as that frame runs them, but their
  // data-dependent taps are this sequence's; the page says which methods have how many.
  // The fewest and most per label: a run's scenes of other sizes skip more or fewer.
  std::map<std::string, std::pair<int, int>> skipped;
  for (const PairResult& pair : results.pairs)
    if (const json& timing = pair.timing();
        timing.contains("gpuPredicted") && timing["gpuPredicted"].is_object()) {
      const int n = timing["gpuPredicted"].value("skippedHere", 0);
      auto [it, first] = skipped.try_emplace(pair.label, n, n);
      if (!first) it->second = {std::min(it->second.first, n), std::max(it->second.second, n)};
    }
  std::erase_if(skipped, [](const auto& s) { return s.second.second == 0; });
  if (!skipped.empty()) {
    std::string list;
    bool ranges = false;
    for (const auto& [label, n] : skipped) ranges = ranges || n.first != n.second;
    for (const auto& [label, n] : skipped)
      list += (list.empty() ? "" : ", ") + label + " " +
              (n.first == n.second ? std::to_string(n.first)
                                   : std::to_string(n.first) + "-" + std::to_string(n.second));
    out["gpuSkipped"] =
        "At this run's resolution the footprint skipped passes (à-trous steps below half a pixel, "
        "mip levels of a scaled chain) that a 1080p frame runs; the prediction prices them as "
        "that frame would run them: " +
        list + " per frame (" + (ranges ? "a range: fewer on the larger scenes; " : "") +
        "`arena bench gpu-model` times a 1080p frame's own passes). ";
  }
  return out;
}

// The rankings the tables show: the run's own (metrics/statistics: ranks with ties from paired
// differences) when present; else, for older runs, ranks by mean relMSE with ties unknown.
json rankingData(const RunResults& results, const std::vector<std::string>& scenes) {
  // `statistics`: whether the run has paired statistics at all (a scene absent from them is not
  // ranked; a run without them is an older one, ranked by means with ties unknown).
  json out = {{"scenes", json::object()},
              {"overall", nullptr},
              {"statistics", results.statistics.has_value()}};
  for (const std::string& scene : scenes) {
    const SceneStatistics* found = nullptr;
    if (results.statistics)
      if (const auto it = results.statistics->scenes.find(scene); it != results.statistics->scenes.end())
        found = &it->second;
    if (found) {
      const SceneStatistics& st = *found;
      // The ranking and its counts; every pair's difference is left out (tiedWith says enough).
      json r = st.ranking.toJson();
      r.erase("pairs");
      r["tiesKnown"] = true;
      // Per ranked metric, the methods at rank 1 (none resolved better; ties among them included):
      // the summary table marks these, and only these, as the best of a column. relMseCorrected
      // shares relMse's (the reference's floor subtracted from every method leaves each paired
      // difference as it was). A ranking of one method has none.
      json first = json::object();
      auto addFirst = [&](const std::string& metric, const SceneRanking& ranking) {
        if (ranking.ranking.size() < 2) return;
        json labels = json::array();
        for (const RankedMethod& m : ranking.ranking)
          if (m.rank == 1) labels.push_back(m.label);
        first[metric] = labels;
      };
      addFirst(st.ranking.metric, st.ranking);
      if (st.ranking.metric == "relMse") addFirst("relMseCorrected", st.ranking);
      for (const auto& [metric, ranking] : st.byMetric) addFirst(metric, ranking);
      r["firstByMetric"] = first;
      // Events and cuts: per figure, who is ranked first with whom tied (the ghosting panel marks
      // the best with ties, metrics/ghosting_intervals).
      st.forEachEvent([&](const EventStatistics& e, bool cut) {
        json figures = json::object();
        for (const auto& [figure, ranking] : e.byFigure) {
          json ranks = json::array();
          for (const RankedMethod& m : ranking.ranking)
            ranks.push_back({{"label", m.label}, {"rank", m.rank}, {"tiedWith", m.tiedWith}});
          figures[figure] = {{"ranking", ranks},
                             {"resolvedPairs", ranking.resolvedPairs},
                             {"totalPairs", ranking.pairs.size()}};
        }
        r[cut ? "cuts" : "events"].push_back({{"eventFrame", e.eventFrame}, {"byFigure", figures}});
      });
      out["scenes"][scene] = r;
      continue;
    }
    std::vector<std::pair<double, std::string>> order;
    for (const PairResult& pair : results.pairs)
      if (pair.scene == scene && pair.ok())
        if (const SummaryMean m = pair.mean("relMse"); m.present()) order.push_back({m.mean, pair.label});
    if (order.empty()) continue;
    std::stable_sort(order.begin(), order.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    json ranking = json::array();
    for (size_t i = 0; i < order.size(); ++i)
      ranking.push_back({{"label", order[i].second},
                         {"rank", i + 1},
                         {"mean", order[i].first},
                         {"tiedWith", json::array()}});
    out["scenes"][scene] = {{"metric", "relMse"}, {"ranking", ranking}, {"tiesKnown", false}};
  }
  if (results.statistics && results.statistics->overall) {
    out["overall"] = results.statistics->overall->toJson();
    out["overall"]["tiesKnown"] = true;
    // The overall scores on the other metrics that declare one (1 - SSIM, the FLIPs), ranked with
    // ties as relMSE's: the printout's table of them, with their intervals.
    for (const auto& [metric, o] : results.statistics->overallByMetric) {
      if (o.ranking.empty()) continue;
      out["overallByMetric"][metric] = o.toJson();
      out["overallByMetric"][metric]["tiesKnown"] = true;
    }
  }
  return out;
}

// A parameter's value as its label writes it ("2", not "2.0").
std::string valueText(const json& v) {
  if (v.is_number_float()) return shortestText(v.get<double>());
  return v.is_string() ? v.get<std::string>() : v.dump();
}

// The paired difference a - b in `ranking` (its pairs are stored one way round), oriented a - b;
// null when the ranking holds no finite one.
json pairedIn(const SceneRanking* ranking, const std::string& a, const std::string& b) {
  if (!ranking) return nullptr;
  for (const SceneRanking::Pair& d : ranking->pairs) {
    const bool forward = d.a == a && d.b == b;
    const bool backward = d.a == b && d.b == a;
    if (!forward && !backward) continue;
    if (!std::isfinite(d.d.diff)) return nullptr;
    const double sign = forward ? 1.0 : -1.0;
    json out = {{"diff", sign * d.d.diff}, {"resolved", d.d.resolved()}};
    if (d.d.ci.valid())
      out["ci95"] = forward ? json::array({d.d.ci.lo, d.d.ci.hi}) : json::array({-d.d.ci.hi, -d.d.ci.lo});
    return out;
  }
  return nullptr;
}

// The paired difference a - b of `metric` on `scene` from the run's statistics (relMSE's in the
// scene's pairs, the other ranked metrics' in byMetric), oriented a - b; null when not there.
json pairedDifference(const RunResults& results, const std::string& scene,
                      const std::string& metric, const std::string& a, const std::string& b) {
  // relMseCorrected's paired difference is relMSE's: the reference's floor, subtracted from both
  // methods' every frame, cancels in it (as the summary table's firstByMetric has it).
  // dssim is 1 - SSIM frame by frame and tile by tile: its paired difference is SSIM's, negated
  // (the statistics rank SSIM only; the ablation read dssim "no interval" beside SSIM's).
  if (metric == "dssim") {
    json d = pairedDifference(results, scene, "ssim", a, b);
    if (!d.is_object()) return d;
    d["diff"] = -d["diff"].get<double>();
    if (d.contains("ci95"))
      d["ci95"] = json::array({-d["ci95"][1].get<double>(), -d["ci95"][0].get<double>()});
    return d;
  }
  const std::string ranked = metric == "relMseCorrected" ? "relMse" : metric;
  return pairedIn(results.statistics ? results.statistics->ranking(scene, ranked) : nullptr, a, b);
}

// An event-window figure the statistics rank on a scene (metrics/ghosting_intervals), named as
// results.db names it: "ghosting@<frame>.<figure>", "cut@<frame>.<figure>" (all lower is better).
struct EventFigure {
  std::string name, figure;
  int frame = -1;
  bool cut = false;
  const SceneRanking* ranking = nullptr;
};
std::vector<EventFigure> eventFigures(const RunResults& results, const std::string& scene) {
  std::vector<EventFigure> out;
  if (!results.statistics) return out;
  auto st = results.statistics->scenes.find(scene);
  if (st == results.statistics->scenes.end()) return out;
  st->second.forEachEvent([&](const EventStatistics& e, bool cut) {
    for (const auto& [figure, ranking] : e.byFigure)
      out.push_back(
          {std::string(cut ? "cut@" : "ghosting@") + std::to_string(e.eventFrame) + "." + figure,
           figure, e.eventFrame, cut, &ranking});
  });
  return out;
}

// Where a method never settled within an event's window, its response is the window's length and
// its peak excess and ghost energy are read against frames still lagging: bounds, not
// measurements (the printout's "never settled" note). The note for such a figure, else "".
std::string unsettledNote(const PairResult& pair, const EventFigure& f) {
  if (f.cut ||
      (f.figure != "responseFrames" && f.figure != "peakExcess" && f.figure != "ghostEnergy"))
    return "";
  for (const json& e : pair.part("ghosting").is_array() ? pair.part("ghosting") : json::array())
    if (e.value("eventFrame", -1) == f.frame && e.value("settled", json()).is_boolean() &&
        !e["settled"].get<bool>())
      return pair.label + " never settled within the window: its " + f.figure +
             (f.figure == "responseFrames"
                  ? " is the window's length, a lower bound"
                  : " is read against frames still lagging, a lower bound");
  return "";
}

// The oracle layers a pair read, joined ("specHitDistMirror"), or "" where it read none.
std::string oracleLayersText(const PairResult& pair) {
  std::string text;
  if (const json& layers = pair.part("oracleLayers"); layers.is_array())
    for (const json& l : layers) text += (text.empty() ? "" : ", ") + l.get<std::string>();
  return text;
}

// The run's checksum of a pair's outputs (every frame's bits), or "" where it recorded none.
std::string outputChecksumOf(const PairResult& pair) {
  const json& sum = pair.detail.value("outputChecksum", json());
  return sum.is_string() ? sum.get<std::string>() : "";
}

// A method's own value of an event figure (its pairs[].ghosting or .cuts entry), NaN where none:
// what the ablation and points.csv show, without an interval, where the figure's ranking left the
// method out for want of one (a changed region too small to resample).
double pointFigure(const PairResult& pair, const EventFigure& f) {
  const json& entries = pair.part(f.cut ? "cuts" : "ghosting");
  if (!entries.is_array()) return kUndefined;
  for (const json& e : entries)
    if (e.value("eventFrame", -1) == f.frame && e.contains(f.figure) && e[f.figure].is_number())
      return e[f.figure].get<double>();
  return kUndefined;
}

// The reason `ranking` gives for leaving `label` out, "" where it does not (the run's labels read
// a reason from results that stored only its text).
std::string exclusionReason(const SceneRanking& ranking, const std::string& label,
                            const RunResults& results) {
  if (!ranking.leftOut.empty()) return ranking.reasonFor(label, {});  // the list needs no labels
  std::vector<std::string> labels;
  for (const PairResult& p : results.pairs) labels.push_back(p.label);
  return ranking.reasonFor(label, labels);
}

// Why an event's figure ranks nobody on a scene (every method left out: a changed region too small
// to resample, no per-tile data): "ghosting@9.lagEnergy on moving_light_shadow: <reason>", each
// distinct reason once.
std::vector<std::string> unrankedFigures(const RunResults& results, const std::string& scene) {
  std::vector<std::string> out;
  for (const EventFigure& f : eventFigures(results, scene)) {
    if (!f.ranking->ranking.empty() || f.ranking->excluded.empty()) continue;
    std::vector<std::string> reasons;
    for (const PairResult& p : results.pairs)
      if (const std::string why = exclusionReason(*f.ranking, p.label, results);
          p.scene == scene && !why.empty() &&
          std::find(reasons.begin(), reasons.end(), why) == reasons.end())
        reasons.push_back(why);
    std::string text;
    for (const std::string& why : reasons) text += (text.empty() ? "" : " / ") + why;
    out.push_back(f.name + " on " + scene + ": " + (text.empty() ? f.ranking->excluded : text));
  }
  return out;
}

// A method's value in a ranking, or NaN.
double rankedValue(const SceneRanking& ranking, const std::string& label) {
  for (const RankedMethod& m : ranking.ranking)
    if (m.label == label) return m.value;
  return kUndefined;
}

// What several matched paired differences show together: "identical outputs" when every match's
// two outputs are the same bits (no difference to find: their tie is no finding), "not judged" when
// none can show a change (responses neither method settled in), else over the others: "better"
// or "worse" when every one is resolved that way, "mixed" when resolved both ways, "partly better"
// or "partly worse" when some are resolved one way and the rest not, "tie" when none is, "no
// interval" when some has none.
std::string ablationVerdict(size_t matches, size_t intervals, size_t better, size_t worse,
                            size_t identical, size_t unjudged) {
  if (identical + unjudged == matches) return identical > 0 ? "identical outputs" : "not judged";
  matches -= unjudged;
  if (intervals < matches) return "no interval";
  if (better == matches) return "better";
  if (worse == matches) return "worse";
  if (better > 0 && worse > 0) return "mixed";
  if (better > 0) return "partly better";
  if (worse > 0) return "partly worse";
  return "tie";
}

// A tie whose per-frame differences (`a` - `b`, frames after the warm-up) hold one sign on every
// frame: said, since the interval also resamples the image's tiles, and an effect held in a few
// of them (an edge term's, at its edges) is judged across the image's regions. Empty otherwise, and
// under 8 frames. No p-value: a sequence's frames are correlated (a history carries over), so
// counting signs is no test.
std::string oneSignNote(const PairResult& a, const PairResult& b, const std::string& metric,
                        int warmup) {
  const json &fa = a.part("frames"), &fb = b.part("frames");
  if (!fa.is_array() || !fb.is_array()) return "";
  std::map<int, double> other;
  for (const json& f : fb)
    if (f.is_object() && f.contains(metric) && f[metric].is_number())
      other[f.value("frame", -1)] = f[metric].get<double>();
  int n = 0, above = 0, below = 0;
  for (const json& f : fa) {
    if (!f.is_object() || !f.contains(metric) || !f[metric].is_number()) continue;
    const int t = f.value("frame", -1);
    const auto it = other.find(t);
    if (t < warmup || it == other.end()) continue;
    const double d = f[metric].get<double>() - it->second;
    ++n;
    above += d > 0;
    below += d < 0;
  }
  if (n < 8 || (above != n && below != n)) return "";
  return "a tie, yet the difference is " + std::string(above == n ? "positive" : "negative") +
         " on all " + std::to_string(n) +
         " frames after the warm-up: the interval also resamples the image's tiles, so an effect "
         "held in a few of them (an edge term's, say) is judged across the image's regions, and "
         "'tie' means not resolved there, not no effect (frames are correlated: this count is no "
         "test)";
}

// The ablation of a sweep: for each grid parameter and each of its values after the first, the
// change of every metric against the pair that differs only in that parameter (set to the first
// value). Per scene, a ranked metric's change is the run's paired difference (statistics: the same
// frames and tiles, with its interval and whether it is resolved); other metrics' the difference of
// the means. The event-window figures the statistics rank (lag, response, ghosting per scripted
// event and camera cut) are changes too, named as results.db names them ("figures"). Over all
// scenes: the mean of the per-scene changes (no interval). A row's `judged` says per metric what
// the matched pairs' intervals show together (ablationVerdict); where a value is matched under
// several settings of the other parameters on a scene, `byMatch` lists each match ("given" those
// settings) with its own paired difference: an effect that holds under one setting only (an
// interaction) shows there.
// The caveats the run recorded on a scene's results, in a line: its reference short of the goal
// (scenes.<s>.referenceQuality), and too few frames after the warm-up (its warning's first
// clause). Empty when there are none.
std::string sceneCaveat(const RunResults& results, const std::string& scene) {
  if (!results.scenes.is_object() || !results.scenes.contains(scene)) return "";
  const json& info = results.scenes[scene];
  std::vector<std::string> parts;
  if (const json& q = info.value("referenceQuality", json());
      q.is_object() && q.value("meets", true) == false && q.value("ratio", json()).is_number())
    parts.push_back("reference goal not met (noise floor / best corrected relMSE " +
                    shortestText(std::round(q["ratio"].get<double>() * 1000) / 1000) + ", goal " +
                    shortestText(q.value("goal", 0.1)) + ")");
  for (const json& w : info.value("warnings", json::array()))
    if (w.is_string() && w.get<std::string>().rfind("only ", 0) == 0)
      parts.push_back(w.get<std::string>().substr(0, w.get<std::string>().find(':')));
  std::string line;
  for (const std::string& p : parts) line += (line.empty() ? "" : "; ") + p;
  return line;
}

json ablationData(const RunResults& results) {
  if (!results.sweep.is_object()) return nullptr;
  const json& sweep = results.sweep;
  const std::string denoiser = sweep.value("denoiser", "");
  // The grid's own points, in the grid's order (its labels, which the sweep records): not a
  // baseline of the same denoiser, and not in whatever order the pairs were stored (a merge of
  // shards given in another order put the last value first). A sweep recorded without its labels
  // (an older run): the denoiser's pairs, in their order.
  std::vector<const PairResult*> pairs;
  if (const json labels = sweep.value("labels", json()); labels.is_array()) {
    for (const json& label : labels)
      for (const PairResult& p : results.pairs)
        if (label.is_string() && p.label == label.get<std::string>() && p.denoiser == denoiser &&
            p.ok())
          pairs.push_back(&p);
    // Without the grid's first point (failed on every scene) no axis has its first value to be
    // compared with: no rows rather than rows against the second value.
    if (!labels.empty() && (pairs.empty() || pairs.front()->label != labels.front())) pairs.clear();
  } else {
    for (const PairResult& p : results.pairs)
      if (p.denoiser == denoiser && p.ok()) pairs.push_back(&p);
  }
  std::vector<std::string> metrics, figures;
  std::map<std::string, bool> lowerIsBetter;
  for (const MetricDefinition* m : metricCatalog()) {
    metrics.push_back(m->name);
    lowerIsBetter[m->name] = m->lowerIsBetter();
  }
  // Per scope (a scene, or "" for all scenes) and metric: the matched changes, absolute and
  // relative, and how many of them carry a paired difference, resolved each way.
  struct Changes {
    std::vector<double> delta, relative;
    size_t intervals = 0, better = 0, worse = 0, identical = 0, unjudged = 0;
    std::set<std::string> scenes;  // the scenes whose matches it holds
    json lastPaired;  // a single match's paired difference (the row's, when it is the only one)
  };
  // The all-scenes rows name the scenes whose own rows carry a caveat.
  std::string caveatOfAllScenes;
  std::set<std::string> withCaveat;
  {
    std::set<std::string> scenesOfPairs;
    for (const PairResult* p : pairs) scenesOfPairs.insert(p->scene);
    for (const std::string& s : scenesOfPairs)
      if (!sceneCaveat(results, s).empty()) withCaveat.insert(s);
    if (!withCaveat.empty())
      caveatOfAllScenes = "caveats on " + labelList(withCaveat) + " (their rows say which)";
  }
  json rows = json::array();
  for (auto g = sweep["grid"].begin(); g != sweep["grid"].end(); ++g) {
    const std::string name = g.key();
    // Values in order of first appearance: the grid's Cartesian product has every axis starting at
    // its first value, so the first point carries the first value of each.
    std::vector<json> values;
    for (const PairResult* p : pairs)
      if (p->params.contains(name) && std::find(values.begin(), values.end(), p->params[name]) == values.end())
        values.push_back(p->params[name]);
    if (values.size() < 2) continue;
    for (size_t vi = 1; vi < values.size(); ++vi) {
      std::map<std::string, std::map<std::string, Changes>> changes;  // scope -> metric
      std::map<std::string, std::map<std::string, json>> paired;  // scene -> metric -> difference
      std::map<std::string, json> byMatch;                        // scene -> its matches
      std::map<std::string, std::map<std::string, std::string>> notes;  // scene -> metric -> bound
      std::map<std::string, size_t> matched;
      // scope -> "label (layers)" of each compared point that read oracle data.
      std::map<std::string, std::set<std::string>> oracles;
      // Matches whose two outputs are those of a match already counted, bit for bit (another
      // grid parameter without effect there): counted once, or one comparison measured twice read
      // "matches 2, resolved 2" (a statistician's audit).
      std::map<std::string, std::set<std::pair<std::string, std::string>>> outputsSeen;
      std::map<std::string, size_t> repeated;
      for (const PairResult* p : pairs) {
        if (p->params.value(name, json()) != values[vi]) continue;
        json want = p->params;
        want[name] = values[0];
        for (const PairResult* q : pairs) {
          if (q->scene != p->scene || q->params != want) continue;
          const std::string& scene = p->scene;
          const std::string pSum = outputChecksumOf(*p), qSum = outputChecksumOf(*q);
          if (!pSum.empty() && !qSum.empty() && !outputsSeen[scene].insert({pSum, qSum}).second) {
            ++repeated[scene];
            ++repeated[""];
            break;
          }
          ++matched[scene];
          ++matched[""];
          for (const PairResult* x : {p, q})
            if (const std::string named = oracleLayersText(*x); !named.empty())
              for (const std::string& scope : {scene, std::string()})
                oracles[scope].insert(x->label + " (" + named + ")");
          // The other grid parameters' settings under which the two differ only in this one.
          std::string given;
          for (auto other = sweep["grid"].begin(); other != sweep["grid"].end(); ++other)
            if (other.key() != name)
              given += (given.empty() ? "" : ",") + other.key() + "=" +
                       valueText(p->params.value(other.key(), json()));
          json match = {{"given", given},
                        {"delta", json::object()},
                        {"relative", json::object()},
                        {"paired", json::object()},
                        {"judged", json::object()}};
          // The two outputs the same bits on every frame (the run's checksums): every measured
          // difference is 0 with nothing to resolve, a tie that is no finding.
          const bool identical = !pSum.empty() && pSum == qSum;
          if (identical) match["identicalOutputs"] = true;
          // `unjudged`: no change can show (a response neither method settled in).
          auto record = [&](const std::string& m, double delta, double b, const json& d, bool lower,
                            std::string note = "", bool unjudged = false) {
            if (!std::isfinite(delta) || !std::isfinite(b)) return;
            // Relative to a base of 0 (a response of 0 frames, a flicker of 0) there is no
            // relative change: none, rather than the change over 1e-12 (+1.9e15 %).
            const double relative = std::abs(b) > 1e-12 ? delta / std::abs(b) : kUndefined;
            const bool same = identical && delta == 0;
            if (same)
              note =
                  "identical outputs (bit for bit, every frame): no difference to find, so "
                  "this tie is no finding";
            match["delta"][m] = delta;
            match["relative"][m] = std::isfinite(relative) ? json(relative) : json(nullptr);
            if (!note.empty()) {
              match["notes"][m] = note;
              notes[scene][m] = note;
            }
            const bool resolved = d.is_object() && d["resolved"].get<bool>() && delta != 0;
            match["judged"][m] = same                   ? "identical outputs"
                                 : unjudged             ? "not judged"
                                 : !d.is_object()       ? "no interval"
                                 : !resolved            ? "tie"
                                 : (delta < 0) == lower ? "better"
                                                        : "worse";
            if (d.is_object()) {
              paired[scene][m] = d;
              match["paired"][m] = d;
            }
            for (const std::string& scope : {scene, std::string()}) {
              Changes& c = changes[scope][m];
              c.delta.push_back(delta);
              c.scenes.insert(scene);
              if (std::isfinite(relative)) c.relative.push_back(relative);
              if (d.is_object()) c.lastPaired = d;
              c.identical += same;
              c.unjudged += unjudged && !same;
              if (!d.is_object() || (unjudged && !same)) continue;
              ++c.intervals;
              if (d["resolved"].get<bool>() && delta != 0)
                ++((delta < 0) == lower ? c.better : c.worse);
            }
          };
          for (const std::string& m : metrics) {
            if (!p->summary.count(m) || !q->summary.count(m)) continue;
            // Time as the rest of the report reads it, the median frame time: the mean follows a
            // few slow frames (a grid point read +93% slower by its mean, +6% by its median).
            const bool time = m == "ms";
            const double b = time ? timingOf(*q, "msMedian") : q->summary.at(m).mean;
            const json d = time ? json() : pairedDifference(results, scene, m, p->label, q->label);
            const double delta = time            ? timingOf(*p, "msMedian") - b
                                 : d.is_object() ? d["diff"].get<double>()
                                                 : p->summary.at(m).mean - b;
            const bool tie = d.is_object() && !(d["resolved"].get<bool>() && delta != 0);
            record(m, delta, b, d, lowerIsBetter[m],
                   tie && !identical ? oneSignNote(*p, *q, m, results.settings.warmup()) : "");
          }
          for (const EventFigure& f : eventFigures(results, scene)) {
            const json d = pairedIn(f.ranking, p->label, q->label);
            std::string note = unsettledNote(*p, f);
            const bool pUnsettled = !note.empty();
            const std::string other = unsettledNote(*q, f);
            if (!other.empty()) note += (note.empty() ? "" : "; ") + other;
            // Neither settled: both responses are cut at the window's end, no change can show
            // (compare's "not judged").
            const bool unjudged = f.figure == "responseFrames" && pUnsettled && !other.empty();
            // Left out of the figure's ranking (no interval could be drawn): the two methods'
            // own values, their difference without an interval, the reason in the note.
            const double a = d.is_object() ? kUndefined : pointFigure(*p, f),
                         b = d.is_object() ? rankedValue(*f.ranking, q->label) : pointFigure(*q, f);
            if (!d.is_object() && !(std::isfinite(a) && std::isfinite(b))) continue;
            if (!d.is_object()) {
              const std::string why = exclusionReason(*f.ranking, p->label, results);
              note += (note.empty() ? "" : "; ") + std::string("not ranked, so no interval") +
                      (why.empty() ? "" : ": " + why);
            } else if (unjudged) {
              note +=
                  ": both are cut off at the window's end, so no change can show (not judged; "
                  "a longer sequence after the event measures it)";
            } else if (!note.empty()) {
              note += ": the difference is bounded, not measured";
            }
            if (std::find(figures.begin(), figures.end(), f.name) == figures.end())
              figures.push_back(f.name);
            record(f.name, d.is_object() ? d["diff"].get<double>() : a - b, b, d, true, note,
                   unjudged);
          }
          byMatch[scene].push_back(std::move(match));
          break;
        }
      }
      // One scene: its row says all the "all scenes" row would, with the paired interval.
      if (changes.size() == 2) changes.erase("");
      for (const auto& [scope, byMetric] : changes) {
        json d = json::object(), r = json::object(), verdicts = json::object();
        json single = json::object();  // metrics matched once over all scenes: that interval
        for (const auto& [m, c] : byMetric) {
          const size_t n = c.delta.size();
          d[m] = std::accumulate(c.delta.begin(), c.delta.end(), 0.0) / double(n);
          r[m] = c.relative.empty()
                     ? json(nullptr)
                     : json(std::accumulate(c.relative.begin(), c.relative.end(), 0.0) /
                            double(c.relative.size()));
          verdicts[m] = {{"verdict", ablationVerdict(n, c.intervals, c.better, c.worse, c.identical,
                                                     c.unjudged)},
                         {"matches", n},
                         {"intervals", c.intervals},
                         {"resolved", c.better + c.worse}};
          if (scope.empty() && n == 1 && c.lastPaired.is_object()) single[m] = c.lastPaired;
        }
        json row = {{"parameter", name},
                    {"value", valueText(values[vi])},
                    {"versus", valueText(values[0])},
                    {"scene", scope.empty() ? json(nullptr) : json(scope)},
                    {"matched", matched[scope]},
                    {"delta", d},
                    {"relative", r},
                    {"judged", verdicts}};
        if (!scope.empty() && matched[scope] == 1) {
          row["given"] = byMatch[scope][0]["given"];  // one match: the row is that match
          if (paired.count(scope)) row["paired"] = paired[scope];
        }
        if (!scope.empty() && matched[scope] > 1) row["byMatch"] = byMatch[scope];
        if (scope.empty() && !single.empty()) row["paired"] = single;
        // A match's note is its own (byMatch): on a row of several matches it would speak for one
        // of them beside a verdict of all ("partly worse" beside "a tie, yet ...").
        if (!scope.empty() && matched[scope] == 1 && notes.count(scope))
          row["notes"] = notes[scope];
        // What the run said of the scene's results travels with its rows (a table copied into a
        // paper lost it): a reference short of its goal, too few frames after the warm-up.
        // A compared point that read oracle data is not on equal terms: said with the row.
        std::string oracle;
        if (oracles.count(scope))
          oracle = "oracle data read by " + labelList(oracles[scope]) +
                   ", which a real-time engine would not have";
        std::string sceneWords = scope.empty() ? caveatOfAllScenes : sceneCaveat(results, scope);
        if (repeated.count(scope))
          sceneWords += (sceneWords.empty() ? "" : "; ") + std::to_string(repeated[scope]) +
                        (repeated[scope] == 1 ? " further match gave" : " further matches gave") +
                        " the two outputs of a match counted, bit for bit (another parameter "
                        "without effect there): counted once";
        if (const std::string caveat = sceneWords.empty() ? oracle
                                       : oracle.empty()   ? sceneWords
                                                          : sceneWords + "; " + oracle;
            !caveat.empty())
          row["caveat"] = caveat;
        // Over all scenes, each metric's line names only the caveated scenes it holds a change
        // of (an event's figure exists on its scene alone): ablation.csv's note per line.
        if (scope.empty() && (!withCaveat.empty() || !oracle.empty())) {
          json byMetricCaveat = json::object();
          for (const auto& [m, c] : byMetric) {
            std::set<std::string> named;
            for (const std::string& sc : c.scenes)
              if (withCaveat.count(sc)) named.insert(sc);
            std::string words = named.empty()
                                    ? std::string()
                                    : "caveats on " + labelList(named) + " (their rows say which)";
            if (!oracle.empty()) words += (words.empty() ? "" : "; ") + oracle;
            byMetricCaveat[m] = words;
          }
          row["caveatByMetric"] = byMetricCaveat;
        }
        rows.push_back(row);
      }
    }
  }
  // The events whose figures rank nobody (so have no column here), with the statistics' reason.
  json unranked = json::array();
  std::set<std::string> scenes;
  for (const PairResult* p : pairs) scenes.insert(p->scene);
  for (const std::string& scene : scenes)
    for (const std::string& line : unrankedFigures(results, scene)) unranked.push_back(line);
  json out = {{"denoiser", denoiser},
              {"grid", sweep["grid"]},
              {"fixed", sweep.value("fixed", json::object())},
              {"figures", figures},
              {"unrankedFigures", unranked},
              {"rows", rows}};
  if (sweep.contains("footprintNote") && sweep["footprintNote"].is_string())
    out["footprintNote"] = sweep["footprintNote"];
  return out;
}

// The frame number of a kept image named <prefix>_NNNN.png, or -1.
int keptFrame(const std::string& file, const std::string& prefix) {
  if (file.size() != prefix.size() + 9 || file.rfind(prefix + "_", 0) != 0 ||
      file.substr(file.size() - 4) != ".png")
    return -1;
  const std::string digits = file.substr(prefix.size() + 1, 4);
  if (!std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return -1;
  return std::stoi(digits);
}

// The image viewer's panels for a scene: only files that exist, so the page never shows a broken
// image (a failed pair, or a run with --flip none or --keep-frames none, has fewer). Frames: every
// frame some image was kept for (`--keep-frames all` keeps them all), with the auto-chosen ones
// and the scene's event frames marked.
json viewerData(const RunResults& results, const std::string& scene, const json& sceneInfo,
                const fs::path& runDir) {
  const std::string sceneDir = sceneInfo.value("images", "images/" + scene);
  std::set<int> kept;
  json panels = json::array();
  auto add = [&](const std::string& kind, const json& label, const std::string& title,
                 const std::string& dir, const char* prefix) {
    json srcs = json::object();
    std::error_code ec;
    std::vector<int> frames;
    for (const auto& e : fs::directory_iterator(runDir / dir, ec)) {
      const int t = keptFrame(e.path().filename().string(), prefix);
      if (t >= 0) frames.push_back(t);
    }
    std::sort(frames.begin(), frames.end());
    for (int t : frames) {
      srcs[std::to_string(t)] = dir + "/" + frameName(prefix, t);
      kept.insert(t);
    }
    if (!srcs.empty())
      panels.push_back({{"kind", kind}, {"label", label}, {"title", title}, {"srcs", srcs}});
  };
  add("reference", nullptr, "reference", sceneDir, "reference");
  add("noisy", nullptr, "noisy input", sceneDir, "noisy");
  for (const PairResult& pair : results.pairs) {
    if (pair.scene != scene || !pair.ok() || !pair.part("images").is_object()) continue;
    const std::string dir = pair.part("images").value("dir", "");
    const std::string& label = pair.label;
    add("output", label, label, dir, "frame");
    add("flip", label, label + " · LDR-FLIP", dir, "flip");
    add("relerr", label, label + " · rel. error", dir, "relerr");
  }
  json frames = json::array();
  const json chosen = sceneInfo.value("chosenFrames", json::array());
  for (int t : kept) {
    json f = {{"frame", t}, {"chosen", std::find(chosen.begin(), chosen.end(), t) != chosen.end()}};
    json events = json::array();
    for (const json& e : sceneInfo.value("events", json::array()))
      if (e.value("frame", -1) == t)
        events.push_back(e.value("kind", std::string("event")) +
                         (e.contains("what") ? std::string(" ").append(e["what"].get<std::string>()) : ""));
    if (!events.empty()) f["events"] = events;
    frames.push_back(f);
  }
  return {{"frames", frames}, {"panels", panels}};
}

// The colour maps of the kept error maps and their scales, for the page's legends (the stops
// live once, in metrics/error_maps).
json colorMapData() {
  auto stops = [](const ColorMap& m) {
    json out = json::array();
    for (const auto& c : m.stops) out.push_back({c[0], c[1], c[2]});
    return out;
  };
  return {
      {"flip",
       {{"name", magmaColorMap().name},
        {"stops", stops(magmaColorMap())},
        {"min", 0},
        {"max", 1},
        {"scale", "linear"},
        {"title", "LDR-FLIP per pixel (0 = no perceived difference, 1 = largest)"}}},
      {"relerr",
       {{"name", viridisColorMap().name},
        {"stops", stops(viridisColorMap())},
        {"min", std::pow(10.0, kRelErrorMapLog10Min)},
        {"max", std::pow(10.0, kRelErrorMapLog10Max)},
        {"scale", "log"},
        {"title", "relative squared error (d − r)² / (r² + 0.01) per pixel, mean of R, G, B"}}}};
}

// Everything a pair row needs in the page, without the per-pass timings (the table shows totals).
json pairData(const PairResult& pair) {
  json p = {{"scene", pair.scene},
            {"denoiser", pair.denoiser},
            {"label", pair.label},
            {"params", pair.params},
            {"status", pair.status}};
  if (!pair.ok()) {
    p["error"] = pair.error;
    return p;
  }
  json summary = json::object();
  for (const auto& [metric, s] : pair.summary) summary[metric] = s.toJson();
  p["summary"] = summary;
  // Outputs of the same bits (a sweep's points a parameter did not reach): the rankings say so.
  if (pair.detail.contains("outputChecksum")) p["outputChecksum"] = pair.detail["outputChecksum"];
  // No state between frames (PairResult::keepsHistory: older results, passthrough by name).
  if (!pair.keepsHistory()) p["keepsHistory"] = false;
  const json& timing = pair.timing();
  p["timing"] = {{"msMedian", timing.value("msMedian", kNaN)},
                 {"msP5", timing.value("msP5", kNaN)},
                 {"msP95", timing.value("msP95", kNaN)},
                 {"msPerMegapixel", timing.value("msPerMegapixel", kNaN)},
                 {"tapsPerPixel", timing.value("tapsPerPixel", kNaN)},
                 {"passes", timing.contains("passes") ? timing["passes"].size() : 0},
                 {"clock", pair.clock()}};
  if (timing.contains("device")) p["timing"]["device"] = timing["device"];
  if (pair.clock() == "process") p["timing"]["device"] = "reported by the process";
  // The cost model's view (docs/gpu-cost.md): the first device's predicted ms and the GPU memory.
  if (timing.contains("gpuPredicted") && timing["gpuPredicted"].is_object()) {
    const json& g = timing["gpuPredicted"];
    const json devices = g.value("devices", json::array());
    if (!devices.empty() && devices[0].is_object()) {
      p["timing"]["gpuMs"] = devices[0].value("msMedian", kNaN);
      p["timing"]["gpuDevice"] = devices[0].value("device", "");
    }
    const json memory = g.value("memory", json::object());
    p["timing"]["gpuPersistentMiB"] = memory.value("persistentMiB", kNaN);
    p["timing"]["gpuWorkingSetMiB"] = memory.value("workingSetMiB", kNaN);
  }
  auto list = [&](const char* key) { return pair.part(key).is_array() ? pair.part(key) : json::array(); };
  p["series"] = seriesColumns(list("frames"));
  // Events and cuts with their figures and intervals; the tile data behind them stays in the run.
  for (const char* kind : {"ghosting", "cuts"}) {
    p[kind] = list(kind);
    for (json& e : p[kind]) e.erase("tiles");
  }
  p["warnings"] = list("warnings");
  return p;
}

// A CSV field (RFC 4180): quoted where it must be.
std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

// A number as CSV writes it: every digit a double holds; empty where it is not finite.
std::string csvNumber(double v) {
  if (!std::isfinite(v)) return std::string();
  if (v == 0) return "0";  // -0 too: a sign without a magnitude is no information
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return std::string(buf);
}

}  // namespace

std::string ablationCsv(const json& ablation) {
  if (!ablation.is_object() || !ablation.contains("rows") || ablation["rows"].empty()) return "";
  const auto number = [](const json& v) {
    return v.is_number() ? csvNumber(v.get<double>()) : std::string();
  };
  std::string csv =
      "parameter,value,versus,given,scene,matched,metric,delta,relative,verdict,matches,intervals,"
      "resolved,ci95Lo,ci95Hi,note\n";
  // One line: a row's (given empty) or one of its matches' (matched 1, its own paired difference).
  auto line = [&](const json& row, const std::string& given, const std::string& scene,
                  const json& matched, const std::string& m, const json& delta,
                  const json& relative, const std::string& verdict, const json& matches,
                  const json& intervals, const json& resolved, const json& ci,
                  const std::string& note) {
    csv +=
        csvField(row["parameter"].get<std::string>()) + "," +
        csvField(row["value"].get<std::string>()) + "," +
        csvField(row["versus"].get<std::string>()) + "," + csvField(given) + "," + csvField(scene) +
        "," + number(matched) + "," + csvField(m) + "," + number(delta) + "," + number(relative) +
        "," + csvField(verdict) + "," + number(matches) + "," + number(intervals) + "," +
        number(resolved) + "," +
        (ci.is_array() && ci.size() == 2 ? number(ci[0]) + "," + number(ci[1]) : std::string(",")) +
        "," + csvField(note) + "\n";
  };
  for (const json& row : ablation["rows"]) {
    const std::string scene =
        row["scene"].is_string() ? row["scene"].get<std::string>() : "all scenes";
    for (auto d = row["delta"].begin(); d != row["delta"].end(); ++d) {
      const std::string& m = d.key();
      const json judged = row["judged"].value(m, json::object());
      const json ci =
          row.value("paired", json::object()).value(m, json::object()).value("ci95", json());
      // The scene's caveat (a reference short of its goal, too few frames) beside the metric's
      // note.
      const auto noted = [&row, &m](const std::string& note) {
        const std::string caveat = row.contains("caveatByMetric")
                                       ? row["caveatByMetric"].value(m, std::string())
                                       : row.value("caveat", "");
        return caveat.empty() ? note : note.empty() ? caveat : caveat + "; " + note;
      };
      line(row, row.value("given", ""), scene, row["matched"], m, d.value(),
           row["relative"].value(m, json()), judged.value("verdict", ""),
           judged.value("matches", json()), judged.value("intervals", json()),
           judged.value("resolved", json()), ci,
           noted(row.value("notes", json::object()).value(m, "")));
      for (const json& match : row.value("byMatch", json::array())) {
        if (!match["delta"].contains(m)) continue;
        const json paired = match["paired"].value(m, json());
        const std::string verdict = match["judged"].value(m, "");
        line(row, match["given"].get<std::string>(), scene, 1, m, match["delta"][m],
             match["relative"].value(m, json()), verdict, 1, paired.is_object() ? 1 : 0,
             verdict == "better" || verdict == "worse" ? 1 : 0,
             paired.is_object() ? paired.value("ci95", json()) : json(),
             noted(match.value("notes", json::object()).value(m, "")));
      }
    }
  }
  return csv;
}

std::string sweepPointsCsv(const RunResults& results) {
  if (!results.sweep.is_object()) return "";
  const json& sweep = results.sweep;
  const json grid = sweep.value("grid", json::object()),
             fixed = sweep.value("fixed", json::object());
  const auto number = csvNumber;
  // The grid's points first, in the grid's order, then every other contender in run order.
  std::vector<std::string> labels;
  for (const json& label : sweep.value("labels", json::array()))
    if (label.is_string()) labels.push_back(label);
  for (const PairResult& p : results.pairs)  // (a label may hold several pairs: one per scene)
    if (std::find(labels.begin(), labels.end(), p.label) == labels.end()) labels.push_back(p.label);
  std::string csv = "label,point";
  for (auto g = grid.begin(); g != grid.end(); ++g) csv += "," + csvField(g.key());
  for (auto f = fixed.begin(); f != fixed.end(); ++f) csv += "," + csvField(f.key());
  csv += ",scene,metric,mean,ci95Lo,ci95Hi,rank,frames,note\n";
  // A sweep recorded without its labels (an older run): the swept denoiser's pairs are its points.
  const json points = sweep.value("labels", json());
  auto isPoint = [&](const std::string& label, const std::string& denoiser) {
    return points.is_array() ? std::find(points.begin(), points.end(), json(label)) != points.end()
                             : denoiser == sweep.value("denoiser", "");
  };
  // The columns before the scene: the label, whether it is a grid point, its parameters.
  auto head = [&](const std::string& label, bool point, const json& params) {
    std::string out = csvField(label) + "," + (point ? "true" : "false");
    for (auto g = grid.begin(); g != grid.end(); ++g)
      out += "," + (point && params.contains(g.key()) ? csvField(valueText(params[g.key()])) : "");
    for (auto f = fixed.begin(); f != fixed.end(); ++f)
      out += "," + (point ? csvField(valueText(f.value())) : "");
    return out;
  };
  // A point that read oracle data says so on each of its lines, before the line's own note.
  std::string oracleWords;
  auto line = [&](const std::string& front, const std::string& scene, const std::string& metric,
                  double mean, Interval ci, int rank, int frames, const std::string& note) {
    const std::string noted = oracleWords.empty() ? note
                              : note.empty()      ? oracleWords
                                                  : oracleWords + "; " + note;
    csv += front + "," + csvField(scene) + "," + csvField(metric) + "," + number(mean) + "," +
           (ci.valid() ? number(ci.lo) + "," + number(ci.hi) : std::string(",")) + "," +
           (rank > 0 ? std::to_string(rank) : "") + "," +
           (frames > 0 ? std::to_string(frames) : "") + "," + csvField(noted) + "\n";
  };
  auto rankedIn = [](const SceneRanking* r, const std::string& label) -> const RankedMethod* {
    if (!r) return nullptr;
    for (const RankedMethod& m : r->ranking)
      if (m.label == label) return &m;
    return nullptr;
  };
  for (const std::string& label : labels)
    for (const PairResult& p : results.pairs) {
      if (p.label != label || !p.ok()) continue;
      const std::string front = head(label, isPoint(label, p.denoiser), p.params);
      const std::string oracle = oracleLayersText(p);
      oracleWords = oracle.empty() ? std::string()
                                   : "reads oracle data (" + oracle +
                                         "), which a real-time engine would not have";
      for (const MetricDefinition* m : metricCatalog()) {
        auto s = p.summary.find(m->name);
        if (s == p.summary.end()) continue;
        if (m->name == "ms") {
          line(front, p.scene, "ms (median)", timingOf(p, "msMedian"), {}, 0, s->second.frames, "");
          continue;
        }
        if (!s->second.present()) {
          line(front, p.scene, m->name, kUndefined, {}, 0, s->second.frames, s->second.absent);
          continue;
        }
        // relMseCorrected ranks as relMSE (the floor cancels in a paired difference), 1 - SSIM
        // as SSIM (reversed): the rank is theirs; the interval the metric's own.
        const std::string rankedOn = m->name == "relMseCorrected" ? "relMse"
                                     : m->name == "dssim"         ? "ssim"
                                                                  : m->name;
        const SceneRanking* ranking =
            results.statistics ? results.statistics->ranking(p.scene, rankedOn) : nullptr;
        const RankedMethod* r = rankedIn(ranking, label);
        const bool own = rankedOn == m->name;
        line(front, p.scene, m->name, own && r ? r->value : s->second.mean,
             own && r ? r->ci : s->second.ci95, r ? r->rank : 0, s->second.frames,
             own ? "" : "ranked as " + rankedOn);
      }
      for (const EventFigure& f : eventFigures(results, p.scene)) {
        if (const RankedMethod* r = rankedIn(f.ranking, label)) {
          line(front, p.scene, f.name, r->value, r->ci, r->rank, 0, unsettledNote(p, f));
        } else if (const std::string why = exclusionReason(*f.ranking, label, results);
                   !why.empty()) {
          // Left out of the event's ranking: its own value where it has one, no interval, no
          // rank, the statistics' reason.
          line(front, p.scene, f.name, pointFigure(p, f), {}, 0, 0, "not ranked: " + why);
        }
      }
    }
  // The overall scores (geometric mean over the scenes of each method's value over the baseline's),
  // relMSE's and the other metrics' that declare one, as scene "overall".
  if (results.statistics) {
    auto overallLines = [&](const std::string& metric, const OverallRanking& o) {
      for (const std::string& label : labels)
        for (const RankedMethod& m : o.ranking) {
          if (m.label != label) continue;
          const PairResult* any = nullptr;  // its parameters are the same on every scene
          for (const PairResult& p : results.pairs)
            if (p.label == label) any = &p;
          line(head(label, any && isPoint(label, any->denoiser), any ? any->params : json()),
               "overall", metric, m.value, m.label == o.baseline ? Interval{} : m.ci, m.rank, 0,
               o.normalisation);
        }
    };
    if (results.statistics->overall) overallLines("relMse", *results.statistics->overall);
    for (const auto& [metric, o] : results.statistics->overallByMetric) overallLines(metric, o);
  }
  return csv;
}

json reportData(const RunResults& results, const fs::path& runDir, const RunResults* baseline,
                const Gate& gate) {
  const int warmup = results.settings.warmup();
  // Scenes and labels in run order (results.json keeps scenes in an object, sorted by name).
  std::vector<std::string> sceneNames, labels;
  for (const PairResult& p : results.pairs) {
    if (std::find(sceneNames.begin(), sceneNames.end(), p.scene) == sceneNames.end()) sceneNames.push_back(p.scene);
    if (std::find(labels.begin(), labels.end(), p.label) == labels.end()) labels.push_back(p.label);
  }
  const json& sceneInfos = results.scenes;
  for (auto it = sceneInfos.begin(); it != sceneInfos.end(); ++it)
    if (std::find(sceneNames.begin(), sceneNames.end(), it.key()) == sceneNames.end())
      sceneNames.push_back(it.key());

  json scenes = json::array();
  for (const std::string& name : sceneNames) {
    json s = {{"name", name}, {"prepared", sceneInfos.contains(name)}};
    if (sceneInfos.contains(name)) {
      const json& info = sceneInfos[name];
      for (const char* k :
           {"purpose",         "width",        "height",
            "frames",          "events",       "chosenFrames",
            "referenceRelMse", "noisyRelMse",  "referenceSpp",
            "exposure",        "floors",       "referenceQuality",
            "warnings",        "validation",   "source",
            "capture",         "hasReference", "derivedLayers",
            "assets",          "notRun"})  // assets: credits and loader fallbacks (issue 18)
        if (info.contains(k)) s[k] = info[k];
      s["noiseFloor"] = noiseFloor(info, warmup);
      s["viewer"] = viewerData(results, name, info, runDir);
    }
    scenes.push_back(s);
  }

  json pairs = json::array(), failures = json::array();
  for (const PairResult& p : results.pairs) {
    pairs.push_back(pairData(p));
    if (!p.ok()) failures.push_back({{"scene", p.scene}, {"label", p.label}, {"error", p.error}});
  }

  const json metrics = metricCatalogJson();
  // Offer only the error axes some pair measured (FLIP is optional: --flip none | ldr).
  json axes = json::array();
  for (const ErrorAxis& a : kErrorAxes) {
    bool present = false;
    for (const PairResult& p : results.pairs) present = present || (p.ok() && p.summary.count(a.source));
    if (present)
      axes.push_back(
          {{"key", a.key}, {"title", a.title}, {"source", a.source}, {"complement", a.complement}});
  }

  // Where each contender that is not a built-in came from (an external process's manifest, a
  // plugin's library, a capture's stored output): the page marks those rows.
  const json origins = contenderOrigins(results);
  json originKinds = json::object();
  for (const auto& [label, origin] : contenderOrigins(results))
    originKinds[label] = contenderKind(origin);
  const json speed = speedData(results, sceneNames, labels);
  json data = {{"generator", "arena report"},
               {"run",
                {{"name", results.name},
                 {"created", results.created},
                 {"environment", results.environment},
                 {"settings", results.settings.toJson()},
                 {"warmup", warmup}}},
               {"metrics", metrics},
               {"errorAxes", axes},
               {"scenes", scenes},
               {"labels", labels},
               {"origins", origins},
               {"originKinds", originKinds},
               {"pairs", pairs},
               {"failures", failures},
               {"speed", speed},
               {"rankings", rankingData(results, sceneNames)},
               {"colorMaps", colorMapData()},
               {"ablation", ablationData(results)},
               {"regression", nullptr}};
  if (baseline) {
    // The gate's --denoisers: only those contenders' rows, as `arena compare` judges them.
    // --match: a contender relabelled between the runs compared by the pair of labels named.
    const std::map<std::string, std::string> matches =
        checkLabelMatches(gate.matches, *baseline, results);
    // The judgement `arena compare` makes (metrics/gate.hpp); where it would refuse the runs (the
    // same run, other settings), the rows are still shown beside why.
    const GateJudgement judged =
        judgeRuns(*baseline, results, gate, matches, /*rowsWhenRefused=*/true);
    const std::vector<ComparisonRow>& rows = judged.rows;
    const GateSides sides{"the baseline", "this run"};
    json table = comparisonJson(rows);
    // compareRuns leaves the numbers at 0 when one side has no result; say why instead, and keep
    // the side that exists, so "regressed" from a failed pair is not read as a change of +0%.
    for (json& row : table) {
      if (row["metric"] == "*") continue;  // a whole pair: compare's own note says what is missing
      // An event's figure: compare's row holds its figures and says why one is missing.
      if (!gatedEventFigureOf(row["metric"]).empty()) continue;
      const PairResult* b = baseline->find(row["scene"], row["label"]);
      const PairResult* c = results.find(row["scene"], row["candidateLabel"]);
      const std::string metric = row["metric"];
      // The mean, or why there is none (an absent summary gives its own reason).
      auto meanOf = [&](const PairResult* p) -> SummaryMean {
        if (!p) return {0, "not measured"};
        if (!p->ok()) return {0, "failed: " + p->error};
        return p->mean(metric);
      };
      const SummaryMean bm = meanOf(b), cm = meanOf(c);
      if (!cm.present()) {
        row["candidate"] = nullptr;
        row["baseline"] = bm.present() ? json(bm.mean) : json(nullptr);
        row["note"] = "this run: " + cm.absent + (bm.present() ? "" : "; the baseline: " + bm.absent);
      } else if (!bm.present()) {
        row["baseline"] = nullptr;
        row["note"] = "the baseline: " + bm.absent;
      }
    }
    data["regression"] = {{"baseline",
                           {{"name", baseline->name},
                            {"created", baseline->created},
                            {"commit", baseline->environment.value("git_commit", "")},
                            {"revision", baseline->environment.value("revision", "")}}},
                          {"rows", table},
                          {"anyRegression", anyRegression(rows)},
                          {"sameRun", judged.refusal == GateRefusal::SameRun},
                          {"refused", refusalText(judged, sides, /*multiLine=*/false)},
                          {"warnings", gateWarningTexts(judged, sides, /*multiLine=*/false)},
                          {"gate", gateOutcomeName(judged.outcome)},
                          {"exitCode", gateExitCode(judged.outcome)},
                          {"confidence", gate.bootstrap.confidence},
                          {"correction", correctionName(gate.correction)},
                          {"rowsJudgedTogether", judged.rowsJudgedTogether},
                          {"settingsDiffer", judged.settingsDiffer},
                          {"allowSettingsMismatch", gate.allowSettingsMismatch}};
  }
  return data;
}

namespace {

// Marks a page's copies of its run's images: the next report into the folder replaces them.
constexpr const char* kCopiedImagesMark = ".arena-report-copies";

// Copies the run's display images (PNGs only: a keep-all run's EXR frames are not for the page)
// and counts them; a page written into the run directory finds them in place and only counts.
void copyImages(const fs::path& runDir, const fs::path& out, ReportSummary& summary) {
  const fs::path from = runDir / "images";
  if (!fs::exists(from)) return;
  std::error_code ec;
  summary.imagesInPlace = fs::exists(out / "images") && fs::equivalent(from, out / "images", ec);
  if (!summary.imagesInPlace) {
    fs::create_directories(out / "images");
    writeTextAtomically(out / "images" / kCopiedImagesMark,
                        "Copies of " + runDir.string() +
                            "'s images, made by `arena report`: the next report written here "
                            "replaces this folder.\n");
  }
  for (const auto& e : fs::recursive_directory_iterator(from)) {
    if (!e.is_regular_file() || e.path().extension() != ".png") continue;
    ++summary.images;
    if (summary.imagesInPlace) continue;
    const fs::path to = out / "images" / fs::relative(e.path(), from);
    fs::create_directories(to.parent_path());
    fs::copy_file(e.path(), to, fs::copy_options::overwrite_existing);
  }
}

// An 8-bit PNG as interleaved RGB bytes (empty when it cannot be read).
std::vector<uint8_t> readRgb(const fs::path& file, int& width, int& height) {
  const cv::Mat bgr = cv::imread(file.string(), cv::IMREAD_COLOR);
  if (bgr.empty() || bgr.depth() != CV_8U) return {};
  width = bgr.cols, height = bgr.rows;
  std::vector<uint8_t> rgb(size_t(width) * size_t(height) * 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const cv::Vec3b& p = bgr.at<cv::Vec3b>(y, x);
      uint8_t* q = &rgb[(size_t(y) * size_t(width) + size_t(x)) * 3];
      q[0] = p[2], q[1] = p[1], q[2] = p[0];
    }
  return rgb;
}

// 4 significant digits: the crop table shows 3, and data files stay small.
double short4(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return std::strtod(buf, nullptr);
}

// Per-tile means of a per-pixel value (tile x tile pixels; edge tiles are smaller).
struct TileGrid {
  int width, height, tile, cols, rows;
  TileGrid(int w, int h)
      : width(w),
        height(h),
        // About 48 tiles across, each whole blocks of the run's kept relative-error values.
        tile(kRelErrorBlock *
             std::max(1, (std::max(w, h) + 48 * kRelErrorBlock - 1) / (48 * kRelErrorBlock))),
        cols((w + tile - 1) / tile),
        rows((h + tile - 1) / tile) {}
  template <class PixelValue>
  json means(PixelValue value) const {
    std::vector<double> sum(size_t(cols) * size_t(rows), 0.0);
    std::vector<int> n(sum.size(), 0);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const size_t k = size_t(y / tile) * size_t(cols) + size_t(x / tile);
        sum[k] += value(size_t(y) * size_t(width) + size_t(x));
        ++n[k];
      }
    json out = json::array();
    for (size_t k = 0; k < sum.size(); ++k) out.push_back(short4(sum[k] / n[k]));
    return out;
  }
  json counts() const {
    json out = json::array();
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c)
        out.push_back(std::min(tile, width - c * tile) * std::min(tile, height - r * tile));
    return out;
  }
  // Per tile, how many of its pixels `holds`.
  template <class PixelTest>
  json counts(PixelTest holds) const {
    std::vector<int> n(size_t(cols) * size_t(rows), 0);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        if (holds(size_t(y) * size_t(width) + size_t(x)))
          ++n[size_t(y / tile) * size_t(cols) + size_t(x / tile)];
    return n;
  }
};

// The crop measurements: for each kept frame of a scene, per-tile means computed from the kept
// images (so what the page can measure is what it shows): the 8-bit display images' squared
// error against the reference PNG (-> PSNR), the LDR-FLIP value decoded from the magma map, and
// the relative squared error: from the values the run kept beside its map (relerr_NNNN.exr,
// unclamped: the region's relMSE as the run defines it), else decoded from the map, which stops
// at 10 (a region holding such pixels reads low: their count per tile is kept, and the page
// says "at least"). Written as one script per
// frame (tiles/...js, loaded when the user marks a region); returns the scene's index of them.
json writeCropTiles(const json& viewer, const fs::path& runDir, const fs::path& out,
                    const std::string& stem) {
  const json& panels = viewer["panels"];
  const json* reference = nullptr;
  for (const json& p : panels)
    if (p["kind"] == "reference") reference = &p;
  if (!reference) return nullptr;
  json files = json::object();
  json grid;
  for (auto it = (*reference)["srcs"].begin(); it != (*reference)["srcs"].end(); ++it) {
    int w = 0, h = 0;
    const std::vector<uint8_t> ref = readRgb(runDir / it.value().get<std::string>(), w, h);
    if (ref.empty()) continue;
    const TileGrid g(w, h);
    json byPanel = json::object();
    for (const json& p : panels) {
      if (!p["srcs"].contains(it.key()) || p["kind"] == "reference") continue;
      int pw = 0, ph = 0;
      const std::vector<uint8_t> img =
          readRgb(runDir / p["srcs"][it.key()].get<std::string>(), pw, ph);
      if (img.empty() || pw != w || ph != h) continue;
      const std::string key = p["label"].is_string() ? p["label"].get<std::string>() : "noisy";
      const std::string kind = p["kind"];
      if (kind == "output" || kind == "noisy") {
        byPanel[key]["sqerr"] = g.means([&](size_t i) {
          double s = 0;
          for (size_t c = 0; c < 3; ++c) {
            const double d = (double(img[3 * i + c]) - ref[3 * i + c]) / 255.0;
            s += d * d;
          }
          return s / 3;
        });
      } else if (kind == "flip") {
        const std::vector<float> v = decodeColorMap(img, magmaColorMap());
        byPanel[key]["flip"] = g.means([&](size_t i) { return double(v[i]); });
      } else if (kind == "relerr") {
        const fs::path values =
            (runDir / p["srcs"][it.key()].get<std::string>()).replace_extension(".exr");
        std::error_code ec;
        bool exact = false;
        if (fs::exists(values, ec)) try {
            const int block = kRelErrorBlock, bw = (w + block - 1) / block;
            const Image e =
                readExr(values, {{"Y", {}}}, ExrSize{bw, (h + block - 1) / block}).layers.get("Y");
            // Each pixel stands for its block's mean: a tile of whole blocks sums them exactly.
            byPanel[key]["relerr"] = g.means([&](size_t i) {
              const size_t x = i % size_t(w), y = i / size_t(w);
              return double(e.raw()[(y / size_t(block)) * size_t(bw) + x / size_t(block)]);
            });
            exact = true;
          } catch (const Error&) {
            // Unreadable (cut short, another size): measured from the map, as where none was kept.
          }
        if (!exact) {
          const std::vector<float> v = decodeColorMap(img, viridisColorMap());
          byPanel[key]["relerr"] = g.means([&](size_t i) { return relativeErrorOfMapValue(v[i]); });
          byPanel[key]["relerrClamped"] = g.counts([&](size_t i) { return v[i] >= 1.0f; });
        }
      }
    }
    grid = {{"tile", g.tile}, {"cols", g.cols}, {"rows", g.rows},
            {"width", w},     {"height", h},    {"counts", g.counts()}};
    const std::string rel = "tiles/" + stem + "_f" + it.key() + ".js";
    fs::create_directories(out / "tiles");
    json payload = grid;
    payload["panels"] = byPanel;
    writeTextAtomically(out / rel,
                        "// Generated by `arena report`: per-tile means for crops.\n"
                        "(window.ARENA_TILES = window.ARENA_TILES || {})[" +
                            jsonText(json(rel)) + "] = " + jsonText(payload) + ";\n");
    files[it.key()] = rel;
  }
  if (files.empty()) return nullptr;
  return {{"files", files}, {"tile", grid["tile"]}};
}

}  // namespace

void checkPageAssets(const fs::path& webDir, const fs::path& nodeModulesDir,
                     const std::vector<PageFile>& files) {
  for (const PageFile& f : files)
    if (!fs::exists(webDir / f.source))
      throw Error("report: " + (webDir / f.source).string() +
                  " is missing (the page's static files live in reports/web)");
  for (const char* f : kVendorFiles)
    if (!fs::exists(nodeModulesDir / f))
      throw Error("report: the charting library is not installed (" +
                  (nodeModulesDir / f).string() +
                  " is missing); run scripts/setup.sh, which runs `npm ci` in reports/");
}

void requirePageDirectory(const fs::path& out, const std::string& command) {
  if (out.empty()) throw Error(command + ": --out is required (the page's directory)");
  if (std::error_code ec; fs::exists(out, ec) && !fs::is_directory(out, ec))
    throw Error(command + ": --out " + out.string() +
                ": exists and is not a directory; expected a directory for the page");
  // Not among a capture's files, nor in a run directory's images/ (a page in it was copied into
  // itself by the next report of the run: images/images/...; one in a capture sat among its
  // frames; a bad-input trial). A folder of its own in a run directory (RUN/report) is fine.
  std::error_code ec;
  const fs::path resolved = resolvedPath(out);
  for (fs::path dir = resolved; !dir.empty(); dir = dir.parent_path()) {
    if (fs::exists(dir / "capture.json", ec))
      throw Error(command + ": --out " + out.string() + " lies in the capture " + dir.string() +
                  "; expected a directory outside it");
    if (dir != resolved && fs::exists(dir / "results.json", ec) &&
        *resolved.lexically_relative(dir).begin() == "images")
      throw Error(command + ": --out " + out.string() + " lies in the images of the run " +
                  dir.string() + ", which a report of that run copies; expected a directory of "
                  "its own");
    if (dir == dir.parent_path()) break;
  }
}

void requireOwnPageFiles(const fs::path& out, const std::vector<PageFile>& files,
                         const std::string& dataFile, const std::vector<std::string>& outputs,
                         const std::string& command) {
  std::error_code ec;
  const auto begins = [](const fs::path& file, size_t bytes) {
    std::ifstream in(file, std::ios::binary);
    std::string head(bytes, '\0');
    in.read(head.data(), std::streamsize(bytes));
    head.resize(size_t(in.gcount()));
    return head;
  };
  const auto refuse = [&](const std::string& name, const std::string& why) {
    throw Error(command + ": --out " + out.string() + " holds " + name + " that " + why +
                ": the page would replace it; choose a directory of its own (or empty this one)");
  };
  // Both pages' index.html open with a comment naming Denoise Arena (reports/web).
  const fs::path index = out / "index.html";
  const bool ourIndex =
      fs::exists(index, ec) && begins(index, 256).find("<!-- Denoise Arena ") != std::string::npos;
  if (fs::exists(index, ec) && !ourIndex)
    refuse("an index.html", "is no Denoise Arena report's or dashboard's");
  if (fs::exists(out / dataFile, ec) &&
      begins(out / dataFile, 64).rfind("// Generated by `arena ", 0) != 0)
    refuse("a " + dataFile, "`arena` did not write");
  if (ourIndex) return;
  std::vector<std::string> names = outputs;
  for (const PageFile& f : files) names.push_back(f.target);
  for (const char* f : kVendorFiles) names.push_back(fs::path(f).filename().string());
  for (const std::string& name : names)
    if (fs::exists(out / name, ec)) refuse(name, "no Denoise Arena page's index.html is beside");
}

void copyPageAssets(const fs::path& webDir, const fs::path& nodeModulesDir,
                    const std::vector<PageFile>& files, const fs::path& out) {
  fs::create_directories(out);  // the callers checked it with requirePageDirectory first
  // A link in its place is replaced, not written through (its target lies outside the page).
  const auto copy = [&out](const fs::path& from, const std::string& name) {
    if (std::error_code ec; fs::is_symlink(out / name, ec)) fs::remove(out / name);
    fs::copy_file(from, out / name, fs::copy_options::overwrite_existing);
  };
  for (const PageFile& f : files) copy(webDir / f.source, f.target);
  for (const char* f : kVendorFiles) copy(nodeModulesDir / f, fs::path(f).filename().string());
}

ReportSummary writeReport(const ReportOptions& o) {
  requirePageDirectory(o.out, "report");
  // A run stopped before it wrote any results: said so, rather than "no results.json".
  if (const std::string note = unfinishedRunNote(o.run);
      !note.empty() && fs::is_directory(o.run) && !fs::exists(o.run / "results.json"))
    throw Error("report: " + note);
  // Another run's directory holds that run's page and images (a report written in place): this
  // page would replace its index.html and mix the two runs' images.
  if (std::error_code ec; fs::exists(o.out / "results.json", ec) &&
                          !(fs::exists(o.run, ec) && fs::equivalent(o.run, o.out, ec)))
    throw Error("report: --out " + o.out.string() +
                " holds another run (results.json): this "
                "page would replace that run's own page and mix its images with " +
                o.run.string() + "'s; choose a directory of its own, or the run's own (" +
                o.run.string() + ")");
  if (std::error_code ec; fs::exists(o.out / "history-data.js", ec))
    throw Error("report: --out " + o.out.string() +
                " holds a history dashboard (history-data.js): this page's index.html would "
                "replace it; choose a directory of its own, e.g. report/" +
                folderName(o.run));
  const RunResults results = loadResults(o.run);
  // Its images are partly another run's than its numbers: a page would show them side by side.
  if (const std::string note = unfinishedRunNote(o.run); !note.empty())
    throw Error("report: " + note +
                "; a report would show those images beside numbers they do not belong to. Run it "
                "again to completion (`arena compare` reads the earlier numbers, which are whole)");
  // A page of nothing would look like a report; a run always has pairs (failed ones included).
  if (results.pairs.empty())
    throw Error("report: " + (o.run / "results.json").string() +
                ": holds no pairs; nothing to report");
  RunResults baseline;
  if (!o.baseline.empty()) baseline = loadResults(o.baseline);
  std::vector<PageFile> files;
  for (const char* f : kWebFiles) files.push_back({f, f});
  checkPageAssets(o.webDir, o.nodeModulesDir, files);
  // (What else the page writes or replaces: its crops, a sweep's tables.)
  requireOwnPageFiles(o.out, files, "data.js", {"tiles", "ablation.csv", "points.csv"}, "report");
  json data = reportData(results, o.run, o.baseline.empty() ? nullptr : &baseline, o.gate);
  std::error_code ec;
  // The page's copy of the run's images (not the run's own, for a page written in place).
  const bool imagesInPlace = fs::exists(o.out / "images", ec) && fs::exists(o.run / "images", ec) &&
                             fs::equivalent(o.run / "images", o.out / "images", ec);
  const bool earlierPage =
      fs::exists(o.out / "data.js", ec) || fs::exists(o.out / "images" / kCopiedImagesMark, ec);
  if (!imagesInPlace && !earlierPage && fs::exists(o.out / "images", ec))
    throw Error(
        "report: --out " + o.out.string() +
        " holds an images folder that is no earlier report's (neither a data.js beside it "
        "nor the mark of a report's copies in it): the page's copies of the run's images go "
        "there, and it would mix them with what it holds; choose a directory of its own");
  fs::create_directories(o.out);
  const DirectoryLock lock(o.out, DirectoryLock::Mode::Exclusive, DirectoryLock::IfHeld::Refuse,
                           "writing a report");
  // An earlier page here stops being one before anything is written: its copies of its run's
  // images go first (another run's would stay beside this one's, in every copy of the folder; a
  // removal cut short leaves the data.js that says whose folder it is), then its data.js (a page
  // without it is incomplete, so a killed report never shows old data over new tiles), its tiles,
  // and the temporaries of a killed write.
  if (!imagesInPlace) fs::remove_all(o.out / "images", ec);
  fs::remove(o.out / "data.js", ec);
  fs::remove_all(o.out / "tiles", ec);
  removeStaleTemporariesBelow(o.out);
  for (size_t i = 0; i < data["scenes"].size(); ++i) {
    json& scene = data["scenes"][i];
    if (scene.contains("viewer"))
      scene["viewer"]["crops"] =
          writeCropTiles(scene["viewer"], o.run, o.out, std::string("s").append(std::to_string(i)));
  }
  copyPageAssets(o.webDir, o.nodeModulesDir, files, o.out);
  ReportSummary summary;
  copyImages(o.run, o.out, summary);
  // A sweep's ablation as a table a paper or a plot can read; none for a run that is no sweep (an
  // earlier sweep's report here leaves none behind).
  if (const std::string csv = ablationCsv(data["ablation"]); !csv.empty()) {
    writeTextAtomically(o.out / "ablation.csv", csv);
    summary.ablation = o.out / "ablation.csv";
  } else {
    fs::remove(o.out / "ablation.csv", ec);
    if (results.sweep.is_object()) {
      bool twoValues = false;
      for (const json& values : results.sweep.value("grid", json::object()))
        twoValues = twoValues || (values.is_array() && values.size() > 1);
      summary.noAblation =
          twoValues ? "no grid value could be compared with its parameter's first value on any "
                      "scene (the pairs that would match failed or are missing)"
                    : "no grid parameter has two values (a one-point grid compares nothing; the "
                      "run's rankings still compare it with the other contenders)";
    }
  }
  if (const std::string csv = sweepPointsCsv(results); !csv.empty()) {
    writeTextAtomically(o.out / "points.csv", csv);
    summary.points = o.out / "points.csv";
  } else
    fs::remove(o.out / "points.csv", ec);
  // Written last and atomically: a page whose data.js exists is complete.
  writeTextAtomically(o.out / "data.js",
                      "// Generated by `arena report`; read by app.js.\nwindow.ARENA_DATA = " +
                          jsonText(data) + ";\n");
  if (const json& r = data["regression"]; r.is_object()) {
    summary.judged = true;
    summary.gate = r["gate"];
    summary.gateExitCode = r["exitCode"];
    summary.refused = r["refused"];
    summary.gateWarnings = r["warnings"].get<std::vector<std::string>>();
    std::map<std::string, int> counts;
    for (const json& row : r["rows"]) ++counts[row["verdict"].get<std::string>()];
    for (const auto& [verdict, n] : counts)
      summary.verdicts +=
          (summary.verdicts.empty() ? "" : ", ") + std::to_string(n) + " " + verdict;
  }
  summary.index = o.out / "index.html";
  summary.pairs = data["pairs"].size();
  summary.failedPairs = data["failures"].size();
  summary.absentSummaries = absentSummaryLines(results);
  return summary;
}

}  // namespace arena
