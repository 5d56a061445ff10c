// The run matrix end to end on tiny sequences: results, SQLite, compare as a CI gate, sweeps,
// shards and merge, determinism, and clear errors on bad input.
#include "harness/run_matrix.hpp"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>

#include "cli/printout.hpp"
#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/sequence.hpp"
#include "harness/reference_quality.hpp"
#include "harness/scene_selection.hpp"
#include "harness/sweep.hpp"
#include "metrics/compare.hpp"
#include "metrics/results.hpp"
#include "reports/report.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/evaluator_golden.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

fs::path sharedCache() {
  static fs::path dir = test::freshDir("matrix_cache");
  return dir;
}

RunConfig tinyRun(const std::string& name, std::vector<DenoiserRequest> denoisers) {
  RunConfig c;
  c.name = name;
  c.out = test::freshDir("run_" + name);
  c.cache = sharedCache();
  c.render = test::tinySettings(40, 24, 14, 32);
  c.scenes = {test::shippedScene("cornell_static"), test::shippedScene("light_switch")};
  c.denoisers = std::move(denoisers);
  c.warmup = 4;
  c.flip = "ldr";
  c.keepFrames = "chosen";
  return c;
}

const json& pairOf(const json& results, const std::string& scene, const std::string& label) {
  for (const json& p : results["pairs"])
    if (p["scene"] == scene && p["label"] == label) return p;
  throw Error("no pair " + label + " on " + scene);
}

double mean(const json& pair, const char* metric) { return pair["summary"][metric]["mean"].get<double>(); }

// A sweep's values are compared and labelled as the denoiser reads them: "2.0" is "2" (a sweep of
// [2.0,4.0] and one of [2,4] name the same contenders, so compare matches them), "0" and "-0" are
// one value, and so are two values that round to one float for a built-in (it runs both as 4.0f).
TEST(Sweep, ValuesAreComparedAndLabelledAsTheDenoiserReadsThem) {
  const RunConfig c = sweepRun(RunConfig{}, "svgf", {}, {"sigmaL=[2.0,4]", "edge.id=[on,false]"});
  std::vector<std::string> labels;
  for (const DenoiserRequest& r : c.denoisers) labels.push_back(r.label);
  EXPECT_EQ(labels, (std::vector<std::string>{
                        "svgf[edge.id=true,sigmaL=2]", "svgf[edge.id=false,sigmaL=2]",
                        "svgf[edge.id=true,sigmaL=4]", "svgf[edge.id=false,sigmaL=4]"}));
  EXPECT_EQ(c.annotations.at("sweep")["labels"], json(labels));
  EXPECT_EQ(defaultLabel({"svgf", {{"sigmaL", "2.50"}, {"alpha", "-0"}}, ""}),
            "svgf[alpha=0,sigmaL=2.5]");
  EXPECT_NE(test::errorOf([] {
              sweepRun(RunConfig{}, "svgf", {}, {"alpha=[0,-0]"});
            }).find("0 and -0 are the same value of alpha (as svgf reads it: 0)"),
            std::string::npos);
  EXPECT_NE(test::errorOf([] {
              sweepRun(RunConfig{}, "svgf", {}, {"sigmaL=[4,4.0000000001]"});
            }).find("4 and 4.0000000001 are the same value of sigmaL (as svgf reads it: 4)"),
            std::string::npos);
  EXPECT_NO_THROW(sweepRun(RunConfig{}, "svgf", {}, {"sigmaL=[4,4.001]"}));
  // A grid too large to mean it is refused before it is planned, with its size.
  const std::vector<std::string> huge = {"sigmaL=[1,2,3,4,5,6,7,8,9,10]",
                                         "sigmaZ=[1,2,3,4,5,6,7,8,9,10]",
                                         "sigmaN=[1,2,3,4,5,6,7,8,9,10]",
                                         "alpha=[0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,1]",
                                         "momentsAlpha=[0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,1]",
                                         "iterations=[1,2,3,4,5,6,7,8,9,10]"};
  EXPECT_EQ(test::errorOf([&] { sweepRun(RunConfig{}, "svgf", {}, huge); }),
            "--grid: 10 x 10 x 10 x 10 x 10 x 10 = 1000000 grid points, more than 1000 "
            "(--max-points), each run on every scene; narrow the grid, or raise --max-points to "
            "run it");
  EXPECT_EQ(sweepRun(RunConfig{}, "svgf", {}, {huge[0], huge[1]}, 100).denoisers.size(), 100u);
  EXPECT_NE(test::errorOf([&] {
              sweepRun(RunConfig{}, "svgf", {}, {huge[0], huge[1]}, 99);
            }).find("= 100 grid points, more than 99"),
            std::string::npos);
  // Spaces after the commas are layout ("[2, 4]" read " 4" and refused it as no number).
  EXPECT_EQ(sweepRun(RunConfig{}, "svgf", {}, {"sigmaL=[2, 4 ]"}).denoisers[1].label,
            "svgf[sigmaL=4]");
  // ... and so are spaces around the name, the '=' and the brackets ('sigmaL =[2,4]' was an
  // unknown parameter 'sigmaL '); a misspelt name is offered its nearest.
  EXPECT_EQ(sweepRun(RunConfig{}, "svgf", {}, {" sigmaL = [2,4] "}).denoisers[1].label,
            "svgf[sigmaL=4]");
  EXPECT_NE(test::errorOf([] {
              sweepRun(RunConfig{}, "svgf", {}, {"sigmal=[2,4]"});
            }).find("svgf: unknown parameter 'sigmal' (did you mean 'sigmaL'?); valid parameters:"),
            std::string::npos);
  EXPECT_NE(test::errorOf([] {
              sweepRun(RunConfig{}, "svgf", {}, {"sigmaL [2,4]"});
            }).find("--grid 'sigmaL [2,4]': expected NAME=[v1,v2,...]"),
            std::string::npos);
  EXPECT_NE(test::errorOf([] {
              sweepRun(RunConfig{}, "svgf", {}, {"sigmaL=[2, ]"});
            }).find("an empty entry"),
            std::string::npos);
  // A value written with more digits than a float holds is labelled and recorded as the float a
  // built-in reads (0.30000001 ran as 0.3f: a plain run of 0.3 is the same contender, and compare
  // matches them); an external denoiser reads doubles and keeps every digit.
  const RunConfig digits = sweepRun(RunConfig{}, "svgf", {}, {"alpha=[0.1,0.30000001]"});
  EXPECT_EQ(digits.denoisers[1].label, "svgf[alpha=0.3]");
  EXPECT_EQ(defaultLabel({"svgf", {{"alpha", "0.30000001"}}, ""}),
            defaultLabel({"svgf", {{"alpha", "0.3"}}, ""}));
  const ParamSchema& svgf = DenoiserRegistry::instance().find("svgf").schema;
  EXPECT_EQ(svgf.resolve({{"alpha", "0.30000001"}}, "svgf").toJson()["alpha"], json(0.3));
  for (const ParamSpec& spec : svgf.specs()) {  // the defaults stay as the code writes them
    if (spec.type == ParamSpec::Type::Float) {
      EXPECT_EQ(svgf.resolve({}, "svgf").values().at(spec.name), ParamSet::Value(spec.defaultValue))
          << spec.name;
    }
  }
  const ParamSchema external({ParamSpec::real("alpha", 0.2, 0, 1, "a double")});
  EXPECT_EQ(external.resolve({{"alpha", "0.30000001"}}, "ext").toJson()["alpha"], json(0.30000001));
}

// The ablation compares each value with the grid's first, whatever else ran: a baseline of the
// swept denoiser (temporal at its defaults) is not a grid point, and the order the pairs were
// stored in (a merge of shards given in another order) does not choose the first value.
TEST(Sweep, TheAblationComparesWithTheGridsFirstValue) {
  RunConfig c = sweepRun(tinyRun("sweep_temporal", {}), "temporal", {}, {"alphaMin=[0.05,0.2]"});
  c.scenes.resize(1);
  c.keepFrames = "none";
  const json run = runMatrix(c);
  ASSERT_EQ(run["pairs"].size(), 4u);  // passthrough, temporal (baselines), the two grid points
  for (const bool reversed : {false, true}) {
    json stored = run;
    if (reversed) std::reverse(stored["pairs"].begin(), stored["pairs"].end());
    const json data = reportData(test::typed(stored), c.out, nullptr);
    std::set<std::string> compared;
    for (const json& row : data["ablation"]["rows"])
      compared.insert(row["value"].get<std::string>() + " vs " + row["versus"].get<std::string>());
    EXPECT_EQ(compared, std::set<std::string>{"0.2 vs 0.05"}) << (reversed ? "reversed" : "as run");
  }
}

// Grid points whose outputs are bit-identical are named in a warning on each (at 24 lines svgf's
// scaled footprint skips iterations 2-5: iterations=1 and =5 run the same filter), once, also in a
// merge of shards that each held some of them; points that differ get none.
TEST(Sweep, PointsWithIdenticalOutputsAreWarnedOf) {
  RunConfig c =
      sweepRun(tinyRun("sweep_identical", {}), "svgf", {}, {"iterations=[1,5]", "sigmaL=[2,8]"});
  c.scenes.resize(1);
  c.baselines = false;
  c.keepFrames = "none";
  std::vector<std::string> said;
  c.progress = [&](const std::string& line) { said.push_back(line); };
  // A point's warnings that begin with `prefix`.
  auto warningsOf = [](const json& results, const std::string& label, const std::string& prefix) {
    std::vector<std::string> out;
    for (const json& w : pairOf(results, "cornell_static", label).value("warnings", json::array()))
      if (w.get<std::string>().rfind(prefix, 0) == 0) out.push_back(w);
    return out;
  };
  auto identicalTo = [&](const json& results, const std::string& label) {
    return warningsOf(results, label, "its output on this scene is bit-identical to ");
  };
  const std::string same =
      "its output on this scene is bit-identical to svgf[iterations=5,sigmaL=2] (every "
      "frame): the parameters that differ between them changed nothing here";
  const json run = runMatrix(c);
  EXPECT_EQ(identicalTo(run, "svgf[iterations=1,sigmaL=2]"), std::vector<std::string>{same});
  EXPECT_EQ(identicalTo(run, "svgf[iterations=5,sigmaL=8]").size(), 1u);
  // Not said during the run: its printout names them after the table (identicalOutputsText).
  EXPECT_TRUE(std::none_of(said.begin(), said.end(), [](const std::string& line) {
    return line.find("bit-identical") != std::string::npos;
  }));
  EXPECT_NE(pairOf(run, "cornell_static", "svgf[iterations=1,sigmaL=2]")["outputChecksum"],
            pairOf(run, "cornell_static", "svgf[iterations=1,sigmaL=8]")["outputChecksum"]);
  // The grid holds iterations, and iterations=5 ran one pass of five per signal: said on that
  // point (iterations=1 skipped nothing).
  auto skipped = [&](const json& results, const std::string& label) {
    return warningsOf(results, label, "at this resolution its scaled footprint skipped ");
  };
  ASSERT_EQ(skipped(run, "svgf[iterations=5,sigmaL=2]").size(), 1u);
  EXPECT_NE(skipped(run, "svgf[iterations=5,sigmaL=2]")[0].find(
                "skipped 8 à-trous pass(es) (over its signals) whose steps scale below a pixel"),
            std::string::npos)
      << skipped(run, "svgf[iterations=5,sigmaL=2]")[0];
  EXPECT_TRUE(skipped(run, "svgf[iterations=1,sigmaL=2]").empty());
  EXPECT_FALSE(run["sweep"].contains("footprintNote")) << "said per point instead";
  // Shards 0/2 and 1/2 each hold one identical couple; the merge warns of each once.
  std::vector<fs::path> shards;
  for (int i = 0; i < 2; ++i) {
    RunConfig s = c;
    s.shardIndex = i, s.shardCount = 2;
    s.out = test::freshDir("sweep_identical_shard" + std::to_string(i));
    runMatrix(s);
    shards.push_back(s.out);
  }
  const json merged = mergeRuns(shards, test::freshDir("sweep_identical_merged"));
  for (const char* label : {"svgf[iterations=1,sigmaL=2]", "svgf[iterations=5,sigmaL=2]",
                            "svgf[iterations=1,sigmaL=8]", "svgf[iterations=5,sigmaL=8]"})
    EXPECT_EQ(identicalTo(merged, label).size(), 1u) << label;
  EXPECT_EQ(skipped(merged, "svgf[iterations=5,sigmaL=8]").size(), 1u);  // once, after the merge
}

// A grid without iterations: every point ran the same shortened filter (at 24 lines svgf's
// scaled footprint skips four of its five à-trous steps), so the sweep says once that it
// describes the filter as it runs here; at footprint=native nothing is skipped and nothing said.
TEST(Sweep, AShortenedFilterIsSaidOnceForTheSweep) {
  for (const bool native : {false, true}) {
    RunConfig c = sweepRun(tinyRun(native ? "sweep_native" : "sweep_scaled", {}), "svgf",
                           native ? std::map<std::string, std::string>{{"footprint", "native"}}
                                  : std::map<std::string, std::string>{},
                           {"sigmaL=[2,8]"});
    c.scenes.resize(1);
    c.baselines = false;
    c.keepFrames = "none";
    std::vector<std::string> said;
    c.progress = [&](const std::string& line) { said.push_back(line); };
    const json run = runMatrix(c);
    if (native) {
      EXPECT_FALSE(run["sweep"].contains("footprintNote")) << run["sweep"].dump();
      continue;
    }
    ASSERT_TRUE(run["sweep"].contains("footprintNote")) << run["sweep"].dump();
    const std::string note = run["sweep"]["footprintNote"];
    EXPECT_NE(note.find("svgf's scaled footprint skipped up to 8 pass(es) per frame"),
              std::string::npos)
        << note;
    EXPECT_NE(note.find("--param svgf.footprint=native"), std::string::npos) << note;
    EXPECT_EQ(std::count(said.begin(), said.end(), "  note: " + note), 1);
    for (const json& p : run["pairs"])  // not per point: the grid does not name passes
      for (const json& w : p["warnings"])
        EXPECT_EQ(w.get<std::string>().find("scaled footprint skipped"), std::string::npos) << w;
  }
}

TEST(RunMatrix, TwoScenesThreeDenoisersWithEveryMetric) {
  RunConfig c = tinyRun("matrix", {{"svgf", {}, ""}});
  json r = runMatrix(c);
  ASSERT_EQ(r["pairs"].size(), 6u);  // passthrough and temporal added as baselines
  EXPECT_TRUE(failedPairs(r).empty());
  for (const json& p : r["pairs"]) {
    ASSERT_EQ(p["status"], "ok") << p.dump();
    ASSERT_EQ(p["frames"].size(), 14u);
    for (const char* m : {"relMse", "relMseCorrected", "psnr", "ssim", "ldrFlip", "tRmae", "tPsnr", "warpedFlicker",
                          "effectiveSpp", "ms"})
      EXPECT_TRUE(p["summary"].contains(m)) << m;
    EXPECT_GT(p["timing"]["msPerMegapixel"].get<double>(), 0.0);
  }
  // Context: denoising beats the noisy input; the noisy input's effective spp is 1.
  const json& noisy = pairOf(r, "cornell_static", "passthrough");
  const json& svgf = pairOf(r, "cornell_static", "svgf");
  EXPECT_LT(mean(svgf, "relMse"), mean(noisy, "relMse") / 3);
  EXPECT_NEAR(pairOf(r, "light_switch", "passthrough")["summary"]["effectiveSpp"]["median"].get<double>(), 1.0, 0.05);
  // Ghosting on the light switch: the light goes off at frame 12 (on again at 24, beyond 14
  // frames). Two frames from the event on define no figure: absent, the reason, a warning
  // (LagByBias.AnEventNearTheEndKeepsOnlyWhatItsFramesDefine measures one with five).
  const json& lightSwitch = pairOf(r, "light_switch", "svgf");
  const json& ghost = lightSwitch["ghosting"];
  ASSERT_EQ(ghost.size(), 1u);
  EXPECT_EQ(ghost[0]["eventFrame"], 12);
  EXPECT_GT(ghost[0]["maskFraction"].get<double>(), 0.3);
  EXPECT_TRUE(ghost[0]["signedBias"].is_null());
  EXPECT_TRUE(ghost[0]["responseFrames"].is_null());
  EXPECT_NE(ghost[0].value("absent", "").find("holds 2 frame(s) from the event on"),
            std::string::npos)
      << ghost[0];
  bool warned = false;
  for (const json& w : lightSwitch["warnings"])
    warned |=
        w.get<std::string>().find("event at frame 12: the window holds 2") != std::string::npos;
  EXPECT_TRUE(warned) << lightSwitch["warnings"];
  // Results on disk: JSON and SQLite with one row per pair.
  const RunResults onDisk = loadResults(c.out);
  EXPECT_EQ(onDisk.pairs.size(), 6u);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((c.out / "results.db").c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "SELECT COUNT(*) FROM summaries WHERE metric = 'relMse'", -1, &st, nullptr);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(st, 0), 6);
  sqlite3_finalize(st);
  sqlite3_close(db);
  EXPECT_TRUE(fs::exists(c.out / "images" / "cornell_static" / "svgf"));
}

TEST(RunMatrix, CompareGatesARegressionAndPassesAnIdenticalRerun) {
  RunConfig a = tinyRun("baseline", {{"svgf", {}, "svgf"}});
  a.scenes.resize(1);
  a.baselines = false;
  json base = runMatrix(a);
  RunConfig b = a;
  b.out = test::freshDir("run_rerun");
  json rerun = runMatrix(b);
  // Determinism: error metrics identical (times may differ).
  for (const char* m : {"relMse", "ssim", "ldrFlip", "tRmae", "warpedFlicker"})
    EXPECT_EQ(mean(base["pairs"][0], m), mean(rerun["pairs"][0], m)) << m;
  EXPECT_FALSE(anyRegression(compareRuns(test::typed(base), test::typed(rerun), {})));
  // A deliberately worse setting under the same label: no spatial filtering at all.
  RunConfig w = a;
  w.out = test::freshDir("run_worse");
  w.denoisers = {{"svgf", {{"iterations", "0"}, {"feedbackTap", "0"}, {"alpha", "1"}}, "svgf"}};
  json worse = runMatrix(w);
  auto rows = compareRuns(test::typed(base), test::typed(worse), {{"relMse", 0.02}});
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].verdict, "regressed");
  EXPECT_TRUE(anyRegression(rows));
  EXPECT_GT(rows[0].change, 0.5);
  // The change is read from the summaries, its interval from the tiles: a summary edited apart from
  // its tiles (a mean set by hand, or a regressed run's tiles under the old means) is refused, not
  // judged (it passed at +1107% with an interval of [+0%, +0%]).
  json edited = worse;
  edited["pairs"][0]["summary"]["relMse"]["mean"] = mean(base["pairs"][0], "relMse");
  const std::string e = test::errorOf([&] {
    compareRuns(test::typed(base), test::typed(edited), {{"relMse", 0.02}});
  });
  EXPECT_NE(e.find("candidate run, svgf on cornell_static: summary.relMse.mean"), std::string::npos)
      << e;
  EXPECT_NE(e.find("disagrees with its per-tile data"), std::string::npos) << e;
  // So are tiles of no finite value under it: NaN sums with the baseline's mean passed a real
  // regression as "ok, no interval" (a bad-input trial).
  MetricTiles nan = MetricTiles::fromJson(worse["pairs"][0]["tiles"]["relMse"]);
  for (TileSums& row : nan.rows) std::fill(row.sum.begin(), row.sum.end(), std::nan(""));
  edited["pairs"][0]["tiles"]["relMse"] = nan.toJson();
  const std::string nanError = test::errorOf([&] {
    compareRuns(test::typed(base), test::typed(edited), {{"relMse", 0.02}});
  });
  EXPECT_NE(nanError.find("disagrees with its per-tile data (no finite value)"), std::string::npos)
      << nanError;
  // One Inf in one tile, the mean edited by half: the same (the Inf made the allowance infinite).
  MetricTiles inf = MetricTiles::fromJson(worse["pairs"][0]["tiles"]["relMse"]);
  inf.rows[0].sum[0] = std::numeric_limits<double>::infinity();
  edited = worse;
  edited["pairs"][0]["tiles"]["relMse"] = inf.toJson();
  edited["pairs"][0]["summary"]["relMse"]["mean"] = 1.5 * mean(worse["pairs"][0], "relMse");
  EXPECT_NE(test::errorOf([&] {
              compareRuns(test::typed(base), test::typed(edited), {{"relMse", 0.02}});
            }).find("disagrees with its per-tile data (no finite value)"),
            std::string::npos);
  // A slice of a run (a shard) against a whole run is refused as a settings difference: the
  // pairs it lacks read as "new" and a regression in them passed.
  RunResults shard = test::typed(base);
  shard.settings.setShard("1/2");
  const std::vector<std::string> differ = settingsDifferences(shard, test::typed(rerun));
  ASSERT_EQ(differ.size(), 1u);
  EXPECT_EQ(differ[0].rfind("settings.shard: \"1/2\" vs \"0/1\" (a slice of a run", 0), 0u)
      << differ[0];
  EXPECT_TRUE(settingsDifferences(shard, shard).empty());  // the same slice of two runs compares
}

// A results file with one pair twice (every reader kept one of them: the gate passed or failed on
// whichever came last) or an interval written [high, low] is refused naming the path.
TEST(RunMatrix, AResultsFileWithAPairTwiceOrAReversedIntervalIsRefused) {
  RunConfig a = tinyRun("duplicate_pair", {{"passthrough", {}, ""}});
  a.scenes.resize(1);
  a.baselines = false;
  json r = runMatrix(a);
  json twice = r;
  twice["pairs"].push_back(r["pairs"][0]);
  const std::string e = test::errorOf([&] { test::typed(twice); });
  EXPECT_NE(e.find("$.pairs[1]: expected a pair of its own (passthrough on cornell_static is "
                   "already $.pairs[0]"),
            std::string::npos)
      << e;
  json reversed = r;
  reversed["pairs"][0]["summary"]["relMse"]["ci95"] = {0.5, 0.1};
  EXPECT_NE(test::errorOf([&] {
              test::typed(reversed);
            }).find("$.pairs[0].summary.relMse.ci95: expected [low, high]"),
            std::string::npos)
      << test::errorOf([&] { test::typed(reversed); });
}

TEST(RunMatrix, ShardsMergeIntoTheFullRun) {
  RunConfig full = tinyRun("shards", {{"eaw", {}, ""}});
  full.scenes.resize(1);
  full.flip = "none";
  std::vector<fs::path> parts;
  size_t pairs = 0;
  for (int i = 0; i < 2; ++i) {
    RunConfig s = full;
    s.shardIndex = i;
    s.shardCount = 2;
    s.out = test::freshDir("run_shard" + std::to_string(i));
    pairs += runMatrix(s)["pairs"].size();
    parts.push_back(s.out);
  }
  EXPECT_EQ(pairs, 3u);
  fs::path merged = test::freshDir("run_merged");
  json m = mergeRuns(parts, merged);
  EXPECT_EQ(m["pairs"].size(), 3u);
  EXPECT_NO_THROW(loadResults(merged));
  // In the order one run writes its pairs (the plan's contenders), not shard by shard.
  std::vector<std::string> order, planned;
  for (const json& p : m["pairs"]) order.push_back(p["label"]);
  for (const json& l : m["settings"]["plan"]["labels"]) planned.push_back(l);
  EXPECT_EQ(order, planned);
  EXPECT_THROW(mergeRuns({parts[0], parts[0]}, test::freshDir("run_dup")), Error);
  // Shards of another run -- other denoisers, or the same at another size -- are refused: their
  // slices would not add up to one run (each records the whole run's plan).
  for (const std::string change : {"denoisers", "frames"}) {
    RunConfig other = full;
    if (change == "denoisers")
      other.denoisers = {{"svgf", {}, ""}};
    else
      other.render.frames += 1;
    other.shardIndex = 1;
    other.shardCount = 2;
    other.out = test::freshDir("run_shard_other_" + change);
    runMatrix(other);
    const std::string e = test::errorOf([&] {
      mergeRuns({parts[0], other.out}, test::freshDir("run_mixed"));
    });
    EXPECT_NE(e.find("settings differ"), std::string::npos) << change << ": " << e;
    // The message names the field and both values, not only that something differs.
    const std::string field =
        change == "frames" ? "settings.plan.sequences[0].frames: " : "denoisers";
    EXPECT_NE(e.find(field), std::string::npos) << change << ": " << e;
  }
  // --out one of the shards is refused before anything is written; merging again into --out
  // replaces its images.
  const std::string into = test::errorOf([&] { mergeRuns(parts, parts[1]); });
  EXPECT_NE(into.find("is one of the shards it merges"), std::string::npos) << into;
  fs::create_directories(merged / "images");
  std::ofstream(merged / "images" / "stale.png") << "old";
  mergeRuns(parts, merged);
  EXPECT_FALSE(fs::exists(merged / "images" / "stale.png"));
}

// The study's refinement after a scene (RunConfig::refineScene): the scene's pairs are measured
// again from their kept output frames against the refined references, and their records are those
// of a run that starts from the refined references (the denoisers are deterministic), images and
// statistics included; the hook sees each scene once, with its pairs in place.
TEST(RunMatrix, ARefinedSceneIsMeasuredAgainFromItsKeptOutputs) {
  // reblur reading the mirror ray's oracle distance: its warning, the run's own, must survive the
  // measurement again (it was dropped there).
  RunConfig c =
      tinyRun("refine_hook", {{"eaw", {}, ""}, {"reblur", {{"hitDistance", "mirror"}}, ""}});
  c.flip = "ldr";  // the FLIP maps among the images compared below
  c.cache = test::freshDir("refine_hook_cache");  // its references are refined: not the shared cache
  std::vector<std::string> seen;
  json before;  // light_switch as the first pass measured it
  c.refineScene = [&](const Scene& scene, const json& results) {
    seen.push_back(scene.name);
    size_t pairs = 0;
    for (const json& p : results["pairs"])
      if (p["scene"] == scene.name) {
        ++pairs;
        // Screened: the linear errors the decision reads, no more (measured in full afterwards).
        EXPECT_TRUE(p["summary"].contains("relMseCorrected")) << scene.name;
        EXPECT_FALSE(p["summary"].contains("ldrFlip")) << scene.name;
      }
    EXPECT_EQ(pairs, 4u) << scene.name;  // passthrough, temporal, eaw, reblur
    if (scene.name != "light_switch") return false;
    if (!before.is_null()) {  // the second round: the scene and its pairs against the refined references
      EXPECT_LT(results["scenes"]["light_switch"]["referenceRelMse"][6].get<double>(),
                before["scenes"]["light_switch"]["referenceRelMse"][6].get<double>() / 4);
      EXPECT_NE(pairOf(results, "light_switch", "eaw")["summary"]["relMse"]["mean"],
                pairOf(before, "light_switch", "eaw")["summary"]["relMse"]["mean"]);
      return false;
    }
    before = results;
    const SequenceInfo info = Sequence::open(sequenceDir(scene, c.render, c.cache)).info();
    const double worst = *std::max_element(info.referenceEstimatedRelMse.begin(), info.referenceEstimatedRelMse.end());
    refineSequence(scene, c.render, c.cache, worst / 8, 1024, nullptr);
    return true;
  };
  const json refined = runMatrix(c);
  // light_switch twice: a refinement is followed by another call (a round), here declined.
  EXPECT_EQ(seen, (std::vector<std::string>{"cornell_static", "light_switch", "light_switch"}));
  ASSERT_FALSE(before.is_null());
  // It must be able to fail: the floor and the pairs' raw relMSE moved with the references.
  EXPECT_LT(refined["scenes"]["light_switch"]["referenceRelMse"][6].get<double>(),
            before["scenes"]["light_switch"]["referenceRelMse"][6].get<double>() / 4);
  EXPECT_NE(pairOf(refined, "light_switch", "eaw")["summary"]["relMse"]["mean"],
            pairOf(before, "light_switch", "eaw")["summary"]["relMse"]["mean"]);
  const json& oracle = pairOf(refined, "light_switch", "reblur[hitDistance=mirror]");
  ASSERT_FALSE(oracle["warnings"].empty());
  EXPECT_NE(oracle["warnings"][0].get<std::string>().find("reads oracle data"), std::string::npos);
  RunConfig plain = c;
  plain.refineScene = nullptr;
  plain.out = test::freshDir("run_refine_hook_plain");
  const json a = test::goldenPart(refined), b = test::goldenPart(runMatrix(plain));
  ASSERT_EQ(a["pairs"].size(), b["pairs"].size());
  for (size_t i = 0; i < a["pairs"].size(); ++i)
    EXPECT_TRUE(a["pairs"][i] == b["pairs"][i]) << a["pairs"][i]["scene"] << " " << a["pairs"][i]["label"];
  EXPECT_TRUE(a["scenes"] == b["scenes"]);
  EXPECT_TRUE(a["statistics"] == b["statistics"]);
  // The images, of the refined scene and of the one left as it was: the same files.
  for (const char* scene : {"light_switch", "cornell_static"}) {
    size_t images = 0;
    for (const auto& e : fs::directory_iterator(c.out / "images" / scene / "eaw")) {
      ++images;
      EXPECT_EQ(readText(e.path()), readText(plain.out / "images" / scene / "eaw" / e.path().filename()))
          << e.path();
    }
    size_t plainImages = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(plain.out / "images" / scene / "eaw")) ++plainImages;
    EXPECT_EQ(images, plainImages) << scene;
    EXPECT_GT(images, 0u) << scene;
  }
}

// A denoiser reading a layer no real-time engine has (the noise-free mirror ray's hit distance)
// is named with it in the results and a warning; one reading the 1-spp sample's is not.
TEST(RunMatrix, OracleDataIsNamedInThePairThatReadsIt) {
  RunConfig c =
      tinyRun("oracle", {{"reblur", {{"hitDistance", "mirror"}}, ""}, {"reblur", {}, ""}});
  c.scenes.resize(1);
  c.baselines = false;
  const json r = runMatrix(c);
  const json& oracle = pairOf(r, "cornell_static", "reblur[hitDistance=mirror]");
  EXPECT_EQ(oracle["oracleLayers"], json({"specHitDistMirror"}));
  ASSERT_FALSE(oracle["warnings"].empty());
  EXPECT_NE(oracle["warnings"][0].get<std::string>().find(
                "reads oracle data a real-time engine would not have: "
                "specHitDistMirror"),
            std::string::npos)
      << oracle["warnings"];
  const json& plain = pairOf(r, "cornell_static", "reblur");
  EXPECT_FALSE(plain.contains("oracleLayers"));
  // ...and in every ranking it stands in, as a method that read extra paths is (+paths): the
  // statistics name the layers per label, the ranking entries carry them, the printout marks it.
  EXPECT_EQ(r["statistics"]["oracle"]["layers"]["reblur[hitDistance=mirror]"],
            json({"specHitDistMirror"}));
  EXPECT_FALSE(r["statistics"]["oracle"]["layers"].contains("reblur"));
  int marked = 0;
  for (const json& e : r["statistics"]["scenes"]["cornell_static"]["ranking"]) {
    EXPECT_EQ(e.contains("oracleLayers"), e["label"] == "reblur[hitDistance=mirror]") << e.dump();
    marked += e.contains("oracleLayers");
  }
  EXPECT_EQ(marked, 1);
  const RunResults results = RunResults::fromJson(r, "results.json");  // read back as stored
  ASSERT_TRUE(results.statistics.has_value());
  EXPECT_EQ(results.statistics->oracleLayers.at("reblur[hitDistance=mirror]"),
            std::vector<std::string>{"specHitDistMirror"});
  EXPECT_EQ(results.statistics->toJson()["oracle"], r["statistics"]["oracle"]);
  std::ostringstream printed;
  cli::printOverallRanking(printed, results);
  EXPECT_NE(printed.str().find("reblur[hitDistance=mirror] (oracle)"), std::string::npos)
      << printed.str();
  EXPECT_NE(printed.str().find("(oracle): read a layer no real-time engine has"),
            std::string::npos);
  // The other tables that list a label mark it too (markedLabel).
  EXPECT_EQ(cli::markedLabel(results, "reblur[hitDistance=mirror]"),
            "reblur[hitDistance=mirror] (oracle)");
  EXPECT_EQ(cli::markedLabel(results, "reblur"), "reblur");
  // The report's speed chart names its point "(oracle)" from the point's oracleLayers.
  const json data = reportData(test::typed(r), c.out, nullptr);
  int points = 0;
  for (const json& p :
       data["speed"]["views"]["cpu"]["scenes"]["cornell_static"]["relMse"]["points"]) {
    ++points;
    EXPECT_EQ(p.contains("oracleLayers"), p["label"] == "reblur[hitDistance=mirror]") << p.dump();
  }
  EXPECT_EQ(points, 2);
}

TEST(RunMatrix, AFailingPairIsReportedAndTheOthersKept) {
  RunConfig c = tinyRun("failing", {{"svgf", {}, ""}});
  c.scenes.resize(1);
  c.scenes.push_back(test::shippedScene("cornell_static"));
  c.scenes.back().name = "broken";
  c.scenes.back().width = 0;  // not renderable
  c.render.width = 0;         // use each scene's own resolution...
  c.render.height = 0;
  c.scenes.front().width = 40;
  c.scenes.front().height = 24;
  json r = runMatrix(c);
  auto failed = failedPairs(r);
  EXPECT_EQ(failed.size(), 3u);
  EXPECT_EQ(pairOf(r, "cornell_static", "svgf")["status"], "ok");
  EXPECT_NE(failed[0].find("broken"), std::string::npos);
}

TEST(RunMatrix, BadInputIsAClearError) {
  RunConfig c = tinyRun("bad", {{"svgf", {{"sigmaLL", "4"}}, ""}});
  try {
    runMatrix(c);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown parameter 'sigmaLL'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("svgf.sigmaL"), std::string::npos) << e.what();
  }
  // A denoiser that cannot run without the low-resolution buffer, in a run rendering none: refused
  // before anything renders, not pair by pair afterwards.
  RunConfig low = tinyRun("no_lowres", {{"reengine", {{"disocclusionRays", "on"}}, ""}});
  low.render.lowresFactor = 0;
  low.cache = test::freshDir("run_no_lowres_cache");
  const std::string lowError = test::errorOf([&] { runMatrix(low); });
  EXPECT_NE(lowError.find("--lowres-factor 0: reengine[disocclusionRays=on] needs the sequence's "
                          "low-resolution buffer"),
            std::string::npos)
      << lowError;
  EXPECT_TRUE(fs::is_empty(low.cache)) << "rendered before refusing";
  low.denoisers = {{"reengine", {{"disocclusionRays", "auto"}}, ""}};
  low.out = test::freshDir("run_no_lowres_auto");
  low.cache = sharedCache();
  EXPECT_EQ(test::errorOf([&] { runMatrix(low); }), "(no error)");  // auto runs without it
  EXPECT_THROW(loadResults(test::freshDir("run_missing-run")), Error);
  fs::path other = test::freshDir("run_other-schema");
  std::ofstream(other / "results.json") << R"({"kind": "arena-run", "schema": 99})";
  try {
    loadResults(other);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("schema version 99"), std::string::npos);
  }
  EXPECT_THROW(parseShard("2/2"), Error);
  // A sequence frame that lacks a channel the denoiser reads.
  Sequence seq = Sequence::open(renderSequence(test::shippedScene("cornell_static"), c.render, c.cache, nullptr));
  DenoiseRun run({"svgf", {}, "svgf"}, seq);
  LayerSet partial;
  const LayerSet full = seq.frame(0);
  for (const auto& [name, img] : full.all())
    if (name != "motion") partial.set(name, img);
  try {
    run.run([&](int) -> const LayerSet& { return partial; }, [](const DenoisedFrame&) {});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing channel 'motion'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(compareRuns(RunResults{}, RunResults{}, {{"flipp", 0.02}}), Error);
}


// ---- Contract: bad input and state ------------------------------------------------------------

namespace fs = std::filesystem;
using nlohmann::json;

TEST(RunMatrixContract, TwoSceneFilesWithOneStemCannotShareARun) {
  fs::path dir = test::freshDir("same_stem");
  fs::path a = contract::writeScene(dir / "a", "room", contract::minimalScene()),
           b = contract::writeScene(dir / "b", "room", contract::minimalScene());
  try {
    selectScenes(a.string() + "," + b.string(), dir.string());
    ADD_FAILURE() << "accepted two scenes named room";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("share the name 'room'"), std::string::npos) << e.what();
  }
  {
    const std::string e = test::errorOf([] {
      selectScenes("cornell_static,cornell_static", ARENA_SOURCE_DIR "/scenes", "--scenes");
    });
    EXPECT_NE(
        e.find("--scenes 'cornell_static,cornell_static': scene 'cornell_static' is listed twice"),
        std::string::npos)
        << e;
  }
}

// Scenes that would score every method a perfect 0 on nothing: their pairs fail, naming why; the
// others rank.
TEST(RunMatrixContract, ScenesThatMeasureNothingAreRefused) {
  // A light that reaches the camera nowhere (below the floor) renders black references; nothing
  // in view but the light (cornell_static without its objects) renders an input with no noise,
  // equal to its reference (the input scored a perfect 0 beside every method: a bad-input trial).
  json unlit = contract::minimalScene();
  unlit["lights"][0]["keys"][0]["translate"] = {0, -5, 0};
  json bare = parseJsonFile(ARENA_SOURCE_DIR "/scenes/cornell_static.json");
  bare["objects"] = json::array();
  const fs::path dir = test::freshDir("scenes_measuring_nothing");
  RunConfig c = contract::tinyRun("measuring_nothing");
  c.scenes = {loadScene(contract::writeScene(dir, "unlit", unlit).string()),
              loadScene(contract::writeScene(dir, "bare", bare).string()),
              test::shippedScene("cornell_static")};
  const json r = runMatrix(c);
  for (const auto& [scene, why] :
       {std::pair{"unlit", "its reference is black in every frame, so no light reaches the camera"},
        std::pair{"bare",
                  "equals its reference value for value, so the 1-spp input holds no "
                  "noise"}}) {
    const json& pair = pairOf(r, scene, "passthrough");
    EXPECT_EQ(pair["status"], "failed") << scene;
    EXPECT_NE(pair["error"].get<std::string>().find(why), std::string::npos) << pair["error"];
  }
  EXPECT_EQ(pairOf(r, "cornell_static", "passthrough")["status"], "ok");
}

// light_switch's light goes off at frame 12 and back at 24: a 14-frame sequence measures the first
// event only, and says the second is not measured (the scene's warnings, printed by the run).
TEST(RunMatrixContract, EventsBeyondTheFramesAreNamed) {
  RunConfig c = contract::tinyRun("dropped_events");
  c.render = test::tinySettings(16, 8, 14, 2);
  c.scenes = {test::shippedScene("light_switch")};
  const json r = runMatrix(c);
  const json& scene = r["scenes"]["light_switch"];
  EXPECT_EQ(scene["events"].size(), 1u);
  bool named = false;
  for (const json& w : scene.value("warnings", json::array()))
    named |= w.get<std::string>().find(
                 "events beyond the sequence's 14 frames are not measured (light_on") !=
             std::string::npos;
  EXPECT_TRUE(named) << scene["warnings"];
}

// camera_cut's view jumps at frame 8; without its camera_cut event nobody tells the denoisers, and
// no cut is measured: allowed (an engine that forgets to flag a teleport), and said.
TEST(RunMatrixContract, ACameraJumpWithoutACutEventIsNamed) {
  RunConfig c = contract::tinyRun("unflagged_jump");
  c.render = test::tinySettings(16, 8, 10, 2);
  Scene scene = test::shippedScene("camera_cut");
  scene.events.clear();
  c.scenes = {scene};
  const json r = runMatrix(c);
  const json& entry = r["scenes"]["camera_cut"];
  EXPECT_TRUE(entry["events"].empty()) << entry["events"];
  bool named = false;
  for (const json& w : entry.value("warnings", json::array()))
    named |= w.get<std::string>().find(
                 "the camera jumps (a key with \"step\": true) at frame(s) 8 without a "
                 "camera_cut event") != std::string::npos;
  EXPECT_TRUE(named) << entry.value("warnings", json::array());
  // The shipped scene flags its jump: no such warning.
  c.scenes = {test::shippedScene("camera_cut")};
  c.out = test::freshDir("flagged_jump");
  c.cache = test::freshDir("flagged_jump_cache");  // the scene's hash is the file's, events or not
  for (const json& w : runMatrix(c)["scenes"]["camera_cut"].value("warnings", json::array()))
    EXPECT_EQ(w.get<std::string>().find("the camera jumps"), std::string::npos) << w;
}

// Two labels that differ only where a file name cannot hold them would share one image folder (the
// second pair's start removed the first's images): refused before any work.
TEST(RunMatrixContract, LabelsThatShareAnImageFolderAreRefused) {
  RunConfig c = contract::tinyRun("image_folder_clash");
  c.denoisers = {{"eaw", {}, "eaw a"}, {"eaw", {{"sigmaL", "2"}}, "eaw/a"}};
  const std::string e = test::errorOf([&] { runMatrix(c); });
  EXPECT_NE(e.find("contenders 'eaw a' and 'eaw/a' would share the image folder 'eaw_a'"),
            std::string::npos)
      << e;
  EXPECT_FALSE(fs::exists(c.out / "results.json"));
}

TEST(RunMatrixContract, BadOutputsFailBeforeAnyWorkNamingTheFile) {
  struct Case {
    const char* name;
    std::function<void(const fs::path&)> make;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"garbage_db",
       [](const fs::path& d) { writeTextAtomically(d / "results.db", std::string(5000, 'x')); },
       "results.db: "},
      {"foreign_schema",
       [](const fs::path& d) {
         sqlite3* h = nullptr;
         sqlite3_open((d / "results.db").c_str(), &h);
         sqlite3_exec(h, "CREATE TABLE summaries (x INTEGER); INSERT INTO summaries VALUES (1);",
                      nullptr, nullptr, nullptr);
         sqlite3_close(h);
       },
       "results.db: another schema (table"},
      {"truncated_db",
       [](const fs::path& d) {
         RunResults r;
         for (int i = 0; i < 200; ++i)  // enough rows for several pages
           r.pairs.push_back(PairResult{.scene = std::string("s").append(std::to_string(i)), .denoiser = std::string(200, 'd'),
                                        .label = "l", .status = "failed", .error = "e"});
         appendToDatabase(d / "results.db", r);
         fs::resize_file(d / "results.db", fs::file_size(d / "results.db") / 2);
       },
       "results.db: "},
      {"foreign_json",
       [](const fs::path& d) { writeTextAtomically(d / "results.json", "{\"mine\": 1}"); },
       "results.json: not an arena results file; refusing to replace it"},
  };
  for (const Case& c : cases) {
    RunConfig cfg = contract::tinyRun(c.name);
    c.make(cfg.out);
    const bool hadJson = fs::exists(cfg.out / "results.json");
    try {
      runMatrix(cfg);
      ADD_FAILURE() << c.name << ": the run went ahead";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.message), std::string::npos)
          << c.name << ": " << e.what();
    }
    EXPECT_TRUE(fs::is_empty(cfg.cache)) << c.name << ": rendered before checking the outputs";
    EXPECT_EQ(fs::exists(cfg.out / "results.json"), hadJson) << c.name;
  }
  // A file where the cache belongs: refused before any work, not a failed pair for each scene.
  RunConfig fileCache = contract::tinyRun("file_cache");
  fileCache.cache = fileCache.out.parent_path() / "cache_is_a_file";
  writeTextAtomically(fileCache.cache, "not a folder");
  const std::string e = test::errorOf([&] { runMatrix(fileCache); });
  EXPECT_NE(e.find("cache_is_a_file: exists and is not a directory; the sequence cache (--cache)"),
            std::string::npos)
      << e;
  EXPECT_FALSE(fs::exists(fileCache.out / "results.json"));
  EXPECT_TRUE(fs::is_directory(fileCache.out)) << "a directory that existed before the run is kept";
  // Into a directory the run creates: a failure removes it (it held only the run's lock file).
  fileCache.out /= "new_run";
  EXPECT_NE(test::errorOf([&] { runMatrix(fileCache); }).find("cache_is_a_file"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(fileCache.out)) << "a failed run left the directory it created";
  // A run written into the sequence cache, or as the cache itself: refused, nothing created there.
  for (const std::string inside : {"run", ""}) {
    RunConfig intoCache = contract::tinyRun("into_cache");
    intoCache.out = inside.empty() ? intoCache.cache / "" : intoCache.cache / inside;
    const std::string error = test::errorOf([&] { runMatrix(intoCache); });
    EXPECT_NE(error.find("lies in the sequence cache"), std::string::npos) << error;
    EXPECT_TRUE(fs::is_empty(intoCache.cache)) << "wrote into the cache before refusing";
  }
  RunConfig cacheInRun = contract::tinyRun("cache_in_run");
  cacheInRun.cache = cacheInRun.out / "cache";
  std::string inRun = test::errorOf([&] { runMatrix(cacheInRun); });
  EXPECT_NE(inRun.find("lies in the run directory"), std::string::npos) << inRun;
  cacheInRun.cache = "";
  inRun = test::errorOf([&] { runMatrix(cacheInRun); });
  EXPECT_NE(inRun.find("--cache: an empty directory name"), std::string::npos) << inRun;
  // The run's name is its directory's, a trailing slash included.
  EXPECT_EQ(folderName("runs/today/"), "today");
  EXPECT_EQ(folderName("runs/today"), "today");
  EXPECT_EQ(folderName("runs/today/."), "today");
}

TEST(RunMatrixContract, MergeCreatesItsOutputDirectory) {
  RunConfig a = contract::tinyRun("merge_a"), b = contract::tinyRun("merge_b");
  a.denoisers = b.denoisers = {{"passthrough", {}, ""}, {"temporal", {}, ""}};
  b.cache = a.cache;
  a.shardIndex = 0;
  b.shardIndex = 1;
  a.shardCount = b.shardCount = 2;
  runMatrix(a);
  runMatrix(b);
  fs::path out = test::freshDir("merge_out") / "not" / "there";
  // An incomplete set is refused before anything is created: no empty --out is left behind.
  EXPECT_THROW(mergeRuns({a.out}, out), Error);
  EXPECT_FALSE(fs::exists(out.parent_path()));
  json merged = mergeRuns({a.out, b.out}, out);
  EXPECT_EQ(merged["pairs"].size(), 2u);
  EXPECT_TRUE(fs::exists(out / "results.json"));
  EXPECT_EQ(test::countRows(out / "results.db", "pairs"), 2);
}

// Rewrites `layer` channel `channel` of a cached EXR (keeping its attributes, so the cache still
// trusts it) with NaN at the first `count` pixels.
void poisonLayer(const fs::path& file, const std::vector<LayerSpec>& specs, const std::string& layer, int channel,
                 int count) {
  test::rewriteCachedExr(file, specs, [&](LayerSet& layers) {
    Image& image = layers.get(layer);
    for (int i = 0; i < count; ++i)
      image.plane(channel)[size_t(i)] = std::numeric_limits<float>::quiet_NaN();
  });
}

TEST(RunMatrixContract, GuideAndGradientNaNsAreSanitisedCountedAndNamedInAWarning) {
  // The rule itself: NaN/Inf -> 0, and a gradient sample with any non-finite field is invalid.
  LayerSet samples;
  Image gradient(2, 1, 5, 1.0f);
  gradient.plane(2)[0] = std::numeric_limits<float>::infinity();  // lumNew of sample 0
  samples.set("gradient", gradient);
  NonFiniteCounts counts;
  EXPECT_EQ(sanitizeGradientSamples(samples, counts), 1);
  EXPECT_EQ(counts, (NonFiniteCounts{{"gradients: gradient.lumNew", 1}}));
  EXPECT_EQ(samples.get("gradient").plane(2)[0], 0.0f);
  EXPECT_EQ(samples.get("gradient").plane(4)[0], 0.0f) << "the sample is not marked invalid";
  EXPECT_EQ(samples.get("gradient").plane(4)[1], 1.0f) << "a clean sample was touched";

  // A-SVGF reads the guides and the gradient samples: NaNs in normal.Y of frame 2 and in lumNew of
  // frame 2's gradient samples are replaced, counted per channel and named in the pair's warning.
  RunConfig c;
  c.name = "nonfinite";
  c.cache = test::freshDir("nonfinite_cache");
  c.render = test::tinySettings(24, 16, 4, 4);
  c.scenes = {test::shippedScene("cornell_static")};
  c.denoisers = {{"asvgf", {}, ""}};
  c.baselines = false;
  c.warmup = 1;
  c.flip = "none";
  c.keepFrames = "none";
  c.out = test::freshDir("nonfinite_clean");
  const fs::path dir = sequenceDir(c.scenes[0], c.render, c.cache);
  json r = runMatrix(c);
  ASSERT_EQ(r["pairs"].size(), 1u);
  ASSERT_EQ(r["pairs"][0]["status"], "ok") << r["pairs"][0].dump();
  EXPECT_EQ(r["pairs"][0]["sanitizedInputs"]["total"], 0);
  EXPECT_TRUE(r["pairs"][0]["sanitizedInputs"]["channels"].empty());
  for (const json& w : r["pairs"][0]["warnings"]) EXPECT_EQ(w.get<std::string>().find("non-finite"), std::string::npos) << w;

  poisonLayer(Sequence::framePath(dir, 2), channels::frameLayers(), "normal", 1, 30);
  poisonLayer(Sequence::gradientPath(dir, 2), channels::gradientLayers(), "gradient", 2, 30);
  c.out = test::freshDir("nonfinite_poisoned");
  r = runMatrix(c);
  ASSERT_EQ(r["pairs"].size(), 1u);
  const json& pair = r["pairs"][0];
  // status ok: the harness checked every output value was finite.
  ASSERT_EQ(pair["status"], "ok") << pair.dump();
  EXPECT_TRUE(std::isfinite(pair["summary"]["relMse"]["mean"].get<double>()));
  EXPECT_EQ(pair["sanitizedInputs"]["total"], 60);
  EXPECT_EQ(pair["sanitizedInputs"]["channels"],
            json({{"normal.Y", 30}, {"gradients: gradient.lumNew", 30}}));
  ASSERT_FALSE(pair["warnings"].empty());
  EXPECT_EQ(pair["warnings"][0],
            "60 non-finite input values (gradients: gradient.lumNew x30, normal.Y x30) were replaced by 0 "
            "before the denoiser ran; its results may differ from those on clean inputs");
  // The scene says what its cache holds, per file and channel.
  EXPECT_EQ(r["scenes"]["cornell_static"]["nonFiniteInputs"]["frame 2: normal.Y"], 30);
  EXPECT_EQ(r["scenes"]["cornell_static"]["nonFiniteInputs"]["gradients 2: gradient.lumNew"], 30);
}

}  // namespace
}  // namespace arena
