#include "reports/report.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "metrics/compare.hpp"
#include "metrics/results.hpp"
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
const char* const kWebFiles[] = {"index.html", "app.js", "style.css"};
// Browser (UMD) builds that index.html loads with <script>, from reports/node_modules.
const char* const kVendorFiles[] = {"vega/build/vega.min.js", "vega-lite/build/vega-lite.min.js",
                                    "vega-embed/build/vega-embed.min.js"};

// The error metrics the speed-vs-accuracy chart offers. 1-SSIM turns SSIM (higher is better) into
// an error so every choice reads "lower is better" and the Pareto front is always lower-left.
struct ErrorAxis {
  const char* key;
  const char* title;
  const char* source;  // the per-frame metric it comes from
  bool complement;     // value = 1 - source
};
const ErrorAxis kErrorAxes[] = {{"relMse", "relMSE", "relMse", false},
                                {"hdrFlip", "HDR-FLIP", "hdrFlip", false},
                                {"ldrFlip", "LDR-FLIP", "ldrFlip", false},
                                {"dssim", "1 − SSIM", "ssim", true}};

bool isOk(const json& pair) {
  return pair.value("status", "") == "ok";
}

std::string frameFile(const char* prefix, int t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s_%04d.png", prefix, t);
  return buf;
}

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

// The value, p5 and p95 of an error axis from a pair's summary; null when the pair lacks it.
json axisValue(const json& pair, const ErrorAxis& axis) {
  if (!isOk(pair) || !pair.contains("summary") || !pair["summary"].contains(axis.source))
    return nullptr;
  const json& s = pair["summary"][axis.source];
  double mean = s.value("mean", kNaN), p5 = s.value("p5", kNaN), p95 = s.value("p95", kNaN);
  if (axis.complement) {  // 1 - x reverses the order: the low percentile of SSIM is the high one of
                          // 1-SSIM
    mean = 1 - mean;
    std::swap(p5, p95);
    p5 = 1 - p5;
    p95 = 1 - p95;
  }
  if (!std::isfinite(mean)) return nullptr;
  return {{"error", mean}, {"p5", p5}, {"p95", p95}};
}

double msOf(const json& pair) {
  if (!pair.contains("timing")) return kNaN;
  return pair["timing"].value("msMedian", kNaN);
}

// One point per label with its error bars, and the labels on the Pareto front (time x error).
json speedScope(const std::vector<json>& points, bool needsComplete) {
  std::vector<ParetoPoint> pp;
  for (const json& p : points) {
    const bool eligible = !needsComplete || p.value("complete", true);
    pp.push_back({eligible ? p["ms"].get<double>() : kNaN, p["error"].get<double>()});
  }
  json front = json::array();
  for (size_t i : paretoFront(pp)) front.push_back(points[i]["label"]);
  return {{"points", points}, {"front", front}};
}

json speedData(const json& results, const std::vector<std::string>& scenes,
               const std::vector<std::string>& labels) {
  json out = json::object();
  json perScene = json::object();
  for (const std::string& scene : scenes) {
    json byAxis = json::object();
    for (const ErrorAxis& axis : kErrorAxes) {
      std::vector<json> points;
      for (const json& pair : results["pairs"]) {
        if (pair["scene"] != scene) continue;
        json v = axisValue(pair, axis);
        const double ms = msOf(pair);
        if (v.is_null() || !std::isfinite(ms)) continue;
        v["label"] = pair["label"];
        v["ms"] = ms;
        points.push_back(v);
      }
      if (!points.empty()) byAxis[axis.key] = speedScope(points, false);
    }
    perScene[scene] = byAxis;
  }
  out["scenes"] = perScene;
  // All scenes: each label's mean over scenes of its per-scene mean (and of p5, p95, ms). A label
  // missing from some scene (failed there) is drawn but kept off the front: its average covers
  // different, fewer scenes, so it is not comparable.
  json all = json::object();
  for (const ErrorAxis& axis : kErrorAxes) {
    std::vector<json> points;
    size_t maxScenes = 0;
    for (const std::string& label : labels) {
      double e = 0, p5 = 0, p95 = 0, ms = 0;
      size_t n = 0;
      for (const json& pair : results["pairs"]) {
        if (pair["label"] != label) continue;
        json v = axisValue(pair, axis);
        const double t = msOf(pair);
        if (v.is_null() || !std::isfinite(t)) continue;
        e += v["error"].get<double>();
        p5 += v["p5"].get<double>();
        p95 += v["p95"].get<double>();
        ms += t;
        ++n;
      }
      if (n == 0) continue;
      maxScenes = std::max(maxScenes, n);
      const double k = double(n);
      points.push_back({{"label", label},
                        {"error", e / k},
                        {"p5", p5 / k},
                        {"p95", p95 / k},
                        {"ms", ms / k},
                        {"scenes", n}});
    }
    for (json& p : points) p["complete"] = p["scenes"].get<size_t>() == maxScenes;
    if (!points.empty()) all[axis.key] = speedScope(points, true);
  }
  out["all"] = all;
  return out;
}

std::string valueText(const json& v) {
  return v.is_string() ? v.get<std::string>() : v.dump();
}

// The ablation of a sweep: for each grid parameter and each of its values after the first, the
// change of every metric's mean against the pair that differs only in that parameter (set to the
// first value), averaged over the other grid settings; per scene and over all scenes.
json ablationData(const json& results) {
  if (!results.contains("sweep") || !results["sweep"].is_object()) return nullptr;
  const json& sweep = results["sweep"];
  const std::string denoiser = sweep.value("denoiser", "");
  std::vector<const json*> pairs;
  for (const json& p : results["pairs"])
    if (p["denoiser"] == denoiser && isOk(p) && p.contains("params")) pairs.push_back(&p);
  std::vector<std::string> metrics;
  for (const MetricInfo& m : metricCatalog()) metrics.push_back(m.name);
  json rows = json::array();
  for (auto g = sweep["grid"].begin(); g != sweep["grid"].end(); ++g) {
    const std::string name = g.key();
    // Values in order of first appearance: the run enumerates the grid's Cartesian product with
    // every axis starting at its first value, so the first pair carries the first value of each.
    std::vector<json> values;
    for (const json* p : pairs)
      if ((*p)["params"].contains(name) &&
          std::find(values.begin(), values.end(), (*p)["params"][name]) == values.end())
        values.push_back((*p)["params"][name]);
    if (values.size() < 2) continue;
    for (size_t vi = 1; vi < values.size(); ++vi) {
      std::map<std::string, std::map<std::string, std::vector<double>>> deltas, relative;
      std::map<std::string, size_t> matched;
      for (const json* p : pairs) {
        if ((*p)["params"][name] != values[vi]) continue;
        json want = (*p)["params"];
        want[name] = values[0];
        for (const json* q : pairs) {
          if ((*q)["scene"] != (*p)["scene"] || (*q)["params"] != want) continue;
          const std::string scene = (*p)["scene"];
          for (const std::string& scope : {scene, std::string()}) {
            ++matched[scope];
            for (const std::string& m : metrics) {
              if (!(*p)["summary"].contains(m) || !(*q)["summary"].contains(m)) continue;
              const double a = (*p)["summary"][m].value("mean", kNaN);
              const double b = (*q)["summary"][m].value("mean", kNaN);
              if (!std::isfinite(a) || !std::isfinite(b)) continue;
              deltas[scope][m].push_back(a - b);
              relative[scope][m].push_back((a - b) / std::max(std::abs(b), 1e-12));
            }
          }
          break;
        }
      }
      for (auto& [scope, byMetric] : deltas) {
        json d = json::object(), r = json::object();
        for (auto& [m, v] : byMetric) {
          double s = 0, sr = 0;
          for (size_t i = 0; i < v.size(); ++i) s += v[i], sr += relative[scope][m][i];
          d[m] = s / double(v.size());
          r[m] = sr / double(v.size());
        }
        rows.push_back({{"parameter", name},
                        {"value", valueText(values[vi])},
                        {"versus", valueText(values[0])},
                        {"scene", scope.empty() ? json(nullptr) : json(scope)},
                        {"matched", matched[scope]},
                        {"delta", d},
                        {"relative", r}});
      }
    }
  }
  return {{"denoiser", denoiser},
          {"grid", sweep["grid"]},
          {"fixed", sweep.value("fixed", json::object())},
          {"rows", rows}};
}

// The image viewer's panels for a scene: only files that exist, so the page never shows a broken
// image (a failed pair, or a run with --flip none or --keep-frames none, has fewer).
json viewerData(const json& results, const std::string& scene, const json& sceneInfo,
                const fs::path& runDir) {
  json frames = sceneInfo.value("chosenFrames", json::array());
  const std::string sceneDir = sceneInfo.value("images", "images/" + scene);
  json panels = json::array();
  auto add = [&](const std::string& kind, const json& label, const std::string& title,
                 const std::string& dir, const char* prefix) {
    json srcs = json::object();
    for (const json& t : frames) {
      const std::string rel = dir + "/" + frameFile(prefix, t.get<int>());
      if (fs::exists(runDir / rel)) srcs[std::to_string(t.get<int>())] = rel;
    }
    if (!srcs.empty())
      panels.push_back({{"kind", kind}, {"label", label}, {"title", title}, {"srcs", srcs}});
  };
  add("reference", nullptr, "reference", sceneDir, "reference");
  add("noisy", nullptr, "noisy input", sceneDir, "noisy");
  for (const json& pair : results["pairs"]) {
    if (pair["scene"] != scene || !isOk(pair) || !pair.contains("images")) continue;
    const std::string dir = pair["images"].value("dir", "");
    const std::string label = pair["label"];
    add("output", label, label, dir, "frame");
    add("flip", label, label + " · LDR-FLIP", dir, "flip");
    add("relerr", label, label + " · rel. error", dir, "relerr");
  }
  return {{"frames", frames}, {"panels", panels}};
}

// Everything a pair row needs in the page, without the per-pass timings (the table shows totals).
json pairData(const json& pair) {
  json p = {{"scene", pair["scene"]},
            {"denoiser", pair.value("denoiser", "")},
            {"label", pair["label"]},
            {"params", pair.value("params", json::object())},
            {"status", pair.value("status", "?")}};
  if (!isOk(pair)) {
    p["error"] = pair.value("error", "failed without a message");
    return p;
  }
  p["summary"] = pair.value("summary", json::object());
  const json timing = pair.value("timing", json::object());
  p["timing"] = {{"msMedian", timing.value("msMedian", kNaN)},
                 {"msP95", timing.value("msP95", kNaN)},
                 {"msPerMegapixel", timing.value("msPerMegapixel", kNaN)},
                 {"tapsPerPixel", timing.value("tapsPerPixel", kNaN)},
                 {"passes", timing.contains("passes") ? timing["passes"].size() : 0}};
  p["series"] = seriesColumns(pair.value("frames", json::array()));
  p["ghosting"] = pair.value("ghosting", json::array());
  p["warnings"] = pair.value("warnings", json::array());
  return p;
}

}  // namespace

json reportData(const json& results, const fs::path& runDir, const json* baseline) {
  const json settings = results.value("settings", json::object());
  const int warmup = settings.value("warmup", 8);
  // Scenes and labels in run order (results.json keeps scenes in an object, sorted by name).
  std::vector<std::string> sceneNames, labels;
  for (const json& p : results["pairs"]) {
    if (std::find(sceneNames.begin(), sceneNames.end(), p["scene"]) == sceneNames.end())
      sceneNames.push_back(p["scene"]);
    if (std::find(labels.begin(), labels.end(), p["label"]) == labels.end())
      labels.push_back(p["label"]);
  }
  const json sceneInfos = results.value("scenes", json::object());
  for (auto it = sceneInfos.begin(); it != sceneInfos.end(); ++it)
    if (std::find(sceneNames.begin(), sceneNames.end(), it.key()) == sceneNames.end())
      sceneNames.push_back(it.key());

  json scenes = json::array();
  for (const std::string& name : sceneNames) {
    json s = {{"name", name}, {"prepared", sceneInfos.contains(name)}};
    if (sceneInfos.contains(name)) {
      const json& info = sceneInfos[name];
      for (const char* k : {"purpose", "width", "height", "frames", "events", "chosenFrames",
                            "referenceRelMse", "noisyRelMse", "referenceSpp", "exposure"})
        if (info.contains(k)) s[k] = info[k];
      s["noiseFloor"] = noiseFloor(info, warmup);
      s["viewer"] = viewerData(results, name, info, runDir);
    }
    scenes.push_back(s);
  }

  json pairs = json::array(), failures = json::array();
  for (const json& p : results["pairs"]) {
    pairs.push_back(pairData(p));
    if (!isOk(p))
      failures.push_back(
          {{"scene", p["scene"]}, {"label", p["label"]}, {"error", p.value("error", "")}});
  }

  json metrics = json::array();
  for (const MetricInfo& m : metricCatalog())
    metrics.push_back(
        {{"name", m.name}, {"lowerIsBetter", m.lowerIsBetter}, {"meaning", m.meaning}});
  // Offer only the error axes some pair measured (FLIP is optional: --flip none | ldr).
  json axes = json::array();
  for (const ErrorAxis& a : kErrorAxes) {
    bool present = false;
    for (const json& p : results["pairs"])
      present = present || (isOk(p) && p.contains("summary") && p["summary"].contains(a.source));
    if (present)
      axes.push_back(
          {{"key", a.key}, {"title", a.title}, {"source", a.source}, {"complement", a.complement}});
  }

  json data = {{"generator", "arena report"},
               {"run",
                {{"name", results.value("name", "")},
                 {"created", results.value("created", "")},
                 {"environment", results.value("environment", json::object())},
                 {"settings", settings},
                 {"warmup", warmup}}},
               {"metrics", metrics},
               {"errorAxes", axes},
               {"scenes", scenes},
               {"labels", labels},
               {"pairs", pairs},
               {"failures", failures},
               {"speed", speedData(results, sceneNames, labels)},
               {"ablation", ablationData(results)},
               {"regression", nullptr}};
  if (baseline) {
    const std::vector<ComparisonRow> rows = compareRuns(*baseline, results, {});
    json table = comparisonJson(rows);
    // compareRuns leaves the numbers at 0 when one side has no result; say why instead, and keep
    // the side that exists, so "regressed" from a failed pair is not read as a change of +0%.
    auto findPair = [](const json& run, const json& row) -> const json* {
      for (const json& p : run["pairs"])
        if (p["scene"] == row["scene"] && p["label"] == row["label"]) return &p;
      return nullptr;
    };
    for (json& row : table) {
      const json* b = findPair(*baseline, row);
      const json* c = findPair(results, row);
      const std::string metric = row["metric"];
      auto meanOf = [&](const json* p) -> json {
        if (!p || !isOk(*p) || !(*p)["summary"].contains(metric) || !(*p)["summary"][metric].contains("mean"))
          return nullptr;
        return (*p)["summary"][metric]["mean"];
      };
      if (meanOf(c).is_null()) {
        row["candidate"] = nullptr;
        row["baseline"] = meanOf(b);
        row["note"] = c && !isOk(*c) ? "failed in this run: " + c->value("error", "")
                                     : "not measured in this run";
      } else if (meanOf(b).is_null()) {
        row["baseline"] = nullptr;
        row["note"] = b && !isOk(*b) ? "failed in the baseline" : "not measured in the baseline";
      }
    }
    data["regression"] = {
        {"baseline",
         {{"name", baseline->value("name", "")},
          {"created", baseline->value("created", "")},
          {"commit", baseline->value("environment", json::object()).value("git_commit", "")}}},
        {"rows", table},
        {"anyRegression", anyRegression(rows)}};
  }
  return data;
}

namespace {

// Copies the run's display images (PNGs only: a keep-all run's EXR frames are not for the page).
size_t copyImages(const fs::path& runDir, const fs::path& out) {
  const fs::path from = runDir / "images";
  if (!fs::exists(from)) return 0;
  std::error_code ec;
  if (fs::exists(out / "images") && fs::equivalent(from, out / "images", ec))
    return 0;  // reporting in place
  size_t n = 0;
  for (const auto& e : fs::recursive_directory_iterator(from)) {
    if (!e.is_regular_file() || e.path().extension() != ".png") continue;
    const fs::path to = out / "images" / fs::relative(e.path(), from);
    fs::create_directories(to.parent_path());
    fs::copy_file(e.path(), to, fs::copy_options::overwrite_existing);
    ++n;
  }
  return n;
}

}  // namespace

ReportSummary writeReport(const ReportOptions& o) {
  if (o.out.empty()) throw Error("report: --out is required");
  const json results = loadResults(o.run);
  json baseline;
  if (!o.baseline.empty()) baseline = loadResults(o.baseline);
  for (const char* f : kWebFiles)
    if (!fs::exists(o.webDir / f))
      throw Error("report: " + (o.webDir / f).string() +
                  " is missing (the page's static files live in reports/web)");
  for (const char* f : kVendorFiles)
    if (!fs::exists(o.nodeModulesDir / f))
      throw Error("report: the charting library is not installed (" +
                  (o.nodeModulesDir / f).string() +
                  " is missing); run scripts/setup.sh, which runs `npm ci` in reports/");

  const json data = reportData(results, o.run, o.baseline.empty() ? nullptr : &baseline);
  fs::create_directories(o.out);
  for (const char* f : kWebFiles)
    fs::copy_file(o.webDir / f, o.out / f, fs::copy_options::overwrite_existing);
  for (const char* f : kVendorFiles)
    fs::copy_file(o.nodeModulesDir / f, o.out / fs::path(f).filename(),
                  fs::copy_options::overwrite_existing);
  ReportSummary summary;
  summary.imagesCopied = copyImages(o.run, o.out);
  // Written last and atomically: a page whose data.js exists is complete.
  writeTextAtomically(o.out / "data.js",
                      "// Generated by `arena report`; read by app.js.\nwindow.ARENA_DATA = " +
                          data.dump() + ";\n");
  summary.index = o.out / "index.html";
  summary.pairs = data["pairs"].size();
  summary.failedPairs = data["failures"].size();
  return summary;
}

}  // namespace arena
