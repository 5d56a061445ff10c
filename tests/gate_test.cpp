// metrics/gate: one judgement of a candidate run against a baseline, which `arena compare` (its
// exit code), `arena report --baseline` (the regression view's verdict) and `arena history` (each
// run against the one before) show alike, case by case: a pass, a regression, the same run twice,
// runs of other settings refused and allowed, a run that records no settings.
#include "metrics/gate.hpp"

#include <gtest/gtest.h>

#include "core/error.hpp"
#include "metrics/results.hpp"
#include "metrics/tiles.hpp"
#include "reports/history.hpp"
#include "reports/report.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A run of one pair (svgf on "s") whose relMSE is `relMse`, with the per-tile data the gate's
// paired interval resamples (8 frames x 16 tiles around the mean, the mean the summary's).
json gateRun(const std::string& name, const std::string& created, double relMse,
             const json& settings = {{"warmup", 2}}, int width = 64, int frames = 8) {
  MetricTiles tiles;
  for (int f = 2; f < 2 + frames; ++f) {
    TileSums t;
    for (int k = 0; k < 16; ++k)
      t.sum.push_back(relMse * (1 + 0.01 * ((f + k) % 4 - 1.5))), t.count.push_back(1);
    tiles.add(f, std::move(t));
  }
  const json stat = {
      {"mean", relMse}, {"median", relMse}, {"p5", relMse}, {"p95", relMse}, {"frames", frames}};
  return {{"schema", kResultsSchemaVersion},
          {"kind", "arena-run"},
          {"name", name},
          {"created", created},
          {"environment", {{"git_commit", "abc"}}},
          {"settings", settings},
          {"scenes", {{"s", {{"width", width}, {"height", 36}, {"frames", 2 + frames}}}}},
          {"pairs",
           {{{"scene", "s"},
             {"denoiser", "svgf"},
             {"label", "svgf"},
             {"params", json::object()},
             {"status", "ok"},
             {"frames", json::array()},
             {"summary", {{"relMse", stat}}},
             {"tiles", {{"relMse", tiles.toJson()}}}}}}};
}

struct GateCase {
  const char* what;
  json baseline, candidate;
  bool allowSettingsMismatch;
  GateOutcome expected;
  GateRefusal refusal;
  const char* warning;  // a text one of the judgement's warnings holds ("": none)
};

TEST(Gate, CompareReportAndHistoryJudgeEveryCaseAlike) {
  const json before = gateRun("before", "2025-01-01T00:00:00Z", 0.05);
  json tampered = gateRun("after", "2025-01-01T00:01:00Z", 0.05);
  tampered["pairs"][0]["summary"]["relMse"]["mean"] = 0.04;  // its tiles still say 0.05
  const std::vector<GateCase> cases = {
      {"within tolerance", before, gateRun("after", "2025-01-01T00:01:00Z", 0.0505), false,
       GateOutcome::Pass, GateRefusal::None, ""},
      {"20% worse", before, gateRun("after", "2025-01-01T00:01:00Z", 0.06), false,
       GateOutcome::Regressed, GateRefusal::None, ""},
      {"the same run twice", before, before, false, GateOutcome::CouldNotJudge,
       GateRefusal::SameRun, ""},
      {"another warm-up", before, gateRun("after", "2025-01-01T00:01:00Z", 0.06, {{"warmup", 3}}),
       false, GateOutcome::CouldNotJudge, GateRefusal::OtherSettings, ""},
      {"another warm-up, allowed", before,
       gateRun("after", "2025-01-01T00:01:00Z", 0.06, {{"warmup", 3}}), true,
       GateOutcome::Regressed, GateRefusal::None,
       "comparing runs with different settings (baseline vs candidate): settings.warmup: 2 vs 3"},
      {"a candidate that records no settings", before,
       gateRun("after", "2025-01-01T00:01:00Z", 0.0505, json::object()), false, GateOutcome::Pass,
       GateRefusal::None, "records no settings"},
      {"the runs swapped", gateRun("after", "2025-01-01T00:01:00Z", 0.0505), before, false,
       GateOutcome::Pass, GateRefusal::None, "are the two swapped?"},
      // A run that records no settings still has its scenes' sizes checked.
      {"no settings, and another resolution", before,
       gateRun("after", "2025-01-01T00:01:00Z", 0.0505, json::object(), 96), false,
       GateOutcome::CouldNotJudge, GateRefusal::OtherSettings, "records no settings"},
      {"a summary edited away from its tiles", before, tampered, false, GateOutcome::CouldNotJudge,
       GateRefusal::Data, ""},
      // Intervals on 3 frames after the warm-up: too narrow to judge by, either way.
      {"20% worse on 3 frames",
       gateRun("before", "2025-01-01T00:00:00Z", 0.05, {{"warmup", 2}}, 64, 3),
       gateRun("after", "2025-01-01T00:01:00Z", 0.06, {{"warmup", 2}}, 64, 3), false,
       GateOutcome::CouldNotJudge, GateRefusal::None, "7 or fewer frames after the warm-up"},
  };
  for (const GateCase& c : cases) {
    SCOPED_TRACE(c.what);
    Gate gate;
    gate.tolerances = {{"relMse", 0.02}};
    gate.allowSettingsMismatch = c.allowSettingsMismatch;
    const RunResults baseline = test::typed(c.baseline), candidate = test::typed(c.candidate);
    const GateJudgement j = judgeRuns(baseline, candidate, gate, {});
    EXPECT_EQ(gateOutcomeName(j.outcome), std::string(gateOutcomeName(c.expected)));
    EXPECT_EQ(int(j.refusal), int(c.refusal));
    EXPECT_EQ(refusalText(j, {}, false).empty(), c.refusal == GateRefusal::None);
    const std::vector<std::string> warnings = gateWarningTexts(j, {}, false);
    if (*c.warning) {
      ASSERT_EQ(warnings.size(), 1u);
      EXPECT_NE(warnings[0].find(c.warning), std::string::npos) << warnings[0];
    } else {
      EXPECT_TRUE(warnings.empty()) << warnings[0];
    }
    // `arena compare` on the two runs' directories exits with the judgement's code.
    const fs::path dir = test::freshDir("gate_case");
    saveResults(dir / "baseline", c.baseline);
    saveResults(dir / "candidate", c.candidate);
    const contract::CliResult r = contract::arenaCli(
        "compare --metric relMse " + (dir / "baseline").string() + " " +
        (c.refusal == GateRefusal::SameRun ? dir / "baseline" : dir / "candidate").string() +
        (c.allowSettingsMismatch ? " --allow-settings-mismatch" : "") + " 2>&1");
    EXPECT_EQ(r.status, gateExitCode(c.expected)) << r.output;
    // (Its lists one item to an indented line, where a page's run on after a space.)
    std::string oneLine;
    for (size_t k = 0; k < r.output.size(); ++k)
      if (r.output.compare(k, 3, "\n  ") == 0)
        oneLine += ' ', k += 2;
      else
        oneLine += r.output[k];
    if (*c.warning) {
      EXPECT_NE(oneLine.find(c.warning), std::string::npos) << r.output;
    }
    // The report's regression view gives the same verdict and exit code, and the same warnings.
    const json view = reportData(candidate, dir / "candidate", &baseline, gate)["regression"];
    EXPECT_EQ(view["gate"], gateOutcomeName(c.expected)) << view.dump();
    EXPECT_EQ(view["exitCode"], gateExitCode(c.expected));
    EXPECT_EQ(view["refused"].get<std::string>().empty(), c.refusal == GateRefusal::None);
    EXPECT_EQ(view["warnings"].size(), warnings.size()) << view["warnings"];
    // The dashboard of the two fails its one comparison exactly where compare does not pass, and
    // marks it not comparable exactly where compare refuses the runs.
    if (c.candidate["created"] < c.baseline["created"]) continue;  // a history orders them itself
    const json history = historyData({baseline, candidate}, gate);
    EXPECT_EQ(history["failingComparisons"], c.expected == GateOutcome::Pass ? 0 : 1);
    EXPECT_EQ(history["notComparable"], c.refusal == GateRefusal::None ? 0 : 1);
    EXPECT_EQ(history["warnings"].size(), warnings.size()) << history["warnings"];
  }
}

// A difference resolved on 7 or fewer frames after the warm-up is not judged: its interval is too
// narrow to hold its level (a statistician's trial: a gate on 1 frame at 32x18 failed 6 of 8
// reruns of noise alone, with no warning). It does not fail the gate, says so, and stays outside
// the rows judged together, and the gate cannot judge the runs; on 8 frames the same change
// regresses.
TEST(Gate, ADifferenceResolvedOnFewFramesIsNotJudged) {
  const json settings = {{"warmup", 2}};
  for (const auto& [candidate, word] : {std::pair{0.06, "worse"}, std::pair{0.04, "better"}}) {
    const RunResults a = test::typed(gateRun("a", "2025-01-01T00:00:00Z", 0.05, settings, 64, 3)),
                     b = test::typed(
                         gateRun("b", "2025-01-01T00:01:00Z", candidate, settings, 64, 3));
    const GateJudgement j = judgeRuns(a, b, Gate{}, {});
    // The gate cannot pass such runs (a +303% change passed as "not judged", exit 0): could not
    // judge, exit 2, whatever the rows read.
    EXPECT_EQ(j.outcome, GateOutcome::CouldNotJudge);
    ASSERT_EQ(j.rows.size(), 1u);
    const ComparisonRow& r = j.rows[0];
    EXPECT_EQ(r.verdict, "not judged") << r.note;
    EXPECT_TRUE(r.changeCi.valid() && !r.changeCi.containsZero());
    EXPECT_FALSE(std::isfinite(r.pValue));
    EXPECT_NE(r.note.find(std::string(word) +
                          " beyond tolerance, resolved on only 3 frames after the warm-up"),
              std::string::npos)
        << r.note;
    const std::vector<std::string> warnings = gateWarningTexts(j, {"a", "b"}, false);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("7 or fewer frames after the warm-up on scene s"), std::string::npos)
        << warnings[0];
  }
  const GateJudgement eight =
      judgeRuns(test::typed(gateRun("a", "2025-01-01T00:00:00Z", 0.05)),
                test::typed(gateRun("b", "2025-01-01T00:01:00Z", 0.06)), Gate{}, {});
  EXPECT_EQ(eight.outcome, GateOutcome::Regressed);
  EXPECT_TRUE(std::isfinite(eight.rows.at(0).pValue));
  EXPECT_TRUE(gateWarningTexts(eight, {"a", "b"}, false).empty());
}

// Runs read from results.db keep no tiles, so a change within tolerance there is "ok" on the
// summaries alone. On 7 or fewer frames after the warm-up they are held as runs with tiles are:
// the gate cannot pass them (runs of one frame passed from results.db where their directories
// could not judge them).
TEST(Gate, RunsFromTheDatabaseOnFewFramesCannotPass) {
  auto fromDatabase = [](const char* name, const char* created, double relMse, int frames) {
    json run = gateRun(name, created, relMse, {{"warmup", 2}}, 64, frames);
    run["pairs"][0].erase("tiles");
    RunResults r = test::typed(run);
    r.keepsTiles = false;
    return r;
  };
  for (const int frames : {1, 7, 8}) {
    const GateJudgement j =
        judgeRuns(fromDatabase("a", "2025-01-01T00:00:00Z", 0.05, frames),
                  fromDatabase("b", "2025-01-01T00:01:00Z", 0.0505, frames), Gate{}, {});
    ASSERT_EQ(j.rows.size(), 1u);
    EXPECT_EQ(j.rows[0].verdict, "ok") << frames;
    EXPECT_EQ(j.rows[0].fewFrames, frames <= kFewSummarisedFrames) << frames;
    EXPECT_EQ(j.outcome,
              frames <= kFewSummarisedFrames ? GateOutcome::CouldNotJudge : GateOutcome::Pass)
        << frames;
    const std::vector<std::string> warnings = gateWarningTexts(j, {"a", "b"}, false);
    EXPECT_EQ(warnings.size(), frames <= kFewSummarisedFrames ? 1u : 0u) << frames;
    if (!warnings.empty()) {  // said of summaries, which have no interval to be narrow
      EXPECT_NE(warnings[0].find("results.db keeps no tiles to tell it"), std::string::npos)
          << warnings[0];
    }
  }
}

// Mistakes in the options are errors, before any judgement (they are not the runs' fault).
TEST(Gate, AMistakenOptionIsAnErrorNotARefusal) {
  const RunResults a = test::typed(gateRun("a", "2025-01-01T00:00:00Z", 0.05)),
                   b = test::typed(gateRun("b", "2025-01-01T00:01:00Z", 0.05));
  Gate gate;
  gate.contenders = {"reblur"};
  EXPECT_NE(test::errorOf([&] { judgeRuns(a, b, gate, {}); }).find("reblur"), std::string::npos);
  gate.contenders.clear();
  gate.tolerances = {{"noSuchMetric", 0.02}};
  EXPECT_NE(test::errorOf([&] { judgeRuns(a, b, gate, {}); }).find("noSuchMetric"),
            std::string::npos);
  // A metric named that neither run computed: the options' mistake, not a refusal of the runs
  // (`report --baseline --metric ldrFlip` on runs without FLIP wrote a page that "could not
  // judge").
  gate.tolerances = {{"ldrFlip", 0.02}};
  EXPECT_THROW(judgeRuns(a, b, gate, {}), UnmeasuredMetric);
  EXPECT_NE(test::errorOf([&] {
              reportData(b, test::freshDir("gate_unmeasured"), &a, gate);
            }).find("--metric ldrFlip: neither run computed it"),
            std::string::npos);
}

}  // namespace
}  // namespace arena
