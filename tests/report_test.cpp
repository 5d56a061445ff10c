// `arena report`: the generator on a hand-built run (no rendering: the run's JSON is written here),
// the Pareto front on hand-built points, and the bad-input contract.
#include "reports/report.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "metrics/results.hpp"
#include "metrics/statistics.hpp"
#include "reports/pareto.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// ---------------------------------------------------------------- Pareto front

std::vector<size_t> front(const std::vector<ParetoPoint>& p) {
  return paretoFront(p);
}

TEST(Report, ParetoFrontOnHandBuiltPoints) {
  // time, error. Front: 0 (fastest), 2, 4 (most accurate). 1 is beaten by 2 (slower and worse);
  // 3 by 2 on both; 5 is at 2's time with a larger error; 6 has 4's error but is slower.
  const std::vector<ParetoPoint> points = {{1.0, 0.50}, {3.0, 0.40}, {2.0, 0.20}, {4.0, 0.30},
                                           {8.0, 0.05}, {2.0, 0.25}, {9.0, 0.05}};
  EXPECT_EQ(front(points), (std::vector<size_t>{0, 2, 4}));
}

TEST(Report, ParetoFrontTiesAndDegenerateInput) {
  EXPECT_TRUE(front({}).empty());
  EXPECT_EQ(front({{5, 5}}), (std::vector<size_t>{0}));
  // Exact duplicates dominate neither each other: both stay, in input order.
  EXPECT_EQ(front({{2, 0.1}, {1, 0.3}, {2, 0.1}}), (std::vector<size_t>{1, 0, 2}));
  // Same time: only the lower error; same error: only the faster.
  EXPECT_EQ(front({{1, 0.3}, {1, 0.2}}), (std::vector<size_t>{1}));
  EXPECT_EQ(front({{2, 0.2}, {1, 0.2}}), (std::vector<size_t>{1}));
  // A point that is best on both axes is the whole front.
  EXPECT_EQ(front({{3, 3}, {1, 1}, {2, 2}}), (std::vector<size_t>{1}));
  // Non-finite coordinates (unmeasured settings) are ignored, not ranked.
  EXPECT_EQ(front({{NAN, 0.0}, {1, 0.5}, {2, INFINITY}}), (std::vector<size_t>{1}));
}

// ---------------------------------------------------------------- fixture run

json summaryOf(double mean) {
  return {{"mean", mean}, {"median", mean}, {"p5", mean * 0.8}, {"p95", mean * 1.3}, {"frames", 4}};
}

json okPair(const std::string& scene, const std::string& denoiser, const std::string& label,
            json params, double relMse, double ms) {
  json frames = json::array();
  for (int t = 0; t < 6; ++t) {
    json f = {{"frame", t},
              {"relMse", relMse * (1 + 0.1 * t)},
              {"ssim", 0.9},
              {"ldrFlip", relMse},
              {"ms", ms}};
    if (t > 0) f["tRmae"] = 0.1;
    frames.push_back(f);
  }
  return {{"scene", scene},
          {"denoiser", denoiser},
          {"label", label},
          {"params", params},
          {"status", "ok"},
          {"frames", frames},
          {"summary",
           {{"relMse", summaryOf(relMse)},
            {"ssim", summaryOf(0.9)},
            {"ldrFlip", summaryOf(relMse)},
            {"tRmae", summaryOf(0.1)},
            {"ms", summaryOf(ms)}}},
          {"timing",
           {{"msMedian", ms},
            {"msP95", ms * 1.1},
            {"msPerMegapixel", ms * 100},
            {"tapsPerPixel", 25},
            {"passes", json::array()}}},
          {"ghosting", json::array()},
          {"warnings", json::array({"a warning for " + label})},
          {"images", {{"dir", "images/" + scene + "/" + label}, {"all", false}}}};
}

json fixtureRun() {
  json scenes = json::object();
  for (const char* s : {"static", "switch"})
    scenes[s] = {{"purpose", "test"},
                 {"width", 4},
                 {"height", 2},
                 {"frames", 6},
                 {"events", json::array()},
                 {"chosenFrames", {2, 5}},
                 {"images", std::string("images/") + s},
                 // Frames before warm-up (W = 2) carry a large value that must not enter the floor.
                 {"referenceRelMse", {9.0, 9.0, 0.001, 0.001, 0.003, 0.003}},
                 {"noisyRelMse", {1, 1, 1, 1, 1, 1}}};
  json pairs = json::array();
  pairs.push_back(okPair("static", "passthrough", "passthrough", json::object(), 0.5, 0.01));
  pairs.push_back(okPair("static", "svgf", "svgf[a=0]", {{"a", 0}, {"b", true}}, 0.05, 4.0));
  pairs.push_back(okPair("static", "svgf", "svgf[a=1]", {{"a", 1}, {"b", true}}, 0.04, 5.0));
  pairs.push_back(
      okPair("static", "svgf", "svgf[a=1,b=false]", {{"a", 1}, {"b", false}}, 0.06, 3.0));
  pairs.push_back(okPair("switch", "passthrough", "passthrough", json::object(), 0.6, 0.01));
  pairs.push_back({{"scene", "switch"},
                   {"denoiser", "svgf"},
                   {"label", "svgf[a=0]"},
                   {"params", json::object()},
                   {"status", "failed"},
                   {"error", "svgf: missing channel albedo.R (the test's failure)"}});
  return {{"schema", kResultsSchemaVersion},
          {"kind", "arena-run"},
          {"name", "fixture"},
          {"created", "2025-01-01T00:00:00Z"},
          {"environment", {{"cpu", "test"}, {"cores", 2}}},
          {"settings", {{"warmup", 2}, {"flip", "ldr"}, {"relMseEpsilon", 0.01}}},
          {"scenes", scenes},
          {"pairs", pairs},
          {"sweep",
           {{"denoiser", "svgf"},
            {"grid", {{"a", {"0", "1"}}, {"b", {"true", "false"}}}},
            {"fixed", json::object()}}}};
}

// A run directory with results.json and (empty) image files where the viewer looks for them.
fs::path writeFixtureRun(const std::string& name, const json& run) {
  fs::path dir = test::freshDir(name);
  saveResults(dir, run);
  for (const char* s : {"static", "switch"})
    for (const char* f :
         {"reference_0002.png", "noisy_0002.png", "reference_0005.png", "noisy_0005.png"}) {
      fs::create_directories(dir / "images" / s);
      std::ofstream(dir / "images" / s / f) << "png";
    }
  fs::create_directories(dir / "images/static/svgf[a=0]");
  for (const char* f : {"frame_0002.png", "flip_0002.png", "relerr_0002.png"})
    std::ofstream(dir / "images/static/svgf[a=0]" / f) << "png";
  return dir;
}

// Stand-ins for the npm packages: the generator only copies them.
fs::path fakeNodeModules(const std::string& name) {
  fs::path dir = test::freshDir(name);
  for (const char* f : {"vega/build/vega.min.js", "vega-lite/build/vega-lite.min.js",
                        "vega-embed/build/vega-embed.min.js"}) {
    fs::create_directories((dir / f).parent_path());
    std::ofstream(dir / f) << "// stand-in\n";
  }
  return dir;
}

TEST(Report, GeneratorWritesEverySectionAndKeepsTheFailedPair) {
  ReportOptions o;
  o.run = writeFixtureRun("report_fixture", fixtureRun());
  o.out = test::freshDir("report_fixture_out");
  o.nodeModulesDir = fakeNodeModules("report_fixture_modules");
  ReportSummary s = writeReport(o);
  EXPECT_EQ(s.pairs, 6u);
  EXPECT_EQ(s.failedPairs, 1u);
  for (const char* f :
       {"index.html", "data.js", "app.js", "style.css", "vega.min.js", "vega-lite.min.js",
        "vega-embed.min.js", "images/static/svgf[a=0]/flip_0002.png",
        "images/switch/reference_0005.png"})
    EXPECT_TRUE(fs::exists(o.out / f)) << f;

  const std::string html = readText(o.out / "index.html");
  for (const std::string& id : reportSectionIds())
    EXPECT_NE(html.find("<section id=\"" + id + "\""), std::string::npos) << "section " << id;

  const std::string js = readText(o.out / "data.js");
  const std::string prefix = "window.ARENA_DATA = ";
  const size_t at = js.find(prefix);
  ASSERT_NE(at, std::string::npos);
  const std::string body = js.substr(at + prefix.size(), js.rfind(';') - at - prefix.size());
  const json data = json::parse(body);
  // The failed pair is reported with its error; the others are all there.
  ASSERT_EQ(data["failures"].size(), 1u);
  EXPECT_EQ(data["failures"][0]["label"], "svgf[a=0]");
  EXPECT_NE(js.find("missing channel albedo.R"), std::string::npos);
  EXPECT_EQ(data["pairs"].size(), 6u);
  EXPECT_EQ(data["pairs"][5]["status"], "failed");
}

TEST(Report, DataHasFrontNoiseFloorViewerAndAblation) {
  const json run = fixtureRun();
  const fs::path dir = writeFixtureRun("report_data", run);
  const json data = reportData(run, dir, nullptr);

  // Speed on "static", relMSE: passthrough (0.01 ms, 0.5), svgf[a=1,b=false] (3 ms, 0.06),
  // svgf[a=0] (4 ms, 0.05), svgf[a=1] (5 ms, 0.04): every point is on the front here.
  const json& st = data["speed"]["scenes"]["static"]["relMse"];
  EXPECT_EQ(st["points"].size(), 4u);
  EXPECT_EQ(st["front"], json({"passthrough", "svgf[a=1,b=false]", "svgf[a=0]", "svgf[a=1]"}));
  // 1 - SSIM is an error axis: its bars flip (p5 of 1-SSIM = 1 - p95 of SSIM).
  const json& dssim = data["speed"]["scenes"]["static"]["dssim"]["points"][0];
  EXPECT_NEAR(dssim["error"].get<double>(), 0.1, 1e-12);
  EXPECT_NEAR(dssim["p5"].get<double>(), 1 - 0.9 * 1.3, 1e-12);
  // No HDR-FLIP in this run: the axis is not offered.
  for (const json& a : data["errorAxes"]) EXPECT_NE(a["key"], "hdrFlip");
  // All scenes: svgf[a=0] failed on "switch", so it is drawn but kept off the front.
  const json& all = data["speed"]["all"]["relMse"];
  for (const json& p : all["points"]) {
    if (p["label"] == "svgf[a=0]") {
      EXPECT_FALSE(p["complete"].get<bool>());
    }
  }
  for (const json& l : all["front"]) EXPECT_NE(l, "svgf[a=0]");
  // Passthrough over both scenes: mean of 0.5 and 0.6.
  EXPECT_NEAR(all["points"][0]["error"].get<double>(), 0.55, 1e-12);

  // Noise floor: frames t >= W = 2 only.
  EXPECT_NEAR(data["scenes"][0]["noiseFloor"]["mean"].get<double>(), 0.002, 1e-12);

  // Viewer: only existing files; svgf[a=0] has images for frame 2 and not frame 5.
  const json& panels = data["scenes"][0]["viewer"]["panels"];
  bool sawOutput = false;
  for (const json& p : panels)
    if (p["kind"] == "output" && p["label"] == "svgf[a=0]") {
      sawOutput = true;
      EXPECT_TRUE(p["srcs"].contains("2"));
      EXPECT_FALSE(p["srcs"].contains("5"));
    }
  EXPECT_TRUE(sawOutput);

  // Ablation: a=1 vs a=0 with b=true on "static": relMSE 0.04 - 0.05; b=false vs true with a=1:
  // 0.06 - 0.04 (a=0,b=false does not exist, so one match).
  ASSERT_TRUE(data["ablation"].is_object());
  bool sawA = false, sawB = false;
  for (const json& r : data["ablation"]["rows"]) {
    if (r["scene"] != "static") continue;
    if (r["parameter"] == "a") {
      sawA = true;
      EXPECT_EQ(r["value"], "1");
      EXPECT_EQ(r["matched"], 1);
      EXPECT_NEAR(r["delta"]["relMse"].get<double>(), -0.01, 1e-12);
    }
    if (r["parameter"] == "b") {
      sawB = true;
      EXPECT_EQ(r["value"], "false");
      EXPECT_NEAR(r["delta"]["relMse"].get<double>(), 0.02, 1e-12);
    }
  }
  EXPECT_TRUE(sawA);
  EXPECT_TRUE(sawB);
  EXPECT_TRUE(data["regression"].is_null());
}

TEST(Report, BaselineGivesCompareVerdicts) {
  json base = fixtureRun();
  json cand = fixtureRun();
  cand["pairs"][1]["summary"]["relMse"]["mean"] = 0.06;  // svgf[a=0] on static: +20% relMSE
  // The gate needs the per-tile data to resolve the change: 12 frames x 16 tiles around each mean.
  auto tiles = [](double mean) {
    MetricTiles m;
    for (int f = 0; f < 12; ++f) {
      TileSums t;
      for (int k = 0; k < 16; ++k) t.sum.push_back(mean * (1 + 0.01 * ((f * 16 + k) % 5 - 2))), t.count.push_back(1);
      m.add(f, std::move(t));
    }
    return m.toJson();
  };
  base["pairs"][1]["tiles"]["relMse"] = tiles(0.05);
  cand["pairs"][1]["tiles"]["relMse"] = tiles(0.06);
  const json data = reportData(cand, test::freshDir("report_regression"), &base);
  ASSERT_TRUE(data["regression"].is_object());
  EXPECT_TRUE(data["regression"]["anyRegression"].get<bool>());
  bool found = false;
  for (const json& r : data["regression"]["rows"])
    if (r["scene"] == "static" && r["label"] == "svgf[a=0]" && r["metric"] == "relMse") {
      found = true;
      EXPECT_EQ(r["verdict"], "regressed");
      EXPECT_NEAR(r["change"].get<double>(), 0.2, 1e-9);
    }
  EXPECT_TRUE(found);
}

// ---------------------------------------------------------------- bad input

TEST(Report, MissingRunIsAClearError) {
  ReportOptions o;
  o.run = test::freshDir("report_missing") / "no_such_run";
  o.out = test::freshDir("report_missing_out");
  o.nodeModulesDir = fakeNodeModules("report_missing_modules");
  try {
    writeReport(o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no such run directory"), std::string::npos) << e.what();
  }
}

TEST(Report, OtherSchemaVersionIsAClearError) {
  json run = fixtureRun();
  run["schema"] = kResultsSchemaVersion + 1;
  ReportOptions o;
  o.run = writeFixtureRun("report_schema", run);
  o.out = test::freshDir("report_schema_out");
  o.nodeModulesDir = fakeNodeModules("report_schema_modules");
  try {
    writeReport(o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("schema version"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(o.out / "data.js"));
}

TEST(Report, MissingChartingLibrarySaysToRunSetup) {
  ReportOptions o;
  o.run = writeFixtureRun("report_nolib", fixtureRun());
  o.out = test::freshDir("report_nolib_out");
  o.nodeModulesDir = test::freshDir("report_nolib_modules");  // empty
  try {
    writeReport(o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scripts/setup.sh"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace arena
