// metrics/compare: runs of other settings are compared only when asked, and then say which differ.
#include "metrics/compare.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "core/atomic_file.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/results.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

TEST(CompareContract, RunsOfOtherSettingsAreRefusedUnlessAllowed) {
  RunConfig a = contract::tinyRun("settings_a"), b = contract::tinyRun("settings_b");
  b.cache = a.cache;
  b.warmup = 2;
  // 8 frames or more after the warm-up, so that the gate can judge them (a pass or a fail).
  a.render = b.render = test::tinySettings(16, 8, 10, 2);
  runMatrix(a);
  runMatrix(b);
  const RunResults ra = loadResults(a.out), rb = loadResults(b.out);
  EXPECT_TRUE(settingsDifferences(ra, ra).empty());
  // A run from before the lag rule was recorded (settings.ghosting.lagAfterUnsettled) gates as
  // before: the rule changes event figures, never the summaries a gate compares; a gate that judges
  // the lag figures it changed refuses the two (the other event figures do not depend on it).
  json older = ra.toJson();
  older["settings"]["ghosting"].erase("lagAfterUnsettled");
  const RunResults olderRun = RunResults::fromJson(older, "older");
  EXPECT_TRUE(settingsDifferences(olderRun, ra).empty());
  EXPECT_TRUE(settingsDifferences(olderRun, ra, {{"ghosting.responseFrames", 0.02}}).empty());
  for (const char* lag : {"ghosting.lagEnergy", "ghosting.chromaLagEnergy"}) {
    const std::vector<std::string> rule = settingsDifferences(olderRun, ra, {{lag, 0.02}});
    ASSERT_EQ(rule.size(), 1u) << lag;
    EXPECT_EQ(rule[0].rfind("settings.ghosting.lagAfterUnsettled: \"absent\" vs ", 0), 0u)
        << rule[0];
  }
  // Nor does a run that cited the display curve's fit under the wrong year (the same curve); any
  // other change to the display transform is one.
  std::string display = ra.toJson()["settings"]["display"];
  ASSERT_NE(display.find("Narkowicz 2016"), std::string::npos) << display;
  json cited = ra.toJson();
  cited["settings"]["display"] = display.replace(display.find("2016"), 4, "2015");
  EXPECT_TRUE(settingsDifferences(RunResults::fromJson(cited, "cited"), ra).empty());
  cited["settings"]["display"] = "exposure 1, ACES filmic (Narkowicz 2015), clamp, sRGB";
  EXPECT_EQ(settingsDifferences(RunResults::fromJson(cited, "cited"), ra).size(), 1u);
  // A scene whose file (or assets) changed between the runs is another sequence under one name;
  // a run from before the content was recorded compares as before.
  json edited = ra.toJson();
  for (auto& [name, scene] : edited["scenes"].items()) {
    ASSERT_TRUE(scene["content"]["inputs"].is_string()) << name;
    scene["content"]["inputs"] = "0123456789ab";
  }
  const std::vector<std::string> otherScene =
      settingsDifferences(ra, RunResults::fromJson(edited, "edited"));
  ASSERT_FALSE(otherScene.empty());
  EXPECT_NE(otherScene[0].find(".content.inputs: "), std::string::npos) << otherScene[0];
  for (auto& [name, scene] : edited["scenes"].items()) scene.erase("content");
  EXPECT_TRUE(settingsDifferences(ra, RunResults::fromJson(edited, "edited")).empty());
  const std::vector<std::string> differ = settingsDifferences(ra, rb);
  ASSERT_EQ(differ.size(), 1u);
  EXPECT_EQ(differ[0], "settings.warmup: 1 vs 2");
  contract::CliResult r = contract::arenaCli("compare " + a.out.string() + " " + b.out.string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("were run with different settings"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("settings.warmup: 1 vs 2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--allow-settings-mismatch"), std::string::npos) << r.output;
  r = contract::arenaCli("compare " + a.out.string() + " " + b.out.string() + " --allow-settings-mismatch");
  EXPECT_NE(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("warning: comparing runs with different settings"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("verdict"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(r.status == 0 ? "gate: pass (" : "gate: FAIL ("), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("hold the same run"), std::string::npos) << r.output;
  // A pair the candidate lacks has no figures: "-", not "nan".
  RunConfig d = contract::tinyRun("settings_d");
  d.cache = a.cache;
  d.render = a.render;
  d.denoisers = {{"eaw", {}, ""}};
  runMatrix(d);
  r = contract::arenaCli("compare " + a.out.string() + " " + d.out.string());
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("missing"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("nan"), std::string::npos) << r.output;
  // Another resolution shows per scene.
  RunConfig c = contract::tinyRun("settings_c");
  c.render = test::tinySettings(8, 8, 10, 2);
  runMatrix(c);
  const std::vector<std::string> resolution = settingsDifferences(ra, loadResults(c.out));
  EXPECT_NE(std::find(resolution.begin(), resolution.end(), "scenes.cornell_static.width: 16 vs 8"),
            resolution.end());
  // A low-resolution buffer rendered for one run only (a contender of it reads it) is no settings
  // difference: the frames both measure are the same, the other run has no pair reading it. At
  // other settings in both runs, it is one.
  RunResults withLowres = ra, otherLowres = ra;
  json settings = ra.settings.measurement();
  settings["render"]["lowresFactor"] = 8;
  settings["render"]["lowresSpp"] = 4;
  withLowres.settings = RunSettings::fromJson(settings, "test");
  EXPECT_TRUE(settingsDifferences(ra, withLowres).empty());
  EXPECT_TRUE(settingsDifferences(withLowres, ra).empty());
  // ... unless a pair both runs have read it in one of them (reengine at disocclusionRays=auto
  // reads the buffer where there is one): then its inputs differed. A pair that does not say
  // (an older run) might have read it.
  for (const json& reads : {json(true), json()}) {
    RunResults reading = withLowres;
    if (reads.is_null())
      reading.pairs[0].detail.erase("readsLowres");
    else
      reading.pairs[0].detail["readsLowres"] = reads;
    EXPECT_EQ(settingsDifferences(ra, reading),
              (std::vector<std::string>{"settings.render.lowresFactor: \"absent\" vs 8",
                                        "settings.render.lowresSpp: \"absent\" vs 4"}))
        << reads;
  }
  // A pair that failed in either run has no numbers to compare, and records nothing of what it
  // read: no difference (the browser test's baseline read "differ" beside its failed pair).
  RunResults failed = withLowres;
  failed.pairs[0].status = "failed";
  failed.pairs[0].error = "injected";
  failed.pairs[0].detail.erase("readsLowres");
  EXPECT_TRUE(settingsDifferences(ra, failed).empty());
  EXPECT_TRUE(settingsDifferences(failed, ra).empty());
  settings["render"]["lowresFactor"] = 4;
  otherLowres.settings = RunSettings::fromJson(settings, "test");
  EXPECT_EQ(settingsDifferences(withLowres, otherLowres),
            std::vector<std::string>{"settings.render.lowresFactor: 8 vs 4"});
}

// What a CI step reads from the gate: exit 1 for a regression, 2 for what it could not judge (or
// refuses), 0 for a pass; the JSON says the same with the rows; --metric never takes the runs;
// --denoisers gates only the contenders named; a run still being written is refused.
TEST(CompareContract, ACiStepTellsARegressionFromWhatTheGateCouldNotJudge) {
  RunConfig a = contract::tinyRun("gate_a"), b = contract::tinyRun("gate_b");
  b.cache = a.cache;
  a.render = b.render = test::tinySettings(16, 8, 10, 2);  // 8 or more frames after the warm-up
  a.denoisers = b.denoisers = {{"passthrough", {}, ""}, {"eaw", {}, ""}};
  b.revision = "mydn-4f2a9c1";  // the team's own commit of what b measured
  runMatrix(a);
  runMatrix(b);
  const std::string A = a.out.string(), B = b.out.string();
  {  // b was created later (both runs may fall within one second of the clock)
    json later = json::parse(readText(b.out / "results.json"));
    later["created"] = "2999-01-01T00:00:00Z";
    writeTextAtomically(b.out / "results.json", later.dump());
  }
  contract::CliResult r = contract::arenaCli("compare --metric relMse " + A + " " + B + " --json");
  ASSERT_EQ(r.status, 0) << r.output;
  const json j = json::parse(r.output.substr(r.output.find('{')));
  EXPECT_EQ(j["gate"], "pass");
  EXPECT_EQ(j["exitCode"], 0);
  EXPECT_EQ(j["baseline"]["path"], A);
  EXPECT_EQ(j["candidate"]["name"], "gate_b");
  EXPECT_EQ(j["correction"], "holm");
  EXPECT_EQ(j["rows"].size(), 2u) << j.dump();  // relMSE of both pairs: --metric took one value
  // A comma-separated list, and the arguments swapped (the candidate is the older run): said.
  r = contract::arenaCli("compare --metric relMse,dssim " + B + " " + A);
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("is older than the baseline"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("are the two swapped?"), std::string::npos) << r.output;
  // Only the contenders named; a name neither run has is refused with the labels they have.
  r = contract::arenaCli("compare " + A + " " + B + " --metric relMse --denoisers eaw --json");
  ASSERT_EQ(r.status, 0) << r.output;
  const json only = json::parse(r.output.substr(r.output.find('{')));
  ASSERT_EQ(only["rows"].size(), 1u) << only.dump();
  EXPECT_EQ(only["rows"][0]["label"], "eaw");
  // Given empty (an unset variable in a CI script): refused, not every pair gated.
  const std::string emptyListPage = (test::freshDir("gate_empty_list") / "page").string();
  for (const std::string& args :
       {"compare " + A + " " + B, "report " + B + " --baseline " + A + " --out " + emptyListPage,
        "history " + A + " " + B + " --out " + emptyListPage}) {
    r = contract::arenaCli(args + " --denoisers ''");
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_NE(r.output.find("--denoisers '': empty; expected labels or denoiser names"),
              std::string::npos)
        << r.output;
  }
  r = contract::arenaCli("compare " + A + " " + B + " --denoisers svgf");
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--denoisers svgf: neither run has a pair of that label or denoiser "
                          "(their labels: eaw, passthrough)"),
            std::string::npos)
      << r.output;
  // A pair the candidate lost is a regression (exit 1), told apart in the JSON too.
  const fs::path lost = test::freshDir("gate_lost") / "run";
  fs::create_directories(lost);
  json results = json::parse(readText(b.out / "results.json"));
  json kept = json::array();
  for (const json& p : results["pairs"])
    if (p["label"] != "eaw") kept.push_back(p);
  results["pairs"] = kept;
  writeTextAtomically(lost / "results.json", results.dump());
  r = contract::arenaCli("compare " + A + " " + lost.string() + " --json");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_EQ(json::parse(r.output.substr(r.output.find('{')))["gate"], "regressed");
  // ... also when it is the one contender gated: missing, not "could not judge".
  r = contract::arenaCli("compare " + A + " " + lost.string() + " --denoisers eaw");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("missing"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("share no scene"), std::string::npos) << "they share it: " << r.output;
  EXPECT_FALSE(fs::exists(lost / ".arena.lock")) << "a reader leaves a run's directory as it was";
  // A run still being written (another process holds its lock) is refused, naming the writer.
  {
    const DirectoryLock writing(b.out, DirectoryLock::Mode::Exclusive,
                                DirectoryLock::IfHeld::Refuse, "writing this run");
    r = contract::arenaCli("compare " + A + " " + B);
  }
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find(B + ": another arena process (pid "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("writing this run"), std::string::npos) << r.output;
  {  // ... and so is the results.db it is appending to
    const DirectoryLock writing(b.out, DirectoryLock::Mode::Exclusive,
                                DirectoryLock::IfHeld::Refuse, "writing this run");
    r = contract::arenaCli("history " + (b.out / "results.db").string() + " --out " +
                           (test::freshDir("gate_history_locked") / "page").string());
  }
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("writing this run"), std::string::npos) << r.output;
  // Two runs of one name made in the same second are not one run when their numbers differ.
  const RunResults ra = loadResults(a.out);
  RunResults twin = ra;
  EXPECT_TRUE(sameRunRecord(ra, twin));
  twin.pairs[0].summary.begin()->second.mean *= 1.5;
  EXPECT_FALSE(sameRunRecord(ra, twin));
  // The dashboard takes the same options: --metric before the runs does not swallow them.
  const fs::path page = test::freshDir("gate_history") / "page";
  r = contract::arenaCli("history --metric relMse --denoisers eaw " + A + " " + B + " --out " +
                         page.string());
  ASSERT_EQ(r.status, 0) << r.output;
  const std::string data = readText(page / "history-data.js");
  EXPECT_NE(data.find("\"eaw\""), std::string::npos);
  EXPECT_NE(data.find("\"revision\":\"mydn-4f2a9c1\""), std::string::npos)
      << "the run's own revision";
  const json written = json::parse(readText(b.out / "results.json"));
  EXPECT_EQ(written["environment"]["revision"], "mydn-4f2a9c1");
  // --keep-frames none (tinyRun's): no image written, and none recorded.
  EXPECT_FALSE(written["pairs"][0].contains("images")) << written["pairs"][0].dump().substr(0, 300);
  EXPECT_FALSE(written["scenes"]["cornell_static"].contains("chosenFrames"));
  EXPECT_FALSE(written["scenes"]["cornell_static"].contains("images"));
  EXPECT_EQ(data.find("\"passthrough\""), std::string::npos) << "only the contenders named";
  r = contract::arenaCli("history " + A + " " + B + " --denoisers svgf --out " + page.string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("--denoisers svgf: no run has a pair of that label or denoiser"),
            std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace arena
