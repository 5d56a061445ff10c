// metrics/run_statistics: the typed statistics block -- every part written back byte for byte, every
// misshapen part refused naming its JSON path, and a run's own block read back as it was written.
#include "metrics/run_statistics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "harness/run_matrix.hpp"
#include "metrics/results.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

using nlohmann::json;

SceneRanking ranking(const std::string& metric, double offset) {
  SceneRanking r;
  r.metric = metric;
  r.ranking = {{"svgf", 1, 0.1 + offset, {0.09 + offset, 0.11 + offset}, {}},
               {"temporal", 2, 0.2 + offset, {}, {"passthrough"}},
               {"passthrough", 2, kUndefined, {}, {"temporal"}}};
  r.pairs = {{"svgf", "temporal", {-0.1, {-0.12, -0.08}}},
             {"svgf", "passthrough", {kUndefined, {}}},
             {"temporal", "passthrough", {0.01, {-0.02, 0.03}}}};
  r.resolvedPairs = 1;
  return r;
}

// Every part the block can hold: a scene with a byMetric ranking, an event and a cut, a method left
// out, values and intervals that are undefined, the overall scores and the extra paths.
RunStatistics everyPart() {
  RunStatistics s;
  s.method = "crossed bootstrap";
  s.confidence = 0.95;
  s.replicates = 1000;
  s.tileGrid = {4, 3};
  SceneStatistics& scene = s.scenes["light_switch"];
  scene.ranking = ranking("relMse", 0);
  scene.ranking.excluded = "asvgf: no relMse data";
  scene.byMetric["ssim"] = ranking("ssim", 0.5);
  // A label and a reason holding the text's own separators: only the stored list keeps them apart.
  scene.byMetric["ssim"].leaveOut("ext: a; b", "no ssim data; its process failed");
  scene.byMetric["ssim"].leaveOut("asvgf", "no ssim data");
  scene.events.push_back({12, "light_off", "lamp", {{"lagEnergy", ranking("lagEnergy", 1)}}});
  scene.cuts.push_back({20, "camera_cut", "", {{"oldViewLeak", ranking("oldViewLeak", 2)}}});
  s.scenes["cornell_static"].ranking = ranking("relMse", 3);
  OverallRanking overall;
  overall.normalisation = "geometric mean over scenes of relMSE / temporal's";
  overall.baseline = "temporal";
  overall.ranking = {{"svgf", 1, 0.5, {0.4, 0.6}, {}, 0.25}, {"temporal", 2, 1.0, {}, {}}};
  overall.excluded = "passthrough: not on every scene";
  s.overall = overall;
  s.overallByMetric["flip"] = overall;
  s.extraPathsPerPixel["svgf"] = 0.25;
  s.extraPathsMeaning = "paths per pixel per frame beyond the frame's own";
  return s;
}

TEST(RunStatistics, EveryPartRoundTripsByteForByte) {
  const json written = everyPart().toJson();
  const RunStatistics read = RunStatistics::fromJson(written, "r.json");
  EXPECT_EQ(read.toJson().dump(1), written.dump(1));
  // The parts as the readers take them.
  const SceneRanking* ssim = read.ranking("light_switch", "ssim");
  ASSERT_NE(ssim, nullptr);
  EXPECT_DOUBLE_EQ(ssim->ranking[0].value, 0.6);
  EXPECT_EQ(read.ranking("light_switch", "relMse"), &read.scenes.at("light_switch").ranking);
  EXPECT_EQ(read.ranking("light_switch", "psnr"), nullptr);
  EXPECT_EQ(read.ranking("nowhere", "relMse"), nullptr);
  const SceneRanking& relMse = read.scenes.at("light_switch").ranking;
  EXPECT_TRUE(std::isnan(relMse.ranking[2].value));
  EXPECT_FALSE(relMse.ranking[1].ci.valid());
  EXPECT_EQ(relMse.ranking[1].tiedWith, std::vector<std::string>{"passthrough"});
  EXPECT_TRUE(relMse.pairs[0].d.resolved());
  EXPECT_FALSE(relMse.pairs[2].d.resolved());
  EXPECT_EQ(relMse.excluded, "asvgf: no relMse data");
  // Written before the list was stored: the reason is read from the text.
  EXPECT_TRUE(relMse.leftOut.empty());
  EXPECT_EQ(relMse.reasonFor("asvgf", {"svgf", "asvgf"}), "no relMse data");
  EXPECT_EQ(relMse.reasonFor("svgf", {"svgf", "asvgf"}), "");
  EXPECT_EQ(ssim->excluded, "ext: a; b: no ssim data; its process failed; asvgf: no ssim data");
  EXPECT_EQ(ssim->reasonFor("ext: a; b", {}), "no ssim data; its process failed");
  EXPECT_EQ(ssim->reasonFor("asvgf", {}), "no ssim data");
  EXPECT_EQ(ssim->reasonFor("b", {}), "");
  const EventStatistics& event = read.scenes.at("light_switch").events.at(0);
  EXPECT_EQ(event.eventFrame, 12);
  EXPECT_EQ(event.what, "lamp");
  EXPECT_EQ(read.scenes.at("light_switch").cuts.at(0).kind, "camera_cut");
  EXPECT_FALSE(written["scenes"]["light_switch"]["cuts"][0].contains("what"));  // a cut concerns no object
  ASSERT_TRUE(read.overall.has_value());
  EXPECT_DOUBLE_EQ(read.overall->ranking[0].extraPathsPerPixel, 0.25);
  EXPECT_TRUE(std::isnan(read.overall->ranking[1].extraPathsPerPixel));
  EXPECT_EQ(read.overallByMetric.count("flip"), 1u);
  EXPECT_DOUBLE_EQ(read.extraPathsPerPixel.at("svgf"), 0.25);
  // A block without overall scores, events or extra paths stays without them.
  RunStatistics bare = everyPart();
  bare.overall.reset();
  bare.overallByMetric.clear();
  bare.extraPathsPerPixel.clear();
  bare.scenes.at("light_switch").events.clear();
  const json bareJson = bare.toJson();
  for (const char* key : {"overall", "overallByMetric", "extraPaths"}) EXPECT_FALSE(bareJson.contains(key)) << key;
  EXPECT_FALSE(bareJson["scenes"]["light_switch"].contains("events"));
  EXPECT_EQ(RunStatistics::fromJson(bareJson, "r.json").toJson().dump(), bareJson.dump());
}

// Each misshapen part is an error naming the file and the JSON path, never a type_error later.
TEST(RunStatistics, EveryMisshapenPartIsNamedByItsPath) {
  const json good = everyPart().toJson();
  auto errorWith = [&](const std::function<void(json&)>& edit) {
    json d = good;
    edit(d);
    return test::errorOf([&] { RunStatistics::fromJson(d, "r.json"); });
  };
  const std::string scene = "r.json: $.statistics.scenes.light_switch";
  EXPECT_EQ(errorWith([](json& d) { d.erase("method"); }), "r.json: $.statistics.method: missing; expected a string");
  EXPECT_EQ(errorWith([](json& d) { d["rankedOnn"] = "relMse"; }),
            "r.json: $.statistics.rankedOnn: unknown field (check the spelling; unknown fields are errors)");
  // A one-letter field missing is not "a misspelling" of its neighbour: "b" is a field of its own.
  EXPECT_EQ(errorWith([](json& d) { d["scenes"]["light_switch"]["pairs"][0].erase("a"); }),
            scene + ".pairs[0].a: missing; expected a string");
  // The same word in other case is the field misspelt, whatever its length.
  EXPECT_EQ(errorWith([](json& d) {
              json& pair = d["scenes"]["light_switch"]["pairs"][0];
              pair["A"] = pair["a"];
              pair.erase("a");
            }),
            scene +
                ".pairs[0].a: missing; expected a string (the object has \"A\": a misspelling of "
                "\"a\"?)");
  EXPECT_EQ(errorWith([](json& d) { d["tileGrid"] = {0, 4}; }),
            "r.json: $.statistics.tileGrid: expected [columns, rows], two positive integers, got [0,4]");
  EXPECT_EQ(errorWith([](json& d) { d["confidence"] = 95; }), "r.json: $.statistics.confidence: expected a level in (0, 1)");
  EXPECT_EQ(errorWith([](json& d) { d["scenes"]["light_switch"]["ranking"][0]["rank"] = "1"; }),
            scene + ".ranking[0].rank: expected an integer, got a string");
  EXPECT_EQ(errorWith([](json& d) { d["scenes"]["light_switch"]["ranking"][0]["tiedWith"] = {"a", 2}; }),
            scene + ".ranking[0].tiedWith[1]: expected a string, got a number");
  EXPECT_EQ(errorWith([](json& d) { d["scenes"]["light_switch"]["pairs"][2]["resolved"] = true; }),
            scene + ".pairs[2].resolved: expected false (whether the interval excludes zero), got true");
  EXPECT_EQ(errorWith([](json& d) { d["scenes"]["light_switch"]["totalPairs"] = 7; }),
            scene + ".totalPairs: expected 3 (the pairs listed), got 7");
  EXPECT_EQ(errorWith([](json& d) { d["scenes"]["light_switch"]["resolvedPairs"] = 0; }),
            scene + ".resolvedPairs: expected 1 (the pairs marked resolved), got 0");
  EXPECT_EQ(errorWith([](json& d) { d["scenes"]["light_switch"]["byMetric"]["ssim"]["ranking"][0]["ci95"] = {1}; }),
            scene + ".byMetric.ssim.ranking[0].ci95: expected [low, high] (or null), got [1]");
  // The text edited without its list (or the list without its text) would give two reasons.
  EXPECT_EQ(errorWith([](json& d) {
              d["scenes"]["light_switch"]["byMetric"]["ssim"]["excluded"] = "asvgf: no ssim data";
            }),
            scene +
                ".byMetric.ssim.excluded: expected \"ext: a; b: no ssim data; its process failed; "
                "asvgf: no " +
                "ssim data\" (the leftOut entries joined), got \"asvgf: no ssim data\"");
  EXPECT_EQ(errorWith([](json& d) {
              d["scenes"]["light_switch"]["byMetric"]["ssim"]["leftOut"][1]["why"] = 3;
            }),
            scene + ".byMetric.ssim.leftOut[1].why: expected a string, got a number");
  EXPECT_EQ(errorWith([](json& d) {
              d["scenes"]["light_switch"]["byMetric"]["ssim"]["leftOut"][0]["reason"] = "x";
            }),
            scene +
                ".byMetric.ssim.leftOut[0].reason: unknown field (check the spelling; unknown "
                "fields are errors)");
  EXPECT_EQ(errorWith([](json& d) { d["scenes"]["light_switch"]["events"][0]["whatt"] = "lamp"; }),
            scene + ".events[0].whatt: unknown field (check the spelling; unknown fields are errors)");
  EXPECT_EQ(errorWith([](json& d) { d["scenes"]["light_switch"]["cuts"][0]["byFigure"]["oldViewLeak"]["pairs"] = 1; }),
            scene + ".cuts[0].byFigure.oldViewLeak.pairs: expected an array of objects, got a number");
  EXPECT_EQ(errorWith([](json& d) { d["overall"]["ranking"][0]["score"] = "x"; }),
            "r.json: $.statistics.overall.ranking[0].score: expected a number or null, got a string");
  EXPECT_EQ(errorWith([](json& d) { d["extraPaths"]["perPixel"]["svgf"] = nullptr; }),
            "r.json: $.statistics.extraPaths.perPixel.svgf: expected a number, got null");
  EXPECT_EQ(errorWith([](json&) {}), "(no error)");
}

// A run's own block, as the run loop wrote it, is what its results carry.
TEST(RunStatistics, ARunsOwnBlockIsReadBackAsWritten) {
  RunConfig cfg = contract::tinyRun("statistics_block");
  const json doc = runMatrix(cfg);
  const RunResults run = loadResults(cfg.out);
  ASSERT_TRUE(run.statistics.has_value());
  EXPECT_EQ(run.statistics->toJson().dump(), doc["statistics"].dump());
  const std::string scene = run.pairs.at(0).scene;
  const SceneRanking* r = run.statistics->ranking(scene, "relMse");
  ASSERT_NE(r, nullptr);
  EXPECT_EQ(r->ranking.size(), doc["statistics"]["scenes"][scene]["ranking"].size());
  // The statistics of the same document computed again are the same, bit for bit.
  EXPECT_EQ(analyseRun(doc).toJson().dump(), doc["statistics"].dump());
}

}  // namespace
}  // namespace arena
