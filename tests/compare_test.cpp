// metrics/compare: runs of other settings are compared only when asked, and then say which differ.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "harness/run_matrix.hpp"
#include "metrics/compare.hpp"
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
  runMatrix(a);
  runMatrix(b);
  const RunResults ra = loadResults(a.out), rb = loadResults(b.out);
  EXPECT_TRUE(settingsDifferences(ra, ra).empty());
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
  d.denoisers = {{"eaw", {}, ""}};
  runMatrix(d);
  r = contract::arenaCli("compare " + a.out.string() + " " + d.out.string());
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("missing"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("nan"), std::string::npos) << r.output;
  // Another resolution shows per scene.
  RunConfig c = contract::tinyRun("settings_c");
  c.render = test::tinySettings(8, 8, 3, 2);
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
  settings["render"]["lowresFactor"] = 4;
  otherLowres.settings = RunSettings::fromJson(settings, "test");
  EXPECT_EQ(settingsDifferences(withLowres, otherLowres),
            std::vector<std::string>{"settings.render.lowresFactor: 8 vs 4"});
}

}  // namespace
}  // namespace arena
