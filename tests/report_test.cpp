// `arena report`: the generator on a hand-built run (no rendering: the run's JSON is written here),
// the Pareto front on hand-built points, and the bad-input contract.
#include "reports/report.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/exr_io.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/error_maps.hpp"
#include "metrics/results.hpp"
#include "metrics/statistics.hpp"
#include "reports/image_files.hpp"
#include "reports/pareto.hpp"
#include "tests/contract_fixture.hpp"
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
    scenes[s] = {
        {"purpose", "test"},
        {"width", 4},
        {"height", 2},
        {"frames", 6},
        {"events", std::string(s) == "switch"
                       ? json::array({{{"frame", 5}, {"kind", "light_off"}, {"what", "lamp"}}})
                       : json::array()},
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
  EXPECT_EQ(s.images, 11u);  // the fixture's PNGs, copied
  EXPECT_FALSE(s.imagesInPlace);
  // The fixture is a sweep: its ablation is written beside the page as CSV too.
  EXPECT_EQ(s.ablation, o.out / "ablation.csv");
  EXPECT_EQ(readText(o.out / "ablation.csv")
                .rfind("parameter,value,versus,given,scene,matched,metric,", 0),
            0u);
  EXPECT_EQ(s.points, o.out / "points.csv");
  EXPECT_EQ(readText(o.out / "points.csv").rfind("label,point,a,b,scene,metric,", 0), 0u);
  EXPECT_TRUE(s.noAblation.empty());
  // A one-point grid compares nothing: no ablation, said why (the report of a two-value grid
  // before it, in the same folder, leaves no ablation.csv behind).
  {
    json one = fixtureRun();
    one["sweep"]["grid"] = {{"a", {"0"}}};
    one["sweep"]["labels"] = {"svgf[a=0]"};
    json kept = json::array();
    for (const json& pair : one["pairs"])
      if (pair["label"] == "svgf[a=0]" || pair["label"] == "passthrough") kept.push_back(pair);
    one["pairs"] = kept;
    ReportOptions p = o;
    p.run = writeFixtureRun("report_fixture_one_point", one);
    const ReportSummary q = writeReport(p);
    EXPECT_TRUE(q.ablation.empty());
    EXPECT_FALSE(fs::exists(o.out / "ablation.csv"));
    EXPECT_NE(q.noAblation.find("no grid parameter has two values"), std::string::npos)
        << q.noAblation;
  }
  s = writeReport(o);
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
  // Written again into the same folder: an earlier page's tiles go (a killed report had left new
  // tiles beside the old data.js).
  fs::create_directories(o.out / "tiles");
  std::ofstream(o.out / "tiles" / "s9_f99.js") << "stale";
  // The page's copies of an earlier run's images go too: the folder holds this run's alone.
  fs::create_directories(o.out / "images" / "another_scene" / "svgf");
  std::ofstream(o.out / "images" / "another_scene" / "svgf" / "frame_0003.png") << "png";
  writeReport(o);
  EXPECT_FALSE(fs::exists(o.out / "tiles" / "s9_f99.js"));
  EXPECT_FALSE(fs::exists(o.out / "images" / "another_scene"));
  EXPECT_TRUE(fs::exists(o.out / "images/static/svgf[a=0]/flip_0002.png"));
  EXPECT_TRUE(fs::exists(o.out / "data.js"));
  // A folder of images that is no page's is not the report's to empty: refused, nothing written.
  ReportOptions mine = o;
  mine.out = test::freshDir("report_fixture_own_images");
  fs::create_directories(mine.out / "images");
  std::ofstream(mine.out / "images" / "holiday.png") << "png";
  const std::string e = test::errorOf([&] { writeReport(mine); });
  EXPECT_NE(e.find("holds an images folder that is no earlier report's"), std::string::npos) << e;
  EXPECT_TRUE(fs::exists(mine.out / "images" / "holiday.png"));
  // Nor is it where a page's other files lie beside it (an app.js of the user's own), which the
  // page would replace: only a page's own index.html says the folder is a page's.
  std::ofstream(mine.out / "app.js") << "// mine";
  EXPECT_NE(test::errorOf([&] { writeReport(mine); })
                .find("holds app.js that no Denoise Arena page's index.html is beside: the page "
                      "would replace it"),
            std::string::npos);
  EXPECT_TRUE(fs::exists(mine.out / "images" / "holiday.png"));
  fs::remove(mine.out / "app.js");
  EXPECT_EQ(std::distance(fs::directory_iterator(mine.out), fs::directory_iterator()), 1);
  // A website's folder: its index.html, or a data.js `arena report` did not write (which it
  // removed, taking the images beside it for an earlier page's), refused, and nothing touched.
  ReportOptions site = o;
  site.out = test::freshDir("report_fixture_website");
  std::ofstream(site.out / "index.html") << "<!doctype html><title>My renderer</title>";
  EXPECT_NE(test::errorOf([&] {
              writeReport(site);
            }).find("holds an index.html that is no Denoise Arena report's or dashboard's"),
            std::string::npos);
  fs::remove(site.out / "index.html");
  std::ofstream(site.out / "data.js") << "var points = [1, 2, 3];";
  fs::create_directories(site.out / "images");
  std::ofstream(site.out / "images" / "logo.png") << "png";
  EXPECT_NE(test::errorOf([&] {
              writeReport(site);
            }).find("holds a data.js that `arena` did not write: the page would replace it"),
            std::string::npos);
  EXPECT_TRUE(fs::exists(site.out / "images" / "logo.png"));
  EXPECT_EQ(readText(site.out / "data.js"), "var points = [1, 2, 3];");
  EXPECT_EQ(std::distance(fs::directory_iterator(site.out), fs::directory_iterator()), 2);
  // So is a folder of what else the page writes or removes (its crops' tiles/, a sweep's tables)
  // with no page beside it: they were removed.
  for (const char* own : {"tiles/mine.txt", "ablation.csv", "points.csv"}) {
    ReportOptions other = o;
    other.out = test::freshDir("report_fixture_own_outputs");
    fs::create_directories((other.out / own).parent_path());
    std::ofstream(other.out / own) << "mine";
    EXPECT_NE(test::errorOf([&] { writeReport(other); }).find("no Denoise Arena page's index.html"),
              std::string::npos)
        << own;
    EXPECT_EQ(readText(other.out / own), "mine") << own;
  }
  // A page's file that is a link is replaced, not written through to what it points at.
  const fs::path outside = test::freshDir("report_fixture_link_target") / "theirs.css";
  std::ofstream(outside) << "theirs";
  fs::remove(o.out / "style.css");
  fs::create_symlink(outside, o.out / "style.css");
  writeReport(o);
  EXPECT_EQ(readText(outside), "theirs");
  EXPECT_FALSE(fs::is_symlink(o.out / "style.css"));
  // A page cut short after its data.js went keeps the mark in its copies: written again, the
  // report replaces them.
  fs::remove(o.out / "data.js");
  std::ofstream(o.out / "images" / "another.png") << "png";
  writeReport(o);
  EXPECT_FALSE(fs::exists(o.out / "images" / "another.png"));
  // Written in place (into the run's own folder), the run's images are never removed.
  ReportOptions inPlace = o;
  inPlace.out = inPlace.run;
  const ReportSummary placed = writeReport(inPlace);
  EXPECT_TRUE(placed.imagesInPlace);
  EXPECT_TRUE(fs::exists(inPlace.run / "images/static/svgf[a=0]/flip_0002.png"));
  writeReport(inPlace);
  EXPECT_TRUE(fs::exists(inPlace.run / "images/static/svgf[a=0]/flip_0002.png"));
}

TEST(Report, DataHasFrontNoiseFloorViewerAndAblation) {
  const json run = fixtureRun();
  const fs::path dir = writeFixtureRun("report_data", run);
  const json data = reportData(test::typed(run), dir, nullptr);

  // Speed on "static", relMSE: passthrough (0.01 ms, 0.5), svgf[a=1,b=false] (3 ms, 0.06),
  // svgf[a=0] (4 ms, 0.05), svgf[a=1] (5 ms, 0.04): every point is on the front here.
  const json& st = data["speed"]["views"]["cpu"]["scenes"]["static"]["relMse"];
  EXPECT_EQ(st["points"].size(), 4u);
  EXPECT_EQ(st["front"], json({"passthrough", "svgf[a=1,b=false]", "svgf[a=0]", "svgf[a=1]"}));
  // 1 - SSIM is an error axis: its bars flip (p5 of 1-SSIM = 1 - p95 of SSIM).
  const json& dssim = data["speed"]["views"]["cpu"]["scenes"]["static"]["dssim"]["points"][0];
  EXPECT_NEAR(dssim["error"].get<double>(), 0.1, 1e-12);
  EXPECT_NEAR(dssim["p5"].get<double>(), 1 - 0.9 * 1.3, 1e-12);
  // No HDR-FLIP in this run: the axis is not offered.
  for (const json& a : data["errorAxes"]) EXPECT_NE(a["key"], "hdrFlip");
  // All scenes: this run has no statistics, so there is no overall score to show -- and the
  // report makes none up (AllScenesShowStatisticsOverallScoresAndNeverASecondOne has one).
  EXPECT_FALSE(data["speed"]["views"]["cpu"]["all"].contains("relMse"));
  EXPECT_TRUE(data["rankings"]["overall"].is_null());
  // No intervals in this run: the bars are p5-p95 and the rankings say ties are unknown.
  EXPECT_EQ(st["points"][0]["interval"], "p5-p95");
  EXPECT_FALSE(data["rankings"]["scenes"]["static"]["tiesKnown"].get<bool>());
  EXPECT_EQ(data["rankings"]["scenes"]["static"]["ranking"][0]["label"], "svgf[a=1]");
  EXPECT_EQ(data["rankings"]["scenes"]["static"]["ranking"][3]["rank"], 4);

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
  // Frames: every kept one (2 and 5), marked chosen; the event frame says so.
  const json& frames = data["scenes"][1]["viewer"]["frames"];
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1]["frame"], 5);
  EXPECT_TRUE(frames[1]["chosen"].get<bool>());
  EXPECT_EQ(frames[1]["events"], json({"light_off lamp"}));
  EXPECT_FALSE(frames[0].contains("events"));

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

// The time axes (issue 31 section 4): the CPU time measured here, the GPU ms the model predicts
// on each device a pair carries, and a capture's recorded time, each with its own points and front.
// A pair with nothing to price (no counted traffic) is named under the GPU axis, never drawn on it.
TEST(Report, EachTimeAxisHasItsOwnPointsAndFront) {
  json run = fixtureRun();
  // On the predicted axis the order reverses: svgf[a=1,b=false] is the slowest there.
  const std::map<std::string, double> gpuMs = {{"svgf[a=0]", 2.0}, {"svgf[a=1]", 2.5}, {"svgf[a=1,b=false]", 9.0}};
  for (json& pair : run["pairs"]) {
    const std::string label = pair["label"];
    if (pair["scene"] != "static" || !gpuMs.count(label)) continue;
    const double ms = gpuMs.at(label);
    pair["timing"]["gpuPredicted"] = {
        {"resolution", {1920, 1080}},
        {"model", "test"},
        {"devices", json::array({{{"device", "TITAN RTX"}, {"msMedian", ms}, {"msP5", ms * 0.9}, {"msP95", ms * 1.2}, {"msMean", ms}}})},
        {"memory", {{"persistentMiB", 10.0 * ms}, {"workingSetMiB", 30.0 * ms}}}};
    if (label == "svgf[a=1]") pair["timing"]["gpuPredicted"]["skippedHere"] = 4;
    // Extra paths: their tracing time is drawn at its median beside the time's median.
    if (label == "svgf[a=0]") {
      pair["summary"]["tracingMs"] = summaryOf(2.0);
      pair["summary"]["tracingMs"]["median"] = 1.5;
    }
  }
  const fs::path dir = writeFixtureRun("report_clocks", run);
  const json data = reportData(test::typed(run), dir, nullptr);
  // A prediction that priced passes the run's resolution skipped is said under the GPU axis.
  EXPECT_NE(data["speed"]
                .value("gpuSkipped", "")
                .find("as that frame would run them: svgf[a=1] 4 per frame"),
            std::string::npos)
      << data["speed"].value("gpuSkipped", "");
  // On scenes of other sizes the same method skips other counts: the range, not the largest.
  EXPECT_EQ(data["speed"].value("gpuSkipped", "").find("a range"), std::string::npos);
  json sized = run;
  json predicted;
  for (json& pair : sized["pairs"])
    if (pair["label"] == "svgf[a=0]" && pair["scene"] == "static") {
      pair["timing"]["gpuPredicted"]["skippedHere"] = 4;
      predicted = pair["timing"]["gpuPredicted"];
    }
  for (json& pair : sized["pairs"])
    if (pair["label"] == "svgf[a=0]" && pair["scene"] == "switch") {
      pair["timing"]["gpuPredicted"] = predicted;
      pair["timing"]["gpuPredicted"]["skippedHere"] = 2;
    }
  const std::string ranged =
      reportData(test::typed(sized), dir, nullptr)["speed"].value("gpuSkipped", "");
  EXPECT_NE(
      ranged.find("as that frame would run them: svgf[a=0] 2-4, svgf[a=1] 4 per frame (a range"),
      std::string::npos)
      << ranged;
  const json& clocks = data["speed"]["clocks"];
  ASSERT_EQ(clocks.size(), 2u);
  EXPECT_EQ(clocks[0]["key"], "cpu");
  EXPECT_NE(clocks[0]["title"].get<std::string>().find("test, 2 threads, 4x2"), std::string::npos) << clocks[0]["title"];
  json loaded = run;  // the machine's load when the run began is part of what the clock says
  loaded["environment"]["loadAverage"] = {1.7, 1.2, 0.9};
  EXPECT_NE(reportData(test::typed(loaded), dir, nullptr)["speed"]["clocks"][0]["title"]
                .get<std::string>()
                .find("4x2, load 1.70 at the start)"),
            std::string::npos);
  EXPECT_EQ(clocks[1]["key"], "gpu:TITAN RTX");
  EXPECT_NE(clocks[1]["title"].get<std::string>().find("predicted at 1920x1080 on TITAN RTX"), std::string::npos);
  const json& gpu = data["speed"]["views"]["gpu:TITAN RTX"]["scenes"]["static"]["relMse"];
  ASSERT_EQ(gpu["points"].size(), 3u);
  for (const json& p : gpu["points"]) {
    EXPECT_DOUBLE_EQ(p["ms"].get<double>(), gpuMs.at(p["label"]));
    EXPECT_DOUBLE_EQ(p["msHi"].get<double>(), 1.2 * gpuMs.at(p["label"]));
  }
  for (const json& p : data["speed"]["views"]["cpu"]["scenes"]["static"]["relMse"]["points"])
    EXPECT_EQ(p.value("tracingMs", -1.0), p["label"] == "svgf[a=0]" ? 1.5 : -1.0) << p["label"];
  for (const json& p : gpu["points"]) EXPECT_FALSE(p.contains("tracingMs")) << p["label"];
  // svgf[a=1,b=false] (0.06) is slower and worse than svgf[a=0] there: off the GPU front, on the CPU one.
  EXPECT_EQ(gpu["front"], json({"svgf[a=0]", "svgf[a=1]"}));
  EXPECT_EQ(data["speed"]["views"]["cpu"]["scenes"]["static"]["relMse"]["front"],
            json({"passthrough", "svgf[a=1,b=false]", "svgf[a=0]", "svgf[a=1]"}));
  // passthrough carries no prediction here: named under the GPU axis with its own clock.
  bool named = false;
  for (const json& r : data["speed"]["views"]["gpu:TITAN RTX"]["otherClocks"])
    named = named || (r["label"] == "passthrough" && r["scene"] == "static");
  EXPECT_TRUE(named);
  // The tables' GPU columns: the first device's predicted ms and the memory at 1080p.
  for (const json& p : data["pairs"])
    if (p["scene"] == "static" && p["label"] == "svgf[a=1]") {
      EXPECT_DOUBLE_EQ(p["timing"]["gpuMs"].get<double>(), 2.5);
      EXPECT_EQ(p["timing"]["gpuDevice"], "TITAN RTX");
      EXPECT_DOUBLE_EQ(p["timing"]["gpuPersistentMiB"].get<double>(), 25.0);
      EXPECT_DOUBLE_EQ(p["timing"]["gpuWorkingSetMiB"].get<double>(), 75.0);
    }
}

// An external process's own reported time may be a GPU's: it gets an axis of its own, is never
// drawn on the CPU axis, and the tables label it.
TEST(Report, AProcessReportedTimeHasAnAxisOfItsOwn) {
  json run = fixtureRun();
  for (json& pair : run["pairs"])
    if (pair["label"] == "passthrough") {
      pair["timing"]["clock"] = "process";
      pair["timing"]["msSource"] = "reported by the process";
    }
  const fs::path dir = writeFixtureRun("report_process_clock", run);
  const json data = reportData(test::typed(run), dir, nullptr);
  std::vector<std::string> keys;
  for (const json& c : data["speed"]["clocks"]) keys.push_back(c["key"]);
  EXPECT_EQ(keys, (std::vector<std::string>{"cpu", "process"}));
  const json& cpu = data["speed"]["views"]["cpu"]["scenes"]["static"]["relMse"];
  for (const json& p : cpu["points"]) EXPECT_NE(p["label"], "passthrough");
  const json& own = data["speed"]["views"]["process"]["scenes"]["static"]["relMse"];
  ASSERT_EQ(own["points"].size(), 1u);
  EXPECT_EQ(own["points"][0]["label"], "passthrough");
  bool named = false;
  for (const json& r : data["speed"]["views"]["cpu"]["otherClocks"])
    named = named || (r["label"] == "passthrough" && r["source"] == "reported by the process");
  EXPECT_TRUE(named);
  for (const json& p : data["pairs"])
    if (p["label"] == "passthrough") {
      EXPECT_EQ(p["timing"]["clock"], "process");
      EXPECT_EQ(p["timing"]["device"], "reported by the process");
    }
}

TEST(Report, AblationDeltasAreTheRunsPairedDifferences) {
  // The run's statistics hold svgf[a=0] - svgf[a=1] on "static" (the opposite orientation of the
  // ablation's a=1 vs a=0): the row takes that difference, turned round, with its interval.
  json run = fixtureRun();
  // relMseCorrected: each method's relMSE less the reference's floor (here 0.001 for both).
  for (json& p : run["pairs"])
    if (p.contains("summary") && p["summary"].contains("relMse"))
      p["summary"]["relMseCorrected"] =
          summaryOf(p["summary"]["relMse"]["mean"].get<double>() - 0.001);
  for (json& p : run["pairs"])
    if (p.contains("summary") && p["summary"].contains("ssim"))
      p["summary"]["dssim"] = summaryOf(1 - p["summary"]["ssim"]["mean"].get<double>());
  run["statistics"] =
      test::statisticsBlock(json::parse(R"({"scenes": {"static": {"metric": "relMse", "ranking": [],
    "pairs": [{"a": "svgf[a=0]", "b": "svgf[a=1]", "diff": 0.0123, "ci95": [0.004, 0.02], "resolved": true},
              {"a": "svgf[a=1,b=false]", "b": "svgf[a=1]", "diff": 0.02, "ci95": [-0.001, 0.04], "resolved": false}],
    "resolvedPairs": 1, "totalPairs": 2, "byMetric": {"ssim": {"metric": "ssim", "ranking": [],
      "pairs": [{"a": "svgf[a=0]", "b": "svgf[a=1]", "diff": 0.003, "ci95": [0.001, 0.005], "resolved": true}],
      "resolvedPairs": 1, "totalPairs": 1}}}}})"));
  const json data = reportData(test::typed(run), test::freshDir("report_ablation_paired"), nullptr);
  int seen = 0;
  for (const json& r : data["ablation"]["rows"]) {
    if (r["scene"] != "static") continue;
    if (r["parameter"] == "a") {
      ++seen;
      EXPECT_NEAR(r["delta"]["relMse"].get<double>(), -0.0123, 1e-15);  // not the means' -0.01
      EXPECT_EQ(r["judged"]["relMse"]["verdict"], "better");
      EXPECT_EQ(r["paired"]["relMse"]["ci95"], json({-0.02, -0.004}));
      EXPECT_TRUE(r["paired"]["relMse"]["resolved"].get<bool>());
      // The floor cancels in a paired difference: relMseCorrected's is relMSE's, interval included
      // (it was "no interval").
      EXPECT_EQ(r["judged"]["relMseCorrected"]["verdict"], "better");
      EXPECT_EQ(r["paired"]["relMseCorrected"], r["paired"]["relMse"]);
      // 1 - SSIM's is SSIM's, negated (SSIM higher is better, 1 - SSIM lower: the same verdict).
      EXPECT_DOUBLE_EQ(r["paired"]["dssim"]["diff"].get<double>(), 0.003);
      EXPECT_EQ(r["paired"]["dssim"]["ci95"], json({0.001, 0.005}));
      EXPECT_EQ(r["judged"]["dssim"]["verdict"], "worse");
      EXPECT_EQ(r["judged"]["ssim"]["verdict"], "worse");
    }
    if (r["parameter"] == "b") {
      ++seen;
      EXPECT_FALSE(r["paired"]["relMse"]["resolved"].get<bool>());  // drawn as a tie
      EXPECT_EQ(r["judged"]["relMse"]["verdict"], "tie");
      EXPECT_FALSE(r["paired"].contains("ldrFlip")) << "no paired difference on it in this run";
    }
  }
  EXPECT_EQ(seen, 2);
  // The same rows as CSV, one line per metric, the paired interval where one match has it.
  const std::string csv = ablationCsv(data["ablation"]);
  EXPECT_EQ(csv.rfind("parameter,value,versus,given,scene,matched,metric,delta,relative,verdict,"
                      "matches,intervals,resolved,ci95Lo,ci95Hi,note\n",
                      0),
            0u)
      << csv;
  EXPECT_NE(csv.find("\na,1,0,b=true,static,1,relMse,-0.0123"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",better,1,1,1,-0.02,-0.0040000000000000001,\n"), std::string::npos) << csv;
  EXPECT_EQ(ablationCsv(nullptr), "");
  // What the run said of a scene's results travels with its rows, in the CSV's note too (a table
  // copied into a paper lost it): too few frames after the warm-up, a reference short of its goal.
  run["scenes"]["static"]["warnings"] = {
      "only 2 frames follow the warm-up of 8: the intervals resample so few frames that they "
      "hardly cover how a method varies"};
  const json caveated =
      reportData(test::typed(run), test::freshDir("report_ablation_caveat"), nullptr)["ablation"];
  bool sceneRow = false;  // (one scene with matches: no all-scenes row, whose caveat names them)
  for (const json& r : caveated["rows"]) {
    if (r["scene"] == "static") {
      sceneRow = true;
      EXPECT_EQ(r.value("caveat", ""), "only 2 frames follow the warm-up of 8") << r;
    }
    if (r["scene"].is_null()) {
      EXPECT_EQ(r.value("caveat", ""), "caveats on static (their rows say which)") << r;
    }
    if (r["scene"] == "switch") {
      EXPECT_FALSE(r.contains("caveat")) << r;
    }
  }
  EXPECT_TRUE(sceneRow);
  EXPECT_NE(ablationCsv(caveated).find(",static,1,relMse,-0.0123"), std::string::npos);
  EXPECT_NE(ablationCsv(caveated).find(",-0.02,-0.0040000000000000001,only 2 frames follow the "
                                       "warm-up of 8\n"),
            std::string::npos)
      << ablationCsv(caveated);
}

// Over all scenes, each metric's CSV line names only the caveated scenes it holds a change of: an
// event's figure (or any metric) measured on an uncaveated scene alone carries no caveat (every
// line named every caveated scene).
TEST(Report, AnAllScenesLineNamesTheCaveatsOfItsOwnScenes) {
  json run = fixtureRun();
  for (json& p : run["pairs"])
    if (p["scene"] == "switch" && p["label"] == "svgf[a=0]")
      p = okPair("switch", "svgf", "svgf[a=0]", {{"a", 0}, {"b", true}}, 0.07, 4.0);
  run["pairs"].push_back(okPair("switch", "svgf", "svgf[a=1]", {{"a", 1}, {"b", true}}, 0.05, 5.0));
  for (json& p : run["pairs"])
    if (p["scene"] == "switch") p["summary"].erase("ldrFlip");  // measured on static alone
  run["scenes"]["switch"]["warnings"] = {
      "only 2 frames follow the warm-up of 8: the intervals resample so few frames that they "
      "hardly cover how a method varies"};
  const json ablation = reportData(test::typed(run), test::freshDir("report_ablation_all_caveats"),
                                   nullptr)["ablation"];
  int seen = 0;
  for (const json& r : ablation["rows"])
    if (r["scene"].is_null() && r["parameter"] == "a") {
      ++seen;
      EXPECT_EQ(r["caveat"], "caveats on switch (their rows say which)");
      EXPECT_EQ(r["caveatByMetric"]["relMse"], "caveats on switch (their rows say which)");
      EXPECT_EQ(r["caveatByMetric"]["ldrFlip"], "") << r.dump();
    }
  EXPECT_EQ(seen, 1);
  const std::string csv = ablationCsv(ablation);
  EXPECT_NE(csv.find(",all scenes,2,relMse,"), std::string::npos) << csv;
  const size_t ldr = csv.find(",all scenes,2,ldrFlip,");
  ASSERT_NE(ldr, std::string::npos) << csv;
  EXPECT_EQ(csv.substr(ldr, csv.find('\n', ldr) - ldr).find("caveats"), std::string::npos) << csv;
  const size_t rel = csv.find(",all scenes,2,relMse,");
  EXPECT_NE(csv.substr(rel, csv.find('\n', rel) - rel).find("caveats on switch"),
            std::string::npos);
}

// Time in the ablation is the median frame time, as in the summary table and the speed chart: a
// few slow frames move the mean (a grid point read +93% slower by it). A one-scene sweep has no
// "all scenes" row repeating its scene's.
TEST(Report, AblationTimeIsTheMedianAndOneSceneIsOneRow) {
  json run = fixtureRun();
  for (json& p : run["pairs"])
    if (p["label"] == "svgf[a=1]" && p["scene"] == "static") p["summary"]["ms"]["mean"] = 50.0;
  const json data = reportData(test::typed(run), test::freshDir("report_ablation_time"), nullptr);
  int seen = 0;
  for (const json& r : data["ablation"]["rows"]) {
    EXPECT_EQ(r["scene"], "static") << r.dump();  // the fixture's sweep ran on one scene
    if (r["parameter"] != "a") continue;
    ++seen;
    EXPECT_DOUBLE_EQ(r["delta"]["ms"].get<double>(), 1.0);  // medians 5 - 4, not the mean's 46
    EXPECT_DOUBLE_EQ(r["relative"]["ms"].get<double>(), 0.25);
  }
  EXPECT_EQ(seen, 1);
}

// Where a parameter's value matches the first value under several settings of the others, the
// row's colour needs every matched paired difference resolved the same way (and over all scenes);
// a metric without paired intervals has none.
TEST(Report, AblationJudgesEveryMatchedIntervalTogether) {
  json run = fixtureRun();
  run["pairs"].push_back(
      okPair("static", "svgf", "svgf[a=0,b=false]", {{"a", 0}, {"b", false}}, 0.07, 3.0));
  // a=1 against a=0: at b=true resolved lower (better: relMSE is lower-is-better); at b=false as
  // `second` says (oriented a=0 - a=1 in the statistics, as the first is).
  auto judgedA = [&](const json& second, const json& scene) {
    json r = run;
    r["statistics"] =
        test::statisticsBlock(json{{"scenes",
                                    {{"static",
                                      {{"metric", "relMse"},
                                       {"ranking", json::array()},
                                       {"pairs", json::array({json{{"a", "svgf[a=0]"},
                                                                   {"b", "svgf[a=1]"},
                                                                   {"diff", 0.0123},
                                                                   {"ci95", {0.004, 0.02}},
                                                                   {"resolved", true}},
                                                              second})},
                                       {"resolvedPairs", 1 + int(second["resolved"].get<bool>())},
                                       {"totalPairs", 2},
                                       {"byMetric", json::object()}}}}}});
    const json data = reportData(test::typed(r), test::freshDir("report_ablation_judged"), nullptr);
    for (const json& row : data["ablation"]["rows"]) {
      EXPECT_FALSE(row["scene"].is_null()) << "one scene: no all-scenes row repeating it";
      if (row["parameter"] == "a" && row["scene"] == scene) return row;
    }
    ADD_FAILURE() << "no row for a on " << scene.dump();
    return json();
  };
  auto pairOf = [](double diff, double lo, double hi, bool resolved) {
    return json{{"a", "svgf[a=0,b=false]"},
                {"b", "svgf[a=1,b=false]"},
                {"diff", diff},
                {"ci95", {lo, hi}},
                {"resolved", resolved}};
  };
  json row = judgedA(pairOf(0.01, -0.001, 0.02, false), "static");
  EXPECT_EQ(row["matched"], 2);
  // Resolved at b=true, not at b=false: an effect under one setting only, not a tie.
  EXPECT_EQ(
      row["judged"]["relMse"],
      (json{{"verdict", "partly better"}, {"matches", 2}, {"intervals", 2}, {"resolved", 1}}));
  // Each match with its own paired difference, named by the other parameters' settings.
  ASSERT_EQ(row["byMatch"].size(), 2u) << row.dump();
  EXPECT_EQ(row["byMatch"][0]["given"], "b=true");
  EXPECT_EQ(row["byMatch"][0]["judged"]["relMse"], "better");
  EXPECT_EQ(row["byMatch"][0]["paired"]["relMse"]["ci95"], json({-0.02, -0.004}));
  EXPECT_EQ(row["byMatch"][1]["given"], "b=false");
  EXPECT_EQ(row["byMatch"][1]["judged"]["relMse"], "tie");
  EXPECT_EQ(row["byMatch"][1]["judged"]["ssim"], "no interval");
  // ... and in the CSV, a line per match under the row's line.
  json ablation = {{"rows", json::array({row})}};
  const std::string csv = ablationCsv(ablation);
  EXPECT_NE(csv.find("\na,1,0,,static,2,relMse,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",partly better,2,2,1,,,\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\na,1,0,b=true,static,1,relMse,-0.0123"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",better,1,1,1,-0.02,-0.0040000000000000001,\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\na,1,0,b=false,static,1,relMse,-0.01"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",tie,1,1,0,-0.02,0.001,\n"), std::string::npos) << csv;
  EXPECT_EQ(row["judged"]["ssim"]["verdict"],
            "no interval");  // the statistics rank only relMSE here
  EXPECT_FALSE(row.contains("paired")) << "one interval per match: no single interval for the row";
  row = judgedA(pairOf(0.01, 0.001, 0.02, true), "static");
  EXPECT_EQ(row["judged"]["relMse"]["verdict"], "better");
  row = judgedA(pairOf(-0.01, -0.02, -0.001, true), "static");  // a=1 resolved worse at b=false
  EXPECT_EQ(row["judged"]["relMse"],
            (json{{"verdict", "mixed"}, {"matches", 2}, {"intervals", 2}, {"resolved", 2}}));
}

// A scripted event of the fixture's scene "static" with its figures' rankings (statistics JSON).
json event(int frame, const json& byFigure) {
  return {
      {"eventFrame", frame}, {"kind", "light_switch"}, {"what", "lamp"}, {"byFigure", byFigure}};
}
// Statistics that rank nothing on "static" but its events.
json staticSceneEvents(const json& events) {
  return test::statisticsBlock({{"scenes",
                                 {{"static",
                                   {{"metric", "relMse"},
                                    {"ranking", json::array()},
                                    {"pairs", json::array()},
                                    {"resolvedPairs", 0},
                                    {"totalPairs", 0},
                                    {"byMetric", json::object()},
                                    {"events", events}}}}}});
}

// An ablation of an anti-lag term is about lag: the event figures the statistics rank (per
// scripted event and camera cut) are changes of the row too, named as results.db names them,
// with their paired intervals.
TEST(Report, AblationCarriesTheEventFiguresPairedDifferences) {
  json run = fixtureRun();
  const json ranking = json::parse(R"({"metric": "lagEnergy",
    "ranking": [{"label": "svgf[a=1]", "rank": 1, "mean": 0.5, "ci95": [0.4, 0.6], "tiedWith": []},
                {"label": "svgf[a=0]", "rank": 2, "mean": 2.0, "ci95": [1.5, 2.5], "tiedWith": []}],
    "pairs": [{"a": "svgf[a=0]", "b": "svgf[a=1]", "diff": 1.5, "ci95": [1.0, 2.0], "resolved": true}],
    "resolvedPairs": 1, "totalPairs": 1})");
  run["statistics"] = staticSceneEvents(json::array({event(12, {{"lagEnergy", ranking}})}));
  const json data = reportData(test::typed(run), test::freshDir("report_ablation_events"), nullptr);
  EXPECT_EQ(data["ablation"]["figures"], json({"ghosting@12.lagEnergy"}));
  int seen = 0;
  for (const json& r : data["ablation"]["rows"]) {
    if (r["parameter"] != "a") continue;
    ++seen;
    EXPECT_DOUBLE_EQ(r["delta"]["ghosting@12.lagEnergy"].get<double>(), -1.5);  // a=1 - a=0
    EXPECT_DOUBLE_EQ(r["relative"]["ghosting@12.lagEnergy"].get<double>(), -0.75);
    EXPECT_EQ(r["judged"]["ghosting@12.lagEnergy"]["verdict"], "better");
    EXPECT_EQ(r["paired"]["ghosting@12.lagEnergy"]["ci95"], json({-2.0, -1.0}));
  }
  EXPECT_EQ(seen, 1);
  EXPECT_NE(
      ablationCsv(data["ablation"])
          .find("\na,1,0,b=true,static,1,ghosting@12.lagEnergy,-1.5,-0.75,better,1,1,1,-2,-1,\n"),
      std::string::npos)
      << ablationCsv(data["ablation"]);
  // The points themselves, for a plot: the event figure's value, interval and rank per point.
  const std::string points = sweepPointsCsv(test::typed(run));
  EXPECT_NE(
      points.find("\nsvgf[a=1],true,1,true,static,ghosting@12.lagEnergy,0.5,0.40000000000000002,"
                  "0.59999999999999998,1,,\n"),
      std::string::npos)
      << points;
}

// What an event figure cannot say is said: a response of 0 frames has no relative change (it read
// +1.9e15 %), a method that never settled has bounds, not measurements, and an event whose figures
// rank nobody is named with the reason (it had no column and no word).
TEST(Report, AblationFiguresSayWhatTheyCannotMeasure) {
  json run = fixtureRun();
  const json response = json::parse(R"({"metric": "responseFrames",
    "ranking": [{"label": "svgf[a=0]", "rank": 1, "mean": 0, "ci95": [0, 0], "tiedWith": []},
                {"label": "svgf[a=1]", "rank": 2, "mean": 12, "ci95": [12, 12], "tiedWith": []}],
    "pairs": [{"a": "svgf[a=0]", "b": "svgf[a=1]", "diff": -12, "ci95": [-12, -12], "resolved": true}],
    "resolvedPairs": 1, "totalPairs": 1})");
  const json nobody = json::parse(R"({"metric": "lagEnergy", "ranking": [], "pairs": [],
    "resolvedPairs": 0, "totalPairs": 0,
    "excluded": "svgf[a=0]: the changed region spreads over 1.1 effective tiles of 16, fewer than 4; svgf[a=1]: the changed region spreads over 1.1 effective tiles of 16, fewer than 4"})");
  // Neither settled after the event at 20: both responses are the window's length.
  const json neither = json::parse(R"({"metric": "responseFrames",
    "ranking": [{"label": "svgf[a=0]", "rank": 1, "mean": 10, "ci95": [10, 10], "tiedWith": ["svgf[a=1]"]},
                {"label": "svgf[a=1]", "rank": 1, "mean": 10, "ci95": [10, 10], "tiedWith": ["svgf[a=0]"]}],
    "pairs": [{"a": "svgf[a=0]", "b": "svgf[a=1]", "diff": 0, "ci95": [0, 0], "resolved": false}],
    "resolvedPairs": 0, "totalPairs": 1})");
  run["statistics"] = staticSceneEvents(
      json::array({event(3, {{"lagEnergy", nobody}}), event(12, {{"responseFrames", response}}),
                   event(20, {{"responseFrames", neither}})}));
  for (json& p : run["pairs"]) {
    if (p["label"] == "svgf[a=1]")
      p["ghosting"] = json::array({{{"eventFrame", 3}, {"lagEnergy", 0.5}},
                                   {{"eventFrame", 12}, {"settled", false}},
                                   {{"eventFrame", 20}, {"settled", false}}});
    if (p["label"] == "svgf[a=0]")
      p["ghosting"] = json::array(
          {{{"eventFrame", 3}, {"lagEnergy", 2.0}}, {{"eventFrame", 20}, {"settled", false}}});
  }
  const json data = reportData(test::typed(run), test::freshDir("report_ablation_bounds"), nullptr);
  EXPECT_EQ(data["ablation"]["unrankedFigures"],
            json({"ghosting@3.lagEnergy on static: the changed region spreads over 1.1 effective "
                  "tiles of 16, fewer than 4"}));
  int seen = 0;
  for (const json& r : data["ablation"]["rows"]) {
    if (r["parameter"] != "a") continue;
    ++seen;
    EXPECT_DOUBLE_EQ(r["delta"]["ghosting@12.responseFrames"].get<double>(), 12);
    EXPECT_TRUE(r["relative"]["ghosting@12.responseFrames"].is_null()) << r.dump();
    EXPECT_EQ(r["notes"]["ghosting@12.responseFrames"],
              "svgf[a=1] never settled within the window: its responseFrames is the window's "
              "length, a lower bound: the difference is bounded, not measured");
    // Ranked for nobody (no interval could be drawn): the methods' own values' change, no
    // interval, the reason.
    EXPECT_DOUBLE_EQ(r["delta"]["ghosting@3.lagEnergy"].get<double>(), -1.5);
    EXPECT_EQ(r["judged"]["ghosting@3.lagEnergy"]["verdict"], "no interval");
    EXPECT_EQ(r["notes"]["ghosting@3.lagEnergy"],
              "not ranked, so no interval: the changed region spreads over 1.1 effective tiles of "
              "16, fewer than 4");
    // Neither settled: no change can show, so not judged (as compare says), not a tie at [0, 0].
    EXPECT_EQ(r["judged"]["ghosting@20.responseFrames"]["verdict"], "not judged") << r.dump();
    EXPECT_NE(r["notes"]["ghosting@20.responseFrames"].get<std::string>().find(
                  "both are cut off at the window's end, so no change can show (not judged"),
              std::string::npos);
  }
  EXPECT_EQ(seen, 1);
  const std::string csv = ablationCsv(data["ablation"]);
  EXPECT_NE(csv.find(",static,1,ghosting@12.responseFrames,12,,worse,1,1,1,12,12,\"svgf[a=1] never "
                     "settled"),
            std::string::npos)
      << csv;
  const std::string points = sweepPointsCsv(test::typed(run));
  EXPECT_NE(points.find(
                "\nsvgf[a=1],true,1,true,static,ghosting@12.responseFrames,12,12,12,2,,\"svgf[a=1] "
                "never settled within the window"),
            std::string::npos)
      << points;
  EXPECT_NE(
      points.find("\nsvgf[a=0],true,0,true,static,ghosting@3.lagEnergy,2,,,,,\"not ranked: the "
                  "changed region spreads over 1.1 effective tiles of 16, fewer than 4\"\n"),
      std::string::npos)
      << points;
}

// Two grid points whose outputs are the same bits on a scene (their checksums): every difference is
// 0 with nothing to resolve, which the ablation says ("identical outputs", with a note) rather
// than reading as a tie a paper would copy.
TEST(Report, AblationSaysWhereTwoPointsGaveIdenticalOutputs) {
  json run = fixtureRun();
  double relMse = 0;
  for (const json& p : run["pairs"])
    if (p["label"] == "svgf[a=1]" && p["scene"] == "static")
      relMse = p["summary"]["relMse"]["mean"].get<double>();
  for (json& p : run["pairs"])
    if (p["scene"] == "static" &&
        (p["label"] == "svgf[a=1]" || p["label"] == "svgf[a=1,b=false]")) {
      p["outputChecksum"] = "0x5eed";
      p["summary"]["relMse"]["mean"] = relMse;
    }
  run["statistics"] =
      test::statisticsBlock(json::parse(R"({"scenes": {"static": {"metric": "relMse", "ranking": [],
    "pairs": [{"a": "svgf[a=1,b=false]", "b": "svgf[a=1]", "diff": 0, "ci95": [0, 0], "resolved": false}],
    "resolvedPairs": 0, "totalPairs": 1, "byMetric": {}}}})"));
  const json data =
      reportData(test::typed(run), test::freshDir("report_ablation_identical"), nullptr);
  int seen = 0;
  for (const json& r : data["ablation"]["rows"]) {
    if (r["scene"] != "static" || r["parameter"] != "b") continue;
    ++seen;
    EXPECT_EQ(r["judged"]["relMse"]["verdict"], "identical outputs") << r.dump();
    EXPECT_NE(r["notes"]["relMse"].get<std::string>().find("identical outputs (bit for bit"),
              std::string::npos);
  }
  EXPECT_EQ(seen, 1);
  EXPECT_NE(ablationCsv(data["ablation"])
                .find(",relMse,0,0,identical outputs,1,1,0,0,0,\"identical outputs (bit for bit"),
            std::string::npos)
      << ablationCsv(data["ablation"]);
}

// A grid parameter without effect (b here: its two values give the same bits) makes the other's
// matches repeat one comparison: counted once, and said, not "matches 2, resolved 2" for one
// comparison measured twice (a statistician's audit).
TEST(Report, AblationCountsAMatchThatRepeatsAnothersOutputsOnce) {
  json run = fixtureRun();
  run["pairs"].push_back(
      okPair("static", "svgf", "svgf[a=0,b=false]", {{"a", 0}, {"b", false}}, 0.05, 4.0));
  for (json& p : run["pairs"])
    if (p["scene"] == "static" && p["denoiser"] == "svgf") {
      p["outputChecksum"] = p["params"]["a"] == 0 ? "0xa0" : "0xa1";
      p["summary"]["relMse"] = summaryOf(p["params"]["a"] == 0 ? 0.05 : 0.04);
    }
  const json data = reportData(test::typed(run), test::freshDir("report_ablation_repeat"), nullptr);
  int seen = 0;
  for (const json& r : data["ablation"]["rows"]) {
    if (r["scene"] != "static" || r["parameter"] != "a") continue;
    ++seen;
    EXPECT_EQ(r["matched"], 1) << r.dump();
    EXPECT_EQ(r["judged"]["relMse"]["matches"], 1) << r.dump();
    EXPECT_NE(r.value("caveat", "")
                  .find("1 further match gave the two outputs of a match counted, "
                        "bit for bit (another parameter without effect there): "
                        "counted once"),
              std::string::npos)
        << r.dump();
  }
  EXPECT_EQ(seen, 1);
}

// A tie whose per-frame differences hold one sign on every frame after the warm-up is said so (a
// local effect, an edge term's, can read as a tie because the interval resamples tiles); a tie
// whose differences change sign is not, nor one over fewer than 8 frames.
TEST(Report, AblationSaysWhereATieHoldsOneSignOnEveryFrame) {
  const auto withFrames = [](int frames, bool flip) {
    json run = fixtureRun();
    for (json& p : run["pairs"]) {
      if (p["scene"] != "static") continue;
      const bool off = p["label"] == "svgf[a=1,b=false]";
      if (!off && p["label"] != "svgf[a=1]") continue;
      json perFrame = json::array();
      for (int t = 0; t < frames; ++t)
        perFrame.push_back(
            {{"frame", t}, {"relMse", 0.1 + (off ? (flip && t == 5 ? -1e-4 : 1e-4) : 0.0)}});
      p["frames"] = perFrame;
    }
    run["statistics"] = test::statisticsBlock(
        json::parse(R"({"scenes": {"static": {"metric": "relMse", "ranking": [],
      "pairs": [{"a": "svgf[a=1,b=false]", "b": "svgf[a=1]", "diff": 1e-4, "ci95": [-1e-5, 2e-4], "resolved": false}],
      "resolvedPairs": 0, "totalPairs": 1, "byMetric": {}}}})"));
    return reportData(test::typed(run), test::freshDir("report_ablation_one_sign"), nullptr);
  };
  const auto noteOf = [](const json& data) {
    for (const json& r : data["ablation"]["rows"])
      if (r["scene"] == "static" && r["parameter"] == "b")
        return r.value("notes", json::object()).value("relMse", std::string());
    return std::string("no row");
  };
  const json data = withFrames(12, false);  // 10 frames after the warm-up of 2
  EXPECT_EQ(noteOf(data).rfind("a tie, yet the difference is positive on all 10 frames after the "
                               "warm-up: the interval also resamples the image's tiles",
                               0),
            0u)
      << noteOf(data);
  EXPECT_NE(ablationCsv(data["ablation"])
                .find(",tie,1,1,0,-1.0000000000000001e-05,0.00020000000000000001,\"a tie, yet"),
            std::string::npos)
      << ablationCsv(data["ablation"]);
  EXPECT_EQ(noteOf(withFrames(12, true)), "");  // frame 5 the other way
  EXPECT_EQ(noteOf(withFrames(9, false)), "");  // 7 frames after the warm-up
}

// A compared grid point that read oracle data (a layer no real-time engine has) is named with the
// rows that compare it, in ablation.csv's note too: its "better" is not on equal terms.
TEST(Report, AnAblationRowNamesAPointThatReadOracleData) {
  json run = fixtureRun();
  for (json& p : run["pairs"])
    if (p["label"] == "svgf[a=1,b=false]") p["oracleLayers"] = {"specHitDistMirror"};
  const json ablation =
      reportData(test::typed(run), test::freshDir("report_ablation_oracle"), nullptr)["ablation"];
  int seen = 0;
  for (const json& r : ablation["rows"]) {
    if (r["parameter"] == "b") {
      ++seen;
      EXPECT_EQ(r.value("caveat", ""),
                "oracle data read by svgf[a=1,b=false] (specHitDistMirror), which a real-time "
                "engine would not have")
          << r.dump();
    }
    if (r["parameter"] == "a") {
      EXPECT_FALSE(r.contains("caveat")) << r.dump();
    }
  }
  EXPECT_EQ(seen, 1);
  EXPECT_NE(
      ablationCsv(ablation).find(",\"oracle data read by svgf[a=1,b=false] (specHitDistMirror)"),
      std::string::npos)
      << ablationCsv(ablation);
  // points.csv: each of the point's lines says it, and no other point's.
  const std::string points = sweepPointsCsv(test::typed(run));
  size_t lines = 0, oracleLines = 0;
  for (size_t at = points.find('\n'); at != std::string::npos && at + 1 < points.size();
       at = points.find('\n', at + 1)) {
    const std::string l = points.substr(at + 1, points.find('\n', at + 1) - at - 1);
    const bool oracle = l.find("reads oracle data (specHitDistMirror)") != std::string::npos;
    EXPECT_EQ(oracle, l.rfind("\"svgf[a=1,b=false]\",", 0) == 0) << l;
    ++lines;
    oracleLines += oracle;
  }
  EXPECT_GT(oracleLines, 0u);
  EXPECT_LT(oracleLines, lines);
}

// A sweep's points as CSV: the grid's points first in the grid's order, a column per grid and
// fixed parameter (empty for a contender that is no point), the statistics' interval and rank
// where the metric is ranked, the summary's own interval where not, the median time.
TEST(Report, SweepPointsAreOneLinePerContenderSceneAndMetric) {
  json run = fixtureRun();
  run["sweep"]["labels"] = {"svgf[a=0]", "svgf[a=1]", "svgf[a=1,b=false]"};
  run["sweep"]["fixed"] = {{"sigmaL", "8"}};
  for (json& p : run["pairs"]) {
    if (p["label"] == "svgf[a=1]") p["summary"]["ssim"]["ci95"] = {0.85, 0.95};
    if (p["label"] == "svgf[a=1]") p["summary"]["relMseCorrected"] = summaryOf(0.039);
    if (p["label"] == "svgf[a=0]")
      p["summary"]["tRmae"] = {{"frames", 4}, {"absent", "no frame after the warm-up"}};
  }
  run["statistics"] =
      test::statisticsBlock(json::parse(R"({"scenes": {"static": {"metric": "relMse",
    "ranking": [{"label": "svgf[a=1]", "rank": 1, "mean": 0.04, "ci95": [0.03, 0.05], "tiedWith": []},
                {"label": "svgf[a=0]", "rank": 2, "mean": 0.05, "ci95": [0.045, 0.055], "tiedWith": []}],
    "pairs": [], "resolvedPairs": 0, "totalPairs": 0, "byMetric": {}}}})"));
  const std::string csv = sweepPointsCsv(test::typed(run));
  EXPECT_EQ(
      csv.rfind("label,point,a,b,sigmaL,scene,metric,mean,ci95Lo,ci95Hi,rank,frames,note\n", 0), 0u)
      << csv;
  EXPECT_LT(csv.find("\nsvgf[a=0],true,0,true,8,static,relMse,0.050000000000000003,"
                     "0.044999999999999998,0.055,2,4,\n"),
            csv.find("\nsvgf[a=1],true,1,true,8,static,relMse,0.040000000000000001,"
                     "0.029999999999999999,0.050000000000000003,1,4,\n"))
      << csv;
  EXPECT_NE(csv.find("\nsvgf[a=1],true,1,true,8,static,relMse,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\nsvgf[a=1],true,1,true,8,static,ssim,0.90000000000000002,"
                     "0.84999999999999998,0.94999999999999996,,4,\n"),
            std::string::npos)
      << csv;
  EXPECT_NE(csv.find("\nsvgf[a=1],true,1,true,8,static,ms (median),5,,,,4,\n"), std::string::npos)
      << csv;
  EXPECT_NE(csv.find("\npassthrough,false,,,,static,relMse,0.5,,,,4,\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("\npassthrough,false,,,,switch,relMse,0.59999999999999998,,,,4,\n"),
            std::string::npos)
      << csv;
  EXPECT_EQ(csv.find("svgf[a=0],true,0,true,8,switch,"), std::string::npos) << "it failed there";
  // relMseCorrected takes relMSE's rank (the floor cancels in the paired differences), its own
  // interval; a summary without a mean says why, with no number.
  EXPECT_NE(
      csv.find("\nsvgf[a=1],true,1,true,8,static,relMseCorrected,0.039,,,1,4,ranked as relMse\n"),
      std::string::npos)
      << csv;
  EXPECT_NE(csv.find("\nsvgf[a=0],true,0,true,8,static,tRmae,,,,,4,no frame after the warm-up\n"),
            std::string::npos)
      << csv;
  run.erase("sweep");
  EXPECT_EQ(sweepPointsCsv(test::typed(run)), "");
}

// The summary table's "best" of a column is what the statistics rank first, ties included: per
// ranked metric the labels at rank 1; a metric ranked over one method has no first.
TEST(Report, FirstByMetricIsTheStatisticsRankOneWithItsTies) {
  json run = fixtureRun();
  auto ranked = [](const std::string& label, int rank, json tied) {
    return json{{"label", label},
                {"rank", rank},
                {"mean", 0.04},
                {"ci95", {0.03, 0.05}},
                {"tiedWith", tied}};
  };
  const json tiedPair = {{"a", "svgf[a=1]"},
                         {"b", "svgf[a=0]"},
                         {"diff", -0.01},
                         {"ci95", {-0.03, 0.01}},
                         {"resolved", false}};
  run["statistics"] = test::statisticsBlock(
      json{{"scenes",
            {{"static",
              {{"metric", "relMse"},
               {"ranking", json::array({ranked("svgf[a=1]", 1, {"svgf[a=0]"}),
                                        ranked("svgf[a=0]", 1, {"svgf[a=1]"})})},
               {"pairs", json::array({tiedPair})},
               {"resolvedPairs", 0},
               {"totalPairs", 1},
               {"byMetric",
                {{"ssim",
                  {{"metric", "ssim"},
                   {"ranking", json::array({ranked("svgf[a=1]", 1, json::array())})},
                   {"pairs", json::array()},
                   {"resolvedPairs", 0},
                   {"totalPairs", 0}}}}}}}}}});
  const json data = reportData(test::typed(run), test::freshDir("report_first_by_metric"), nullptr);
  const json& first = data["rankings"]["scenes"]["static"]["firstByMetric"];
  EXPECT_EQ(first["relMse"], json({"svgf[a=1]", "svgf[a=0]"}));
  EXPECT_FALSE(first.contains("ssim")) << "one method ranked: nothing to be first among";
  EXPECT_FALSE(first.contains("ldrFlip")) << "not ranked by the statistics";
}

TEST(Report, BaselineGivesCompareVerdicts) {
  json base = fixtureRun();
  json cand = fixtureRun();
  cand["pairs"][1]["summary"]["relMse"]["mean"] = 0.06;  // svgf[a=0] on static: +20% relMSE
  // The gate needs the per-tile data to resolve the change: 12 frames x 16 tiles around each mean,
  // whose mean is the summary's (compare checks that the two agree).
  auto tiles = [](double mean) {
    MetricTiles m;
    for (int f = 0; f < 12; ++f) {
      TileSums t;
      for (int k = 0; k < 16; ++k)
        t.sum.push_back(mean * (1 + 0.01 * ((f + k) % 4 - 1.5))), t.count.push_back(1);
      m.add(f, std::move(t));
    }
    return m.toJson();
  };
  base["pairs"][1]["tiles"]["relMse"] = tiles(0.05);
  cand["pairs"][1]["tiles"]["relMse"] = tiles(0.06);
  const RunResults baseRun = test::typed(base);
  const json data = reportData(test::typed(cand), test::freshDir("report_regression"), &baseRun);
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
  EXPECT_EQ(data["regression"]["gate"], "regressed");
  EXPECT_EQ(data["regression"]["exitCode"], 1);
  EXPECT_EQ(data["regression"]["correction"], "holm");
  // The gate's options reach the view: a tolerance of 25% passes the +20% change.
  Gate loose;
  loose.tolerances = gateTolerances({{"relMse", 0.25}});
  loose.correction = Correction::None;
  const json passed =
      reportData(test::typed(cand), test::freshDir("report_regression_loose"), &baseRun, loose);
  bool judgedLoose = false;
  for (const json& r : passed["regression"]["rows"])
    if (r["scene"] == "static" && r["label"] == "svgf[a=0]") {
      judgedLoose = true;
      EXPECT_EQ(r["verdict"], "ok") << r;
      EXPECT_EQ(r["tolerance"], 0.25) << r;
    }
  EXPECT_TRUE(judgedLoose) << passed["regression"].dump();
  // The fixture's failed pair still fails the gate: the tolerance moved only the +20% row.
  EXPECT_EQ(passed["regression"]["gate"], "regressed");
  EXPECT_EQ(passed["regression"]["correction"], "none");
  // The gate's --denoisers: only that contender's rows.
  Gate one;
  one.contenders = {"passthrough"};
  const json only =
      reportData(test::typed(cand), test::freshDir("report_regression_one"), &baseRun, one);
  ASSERT_FALSE(only["regression"]["rows"].empty());
  for (const json& r : only["regression"]["rows"]) EXPECT_EQ(r["label"], "passthrough") << r;
  // The baseline is the run itself: compare refuses it (exit 2), and the view says so.
  const RunResults self = test::typed(cand);
  const json itself = reportData(self, test::freshDir("report_regression_self"), &self);
  EXPECT_TRUE(itself["regression"]["sameRun"].get<bool>());
  EXPECT_EQ(itself["regression"]["gate"], "could not judge");
  EXPECT_EQ(itself["regression"]["exitCode"], 2);
  // A baseline measured under other settings: compare refuses it (exit 2) unless told to compare
  // anyway, and the view's verdict says the same (it read "regressed", exit 1, beside a note that
  // compare would refuse); its rows are still shown. Allowed, it is judged, and warned of.
  json otherWarmup = base;
  otherWarmup["settings"]["warmup"] = 4;
  const RunResults otherRun = test::typed(otherWarmup);
  const json refused = reportData(test::typed(cand), test::freshDir("report_regression_other"),
                                  &otherRun)["regression"];
  EXPECT_EQ(refused["gate"], "could not judge") << refused.dump();
  EXPECT_EQ(refused["exitCode"], 2);
  EXPECT_NE(refused["refused"].get<std::string>().find(
                "the baseline and this run were run with different settings (baseline vs "
                "candidate): settings.warmup: 4 vs 2; their numbers are not comparable"),
            std::string::npos)
      << refused["refused"];
  EXPECT_FALSE(refused["rows"].empty());
  EXPECT_TRUE(refused["warnings"].empty()) << refused["warnings"];
  Gate allowing;
  allowing.allowSettingsMismatch = true;
  const json allowed = reportData(test::typed(cand), test::freshDir("report_regression_allowed"),
                                  &otherRun, allowing)["regression"];
  EXPECT_EQ(allowed["gate"], "regressed") << allowed.dump();
  EXPECT_EQ(allowed["refused"], "");
  ASSERT_EQ(allowed["warnings"].size(), 1u) << allowed["warnings"];
  EXPECT_NE(allowed["warnings"][0].get<std::string>().find(
                "comparing runs with different settings (baseline vs candidate): settings.warmup"),
            std::string::npos)
      << allowed["warnings"];
  // The same contender under another label (a sweep's grid point against a plain run's default):
  // compare matches it by denoiser and parameters, and the page shows the candidate's figures
  // (it said "this run: not measured" beside compare's verdict).
  json base2 = base, cand2 = cand;
  base2["pairs"][1]["params"] = cand2["pairs"][1]["params"] = {{"a", 0}};
  base2["pairs"][1]["label"] = "svgf";
  const RunResults base2Run = test::typed(base2);
  const json relabelled =
      reportData(test::typed(cand2), test::freshDir("report_regression_relabelled"), &base2Run);
  found = false;
  for (const json& r : relabelled["regression"]["rows"])
    if (r["scene"] == "static" && r["label"] == "svgf" && r["metric"] == "relMse") {
      found = true;
      EXPECT_EQ(r["candidateLabel"], "svgf[a=0]");
      EXPECT_EQ(r["verdict"], "regressed");
      EXPECT_NEAR(r["candidate"].get<double>(), 0.06, 1e-12) << r;
      EXPECT_EQ(r["note"], "") << r;
    }
  EXPECT_TRUE(found);
  // Another label and other parameters (an ablation): compared only when asked, with --match.
  json base3 = base;
  for (json& p : base3["pairs"])
    if (p["label"] == "svgf[a=0]") p["label"] = "svgf-before", p["params"] = {{"a", 5}};
  const RunResults base3Run = test::typed(base3);
  Gate matched;
  matched.matches = {"svgf-before=svgf[a=0]"};
  for (const bool ask : {false, true}) {
    const json view = reportData(test::typed(cand), test::freshDir("report_regression_match"),
                                 &base3Run, ask ? matched : Gate{});
    std::string verdict;
    for (const json& r : view["regression"]["rows"])
      if (r["scene"] == "static" && r["label"] == "svgf-before" &&
          (r["metric"] == "relMse" || r["metric"] == "*"))
        verdict =
            r["verdict"].get<std::string>() + (ask ? " " + r.value("candidateLabel", "") : "");
    EXPECT_EQ(verdict, ask ? "regressed svgf[a=0]" : "missing") << view["regression"].dump();
  }
  matched.matches = {"svgf-before=svgf[a=9]"};
  const std::string e = test::errorOf([&] {
    reportData(test::typed(cand), test::freshDir("report_regression_match"), &base3Run, matched);
  });
  EXPECT_NE(e.find("--match svgf-before=svgf[a=9]: the candidate has no pair labelled svgf[a=9]"),
            std::string::npos)
      << e;
  // A pair only this run has keeps compare's own note (a whole pair: metric "*").
  json more = cand;
  json extra = more["pairs"][1];
  extra["label"] = "svgf[a=9]";
  more["pairs"].push_back(extra);
  const json withNew =
      reportData(test::typed(more), test::freshDir("report_regression_new"), &baseRun);
  bool noted = false;
  for (const json& r : withNew["regression"]["rows"])
    if (r["label"] == "svgf[a=9]") {
      noted = true;
      EXPECT_EQ(r["metric"], "*");
      EXPECT_EQ(r["note"], "pair not in the baseline run") << r;
    }
  EXPECT_TRUE(noted);
}

TEST(Report, AllScenesShowStatisticsOverallScoresAndNeverASecondOne) {
  // The all-scenes chart's value on every axis is statistics' overall score for that axis's
  // metric: without one the axis has no all-scenes view (the report computes no aggregate of its
  // own, so the page and the printout cannot disagree).
  json run = fixtureRun();
  run["statistics"] = test::statisticsBlock(json::parse(R"json({"scenes": {},
    "overall": {"normalisation": "geometric mean over 2 scenes of relMse / relMse(passthrough)", "baseline": "passthrough",
      "ranking": [{"label": "passthrough", "rank": 1, "score": 1.0, "ci95": [1.0, 1.0], "tiedWith": []}]},
    "overallByMetric": {"dssim": {"normalisation": "geometric mean over 2 scenes of dssim / dssim(passthrough)",
      "baseline": "passthrough",
      "ranking": [{"label": "svgf[a=0]", "rank": 1, "score": 0.25, "ci95": [0.2, 0.3], "tiedWith": []},
                  {"label": "passthrough", "rank": 2, "score": 1.0, "ci95": [1.0, 1.0], "tiedWith": []}]}}})json"));
  const json data = reportData(test::typed(run), test::freshDir("report_overall_axes"), nullptr);
  const json& all = data["speed"]["views"]["cpu"]["all"];
  EXPECT_TRUE(all.contains("relMse"));
  EXPECT_FALSE(all.contains("ldrFlip")) << "no statistics score on LDR-FLIP: no all-scenes view of it";
  EXPECT_FALSE(all.contains("hdrFlip"));
  ASSERT_TRUE(all.contains("dssim"));
  EXPECT_EQ(all["dssim"]["source"], "statistics");
  EXPECT_EQ(all["dssim"]["normalisation"], "geometric mean over 2 scenes of dssim / dssim(passthrough)");
  std::map<std::string, json> byLabel;
  for (const json& p : all["dssim"]["points"]) byLabel[p["label"]] = p;
  ASSERT_EQ(byLabel.size(), 2u);
  EXPECT_EQ(byLabel["svgf[a=0]"]["error"].get<double>(), 0.25);
  EXPECT_EQ(byLabel["svgf[a=0]"]["lo"].get<double>(), 0.2);
  EXPECT_EQ(byLabel["svgf[a=0]"]["hi"].get<double>(), 0.3);
  EXPECT_GT(byLabel["svgf[a=0]"]["ms"].get<double>(), 0.0);  // the label's mean time over its scenes

  // A scene no overall score covers (a capture without a reference: no relMSE anywhere) leaves the
  // points complete: they cover every scene the score does, and the front is drawn.
  json withNoRef = run;
  std::set<std::string> scored;
  for (const json& p : run["pairs"]) scored.insert(p["scene"].get<std::string>());
  json extra = run["pairs"][0];
  extra["scene"] = "noref";
  extra["summary"].erase("relMse");
  withNoRef["pairs"].push_back(extra);
  withNoRef["scenes"]["noref"] = withNoRef["scenes"].begin().value();
  const json relMse = reportData(test::typed(withNoRef), test::freshDir("report_overall_noref"),
                                 nullptr)["speed"]["views"]["cpu"]["all"]["relMse"];
  EXPECT_EQ(relMse["sceneCount"], scored.size());
  for (const json& p : relMse["points"]) EXPECT_TRUE(p["complete"].get<bool>()) << p;
  EXPECT_FALSE(relMse["front"].empty());
}

TEST(Report, IntervalsAndTheRunsOwnRankingsAreUsedWhenPresent) {
  json run = fixtureRun();
  for (json& p : run["pairs"]) {
    if (p["status"] != "ok") continue;
    const double m = p["summary"]["relMse"]["mean"];
    p["summary"]["relMse"]["ci95"] = {0.95 * m, 1.05 * m};
    const double ssim = p["summary"]["ssim"]["mean"];
    p["summary"]["ssim"]["ci95"] = {ssim - 0.01, ssim + 0.02};
    p["timing"]["msP5"] = 0.5 * p["timing"]["msMedian"].get<double>();
  }
  run["statistics"] = test::statisticsBlock(json::parse(R"({
    "scenes": {"static": {"metric": "relMse",
      "ranking": [{"label": "svgf[a=1]", "rank": 1, "mean": 0.04, "ci95": null, "tiedWith": ["svgf[a=0]"]},
                  {"label": "svgf[a=0]", "rank": 1, "mean": 0.05, "ci95": null, "tiedWith": ["svgf[a=1]"]}],
      "pairs": [{"a": "svgf[a=1]", "b": "svgf[a=0]", "diff": -0.01, "ci95": [-0.02, 0.01], "resolved": false}],
      "resolvedPairs": 0, "totalPairs": 1, "byMetric": {}}},
    "overall": {"normalisation": "geometric mean of relMSE ratios to passthrough", "baseline": "passthrough",
      "ranking": [{"label": "passthrough", "rank": 1, "score": 0.7, "ci95": [0.6, 0.8], "tiedWith": []}]}})"));
  const json data = reportData(test::typed(run), test::freshDir("report_stats"), nullptr);
  const json& p = data["speed"]["views"]["cpu"]["scenes"]["static"]["relMse"]["points"][1];  // svgf[a=0], 0.05
  EXPECT_EQ(p["interval"], "ci95");
  EXPECT_NEAR(p["lo"].get<double>(), 0.0475, 1e-12);
  EXPECT_NEAR(p["msLo"].get<double>(), 2.0, 1e-12);
  // 1 - SSIM: the interval flips with the axis.
  const json& d = data["speed"]["views"]["cpu"]["scenes"]["static"]["dssim"]["points"][0];
  EXPECT_NEAR(d["lo"].get<double>(), 1 - 0.92, 1e-12);
  EXPECT_NEAR(d["hi"].get<double>(), 1 - 0.89, 1e-12);
  // The run's own overall score replaces the report's aggregate, named as the run names it.
  const json& all = data["speed"]["views"]["cpu"]["all"]["relMse"];
  EXPECT_EQ(all["source"], "statistics");
  EXPECT_EQ(all["normalisation"], "geometric mean of relMSE ratios to passthrough");
  EXPECT_NEAR(all["points"][0]["error"].get<double>(), 0.7, 1e-12);
  EXPECT_NEAR(all["points"][0]["hi"].get<double>(), 0.8, 1e-12);
  // Rankings pass through with their ties; a scene without statistics falls back to means.
  const json& r = data["rankings"]["scenes"]["static"];
  EXPECT_TRUE(r["tiesKnown"].get<bool>());
  EXPECT_EQ(r["ranking"][1]["tiedWith"], json({"svgf[a=1]"}));
  EXPECT_EQ(r["resolvedPairs"], 0);
  EXPECT_EQ(r["totalPairs"], 1);
  EXPECT_FALSE(data["rankings"]["scenes"]["switch"]["tiesKnown"].get<bool>());
  EXPECT_TRUE(data["rankings"]["overall"]["tiesKnown"].get<bool>());
  // Summaries keep their intervals for the tables; timing keeps msP5.
  EXPECT_TRUE(data["pairs"][1]["summary"]["relMse"].contains("ci95"));
  EXPECT_NEAR(data["pairs"][1]["timing"]["msP5"].get<double>(), 2.0, 1e-12);
}

TEST(Report, CropTilesComeFromTheKeptImages) {
  // A 20x10 frame: the output equals the reference on the left, is 25/255 brighter from x = 16
  // (the third column of 8-pixel tiles); the FLIP map is magma of 0.2 everywhere.
  json run = fixtureRun();
  const fs::path dir = writeFixtureRun("report_tiles", run);
  run["scenes"]["static"]["width"] = 20;
  run["scenes"]["static"]["height"] = 10;
  saveResults(dir, run);
  const fs::path sd = dir / "images/static";
  Image ref(20, 10, 3, 128.0f / 255.0f), out = ref, noisy = ref, flip(20, 10, 1, 0.2f);
  for (int y = 0; y < 10; ++y)
    for (int x = 16; x < 20; ++x)
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = 153.0f / 255.0f;
  writePng(sd / "reference_0002.png", ref);
  writePng(sd / "noisy_0002.png", noisy);
  writePng(sd / "svgf[a=0]/frame_0002.png", out);
  writePng(sd / "svgf[a=0]/flip_0002.png", applyColorMap(flip, magmaColorMap()));
  std::filesystem::remove(sd / "svgf[a=0]/relerr_0002.png");
  ReportOptions o;
  o.run = dir;
  o.out = test::freshDir("report_tiles_out");
  o.nodeModulesDir = fakeNodeModules("report_tiles_modules");
  writeReport(o);
  const std::string js = readText(o.out / "tiles/s0_f2.js");
  const json t = json::parse(js.substr(js.find("] = ") + 4, js.rfind(';') - js.find("] = ") - 4));
  EXPECT_EQ(t["tile"], 8);
  EXPECT_EQ(t["cols"], 3);
  EXPECT_EQ(t["rows"], 2);
  EXPECT_EQ(t["counts"], json({64, 64, 32, 16, 16, 8}));
  const json& sq = t["panels"]["svgf[a=0]"]["sqerr"];
  const double d = 25.0 / 255.0;
  EXPECT_NEAR(sq[0].get<double>(), 0.0, 1e-12);
  EXPECT_NEAR(sq[2].get<double>(), d * d, 1e-6);  // x 16..19: all changed
  EXPECT_NEAR(t["panels"]["svgf[a=0]"]["flip"][4].get<double>(), 0.2, 1.0 / 255.0);
  EXPECT_NEAR(t["panels"]["noisy"]["sqerr"][5].get<double>(), 0.0, 1e-12);
  // Frame 5 has no real reference image (the fixture's stand-in is not a PNG): no tiles for it.
  const std::string data = readText(o.out / "data.js");
  EXPECT_NE(data.find("\"crops\":{\"files\":{\"2\":\"tiles/s0_f2.js\"}"), std::string::npos);

  // The relative error: a firefly of 1000 in the first tile, 0.5 elsewhere there. The map stops
  // at 10: decoded from it the tile reads low, and its clamped pixel is counted (the page says
  // "at least"); from the values the run keeps beside the map, the tile's mean is exact.
  Image errors(20, 10, 1, 0.5f);
  errors.at(0, 0, 0) = 1000.0f;
  writePng(sd / "svgf[a=0]/relerr_0002.png", relativeErrorMap(errors));
  const auto relerrOf = [&](const std::string& name) {
    ReportOptions again = o;
    again.out = test::freshDir(name);
    writeReport(again);
    const std::string text = readText(again.out / "tiles/s0_f2.js");
    return json::parse(text.substr(text.find("] = ") + 4,
                                   text.rfind(';') - text.find("] = ") - 4))["panels"]["svgf[a=0]"];
  };
  const json decoded = relerrOf("report_tiles_map");
  EXPECT_NEAR(decoded["relerr"][0].get<double>(), (10.0 + 63 * 0.5) / 64, 0.05);
  EXPECT_EQ(decoded["relerrClamped"], json({1, 0, 0, 0, 0, 0}));
  LayerSet values;  // as the run keeps them: block means
  values.set("Y", blockMeans(errors, kRelErrorBlock));
  writeExr(sd / "svgf[a=0]/relerr_0002.exr", values, {{"Y", {}}});
  const json exact = relerrOf("report_tiles_values");
  EXPECT_NEAR(exact["relerr"][0].get<double>(), (1000.0 + 63 * 0.5) / 64, 1e-3 * 16.1);
  EXPECT_NEAR(exact["relerr"][5].get<double>(), 0.5, 1e-12);
  EXPECT_FALSE(exact.contains("relerrClamped"));
  // Values that cannot be read (a file cut short) leave the page to the map, as none kept would.
  std::ofstream(sd / "svgf[a=0]/relerr_0002.exr", std::ios::trunc) << "not an EXR";
  const json unreadable = relerrOf("report_tiles_unreadable");
  EXPECT_EQ(unreadable["relerrClamped"], json({1, 0, 0, 0, 0, 0}));
}

// End to end: a region's relMSE in the page is the run's. Over the whole frame the tiles' pixel-
// weighted mean is the frame's relMSE as the run recorded it (to the tiles' 4 digits), for the
// noisy input passed through, whose fireflies lie far beyond the error map's scale.
TEST(Report, ARegionsRelMseIsTheRunsOwn) {
  RunConfig c = contract::tinyRun("crop_e2e");
  c.render = test::tinySettings(40, 24, 8, 8);
  c.scenes = {test::shippedScene("light_switch")};
  c.keepFrames = "chosen";
  const json run = runMatrix(c);
  ReportOptions o;
  o.run = c.out;
  o.out = test::freshDir("report_crop_out");
  o.nodeModulesDir = fakeNodeModules("report_crop_modules");
  writeReport(o);
  const json& pair = run["pairs"][0];
  int checked = 0;
  bool beyondTheMap = false;
  for (const auto& entry : fs::directory_iterator(o.out / "tiles")) {
    const std::string text = readText(entry.path());
    const json t =
        json::parse(text.substr(text.find("] = ") + 4, text.rfind(';') - text.find("] = ") - 4));
    const std::string name = entry.path().stem().string();  // s0_f<frame>
    const int frame = std::stoi(name.substr(name.find("_f") + 2));
    double sum = 0, pixels = 0;
    for (size_t k = 0; k < t["counts"].size(); ++k) {
      sum += t["panels"]["passthrough"]["relerr"][k].get<double>() * t["counts"][k].get<double>();
      pixels += t["counts"][k].get<double>();
    }
    const double recorded = pair["frames"][size_t(frame)]["relMse"].get<double>();
    EXPECT_NEAR(sum / pixels, recorded, 1e-3 * recorded) << "frame " << frame;
    // The kept map, decoded: pixels at its top stand for errors of 10 or more.
    int w = 0, h = 0;
    const fs::path map = c.out / pair["images"]["dir"].get<std::string>() /
                         ("relerr_" + std::string(4 - std::to_string(frame).size(), '0') +
                          std::to_string(frame) + ".png");
    const cv::Mat bgr = cv::imread(map.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(bgr.empty()) << map;
    w = bgr.cols, h = bgr.rows;
    std::vector<uint8_t> rgb;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const cv::Vec3b p = bgr.at<cv::Vec3b>(y, x);
        rgb.insert(rgb.end(), {p[2], p[1], p[0]});
      }
    for (float v : decodeColorMap(rgb, viridisColorMap())) beyondTheMap = beyondTheMap || v >= 1.0f;
    ++checked;
  }
  EXPECT_GE(checked, 1);
  EXPECT_TRUE(beyondTheMap) << "the case this test is for: pixels the map clamps";
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

// A page written into its run directory shows the run's own images: counted there, not copied
// (the printout said "0 images" for a page that showed every one of them).
TEST(Report, APageInItsRunDirectoryCountsTheImagesInPlace) {
  ReportOptions o;
  o.run = writeFixtureRun("report_in_place", fixtureRun());
  o.out = o.run;
  o.nodeModulesDir = fakeNodeModules("report_in_place_modules");
  const ReportSummary s = writeReport(o);
  EXPECT_EQ(s.images, 11u);
  EXPECT_TRUE(s.imagesInPlace);
  EXPECT_TRUE(fs::exists(o.out / "index.html"));
  EXPECT_TRUE(fs::exists(o.out / "images/switch/reference_0005.png"));
  // Another run's page into this run's directory: refused, this run's page left as it was.
  ReportOptions other = o;
  other.run = writeFixtureRun("report_in_place_other", fixtureRun());
  const std::string page = readText(o.out / "data.js");
  EXPECT_NE(test::errorOf([&] {
              writeReport(other);
            }).find("report: --out " + o.out.string() + " holds another run (results.json)"),
            std::string::npos);
  EXPECT_EQ(readText(o.out / "data.js"), page);
  // A page in a run directory's images/ or in a capture: refused, naming it (the next report
  // of the run copied images/images/...; a bad-input trial).
  ReportOptions below = o;
  below.out = o.run / "images";
  EXPECT_NE(test::errorOf([&] { writeReport(below); })
                .find("report: --out " + below.out.string() + " lies in the images of the run " +
                      fs::weakly_canonical(o.run).string()),
            std::string::npos);
  const fs::path capture = test::freshDir("report_in_capture");
  std::ofstream(capture / "capture.json") << "{}";
  below.out = capture / "page";
  EXPECT_NE(test::errorOf([&] { writeReport(below); }).find(" lies in the capture "),
            std::string::npos);
  EXPECT_FALSE(fs::exists(capture / "page"));
}

// A run's results.json given where its directory is expected: the directory is named.
TEST(Report, AResultsFileGivenForItsRunNamesTheDirectory) {
  const fs::path run = writeFixtureRun("report_file_for_run", fixtureRun());
  const std::string e = test::errorOf([&] { loadResults(run / "results.json"); });
  EXPECT_NE(
      e.find(
          "results.json: a file; expected a run directory (the folder that holds results.json: " +
          run.string() + ")"),
      std::string::npos)
      << e;
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

// A results file with no pairs (only a hand-made one has none) is no report: refused, nothing
// written.
TEST(Report, AResultsFileWithNoPairsIsRefused) {
  json run = fixtureRun();
  run["pairs"] = json::array();
  ReportOptions o;
  o.run = writeFixtureRun("report_nopairs", run);
  o.out = test::freshDir("report_nopairs_out") / "page";
  o.nodeModulesDir = fakeNodeModules("report_nopairs_modules");
  const std::string e = test::errorOf([&] { writeReport(o); });
  EXPECT_NE(e.find("results.json: holds no pairs; nothing to report"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(o.out));
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
