// metrics/results and metrics/run_results: results.json and results.db are written together; the
// typed model reads a run and writes it back byte for byte; a results file of the wrong shape or
// type is an error naming the file and the JSON path.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/results.hpp"
#include "metrics/summary.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(ResultsContract, ResultsOfTheWrongShapeAreErrorsNamingThePath) {
  fs::path run = test::freshDir("shapeless_run");
  json doc = {{"schema", kResultsSchemaVersion},
              {"kind", "arena-run"},
              {"name", "x"},
              {"settings", json::object()},
              {"environment", json::object()},
              {"scenes", json::object()}};
  writeTextAtomically(run / "results.json", doc.dump());
  try {
    loadResults(run);
    ADD_FAILURE() << "accepted a results.json without pairs";
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find(
            "results.json: $.pairs: expected an array of pairs, got nothing (the field is absent)"),
        std::string::npos)
        << e.what();
  }
  doc["pairs"] = json::array(
      {{{"scene", "a"}, {"denoiser", "d"}, {"label", "d"}, {"status", "ok"}, {"summary", 3}}});
  writeTextAtomically(run / "results.json", doc.dump());
  EXPECT_THROW(loadResults(run), Error);
  doc["kind"] = 7;  // a wrong type where a string is expected
  writeTextAtomically(run / "results.json", doc.dump());
  EXPECT_THROW(loadResults(run), Error);
  // `arena report` on it: exit 2 naming the path, not an out-of-bounds read.
  doc["kind"] = "arena-run";
  doc.erase("pairs");
  writeTextAtomically(run / "results.json", doc.dump());
  contract::CliResult r = contract::arenaCli("report " + run.string() + " --out " + (run / "report").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("$.pairs"), std::string::npos) << r.output;
}

TEST(ResultsContract, ResultsJsonAndDatabaseCommitTogether) {
  RunConfig cfg = contract::tinyRun("commit");
  json first = runMatrix(cfg);
  ASSERT_EQ(test::countRows(cfg.out / "results.db", "runs"), 1);
  const std::string jsonBefore = readText(cfg.out / "results.json");
  const std::string dbBefore = readText(cfg.out / "results.db");
  // A document the database append rejects halfway (a pair whose scene is not a string): neither
  // file may change, and no temporary may be left behind.
  json bad = first;
  bad["pairs"].push_back({{"scene", 17}});
  EXPECT_ANY_THROW(commitResults(cfg.out, bad));
  EXPECT_EQ(readText(cfg.out / "results.json"), jsonBefore);
  EXPECT_EQ(readText(cfg.out / "results.db"), dbBefore);
  for (auto& e : fs::directory_iterator(cfg.out))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  // A good second run appends: both files move together.
  runMatrix(cfg);
  EXPECT_EQ(test::countRows(cfg.out / "results.db", "runs"), 2);
  EXPECT_NE(readText(cfg.out / "results.json"), jsonBefore);
}

TEST(ResultsContract, AWrongTypeInResultsNamesTheFileAndThePath) {
  fs::path dir = test::freshDir("typed_results");
  RunConfig cfg = contract::tinyRun("typed");
  json r = runMatrix(cfg);
  ASSERT_TRUE(r["pairs"][0]["summary"]["relMse"].contains("mean"));
  r["pairs"][0]["summary"]["relMse"]["mean"] = "0.5";
  writeTextAtomically(cfg.out / "results.json", r.dump());
  try {
    loadResults(cfg.out);
    ADD_FAILURE() << "accepted a string mean";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("results.json: $.pairs[0].summary.relMse.mean: expected a "
                                         "number (or null), got a string"),
              std::string::npos)
        << e.what();
  }
  contract::CliResult c = contract::arenaCli("compare " + cfg.out.string() + " " + cfg.out.string());
  EXPECT_EQ(c.status, 2) << c.output;
  EXPECT_NE(c.output.find("$.pairs[0].summary.relMse.mean"), std::string::npos) << c.output;
}

// What the run wrote is what the typed model writes back: every byte of results.json, failed pairs,
// absent summaries (with their non-finite counts) and a sweep's grid included.
TEST(RunResults, ARunRoundTripsByteForByte) {
  RunConfig cfg = contract::tinyRun("round_trip");
  json doc = runMatrix(cfg);
  const std::string written = readText(cfg.out / "results.json");
  const RunResults run = loadResults(cfg.out);
  ASSERT_FALSE(run.pairs.empty());
  EXPECT_EQ(run.toJson().dump(1), written);
  // The parts a tiny run lacks, added by hand.
  doc["pairs"].push_back({{"scene", "cornell_static"}, {"denoiser", "svgf"}, {"label", "svgf[x]"},
                          {"params", json::object()}, {"status", "failed"}, {"error", "it broke"}});
  doc["pairs"][0]["summary"]["relMse"] = {{"frames", 3}, {"nonFinite", 1},
                                          {"absent", "1 of 3 frames after the warm-up are not finite (NaN or Inf)"}};
  doc["pairs"][0]["summary"]["ssim"]["ci95"] = nullptr;
  doc["sweep"] = {{"denoiser", "svgf"}, {"grid", {{"alpha", {0.1, 0.2}}}}, {"fixed", json::object()}};
  const RunResults edited = test::typed(doc);
  EXPECT_EQ(edited.toJson().dump(1), doc.dump(1));
  EXPECT_EQ(edited.pairs.back().error, "it broke");
  EXPECT_EQ(edited.pairs[0].summary.at("relMse").nonFinite, 1);
  EXPECT_FALSE(edited.pairs[0].summary.at("ssim").ci95.valid());
}

// A reader asks a pair for a mean and gets it, or the reason there is none; never a number made up.
// A pair says whether its denoiser carries state between frames; results written before it was
// recorded know it of passthrough alone.
TEST(RunResults, APairSaysWhetherItsDenoiserKeepsHistory) {
  PairResult p;
  p.denoiser = "svgf";
  EXPECT_TRUE(p.keepsHistory());
  p.detail["keepsHistory"] = false;
  EXPECT_FALSE(p.keepsHistory());
  p.detail.erase("keepsHistory");
  p.denoiser = "passthrough";
  EXPECT_FALSE(p.keepsHistory());
  p.detail["keepsHistory"] = true;  // what a run recorded wins
  EXPECT_TRUE(p.keepsHistory());
}

TEST(RunResults, AMeanOrWhyThereIsNone) {
  RunConfig cfg = contract::tinyRun("why_no_mean");
  json doc = runMatrix(cfg);
  doc["pairs"][0]["summary"]["relMse"] = {{"frames", 0}, {"absent", "no frame after the warm-up"}};
  doc["pairs"][0]["summary"].erase("ssim");
  doc["pairs"].push_back({{"scene", "cornell_static"}, {"denoiser", "svgf"}, {"label", "svgf[x]"},
                          {"params", json::object()}, {"status", "failed"}, {"error", "it broke"}});
  const RunResults run = test::typed(doc);
  const PairResult& p = run.pairs[0];
  EXPECT_TRUE(p.mean("psnr").present());
  EXPECT_EQ(p.mean("psnr").mean, doc["pairs"][0]["summary"]["psnr"]["mean"].get<double>());
  EXPECT_EQ(p.mean("relMse").absent, "no frame after the warm-up");
  EXPECT_FALSE(p.mean("ssim").computed);
  EXPECT_EQ(p.mean("ssim").absent, "ssim was not computed in this run");
  EXPECT_EQ(run.pairs.back().mean("relMse").absent, "the pair has no summary (failed: it broke)");
  EXPECT_EQ(run.find("cornell_static", "svgf[x]"), &run.pairs.back());
  EXPECT_EQ(run.find("cornell_static", "nobody"), nullptr);
  const std::vector<std::string> lines = absentSummaryLines(run, {"relMse"});
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "cornell_static: relMse absent in 1 pair(s): no frame after the warm-up");
  // The timing and its clock: measured here, or as the pair says; a failed pair has none.
  EXPECT_EQ(p.clock(), "cpu");
  EXPECT_EQ(p.timing().at("msMedian"), doc["pairs"][0]["timing"]["msMedian"]);
  EXPECT_TRUE(run.pairs.back().timing().is_object());
  EXPECT_TRUE(run.pairs.back().timing().empty());
  EXPECT_EQ(run.pairs.back().clock(), "cpu");
  doc["pairs"][0]["timing"]["clock"] = "process";
  EXPECT_EQ(test::typed(doc).pairs[0].clock(), "process");
}

// Each part of a summary and of the run is checked where the model reads it.
TEST(RunResults, EveryMisshapenPartIsNamedByItsPath) {
  RunConfig cfg = contract::tinyRun("misshapen");
  const json doc = runMatrix(cfg);
  auto errorWith = [&](const std::function<void(json&)>& edit) {
    json d = doc;
    edit(d);
    return test::errorOf([&] { RunResults::fromJson(d, "r.json"); });
  };
  EXPECT_NE(errorWith([](json& d) {
              d["pairs"][0]["summary"]["relMse"]["ci95"] = {0.2, 0.1};
            })
                .find("r.json: $.pairs[0].summary.relMse.ci95: expected [low, high] with low <= "
                      "high (or null), got [0.2,0.1]: its ends are swapped"),
            std::string::npos);
  EXPECT_NE(errorWith([](json& d) { d["pairs"][0]["summary"]["relMse"]["ci95"] = {1}; })
                .find("r.json: $.pairs[0].summary.relMse.ci95: expected [low, high] (or null), got an array"),
            std::string::npos);
  EXPECT_NE(errorWith([](json& d) { d["pairs"][0]["summary"]["relMse"]["meen"] = 1; })
                .find("$.pairs[0].summary.relMse.meen: expected no such field"),
            std::string::npos);
  EXPECT_NE(errorWith([](json& d) { d["pairs"][0]["summary"]["relMse"]["frames"] = -3; })
                .find("$.pairs[0].summary.relMse.frames: expected a non-negative integer"),
            std::string::npos);
  EXPECT_NE(errorWith([](json& d) { d["pairs"][0]["summary"]["relMse"] = {{"frames", 0}, {"absent", ""}}; })
                .find("$.pairs[0].summary.relMse.absent: expected the reason the summary is absent"),
            std::string::npos);
  EXPECT_NE(errorWith([](json& d) { d["note"] = "mine"; }).find("r.json: $.note: expected no such field"),
            std::string::npos);
  EXPECT_NE(errorWith([](json& d) { d["pairs"][0]["denoiser"] = 3; })
                .find("$.pairs[0].denoiser: expected a string, got a number"),
            std::string::npos);
  EXPECT_NE(
      errorWith([](json& d) { d["pairs"][0]["status"] = "failed"; })
          .find("$.pairs[0].error: expected a string (the failure), got nothing (the field is "
                "absent)"),
      std::string::npos);
  // A frame's record listed twice (the charts drew both; a bad-input trial).
  EXPECT_NE(errorWith([](json& d) { d["pairs"][0]["frames"][2]["frame"] = 1; })
                .find("$.pairs[0].frames[2].frame: expected a frame after 1 (one record per "
                      "frame, in order), not 1, got a number"),
            std::string::npos);
  EXPECT_NE(errorWith([](json& d) { d["statistics"] = 1; }).find("$.statistics: expected an object"),
            std::string::npos);
  EXPECT_NE(errorWith([](json& d) { d["schema"] = 1; }).find("r.json: results schema version 1"), std::string::npos);
  EXPECT_EQ(errorWith([](json&) {}), "(no error)");
}

// The parts of a scene's record and of a pair that readers (printouts, report, merge) take are
// checked where the model reads them: an Error naming the path, never a JSON type error later.
TEST(RunResults, ScenesAndPairDetailsAreCheckedWhereReadersTakeThem) {
  RunConfig cfg = contract::tinyRun("details_checked");
  const json doc = runMatrix(cfg);
  const std::string scene = doc["scenes"].begin().key(), at = "r.json: $.scenes." + scene;
  auto errorWith = [&](const std::function<void(json&)>& edit) {
    json d = doc;
    edit(d);
    return test::errorOf([&] { RunResults::fromJson(d, "r.json"); });
  };
  EXPECT_EQ(errorWith([&](json& d) { d["scenes"][scene]["width"] = "x"; }),
            at + ".width: expected a non-negative integer, got a string");
  EXPECT_EQ(errorWith([&](json& d) { d["scenes"][scene]["referenceQuality"] = 5; }),
            at + ".referenceQuality: expected an object, got a number");
  EXPECT_EQ(errorWith([&](json& d) { d["scenes"][scene]["referenceQuality"]["meets"] = "yes"; }),
            at + ".referenceQuality.meets: expected true or false, got a string");
  EXPECT_EQ(errorWith([&](json& d) { d["scenes"][scene]["warnings"] = {1}; }),
            at + ".warnings[0]: expected a string, got a number");
  EXPECT_EQ(errorWith([&](json& d) { d["scenes"][scene]["images"] = json::object(); }),
            at + ".images: expected a string, got an object");
  EXPECT_EQ(errorWith([&](json& d) { d["scenes"][scene]["events"] = {{{"frame", "3"}, {"kind", "light_off"}}}; }),
            at + ".events[0].frame: expected an integer, got a string");
  EXPECT_EQ(errorWith([&](json& d) { d["scenes"][scene]["floors"]["relMse"] = "low"; }),
            at + ".floors.relMse: expected a number (or null), got a string");
  EXPECT_EQ(errorWith([&](json& d) { d["scenes"][scene]["note"] = "mine"; }), at + ".note: expected no such field, got a string");
  EXPECT_EQ(errorWith([](json& d) { d["pairs"][0]["timing"]["clock"] = 5; }),
            "r.json: $.pairs[0].timing.clock: expected a string, got a number");
  EXPECT_EQ(errorWith([](json& d) { d["pairs"][0]["timing"]["msMedian"] = nullptr; }),
            "r.json: $.pairs[0].timing.msMedian: expected a finite number, got null");
  EXPECT_EQ(errorWith([](json& d) { d["pairs"][0]["ghosting"] = {1}; }),
            "r.json: $.pairs[0].ghosting[0]: expected an object (one event's figures), got a number");
  EXPECT_EQ(errorWith([](json& d) { d["pairs"][0]["cuts"] = {{{"eventFrame", nullptr}}}; }),
            "r.json: $.pairs[0].cuts[0].eventFrame: expected an integer, got null");
  EXPECT_EQ(errorWith([](json& d) { d["pairs"][0]["images"]["dir"] = 5; }),
            "r.json: $.pairs[0].images.dir: expected a string, got a number");
  EXPECT_EQ(errorWith([](json& d) { d["pairs"][0]["warnings"] = {json::object()}; }),
            "r.json: $.pairs[0].warnings[0]: expected a string, got an object");
  EXPECT_EQ(errorWith([](json&) {}), "(no error)");
}

// The settings are the record the run wrote, checked field by field when read: a reader (report,
// merge, compare) never meets a string where the warm-up belongs.
TEST(RunResults, SettingsAreCheckedFieldByFieldAndReadThroughAccessors) {
  RunConfig cfg = contract::tinyRun("settings_checked");
  const json doc = runMatrix(cfg);
  auto errorWith = [&](const std::function<void(json&)>& edit) {
    json d = doc;
    edit(d["settings"]);
    return test::errorOf([&] { RunResults::fromJson(d, "r.json"); });
  };
  EXPECT_EQ(errorWith([](json& s) { s["warmup"] = "x"; }), "r.json: $.settings.warmup: expected an integer, got a string");
  EXPECT_EQ(errorWith([](json& s) { s["seeds"] = 0; }),
            "r.json: $.settings.seeds: expected an integer in [1, 2147483647], got 0");
  EXPECT_EQ(errorWith([](json& s) { s["shard"] = 3; }), "r.json: $.settings.shard: expected a string, got a number");
  EXPECT_EQ(errorWith([](json& s) { s["render"] = 5; }), "r.json: $.settings.render: expected an object, got a number");
  EXPECT_EQ(errorWith([](json& s) { s["render"]["referenceSpp"] = -1; }),
            "r.json: $.settings.render.referenceSpp: expected an integer in [0, 2147483647], got -1");
  EXPECT_EQ(errorWith([](json& s) { s["render"]["inputSeed"] = -2; }),
            "r.json: $.settings.render.inputSeed: expected an integer in [0, 4294967295], got -2");
  EXPECT_EQ(errorWith([](json& s) { s["ghosting"]["tauu"] = 0.2; }),
            "r.json: $.settings.ghosting.tauu: unknown field (check the spelling; unknown fields are errors)");
  EXPECT_EQ(errorWith([](json& s) { s["captures"] = {"a", 1}; }),
            "r.json: $.settings.captures[1]: expected a string, got a number");
  EXPECT_EQ(errorWith([](json& s) { s["relMseEpsilon"] = nullptr; }),
            "r.json: $.settings.relMseEpsilon: expected a number, got null");
  EXPECT_EQ(errorWith([](json& s) { s = json::array(); }), "r.json: $.settings: expected an object, got an array");
  EXPECT_EQ(errorWith([](json&) {}), "(no error)");
  // The accessors, and what a field the run did not record reads as.
  RunResults run = test::typed(doc);
  EXPECT_EQ(run.settings.warmup(), cfg.warmup);
  EXPECT_EQ(run.settings.shard(), "0/1");
  EXPECT_EQ(run.settings.render().value("referenceSpp", 0), cfg.render.referenceSpp);
  EXPECT_FALSE(run.settings.measurement().contains("shard"));
  run.settings.setShard("merged");
  EXPECT_EQ(run.settings.toJson()["shard"], "merged");
  json bare = doc;
  bare["settings"] = json::object();
  const RunResults none = test::typed(bare);
  EXPECT_EQ(none.settings.warmup(), kDefaultWarmup);
  EXPECT_EQ(none.settings.seeds(), 1);
  EXPECT_EQ(none.settings.shard(), "");
  EXPECT_TRUE(none.settings.render().empty());
  // `arena report` of a run whose settings are out of shape: the error names the file and the
  // field, not a JSON type error.
  json bad = doc;
  bad["settings"]["warmup"] = "x";
  const fs::path dir = test::freshDir("settings_bad");
  writeTextAtomically(dir / "results.json", bad.dump());
  const contract::CliResult r = contract::arenaCli("report " + dir.string() + " --out " + (dir / "report").string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find((dir / "results.json").string() + ": $.settings.warmup: expected an integer, got a string"),
            std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("unexpected error"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace arena
