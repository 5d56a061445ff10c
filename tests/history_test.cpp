// `arena history`: runs from run directories and results databases, ordered by time; the flags
// are exactly the rows `arena compare` calls regressed; the dashboard's files; bad input.
#include "reports/history.hpp"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <fstream>

#include "core/atomic_file.hpp"
#include "core/env_info.hpp"
#include "core/error.hpp"
#include "metrics/results.hpp"
#include "metrics/statistics.hpp"
#include "reports/report.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

json stat(double v) {
  // 8 frames after the warm-up: enough for the gate to judge (kFewSummarisedFrames).
  return {{"mean", v}, {"median", v}, {"p5", 0.9 * v}, {"p95", 1.1 * v}, {"frames", 8}};
}

// Run i of a history: svgf's relMSE on "s" wobbles by 0.5% and jumps 10% from run `jump` on.
json historyRun(int i, int jump) {
  const double wobble = 1 + 0.005 * ((i % 3) - 1);
  const double relMse = 0.02 * wobble * (i >= jump ? 1.10 : 1.0);
  json pairs = json::array();
  for (const char* label : {"passthrough", "svgf"}) {
    const bool svgf = std::string(label) == "svgf";
    pairs.push_back({{"scene", "s"},
                     {"denoiser", label},
                     {"label", label},
                     {"params", json::object()},
                     {"status", "ok"},
                     {"frames", json::array()},
                     {"summary",
                      {{"relMse", stat(svgf ? relMse : 0.5)},
                       {"ssim", stat(svgf ? 0.9 : 0.5)},
                       {"ms", stat(svgf ? 3.0 : 0.01)}}}});
  }
  char created[32];
  std::snprintf(created, sizeof created, "2025-01-01T00:%02d:00Z", i);
  return {{"schema", kResultsSchemaVersion},
          {"kind", "arena-run"},
          {"name", "run" + std::to_string(i)},
          {"created", created},
          {"environment", {{"git_commit", "abc" + std::to_string(i)}}},
          {"settings", {{"warmup", 2}}},
          {"scenes", json::object()},
          {"pairs", pairs}};
}

// The runs where the history has a non-ok verdict, for one label and metric.
std::vector<int> changedRuns(const json& data, const std::string& label,
                             const std::string& metric) {
  std::vector<int> out;
  for (const json& c : data["changes"])
    if (c["label"] == label && c["metric"] == metric) out.push_back(c["run"].get<int>());
  return out;
}

TEST(History, MarksWhatCompareSaysRunByRun) {
  std::vector<RunResults> runs;
  for (int i = 0; i < 8; ++i) runs.push_back(test::typed(historyRun(i, 5)));
  const std::vector<Tolerance> tolerances = {{"relMse", 0.02}, {"ssim", 0.02}};
  const json data = historyData(runs, {tolerances});
  ASSERT_EQ(data["runs"].size(), 8u);
  EXPECT_EQ(data["runs"][5]["commit"], "abc5");
  // The 10% jump at run 5 is the only change beyond the 2% tolerance (the wobble is 0.5%).
  EXPECT_EQ(changedRuns(data, "svgf", "relMse"), std::vector<int>{5}) << data["changes"].dump();
  EXPECT_TRUE(changedRuns(data, "passthrough", "relMse").empty());
  for (const json& c : data["changes"])
    if (c["run"] == 5 && c["metric"] == "relMse") {  // run 4's wobble is 1, run 5's 1.005: 1.005 x 1.1 - 1
      EXPECT_NEAR(c["change"].get<double>(), 0.1055, 1e-9);
    }
  // Whether the gate fails is compare's own verdict on the same two runs, run by run.
  size_t failing = 0;
  for (size_t i = 1; i < runs.size(); ++i) {
    bool marked = false;
    for (const json& c : data["changes"]) marked |= c["run"] == i && c["fails"].get<bool>();
    EXPECT_EQ(marked, anyRegression(compareRuns(runs[i - 1], runs[i], tolerances))) << i;
    failing += marked;
  }
  EXPECT_EQ(data["failingComparisons"].get<size_t>(), failing);
  EXPECT_EQ(data["comparisons"], 7);
  // Rows and comparisons are counted apart: one comparison may fail several rows (here
  // passthrough's relMSE jumps with svgf's at run 5: two rows, one comparison).
  std::vector<RunResults> both;
  for (int i = 0; i < 8; ++i) {
    json r = historyRun(i, 5);
    if (i >= 5) r["pairs"][0]["summary"]["relMse"] = stat(0.55);
    for (json& p : r["pairs"]) {  // relMSE tiles: the summary's mean on every tile and frame
      MetricTiles tiles;
      for (int f = 0; f < 8; ++f) {
        TileSums t;
        for (int k = 0; k < 4; ++k)
          t.sum.push_back(float(p["summary"]["relMse"]["mean"].get<double>())),
              t.count.push_back(1);
        tiles.add(f, std::move(t));
      }
      p["tiles"]["relMse"] = tiles.toJson();
    }
    both.push_back(test::typed(r));
  }
  const json all = historyData(both, {tolerances});
  size_t failingRows = 0;
  std::set<int> failingRuns;
  for (const json& c : all["changes"])
    if (c["fails"].get<bool>()) {
      ++failingRows;
      failingRuns.insert(c["run"].get<int>());
    }
  EXPECT_EQ(failingRows, 2u) << all["changes"].dump();
  EXPECT_EQ(failingRuns, std::set<int>{5});
  EXPECT_EQ(all["failing"].get<size_t>(), 2u);
  EXPECT_EQ(all["failingComparisons"].get<size_t>(), 1u);
  EXPECT_TRUE(all["warnings"].empty()) << all["warnings"].dump();
  // At a confidence whose smallest Holm threshold no replicate count can show (0 rows resolvable),
  // the dashboard warns as `arena compare` does, once.
  BootstrapConfig strict;
  strict.confidence = 0.99999;
  ASSERT_EQ(holmResolvableRows(strict.confidence), 0u);
  const json unresolvable = historyData(both, {tolerances, strict});
  ASSERT_EQ(unresolvable["warnings"].size(), 1u) << unresolvable["warnings"].dump();
  EXPECT_NE(unresolvable["warnings"][0].get<std::string>().find(
                "rows judged together: more than 0, beyond which the correction "
                "can resolve no row"),
            std::string::npos);
  // Series per scene x label x metric, one slot per run; gated metrics carry their tolerance.
  const json& v = data["series"]["s"]["svgf"]["relMse"]["value"];
  ASSERT_EQ(v.size(), 8u);
  EXPECT_NEAR(v[7].get<double>(), 0.02 * 1.1 * (1 + 0.005 * ((7 % 3) - 1)), 1e-12);
  for (const json& m : data["metrics"]) {
    if (m["name"] == "relMse") {
      EXPECT_NEAR(m["tolerance"].get<double>(), 0.02, 1e-12);
    }
    if (m["name"] == "ms") {
      EXPECT_TRUE(m["tolerance"].is_null());
    }
  }
  // A zero tolerance gates too (any resolved worsening fails), and a one-run history shows the
  // gate it would apply.
  for (const size_t count : {size_t(8), size_t(1)}) {
    const std::vector<RunResults> some(runs.begin(), runs.begin() + long(count));
    const json zero = historyData(some, {{{"relMse", 0.0}}});
    bool seen = false;
    for (const json& m : zero["metrics"])
      if (m["name"] == "relMse") {
        seen = true;
        ASSERT_TRUE(m["tolerance"].is_number()) << count;
        EXPECT_EQ(m["tolerance"].get<double>(), 0.0);
      }
    EXPECT_TRUE(seen);
  }
  // Two consecutive runs with no scene in common: the history is still built, the second run's
  // comparison fails the gate with the pairs it lost.
  json moved = historyRun(8, 5);
  for (json& p : moved["pairs"]) p["scene"] = "elsewhere";
  std::vector<RunResults> withMove = runs;
  withMove.push_back(test::typed(moved));
  const json movedData = historyData(withMove, {tolerances});
  EXPECT_FALSE(changedRuns(movedData, "svgf", "*").empty());
  EXPECT_GT(movedData["failing"].get<size_t>(), failing);
  // A run measured under other settings: not comparable, as arena compare refuses it; the gate
  // fails there and compares nothing.
  json last = historyRun(7, 5), otherWarmup = historyRun(8, 5);
  otherWarmup["settings"] = {{"warmup", 3}};
  std::vector<RunResults> withOther(runs.begin(), runs.begin() + 7);
  withOther.push_back(test::typed(last));
  withOther.push_back(test::typed(otherWarmup));
  const json otherData = historyData(withOther, {tolerances});
  int notComparable = 0;
  for (const json& c : otherData["changes"])
    if (c["run"] == 8) {
      EXPECT_EQ(c["verdict"], "not comparable") << c;
      EXPECT_NE(c["note"].get<std::string>().find("settings.warmup"), std::string::npos) << c;
      EXPECT_TRUE(c["fails"].get<bool>());
      ++notComparable;
    }
  EXPECT_EQ(notComparable, 1);
  // --allow-settings-mismatch (a warm-up changed on purpose in the command CI runs): compared, as
  // `arena compare --allow-settings-mismatch` compares them, and said once.
  Gate allowing{tolerances};
  allowing.allowSettingsMismatch = true;
  const json allowed = historyData(withOther, allowing);
  for (const json& c : allowed["changes"]) EXPECT_NE(c["verdict"], "not comparable") << c;
  EXPECT_EQ(allowed["notComparable"], 0);
  ASSERT_EQ(allowed["warnings"].size(), 1u) << allowed["warnings"];
  EXPECT_NE(allowed["warnings"][0].get<std::string>().find(
                "comparing runs with different settings (baseline vs candidate): settings.warmup: "
                "2 vs 3"),
            std::string::npos)
      << allowed["warnings"];
  // Another setting changed later: said too (one warning per kind hid it), each text once.
  json otherFlip = historyRun(9, 5), sameAgain = historyRun(10, 5);
  otherFlip["settings"] = sameAgain["settings"] = {{"warmup", 3}, {"flip", "ldr"}};
  std::vector<RunResults> twice = withOther;
  twice.push_back(test::typed(otherFlip));
  twice.push_back(test::typed(sameAgain));
  const json later = historyData(twice, allowing);
  ASSERT_EQ(later["warnings"].size(), 2u) << later["warnings"];
  EXPECT_NE(later["warnings"][1].get<std::string>().find(
                "comparing the run run9 of 2025-01-01T00:09:00Z with the run before: comparing "
                "runs with different settings (baseline vs candidate): settings.flip: \"absent\" "
                "vs \"ldr\""),
            std::string::npos)
      << later["warnings"];
  // A run that records no settings (older than the record) cannot be checked: compared, and said.
  // Two such runs: said once, with the number of comparisons it concerns (7 against 8 and 8
  // against 9, each counted once though both of the second's runs record none).
  json unrecorded = historyRun(8, 5), unrecordedToo = historyRun(9, 5);
  unrecorded["settings"] = unrecordedToo["settings"] = json::object();
  std::vector<RunResults> withUnrecorded(runs.begin(), runs.begin() + 8);
  withUnrecorded.push_back(test::typed(unrecorded));
  withUnrecorded.push_back(test::typed(unrecordedToo));
  const json unchecked = historyData(withUnrecorded, {tolerances});
  EXPECT_EQ(unchecked["notComparable"], 0);
  ASSERT_EQ(unchecked["warnings"].size(), 1u) << unchecked["warnings"];
  EXPECT_NE(unchecked["warnings"][0].get<std::string>().find(
                "the run run8 of 2025-01-01T00:08:00Z records no settings"),
            std::string::npos)
      << unchecked["warnings"];
  EXPECT_NE(
      unchecked["warnings"][0].get<std::string>().find("(and 1 more comparison(s) of the history)"),
      std::string::npos)
      << unchecked["warnings"];
}

// A run read from results.db keeps the settings it recorded: beside a run directory of the same
// settings it is comparable, beside one of other settings it is not (as arena compare says).
// A contender run under a new label with the same denoiser and parameters (a default named
// explicitly: "svgf[iterations=5]" is svgf) stays one series, as `arena compare` matches it.
TEST(History, ARelabelledContenderStaysOneSeries) {
  std::vector<RunResults> runs;
  for (int i = 0; i < 3; ++i) {
    json r = historyRun(i, 2);  // run 2 jumps 10%
    for (json& p : r["pairs"])
      if (p["label"] == "svgf") {
        p["params"] = {{"iterations", 5}};
        if (i >= 1) p["label"] = "svgf[iterations=5]";
      }
    runs.push_back(test::typed(r));
  }
  const json data = historyData(runs, {});
  // The gate's row for run 2 names the pair's label; the page's flag names the series it charts.
  bool flagged = false;
  for (const json& c : data["changes"])
    if (c["run"] == 2 && c["metric"] == "relMse") {
      flagged = true;
      EXPECT_EQ(c["label"], "svgf") << c;
    }
  EXPECT_TRUE(flagged) << data["changes"];
  ASSERT_TRUE(data["series"]["s"].contains("svgf"));
  EXPECT_FALSE(data["series"]["s"].contains("svgf[iterations=5]"))
      << data["series"]["s"].dump().substr(0, 300);
  for (const json& v : data["series"]["s"]["svgf"]["relMse"]["value"])
    EXPECT_TRUE(v.is_number()) << v;
  EXPECT_EQ(data["series"]["s"]["svgf"]["aliases"], json::array({"svgf[iterations=5]"}));
  // Two labels for one contender in one run: no alias (they would overwrite each other's values).
  json twice = historyRun(3, 99);
  json copy = twice["pairs"][1];
  copy["label"] = "svgf[iterations=5]";
  twice["pairs"][1]["params"] = copy["params"] = {{"iterations", 5}};
  twice["pairs"][1]["label"] = "svgf-again";
  twice["pairs"].push_back(copy);
  std::vector<RunResults> withTwice = {runs[0], test::typed(twice)};
  const json both = historyData(withTwice, {})["series"]["s"];
  EXPECT_TRUE(both.contains("svgf-again") && both.contains("svgf[iterations=5]"))
      << both.dump().substr(0, 300);
  // Other parameters are another contender: another series.
  json other = historyRun(3, 99);
  for (json& p : other["pairs"])
    if (p["label"] == "svgf") p["label"] = "svgf[iterations=2]", p["params"] = {{"iterations", 2}};
  runs.push_back(test::typed(other));
  EXPECT_TRUE(historyData(runs, {})["series"]["s"].contains("svgf[iterations=2]"));
}

// A contender relabelled on purpose (a parameter added to the command CI runs, from run 2 on):
// without --match its series splits and the change reads missing, failing the gate at run 2 for
// good; with it, one series, and run 2's pair is compared with run 1's as `arena compare --match`
// compares them.
TEST(History, MatchJoinsARelabelledContenderAndComparesIt) {
  std::vector<RunResults> runs;
  for (int i = 0; i < 4; ++i) {
    json r = historyRun(i, 2);  // the new parameter makes relMSE 10% worse
    if (i >= 2)
      for (json& p : r["pairs"])
        if (p["label"] == "svgf") p["label"] = "svgf[sigmaL=8]", p["params"] = {{"sigmaL", 8}};
    runs.push_back(test::typed(r));
  }
  const std::vector<Tolerance> tolerances = {{"relMse", 0.02}};
  const json split = historyData(runs, {tolerances});
  EXPECT_TRUE(split["series"]["s"].contains("svgf[sigmaL=8]"));
  bool missing = false;
  for (const json& c : split["changes"])
    missing |= c["run"] == 2 && c["label"] == "svgf" && c["verdict"] == "missing";
  EXPECT_TRUE(missing) << split["changes"].dump();
  EXPECT_TRUE(split["matches"].empty());

  // Typed as a user would type it: the number another way.
  const json data =
      historyData(runs, {tolerances, {}, Correction::Holm, {}, {"svgf=svgf[sigmaL=8.0]"}});
  const json& series = data["series"]["s"];
  EXPECT_FALSE(series.contains("svgf[sigmaL=8]")) << series.dump().substr(0, 300);
  ASSERT_TRUE(series.contains("svgf"));
  EXPECT_EQ(series["svgf"]["aliases"], json::array({"svgf[sigmaL=8]"}));
  for (const json& v : series["svgf"]["relMse"]["value"]) EXPECT_TRUE(v.is_number()) << v;
  // Said with the labels as the runs wrote them.
  EXPECT_EQ(data["matches"], json({{"svgf=svgf[sigmaL=8]", {2}}}));
  // Run 2's row is compare's own on the two runs with the match: the same verdict and change.
  const std::vector<ComparisonRow> expected =
      compareRuns(runs[1], runs[2], tolerances, {}, Correction::Holm, {{"svgf", "svgf[sigmaL=8]"}});
  const auto svgfRow = std::find_if(expected.begin(), expected.end(), [](const ComparisonRow& r) {
    return r.label == "svgf" && r.metric == "relMse";
  });
  ASSERT_NE(svgfRow, expected.end());
  ASSERT_NE(svgfRow->verdict, "ok");  // a 10.6% rise is beyond the 2% tolerance
  bool seen = false;
  for (const json& c : data["changes"]) {
    EXPECT_NE(c["verdict"], "missing") << c;
    EXPECT_NE(c["verdict"], "new") << c;
    if (c["run"] == 2 && c["metric"] == "relMse" && c["label"] == "svgf") {
      seen = true;
      EXPECT_EQ(c["candidateLabel"], "svgf[sigmaL=8]") << c;
      EXPECT_EQ(c["pairLabel"], "svgf") << c;
      EXPECT_TRUE(c["matchedByRequest"].get<bool>()) << c;
      EXPECT_EQ(c["verdict"], svgfRow->verdict) << c;
      EXPECT_NEAR(c["change"].get<double>(), svgfRow->change, 1e-12) << c;
    }
  }
  EXPECT_TRUE(seen) << data["changes"].dump();
  // Naming either label with --denoisers keeps the contender on both sides of the change.
  for (const char* name : {"svgf[sigmaL=8]", "svgf"}) {
    const json only =
        historyData(runs, {tolerances, {}, Correction::Holm, {name}, {"svgf=svgf[sigmaL=8]"}});
    EXPECT_EQ(only["comparisons"], 3) << name;
    EXPECT_EQ(only["series"]["s"].size(), 1u) << name << only["series"].dump().substr(0, 300);
    EXPECT_EQ(only["matches"], json({{"svgf=svgf[sigmaL=8]", {2}}})) << name;
  }
}

// --match on a history: each label one some run has, each once, and met where the gate would use
// it.
TEST(History, MatchThatCannotApplyIsRefusedNamingIt) {
  std::vector<RunResults> runs;
  for (int i = 0; i < 4; ++i) {
    json r = historyRun(i, 99);
    if (i >= 2)
      for (json& p : r["pairs"])
        if (p["label"] == "svgf") p["label"] = "svgf[sigmaL=8]", p["params"] = {{"sigmaL", 8}};
    runs.push_back(test::typed(r));
  }
  const auto error = [&](std::vector<RunResults> rs, const std::vector<std::string>& m) {
    return test::errorOf([&] { historyData(std::move(rs), {{}, {}, Correction::Holm, {}, m}); });
  };
  const auto has = [](const std::string& e, const std::string& part) {
    return e.find(part) != std::string::npos;
  };
  std::string e = error(runs, {"svgf=reblur"});
  EXPECT_TRUE(has(e,
                  "history: --match svgf=reblur: no run has a pair labelled reblur (their "
                  "labels: passthrough, svgf, svgf[sigmaL=8])"))
      << e;
  e = error(runs, {"svgf"});
  EXPECT_TRUE(has(e, "--match svgf: expected BASELINE=CANDIDATE")) << e;
  e = error(runs, {"svgf=svgf"});
  EXPECT_TRUE(has(e, "history: --match svgf=svgf: matches svgf with itself")) << e;
  e = error(runs, {"svgf=svgf[sigmaL=8]", "passthrough=svgf[sigmaL=8]"});
  EXPECT_TRUE(
      has(e, "history: --match passthrough=svgf[sigmaL=8]: svgf[sigmaL=8] is matched twice"))
      << e;
  // The wrong way round: svgf[sigmaL=8] never comes before svgf.
  e = error(runs, {"svgf[sigmaL=8]=svgf"});
  EXPECT_TRUE(has(e,
                  "no run with a pair labelled svgf[sigmaL=8] is followed by one with svgf "
                  "(the history compares each run with the one before"))
      << e;
  EXPECT_TRUE(has(e, "svgf[sigmaL=8] is in runs 2, 3, svgf in runs 0, 1, 0 the oldest")) << e;
  // Not adjacent: a run between them has neither (each run is compared with the one before).
  std::vector<RunResults> gap = runs;
  std::erase_if(gap[2].pairs, [](const PairResult& p) { return p.label == "svgf[sigmaL=8]"; });
  e = error(gap, {"svgf=svgf[sigmaL=8]"});
  EXPECT_TRUE(has(e, "svgf is in runs 0, 1, svgf[sigmaL=8] in runs 3, 0 the oldest")) << e;
  // Both labels in one run (a sweep that ran both): its two contenders cannot be one series.
  std::vector<RunResults> both = runs;
  both[1].pairs.push_back(both[2].pairs[1]);
  both[1].pairs.back().label = "svgf[sigmaL=8]";
  e = error(both, {"svgf=svgf[sigmaL=8]"});
  EXPECT_TRUE(has(e, "history: --match svgf=svgf[sigmaL=8]: run 1 (")) << e;
  EXPECT_TRUE(has(e,
                  ") has pairs labelled svgf, svgf[sigmaL=8]: a run's two contenders cannot be "
                  "one series"))
      << e;
  // So with a chain: run 1 holding the first and the last label of A=B, B=C.
  std::vector<RunResults> chain = runs;
  for (int i : {1, 3}) chain[i].pairs.push_back(chain[i].pairs[1]);
  chain[1].pairs.back().label = "svgf[sigmaL=9]";
  chain[3].pairs.back().label = "svgf[sigmaL=9]";
  std::erase_if(chain[3].pairs, [](const PairResult& p) { return p.label == "svgf[sigmaL=8]"; });
  e = error(chain, {"svgf=svgf[sigmaL=8]", "svgf[sigmaL=8]=svgf[sigmaL=9]"});
  // The message names the chain that joins them, not its first link alone.
  EXPECT_TRUE(has(e,
                  "history: --match svgf=svgf[sigmaL=8] and --match "
                  "svgf[sigmaL=8]=svgf[sigmaL=9]: together they make svgf, svgf[sigmaL=8], "
                  "svgf[sigmaL=9] one series, but run 1 ("))
      << e;
  EXPECT_TRUE(has(e, "has pairs labelled svgf, svgf[sigmaL=9]")) << e;
  // --denoisers that keeps neither label: said, not a dashboard without the match.
  e = error(runs, {"svgf=svgf[sigmaL=8]"});
  EXPECT_EQ(e, "(no error)");
  e = test::errorOf([&] {
    historyData(runs, {{}, {}, Correction::Holm, {"passthrough"}, {"svgf=svgf[sigmaL=8]"}});
  });
  EXPECT_TRUE(has(e, "history: --match svgf=svgf[sigmaL=8]: --denoisers keeps neither label")) << e;
  // Brackets that do not pair up are no assignment (an extra ']' read as part of a label).
  e = error(runs, {"svgf[sigmaL=8]]=svgf"});
  EXPECT_TRUE(has(e, "--match svgf[sigmaL=8]]=svgf: its brackets do not pair up")) << e;
  e = error(runs, {"svgf[sigmaL=8=svgf"});
  EXPECT_TRUE(has(e, "its brackets do not pair up")) << e;
  // --denoisers typed otherwise names the runs' label; one no run has lists theirs.
  e = test::errorOf([&] { historyData(runs, {{}, {}, Correction::Holm, {"svgf[sigmaL=8.0]"}}); });
  EXPECT_EQ(e, "(no error)");
  e = test::errorOf([&] { historyData(runs, {{}, {}, Correction::Holm, {"svgf[sigmaL=7]"}}); });
  EXPECT_TRUE(has(e,
                  "history: --denoisers svgf[sigmaL=7]: no run has a pair of that label or "
                  "denoiser (their labels: passthrough, svgf, svgf[sigmaL=8])"))
      << e;
}

// A chain of relabellings (A from run 0, B from run 2, C from run 4) is one series, each change
// compared where it happened; --denoisers naming any of the three keeps all; a flag row of a
// later run compares one label with itself and says so (no arrow: matchedByRequest false).
TEST(History, AChainOfMatchesIsOneSeries) {
  std::vector<RunResults> runs;
  for (int i = 0; i < 6; ++i) {
    json r = historyRun(i, 5);  // svgf's relMSE jumps at run 5, after the last relabelling
    for (json& p : r["pairs"])
      if (p["label"] == "svgf" && i >= 2)
        p["label"] = i >= 4 ? "svgf[sigmaL=9]" : "svgf[sigmaL=8]",
        p["params"] = {{"sigmaL", i >= 4 ? 9 : 8}};
    runs.push_back(test::typed(r));
  }
  const std::vector<std::string> chain = {"svgf=svgf[sigmaL=8]", "svgf[sigmaL=8]=svgf[sigmaL=9]"};
  for (const std::vector<std::string>& contenders :
       {std::vector<std::string>{}, {"svgf"}, {"svgf[sigmaL=8]"}, {"svgf[sigmaL=9]"}}) {
    const json data =
        historyData(runs, {{{"relMse", 0.02}}, {}, Correction::Holm, contenders, chain});
    const std::string which = contenders.empty() ? "all" : contenders[0];
    ASSERT_TRUE(data["series"]["s"].contains("svgf")) << which;
    EXPECT_EQ(data["series"]["s"].size(), contenders.empty() ? 2u : 1u)
        << which << data["series"].dump().substr(0, 300);
    EXPECT_EQ(data["series"]["s"]["svgf"]["aliases"],
              json::array({"svgf[sigmaL=8]", "svgf[sigmaL=9]"}))
        << which;
    for (const json& v : data["series"]["s"]["svgf"]["relMse"]["value"])
      EXPECT_TRUE(v.is_number()) << which << v;
    EXPECT_EQ(data["matches"],
              json({{"svgf=svgf[sigmaL=8]", {2}}, {"svgf[sigmaL=8]=svgf[sigmaL=9]", {4}}}))
        << which;
    bool jump = false;
    for (const json& c : data["changes"]) {
      EXPECT_NE(c["verdict"], "missing") << which << c;
      if (c["run"] == 5 && c["metric"] == "relMse") {
        jump = true;
        EXPECT_EQ(c["label"], "svgf") << c;  // the series
        EXPECT_EQ(c["pairLabel"], "svgf[sigmaL=9]") << c;
        EXPECT_FALSE(c["matchedByRequest"].get<bool>()) << c;
      }
    }
    EXPECT_TRUE(jump) << which << data["changes"].dump();
  }
}

// A run the gate refuses to judge (its summary disagrees with its per-tile data) fails the gate at
// that run, saying why; the dashboard is still built from the others.
TEST(History, ARunTheGateRefusesIsMarkedNotComparable) {
  std::vector<RunResults> runs;
  for (int i = 0; i < 3; ++i) {
    json r = historyRun(i, 99);
    MetricTiles tiles;  // svgf's relMSE tiles: its summary's mean on every frame
    const double mean = r["pairs"][1]["summary"]["relMse"]["mean"];
    for (int f = 0; f < 8; ++f) {
      TileSums t;
      for (int k = 0; k < 4; ++k) t.sum.push_back(float(mean)), t.count.push_back(1);
      tiles.add(f, std::move(t));
    }
    r["pairs"][1]["tiles"]["relMse"] = tiles.toJson();
    if (i == 1) r["pairs"][1]["summary"]["relMse"]["mean"] = 0.5;  // edited by hand
    runs.push_back(test::typed(r));
  }
  const std::vector<RunResults> unedited = {runs[0], runs[2]};  // their tiles agree: judged
  const json judged = historyData(unedited, {});  // held: a loop over a temporary's member dangles
  for (const json& c : judged["changes"]) EXPECT_NE(c["verdict"], "not comparable") << c;
  const json data = historyData(runs, {});
  int refused = 0;
  for (const json& c : data["changes"])
    if (c["verdict"] == "not comparable" &&
        c["note"].get<std::string>().find("disagrees with its per-tile data") != std::string::npos)
      ++refused;
  EXPECT_EQ(refused, 2) << data["changes"];  // runs 1 (against 0) and 2 (against 1)
  EXPECT_EQ(data["failing"], 2);
  // Counted apart too: compare exits 2 there ("could not judge"), not 1 (a regression).
  EXPECT_EQ(data["notComparable"], 2);
  EXPECT_EQ(historyData(unedited, {})["notComparable"], 0);
  EXPECT_TRUE(data["series"]["s"].contains("svgf"));
}

TEST(History, RunsFromADatabaseAreJudgedOnTheSettingsTheyRecorded) {
  const fs::path dir = test::freshDir("history_settings");
  json first = historyRun(0, 3), same = historyRun(1, 3), other = historyRun(2, 3);
  first["settings"] = same["settings"] = {{"warmup", 2}};
  other["settings"] = {{"warmup", 3}};
  appendToDatabase(dir / "results.db", test::typed(first));
  saveResults(dir / "same", same);
  saveResults(dir / "other", other);
  auto notComparable = [](const json& data) {
    int n = 0;
    for (const json& c : data["changes"]) n += c["verdict"] == "not comparable";
    return n;
  };
  EXPECT_EQ(notComparable(historyData(loadHistory({dir / "results.db", dir / "same"}), {})), 0);
  EXPECT_EQ(notComparable(historyData(loadHistory({dir / "results.db", dir / "other"}), {})), 1);
  // Compared anyway (--allow-settings-mismatch), the summaries cover other frames (warm-up 2 and
  // 3) and the database keeps no per-frame tiles to take the frames both have: no change is given
  // (the same input read -2.7% across the two windows), and the row says why.
  other["pairs"][1]["summary"]["relMse"]["frames"] = 7;
  appendToDatabase(dir / "other.db", test::typed(other));
  Gate allowing{{{"relMse", 0.02}}};
  allowing.allowSettingsMismatch = true;
  const json windows = historyData(loadHistory({dir / "results.db", dir / "other.db"}), allowing);
  bool said = false;
  for (const json& c : windows["changes"])
    if (c["label"] == "svgf" && c["metric"] == "relMse") {
      said = true;
      EXPECT_EQ(c["verdict"], "not judged") << c;
      EXPECT_TRUE(c["change"].is_null()) << c;
      EXPECT_NE(c["note"].get<std::string>().find(
                    "the runs summarise other frames (baseline 8, candidate 7) and results.db "
                    "keeps no per-frame tiles"),
                std::string::npos)
          << c;
    }
  EXPECT_TRUE(said) << windows["changes"].dump();
  // A change of unknown size may be worse: counted among those not judged (the printout's warning
  // and the page's list), not passed over.
  EXPECT_EQ(windows["notJudged"], 1) << windows["changes"].dump();
  EXPECT_EQ(windows["notJudgedFromDatabase"], 1);
  // The database's rows are checked as a results.json's summaries are: an interval whose ends
  // were swapped names its run, pair and metric.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((dir / "other.db").string().c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "UPDATE summaries SET ci_lo = 0.5, ci_hi = 0.001 WHERE label = 'svgf' "
                         "AND metric = 'relMse'",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  EXPECT_NE(test::errorOf([&] { loadHistory({dir / "other.db"}); })
                .find(": summaries, svgf on s, relMse: the interval [0.5, 0.001] has its ends "
                      "swapped"),
            std::string::npos);
  // So are a summary of 0 frames that holds a value (a perfect 0 from no frame, charted), a pair or
  // summary listed twice, and settings that are no JSON (read as "no settings": a bad-input
  // trial). Each edit on a fresh copy of the database.
  const std::vector<std::pair<std::string, std::string>> damages = {
      {"UPDATE summaries SET frames = 0, mean = 0, ci_lo = 0, ci_hi = 0 WHERE label = 'svgf' AND "
       "metric = 'relMse'",
       ": summaries, svgf on s, relMse: a summary of 0 frames holds a value (mean 0)"},
      {"INSERT INTO pairs SELECT * FROM pairs WHERE label = 'svgf'",
       ": pairs: svgf on s is listed twice"},
      {"INSERT INTO summaries SELECT * FROM summaries WHERE label = 'svgf' AND metric = 'relMse'",
       ": summaries, svgf on s, relMse: listed twice"},
      {"UPDATE runs SET settings = '{garbage'",
       ": runs.settings: expected the run's settings as JSON, got \"{garbage\""}};
  for (const auto& [sql, error] : damages) {
    const fs::path copy = dir / "damaged.db";
    fs::remove(copy);
    appendToDatabase(copy, test::typed(historyRun(0, 2)));
    ASSERT_EQ(sqlite3_open(copy.string().c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK) << sql;
    sqlite3_close(db);
    const std::string e = test::errorOf([&] { loadHistory({copy}); });
    EXPECT_NE(e.find(error), std::string::npos) << sql << "\n" << e;
  }
}

// A scene's resolution and frame count are part of what the gate compares; a database keeps them
// (table scenes), so a history read from one alone flags a run at another size, as compare
// refuses it (it charted 64x36 against 96x54 as ordinary changes).
TEST(History, RunsFromADatabaseKeepTheirScenesSizes) {
  const fs::path dir = test::freshDir("history_scene_sizes");
  json small = historyRun(0, 3), same = historyRun(1, 3), large = historyRun(2, 3),
       longer = historyRun(3, 3);
  for (json* r : {&small, &same, &large, &longer}) {
    (*r)["settings"] = {{"warmup", 2}};
    (*r)["scenes"]["s"] = {{"width", 64}, {"height", 36}, {"frames", 16}};
  }
  large["scenes"]["s"]["width"] = 96;
  longer["scenes"]["s"]["frames"] = 12;
  for (const json* r : {&small, &same, &large, &longer})
    appendToDatabase(dir / "results.db", test::typed(*r));
  const json data = historyData(loadHistory({dir / "results.db"}), {});
  std::vector<std::string> why;
  for (const json& c : data["changes"])
    if (c["verdict"] == "not comparable")
      why.push_back(std::to_string(c["run"].get<int>()) + " " + c["note"].get<std::string>());
  ASSERT_EQ(why.size(), 2u) << data["changes"].dump();
  EXPECT_NE(why[0].find("2 the run run1 of 2025-01-01T00:01:00Z and the run run2 of "
                        "2025-01-01T00:02:00Z were run with different settings"),
            std::string::npos)
      << why[0];
  EXPECT_NE(why[0].find("scenes.s.width: 64 vs 96"), std::string::npos) << why[0];
  EXPECT_NE(why[1].find("3 the run run2 of 2025-01-01T00:02:00Z and the run run3 of "
                        "2025-01-01T00:03:00Z were run with different settings"),
            std::string::npos)
      << why[1];
  EXPECT_NE(why[1].find("scenes.s.width: 96 vs 64"), std::string::npos) << why[1];
  EXPECT_NE(why[1].find("scenes.s.frames: 16 vs 12"), std::string::npos) << why[1];
}

// Runs from a database keep no tiles: a change beyond the tolerance there is "not judged", never a
// failure and never "within noise", and the summary counts those so the CI log does not read
// "0 failing" alone.
// A metric the caller names that no run computed is an error, as in compare (not a page of
// "nothing compared" that hid every other change).
TEST(History, CountsWhatItCouldNotResolveAndRefusesAMetricNoRunComputed) {
  const fs::path dir = test::freshDir("history_unresolved");
  for (int i = 0; i < 4; ++i) appendToDatabase(dir / "results.db", test::typed(historyRun(i, 2)));
  const json data = historyData(loadHistory({dir / "results.db"}), {{{"relMse", 0.02}}});
  EXPECT_EQ(data["failing"], 0);
  EXPECT_EQ(data["failingComparisons"], 0);
  EXPECT_EQ(data["comparisons"], 3);
  EXPECT_EQ(data["unresolved"], 0) << data["changes"].dump();
  EXPECT_EQ(data["notJudged"], 1) << data["changes"].dump();
  EXPECT_EQ(data["notJudgedFromDatabase"], 1);  // the printout's warning names results.db then
  EXPECT_EQ(data["correction"], "holm");
  EXPECT_EQ(data["confidence"], 0.95);
  EXPECT_EQ(changedRuns(data, "svgf", "relMse"), std::vector<int>{2});
  const std::string e = test::errorOf([&] {
    historyData(loadHistory({dir / "results.db"}), {{{"ldrFlip", 0.02}}});
  });
  EXPECT_NE(e.find("history: --metric ldrFlip: no run computed it"), std::string::npos) << e;
  // An improvement the gate could not judge is listed as a change but not counted: it could never
  // fail the gate (a trial's dashboard warned of 24 improvements as "NOT JUDGED").
  const fs::path better = test::freshDir("history_improved");
  for (int i = 0; i < 4; ++i) {
    json r = historyRun(i, 2);
    const double relMse = r["pairs"][1]["summary"]["relMse"]["mean"].get<double>();
    if (i >= 2) r["pairs"][1]["summary"]["relMse"] = stat(relMse / 1.21);  // 10% better, not worse
    appendToDatabase(better / "results.db", test::typed(r));
  }
  const json improved = historyData(loadHistory({better / "results.db"}), {{{"relMse", 0.02}}});
  EXPECT_EQ(improved["notJudged"], 0) << improved["changes"].dump();
  bool listed = false;
  for (const json& c : improved["changes"]) listed |= c["verdict"] == "not judged";
  EXPECT_TRUE(listed) << improved["changes"].dump();
}

// --denoisers: only the named contender is gated; the runs from before it existed are no
// comparisons (they read "nothing compared", failing, before), and a name no run has is refused.
TEST(History, GatesOnlyTheNamedContenderFromWhenItExists) {
  std::vector<RunResults> runs;
  for (int i = 0; i < 5; ++i) {
    json r = historyRun(i, 99);
    if (i < 2) r["pairs"].erase(1);  // svgf first ran in run 2
    runs.push_back(test::typed(r));
  }
  const json data = historyData(runs, {{{"relMse", 0.02}}, {}, Correction::Holm, {"svgf"}});
  EXPECT_EQ(data["comparisons"], 2) << data["changes"].dump();  // 3 against 2, 4 against 3
  EXPECT_EQ(data["notMadeBeforeContenders"], 2);                // 1 against 0, 2 against 1: said
  EXPECT_EQ(data["failingComparisons"], 0) << data["changes"].dump();
  EXPECT_FALSE(data["series"]["s"].contains("passthrough"));
  EXPECT_TRUE(data["series"]["s"].contains("svgf"));
  const std::string e = test::errorOf([&] {
    historyData(runs, {{}, {}, Correction::Holm, {"reblur"}});
  });
  EXPECT_NE(e.find("history: --denoisers reblur: no run has a pair of that label or denoiser"),
            std::string::npos)
      << e;
}

// A database written before the scenes table existed is still this schema: a run appends to it
// (adding the table), and its older runs are read without their scenes' sizes.
TEST(History, ADatabaseWithoutTheScenesTableIsStillRead) {
  const fs::path dir = test::freshDir("history_no_scenes_table");
  json first = historyRun(0, 3), second = historyRun(1, 3);
  first["scenes"]["s"] = second["scenes"]["s"] = {{"width", 64}, {"height", 36}, {"frames", 16}};
  appendToDatabase(dir / "results.db", test::typed(first));
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((dir / "results.db").c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "DROP TABLE scenes", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  EXPECT_EQ(test::errorOf([&] { (void)checkRunOutputs(dir); }), "(no error)");
  appendToDatabase(dir / "results.db", test::typed(second));
  const std::vector<RunResults> runs = loadHistory({dir / "results.db"});
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_FALSE(runs[0].scenes.contains("s"));  // written before the table
  EXPECT_EQ(runs[1].scenes["s"]["width"], 64);
}

TEST(History, ReadsRunDirectoriesAndDatabasesInTimeOrder) {
  const fs::path dir = test::freshDir("history_inputs");
  // Runs 0..3 in a database (appended out of order), 4 and 5 as run directories.
  const fs::path db = dir / "results.db";
  for (int i : {1, 0, 3, 2}) appendToDatabase(db, test::typed(historyRun(i, 3)));
  std::vector<fs::path> inputs = {dir / "r5", db, dir / "r4"};
  for (int i : {4, 5}) saveResults(dir / ("r" + std::to_string(i)), historyRun(i, 3));
  const std::vector<RunResults> runs = loadHistory(inputs);
  ASSERT_EQ(runs.size(), 6u);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(runs[size_t(i)].name, "run" + std::to_string(i));
  // A database run has its pairs' summaries and commit.
  EXPECT_EQ(runs[0].environment["git_commit"], "abc0");
  bool found = false;
  for (const PairResult& p : runs[2].pairs)
    if (p.label == "svgf") {
      found = true;
      EXPECT_NEAR(p.summary.at("relMse").mean,
                  historyRun(2, 3)["pairs"][1]["summary"]["relMse"]["mean"].get<double>(), 1e-15);
    }
  EXPECT_TRUE(found);
  // The jump at run 3 is marked whichever container held the runs.
  const json data = historyData(runs, {{{"relMse", 0.02}}});
  EXPECT_EQ(changedRuns(data, "svgf", "relMse"), std::vector<int>{3}) << data["changes"].dump();
}

TEST(History, TimesAreTheFormRunsWrite) {
  EXPECT_TRUE(isUtcTimestamp(utcTimestamp()));
  for (const char* good : {"2026-11-28T21:15:00Z", "2024-02-29T00:00:00Z", "2016-12-31T23:59:60Z"})
    EXPECT_TRUE(isUtcTimestamp(good)) << good;
  for (const char* bad : {"", "2026-11-28", "2026-11-28T21:15:00", "2026-11-28 21:15:00Z",
                          "2026-11-28T21:15:00+01:00", "2026-13-01T00:00:00Z",
                          "2026-00-10T00:00:00Z", "2025-02-29T00:00:00Z", "2026-04-31T00:00:00Z",
                          "2026-11-28T24:00:00Z", "2026-11-28T21:60:00Z", "2026-11-28T21:15:61Z",
                          "2026-11-2aT21:15:00Z", "+026-11-28T21:15:00Z"})
    EXPECT_FALSE(isUtcTimestamp(bad)) << bad;
}

// The commit a run records is the one its binary was built from, written at build time by
// cmake/git_state.cmake; tried here on a repository of its own: clean, edited, untracked, none.
TEST(History, TheRecordedCommitIsTheBuiltTreeAndSaysWhenItWasDirty) {
  const std::string recorded = environmentInfo()["git_commit"];
  const auto isHash = [](const std::string& text) {
    return text.size() == 12 && text.find_first_not_of("0123456789abcdef") == std::string::npos;
  };
  const std::string bare = recorded.size() > 6 && recorded.ends_with("-dirty")
                               ? recorded.substr(0, recorded.size() - 6)
                               : recorded;
  EXPECT_TRUE(recorded.empty() || isHash(bare)) << recorded;
  const json load = environmentInfo()["loadAverage"];  // 1, 5, 15 minutes, where the OS says
  EXPECT_TRUE(load.is_null() || (load.is_array() && load.size() == 3 && load[0].get<double>() >= 0))
      << load;

  const fs::path repo = test::freshDir("git_state");
  const fs::path header = repo / "out" / "git_state.hpp";
  fs::create_directories(header.parent_path());
  if (test::runCommand("git --version").status != 0) GTEST_SKIP() << "no git on this machine";
  const std::string git =
      "git -C '" + repo.string() + "' -c user.name=t -c user.email=t@t -c commit.gpgsign=false ";
  const auto state = [&](const fs::path& source) {
    const test::CommandResult r =
        test::runCommand("cmake -DSOURCE='" + source.string() + "' -DOUTPUT='" + header.string() +
                         "' -P '" ARENA_SOURCE_DIR "/cmake/git_state.cmake'");
    EXPECT_EQ(r.status, 0) << r.output;
    std::ifstream in(header);
    const std::string text{std::istreambuf_iterator<char>(in), {}};
    const size_t open = text.find("ARENA_GIT_COMMIT \"") + 18;
    return text.substr(open, text.find('"', open) - open);
  };
  EXPECT_EQ(state(repo), "");  // not a checkout (or inside another's): nothing to claim
  ASSERT_EQ(test::runCommand(git + "init -q").status, 0);
  std::ofstream(repo / "code.cpp") << "int x;\n";
  std::ofstream(repo / ".gitignore") << "out/\n";
  ASSERT_EQ(test::runCommand(git + "add -A && " + git + "commit -q -m one").status, 0);
  const std::string head = test::runCommand(git + "rev-parse --short=12 HEAD").output.substr(0, 12);
  EXPECT_EQ(state(repo), head);
  const auto written = fs::last_write_time(header);
  EXPECT_EQ(state(repo), head);
  EXPECT_EQ(fs::last_write_time(header), written);  // unchanged: nothing recompiles
  std::ofstream(repo / "notes.txt") << "untracked\n";
  EXPECT_EQ(state(repo), head);  // an untracked file changes no code
  std::ofstream(repo / "code.cpp") << "int y;\n";
  EXPECT_EQ(state(repo), head + "-dirty");
  fs::create_directories(repo / "vendored");  // a tree inside another checkout is not that one
  EXPECT_EQ(state(repo / "vendored"), "");
}

TEST(History, BadInputNamesThePath) {
  const fs::path dir = test::freshDir("history_bad");
  try {
    loadHistory({dir / "nope"});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "nope").string()), std::string::npos) << e.what();
  }
  std::ofstream(dir / "notes.txt") << "not a database";
  try {
    loadHistory({dir / "notes.txt"});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("notes.txt"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loadHistory({}), Error);
  // A database of another schema, or of none, could be read as if it were this one's; one with no
  // runs would chart and gate nothing and pass; a run given twice would be compared with itself.
  const fs::path db = dir / "results.db";
  appendToDatabase(db, test::typed(historyRun(0, 3)));
  auto withSql = [&](const std::string& name, const std::string& sql) {
    const fs::path copy = dir / name;
    fs::copy_file(db, copy, fs::copy_options::overwrite_existing);
    sqlite3* h = nullptr;
    sqlite3_open(copy.c_str(), &h);
    sqlite3_exec(h, sql.c_str(), nullptr, nullptr, nullptr);
    sqlite3_close(h);
    return copy;
  };
  std::string e =
      test::errorOf([&] { loadHistory({withSql("v99.db", "PRAGMA user_version = 99")}); });
  EXPECT_NE(e.find("v99.db: a results database of schema version 99; this arena reads version 2"),
            std::string::npos)
      << e;
  e = test::errorOf([&] { loadHistory({withSql("v0.db", "PRAGMA user_version = 0")}); });
  EXPECT_NE(e.find("v0.db: not an arena results database"), std::string::npos) << e;
  e = test::errorOf([&] {
    loadHistory(
        {withSql("empty.db", "DELETE FROM summaries; DELETE FROM pairs; DELETE FROM runs")});
  });
  EXPECT_NE(e.find("empty.db: holds no runs"), std::string::npos) << e;
  // Runs are placed by when they were made: a time in another form, or none, would put a run
  // beside the wrong neighbour for the gate; each is refused, naming where it was read.
  e = test::errorOf(
      [&] { loadHistory({withSql("when.db", "UPDATE runs SET created = '28/11/2026 21:15'")}); });
  EXPECT_NE(e.find("when.db#1: runs.created: expected a UTC time as 2026-11-28T21:15:00Z"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("got \"28/11/2026 21:15\""), std::string::npos) << e;
  json run = historyRun(1, 3);
  run["created"] = "2025-02-30T00:00:00Z";  // no such day
  saveResults(dir / "badday", run);
  e = test::errorOf([&] { loadHistory({dir / "badday"}); });
  EXPECT_NE(e.find("$.created: expected a UTC time"), std::string::npos) << e;
  run.erase("created");
  saveResults(dir / "undated", run);
  e = test::errorOf([&] { loadHistory({db, dir / "undated"}); });
  EXPECT_NE(
      e.find("history: " + (dir / "undated").string() + ": the run records no `created` time"),
      std::string::npos)
      << e;
  // The same run given twice is taken once (compared with itself, the gate would pass on nothing).
  EXPECT_EQ(loadHistory({db, dir / "." / "results.db"}).size(), 1u);
  fs::copy_file(db, dir / "copy.db", fs::copy_options::overwrite_existing);  // another file
  std::vector<std::string> said;
  EXPECT_EQ(loadHistory({db, dir / "copy.db"}, &said).size(), 1u);
  // ... and said: a copy given beside its original is taken once, with a warning naming both.
  ASSERT_FALSE(said.empty());
  EXPECT_NE(said[0].find("copy.db#"), std::string::npos) << said[0];
  EXPECT_NE(said[0].find("holds the same run as " + db.string() + "#"), std::string::npos)
      << said[0];
  EXPECT_NE(said[0].find("taken once"), std::string::npos) << said[0];
  // Two runs made in the same second keep the order given, said (their changes would read reversed
  // if given out of order).
  json first = historyRun(1, 3), second = historyRun(2, 3);
  second["created"] = first["created"];
  saveResults(dir / "same_a", first);
  saveResults(dir / "same_b", second);
  std::vector<std::string> tied;
  const std::vector<RunResults> ordered = loadHistory({dir / "same_b", dir / "same_a"}, &tied);
  ASSERT_EQ(ordered.size(), 2u);
  EXPECT_EQ(ordered[0].name, second["name"].get<std::string>());  // as given
  ASSERT_EQ(tied.size(), 1u);
  EXPECT_NE(
      tied[0].find(" were created in the same second (" + first["created"].get<std::string>()),
      std::string::npos)
      << tied[0];
  e = test::errorOf([&] { loadHistory({dir / "notes.txt"}); });
  EXPECT_NE(e.find("notes.txt: not an SQLite database"), std::string::npos) << e;
  // A file where the page's directory belongs, named with the option.
  HistoryOptions o;
  o.inputs = {db};
  o.out = dir / "notes.txt";
  e = test::errorOf([&] { writeHistory(o); });
  EXPECT_NE(e.find("history: --out " + o.out.string() + ": exists and is not a directory"),
            std::string::npos)
      << e;
  o.out.clear();
  e = test::errorOf([&] { writeHistory(o); });
  EXPECT_NE(e.find("history: --out is required"), std::string::npos) << e;
}

TEST(History, WritesTheDashboard) {
  const fs::path dir = test::freshDir("history_page");
  std::vector<fs::path> inputs;
  for (int i = 0; i < 4; ++i) {
    inputs.push_back(dir / ("r" + std::to_string(i)));
    saveResults(inputs.back(), historyRun(i, 2));
  }
  HistoryOptions o;
  o.inputs = inputs;
  o.out = dir / "out";
  o.nodeModulesDir = dir / "modules";
  for (const char* f : {"vega/build/vega.min.js", "vega-lite/build/vega-lite.min.js",
                        "vega-embed/build/vega-embed.min.js"}) {
    fs::create_directories((o.nodeModulesDir / f).parent_path());
    std::ofstream(o.nodeModulesDir / f) << "// stand-in\n";
  }
  const HistorySummary s = writeHistory(o);
  EXPECT_EQ(s.runs, 4u);
  EXPECT_LE(s.failing, 1u);
  for (const char* f :
       {"index.html", "history.js", "shared.js", "style.css", "history-data.js", "vega.min.js"})
    EXPECT_TRUE(fs::exists(o.out / f)) << f;
  EXPECT_NE(readText(o.out / "index.html").find("history.js"), std::string::npos);
  // Into a run's directory (where `arena report` may have written the run's own page): refused,
  // nothing written.
  HistoryOptions intoRun = o;
  intoRun.out = inputs[1];
  EXPECT_EQ(test::errorOf([&] { writeHistory(intoRun); }),
            "history: --out " + inputs[1].string() +
                " holds a run (results.json): the dashboard's index.html would replace the run's "
                "own page there; choose a directory of its own, e.g. report/history");
  EXPECT_FALSE(fs::exists(inputs[1] / "index.html"));
  EXPECT_FALSE(fs::exists(inputs[1] / "history-data.js"));
  // Into a run's report (data.js beside its index.html): refused too.
  const fs::path page = dir / "page";
  fs::create_directories(page);
  std::ofstream(page / "data.js") << "window.ARENA_DATA = {};\n";
  std::ofstream(page / "index.html") << "<title>report</title>\n";
  HistoryOptions intoReport = o;
  intoReport.out = page;
  EXPECT_NE(test::errorOf([&] { writeHistory(intoReport); }).find("holds a run's report (data.js)"),
            std::string::npos);
  EXPECT_EQ(readText(page / "index.html"), "<title>report</title>\n");
  // ... and a report into this dashboard's folder.
  ReportOptions report;
  report.run = inputs[0];
  report.out = o.out;
  report.nodeModulesDir = o.nodeModulesDir;
  EXPECT_NE(test::errorOf([&] {
              writeReport(report);
            }).find("holds a history dashboard (history-data.js)"),
            std::string::npos);
  EXPECT_NE(readText(o.out / "index.html").find("history.js"), std::string::npos);
  // Written again into its own folder: fine. Into a website's (an index.html no arena page
  // wrote): refused, nothing written.
  writeHistory(o);
  HistoryOptions intoSite = o;
  intoSite.out = dir / "site";
  fs::create_directories(intoSite.out);
  std::ofstream(intoSite.out / "index.html") << "<title>our renderer</title>\n";
  EXPECT_NE(test::errorOf([&] { writeHistory(intoSite); })
                .find("history: --out " + intoSite.out.string() +
                      " holds an index.html that is no Denoise Arena report's or dashboard's"),
            std::string::npos);
  EXPECT_EQ(std::distance(fs::directory_iterator(intoSite.out), fs::directory_iterator()), 1);
}

}  // namespace
}  // namespace arena
