// What `arena study` prints (cli/printout.hpp): the summary of the default study fits on one
// screen, and a warning that concerns a scene is stored and printed once per scene, not once per
// denoiser (issue 33). These tests count lines and occurrences; they read no numbers from the text.
#include "cli/printout.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/text.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/results.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

size_t lineCount(const std::string& text) { return size_t(std::count(text.begin(), text.end(), '\n')); }

size_t occurrences(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

// A long line of the kind the harness writes (a verdict, a warning), so that wrapping is not what
// keeps the count low.
std::string sentence(const std::string& subject) {
  return subject + ": " + std::string(160, 'x');
}

// The results of a default study at its worst for the printout: every shipped scene, every
// built-in denoiser, ties, two scenes missing the reference goal and one missing it between its
// events only, a capped-reference warning on
// every scene, asset fallbacks on two, and warnings on every pair.
json worstDefaultStudy() {
  std::vector<std::string> scenes;  // the suite's scene files (loading them would need the extracted assets)
  for (const fs::directory_entry& e : fs::directory_iterator(std::string(ARENA_SOURCE_DIR) + "/scenes"))
    if (e.path().extension() == ".json") scenes.push_back(e.path().stem().string());
  std::sort(scenes.begin(), scenes.end());
  // The default study's denoisers are the built-in ones; external tests earlier in this process
  // register more (with an origin), which the default study never runs.
  std::vector<std::string> labels;
  for (const std::string& name : DenoiserRegistry::instance().names())
    if (DenoiserRegistry::instance().find(name).origin.empty()) labels.push_back(name);
  json results = {{"schema", kResultsSchemaVersion}, {"kind", "arena-run"}, {"name", "worst"},
                  {"environment", json::object()}, {"settings", json::object()},
                  {"scenes", json::object()}, {"pairs", json::array()}};
  json stScenes = json::object();
  for (size_t i = 0; i < scenes.size(); ++i) {
    const std::string& name = scenes[i];
    const bool missed = i < 2;
    results["scenes"][name] = {
        {"referenceQuality",
         {{"meets", !missed}, {"verdict", sentence(name) + (missed ? " goal NOT MET" : " goal met")}}},
        {"warnings", {sentence(name + " capped references")}}};
    if (i == 2)
      results["scenes"][name]["referenceQuality"] = {
          {"meets", true},
          {"segmentsMeet", false},
          {"verdict", sentence(name) + " segment NOT MET"}};
    if (i >= scenes.size() - 2)
      results["scenes"][name]["assets"] = {{"warnings", {"fallback a", "fallback b", "fallback c"}}};
    json ranking = json::array();
    for (size_t k = 0; k < labels.size(); ++k) {
      json tied = json::array();
      for (size_t j = 0; j < labels.size(); ++j)
        if (j != k && (j < 4) == (k < 4)) tied.push_back(labels[j]);
      ranking.push_back({{"label", labels[k]}, {"rank", k < 4 ? 1 : 5}, {"mean", 1e-3 * double(k + 1)},
                         {"ci95", {1e-3 * double(k), 1e-3 * double(k + 2)}}, {"tiedWith", tied}});
      results["pairs"].push_back({{"scene", name}, {"denoiser", labels[k]}, {"label", labels[k]}, {"status", "ok"},
                                  {"params", json::object()}, {"frames", json::array()},
                                  {"summary", {{"relMse", {{"mean", 1e-3}}}}},
                                  {"warnings", {sentence("a floor"), sentence("another floor")}}});
    }
    // The pairs the ties imply: within a group not resolved, across the groups resolved.
    json pairs = json::array();
    int resolved = 0;
    for (size_t k = 0; k < labels.size(); ++k)
      for (size_t j = k + 1; j < labels.size(); ++j) {
        const bool apart = (j < 4) != (k < 4);
        const double diff = 1e-3 * (double(k) - double(j));
        pairs.push_back({{"a", labels[k]}, {"b", labels[j]}, {"diff", diff},
                         {"ci95", apart ? json({1.5 * diff, 0.5 * diff}) : json({diff - 1e-2, diff + 1e-2})},
                         {"resolved", apart}});
        resolved += apart;
      }
    stScenes[name] = {{"metric", "relMse"}, {"ranking", ranking}, {"pairs", pairs}, {"byMetric", json::object()},
                      {"resolvedPairs", resolved}, {"totalPairs", pairs.size()}};
  }
  json overall = json::array();
  for (size_t k = 0; k < labels.size(); ++k)
    overall.push_back({{"label", labels[k]}, {"rank", int(k) + 1}, {"score", 0.1 * double(k + 1)},
                       {"ci95", {0.1 * double(k), 0.1 * double(k + 2)}}, {"tiedWith", json::array()}});
  // The other metrics' overall scores (1 - SSIM, both FLIPs and tRMAE, as the default study has
  // them), in the reverse order.
  json byMetric = json::object();
  for (const char* metric : {"dssim", "ldrFlip", "hdrFlip", "tRmae"}) {
    json ranking = json::array();
    for (size_t k = 0; k < labels.size(); ++k)
      ranking.push_back({{"label", labels[labels.size() - 1 - k]},
                         {"rank", int(k) + 1},
                         {"score", 0.2 * double(k + 1)},
                         {"ci95", {0.2 * double(k), 0.2 * double(k + 2)}},
                         {"tiedWith", json::array()}});
    byMetric[metric] = {{"normalisation", std::string("geometric mean over scenes of ") + metric +
                                              " / " + metric + "(temporal)"},
                        {"baseline", "temporal"},
                        {"ranking", ranking}};
  }
  results["statistics"] = test::statisticsBlock(
      {{"scenes", stScenes},
       {"overall",
        {{"normalisation", "geometric mean over scenes of relMse / relMse(temporal)"},
         {"baseline", "temporal"},
         {"ranking", overall}}},
       {"overallByMetric", byMetric}});
  return results;
}

TEST(StudySummary, TheDefaultStudyFitsOnOneScreen) {
  const json results = worstDefaultStudy();
  ASSERT_GE(results["scenes"].size(), 12u);  // the default suite: every scene in scenes/
  std::ostringstream out;
  cli::printStudySummary(out, test::typed(results),
                         {"runs/study/results.json", "runs/study/results.db", "report/index.html", 61});
  const std::string text = out.str();
  EXPECT_LE(lineCount(text), 60u) << text;
  // Every scene has its one line and its warning once; only the missed goals are printed.
  for (const auto& [name, scene] : results["scenes"].items()) {
    EXPECT_EQ(occurrences(text, name + " capped references"), 1u) << name;
    EXPECT_EQ(occurrences(text, "\n  " + name + " "), 1u) << name << ": its line among the scenes";
  }
  EXPECT_EQ(occurrences(text, "goal NOT MET"), 2u);
  EXPECT_EQ(occurrences(text, "goal met"), 0u);
  EXPECT_EQ(occurrences(text, "segment NOT MET"), 1u);
  EXPECT_NE(text.find("goal missed between events (met for the whole scene) on 1 scene(s)"),
            std::string::npos)
      << text;
  EXPECT_EQ(occurrences(text, "a floor"), 0u) << "the pairs' own warnings are counted, not listed";
  EXPECT_EQ(occurrences(text, "report/index.html"), 1u);
  // The full tables are longer: they are what --verbose adds.
  std::ostringstream tables;
  cli::printStudyTables(tables, test::typed(results));
  EXPECT_GT(lineCount(tables.str()), 100u);
}

// The methods still lagging where an event's window ends are named per event in the summary:
// the headline scores average the lag away (a report reader took the method first on flicker,
// which never settled after the light went off, for the 60 fps choice).
TEST(StudySummary, MethodsThatNeverSettleAfterAnEventAreNamed) {
  json results = worstDefaultStudy();
  const std::string scene = results["scenes"].begin().key();
  std::vector<std::string> lagging;
  for (json& p : results["pairs"]) {
    if (p["scene"] != scene) continue;
    const bool settled = lagging.size() >= 2;
    if (!settled) lagging.push_back(p["label"]);
    p["ghosting"] = json::array({{{"eventFrame", 12},
                                  {"kind", "light_off"},
                                  {"windowBegin", 7},
                                  {"windowEnd", 23},
                                  {"settled", settled}}});
  }
  std::ostringstream out;
  cli::printStudySummary(out, test::typed(results), {"r.json", "r.db", "index.html", 1});
  EXPECT_NE(out.str().find("never settled after a scripted event"), std::string::npos) << out.str();
  EXPECT_NE(out.str().find("  " + scene + " @12 light_off (12 frames from it): " + lagging[0] +
                           ", " + lagging[1] + "\n"),
            std::string::npos)
      << out.str();
  // Without an unsettled method, nothing.
  std::ostringstream none;
  cli::printStudySummary(none, test::typed(worstDefaultStudy()),
                         {"r.json", "r.db", "index.html", 1});
  EXPECT_EQ(none.str().find("never settled"), std::string::npos);
}

// A change that rounds to 0.0% but is not zero keeps its sign and two digits: an interval end at
// -0.03% read "-0.0%", as if it touched zero.
TEST(ComparePrintout, ChangesNearZeroKeepTheirSign) {
  EXPECT_EQ(cli::changePercentText(0.041), "+4.1%");
  EXPECT_EQ(cli::changePercentText(-0.145), "-14.5%");
  EXPECT_EQ(cli::changePercentText(-0.00031), "-0.031%");
  EXPECT_EQ(cli::changePercentText(0.0000042), "+0.00042%");
  EXPECT_EQ(cli::changePercentText(0.0), "+0.0%");
  EXPECT_EQ(cli::changePercentText(-0.0), "+0.0%");
  EXPECT_EQ(cli::changePercentText(kUndefined), "-");
}

// The cost model's times are printed with two significant digits, never in exponent form.
TEST(StudySummary, ModelTimesHaveTwoDigits) {
  EXPECT_EQ(cli::twoDigitsText(0.3412), "0.34");
  EXPECT_EQ(cli::twoDigitsText(4.237), "4.2");
  EXPECT_EQ(cli::twoDigitsText(7.009), "7");
  EXPECT_EQ(cli::twoDigitsText(9.96), "10");
  EXPECT_EQ(cli::twoDigitsText(123.4), "120");
  EXPECT_EQ(cli::twoDigitsText(1234.0), "1200");
  EXPECT_EQ(cli::twoDigitsText(0.04561), "0.046");
}

// A denoiser not resolved from the noisy input on a scene is named, and one resolved worse than it
// apart: the scene's winner line does not show either (a report reader found svgf and reblur
// tied with passthrough on light_switch only in the full tables).
TEST(StudySummary, DenoisersNotResolvedFromTheNoisyInputAreNamed) {
  json results = worstDefaultStudy();
  json& scenes = results["statistics"]["scenes"];
  const std::string first = scenes.begin().key(), second = std::next(scenes.begin()).key();
  // Everywhere but the first scene passthrough is last and resolved from every method.
  for (auto it = scenes.begin(); it != scenes.end(); ++it) {
    json& ranking = it.value()["ranking"];
    const size_t n = ranking.size();
    for (size_t k = 0; k < n; ++k) {
      ranking[k]["rank"] = int(k) + 1;
      ranking[k]["tiedWith"] = json::array();
    }
    for (size_t k = 0; k < n; ++k)
      if (ranking[k]["label"] == "passthrough" && k + 1 != n) std::swap(ranking[k], ranking[n - 1]);
    ranking[n - 1]["rank"] = int(n);
    // On the second: one method ranks below passthrough, yet its pair with it (below) resolves it
    // better: ranks need not be transitive, and the line reads the pair.
    if (it.key() == second) ranking[n - 2]["rank"] = int(n), ranking[n - 1]["rank"] = int(n) - 1;
    if (it.key() != first) continue;
    // On the first: passthrough ranks 2, tied with the methods at 1 and 3; the rest are worse.
    std::swap(ranking[1], ranking[n - 1]);
    ranking[1]["rank"] = 2;
    ranking[n - 1]["rank"] = int(n);
    ranking[1]["tiedWith"] = {ranking[0]["label"], ranking[2]["label"]};
    ranking[0]["tiedWith"] = {"passthrough"};
    ranking[2]["tiedWith"] = {"passthrough"};
  }
  // Each scene's paired differences with passthrough as its ranking now says (the line reads the
  // pair's own sign, not the rank): resolved better everywhere but on the first scene, where the
  // methods at 1 and 3 tie with it and the rest are resolved worse.
  for (auto it = scenes.begin(); it != scenes.end(); ++it) {
    const json& ranking = it.value()["ranking"];
    for (json& pair : it.value()["pairs"]) {
      if (pair["a"] != "passthrough" && pair["b"] != "passthrough") continue;
      const std::string other = pair["a"] == "passthrough" ? pair["b"] : pair["a"];
      size_t k = 0;
      while (ranking[k]["label"] != other) ++k;
      const bool onFirst = it.key() == first;
      const bool tie = onFirst && (k == 0 || k == 2), worseThanInput = onFirst && k >= 3;
      const double diff = (tie              ? 0.001
                           : worseThanInput ? 0.5
                                            : -0.5) *
                          (pair["a"] == other ? 1 : -1);
      pair["diff"] = diff;
      pair["ci95"] = tie ? json{-0.01, 0.01} : json{diff - 0.1, diff + 0.1};
      pair["resolved"] = !tie;
    }
    const json& pairs = it.value()["pairs"];
    it.value()["resolvedPairs"] = std::count_if(
        pairs.begin(), pairs.end(), [](const json& p) { return p["resolved"].get<bool>(); });
  }
  const json& r = scenes[first]["ranking"];
  std::string worse;
  for (size_t k = 3; k < r.size(); ++k)
    worse += (k > 3 ? ", " : "") + r[k]["label"].get<std::string>();
  std::ostringstream out;
  cli::printStudySummary(out, test::typed(results), {"r.json", "r.db", "index.html", 1});
  const std::string text = out.str();
  EXPECT_NE(text.find("not resolved from the noisy input (passthrough, no denoising) on relMSE: " +
                      first + ": " + r[0]["label"].get<std::string>() + ", " +
                      r[2]["label"].get<std::string>() + "\n"),
            std::string::npos)
      << text;
  EXPECT_NE(
      text.find("resolved WORSE than the noisy input on relMSE: " + first + ": " + worse + "\n"),
      std::string::npos)
      << text;
  // The other scenes, where every method is resolved better, are not named.
  for (const char* head :
       {"not resolved from the noisy input", "resolved WORSE than the noisy input"}) {
    const size_t at = text.find(head);
    ASSERT_NE(at, std::string::npos);
    const std::string line = text.substr(at, text.find('\n', at) - at);
    EXPECT_EQ(line.find(second), std::string::npos) << line;
  }
}

// The overall ranking says which contenders are not built in, and where each came from.
TEST(StudySummary, TheOverallRankingNamesTheContendersNotBuiltIn) {
  json results = worstDefaultStudy();
  const std::string label = results["statistics"]["overall"]["ranking"][0]["label"];
  for (json& p : results["pairs"])
    if (p["label"] == label) p["origin"] = "plugin /opt/team/libmine.so";
  std::ostringstream out;
  cli::printOverallRanking(out, test::typed(results));
  EXPECT_NE(out.str().find("  not built in: " + label + " (plugin /opt/team/libmine.so)\n"),
            std::string::npos)
      << out.str();
  std::ostringstream plain;
  cli::printOverallRanking(plain, test::typed(worstDefaultStudy()));
  EXPECT_EQ(plain.str().find("not built in"), std::string::npos) << plain.str();
  // The fixture's noisy input ranks first alone; tied at rank 1, it is said to share it (a rank
  // column copied into a paper would read it as a method as good as the best).
  EXPECT_NE(plain.str().find("  passthrough, the noisy input itself, ranks first: every method is "
                             "resolved worse than no denoising on these scenes and frames (its "
                             "interval [0, 0.2])\n"),
            std::string::npos)
      << plain.str();
  json tied = worstDefaultStudy();
  for (json& m : tied["statistics"]["overall"]["ranking"])
    if (m["label"] == "passthrough" || m["label"] == "temporal") {
      m["rank"] = 1;
      m["tiedWith"] = {m["label"] == "temporal" ? "passthrough" : "temporal"};
    }
  std::ostringstream input;
  cli::printOverallRanking(input, test::typed(tied));
  EXPECT_NE(input.str().find("  passthrough, the noisy input itself, shares rank 1: no method is "
                             "resolved better than no denoising on these scenes and frames (its "
                             "interval ["),
            std::string::npos)
      << input.str();
}

// A camera cut whose old-view leak is undefined for every pair (the references did not change)
// ranks no method on it; the cut's table still lists every pair's figures, unranked.
TEST(StudySummary, ACutWithNoRankedFigureStillListsItsPairs) {
  json results = worstDefaultStudy();
  const std::string scene = results["scenes"].begin().key();
  results["statistics"]["scenes"][scene]["cuts"] =
      json::array({{{"eventFrame", 8},
                    {"kind", "camera_cut"},
                    {"byFigure",
                     {{"oldViewLeak",
                       {{"metric", "oldViewLeak"},
                        {"ranking", json::array()},
                        {"pairs", json::array()},
                        {"resolvedPairs", 0},
                        {"totalPairs", 0},
                        {"excluded", "the figure itself is undefined for this event"}}}}}}});
  std::vector<std::string> labels;
  for (json& p : results["pairs"])
    if (p["scene"] == scene) {
      p["cuts"] = json::array(
          {{{"eventFrame", 8}, {"kind", "camera_cut"}, {"atCut", 2.5}, {"oldViewLeak", nullptr}}});
      labels.push_back(p["label"]);
    }
  ASSERT_GE(labels.size(), 2u);
  std::ostringstream tables;
  cli::printStudyTables(tables, test::typed(results));
  const std::string text = tables.str();
  const size_t at =
      text.find(scene + ": camera_cut at frame 8: ranked on oldViewLeak (0 of 0 pairs resolved)");
  ASSERT_NE(at, std::string::npos) << text;
  for (const std::string& label : labels)
    EXPECT_NE(text.find("  -   " + label, at), std::string::npos) << label << "\n"
                                                                  << text.substr(at, 2000);
  EXPECT_NE(text.find("not ranked: the figure itself is undefined for this event", at),
            std::string::npos);
}

// An event's methods that never settled are named beside the figures their lagging E_ss lowers.
TEST(StudySummary, MethodsThatNeverSettledAreNamedBesideTheirEventFigures) {
  json results = worstDefaultStudy();
  const std::string scene = results["scenes"].begin().key();
  results["statistics"]["scenes"][scene]["events"] = json::array({{{"eventFrame", 12},
                                                                   {"kind", "light_off"},
                                                                   {"what", "lamp"},
                                                                   {"byFigure",
                                                                    {{"lagEnergy",
                                                                      {{"metric", "lagEnergy"},
                                                                       {"ranking", json::array()},
                                                                       {"pairs", json::array()},
                                                                       {"resolvedPairs", 0},
                                                                       {"totalPairs", 0}}}}}}});
  std::vector<std::string> labels;
  for (json& p : results["pairs"])
    if (p["scene"] == scene) {
      const bool settled = !labels.empty();  // the first never settles
      p["ghosting"] = json::array({{{"eventFrame", 12},
                                    {"kind", "light_off"},
                                    {"settled", settled},
                                    {"steadyState", 0.01},
                                    {"peakExcess", 0.02},
                                    {"lagEnergy", 1.0}}});
      labels.push_back(p["label"]);
    }
  ASSERT_GE(labels.size(), 2u);
  std::ostringstream tables;
  cli::printStudyTables(tables, test::typed(results));
  const std::string text = tables.str();
  EXPECT_EQ(occurrences(text, "  never settled within the window: " + labels[0] +
                                  " (E_ss is then a median of frames still lagging"),
            1u)
      << text;
  EXPECT_EQ(text.find("never settled within the window: " + labels[0] + ", "), std::string::npos);
  EXPECT_EQ(text.find("keep(s) no history"), std::string::npos) << "nobody ranked: nothing said";
  // A method without history at rank 1 on the event's figure is said to be first by construction.
  json& lag = results["statistics"]["scenes"][scene]["events"][0]["byFigure"]["lagEnergy"];
  lag["ranking"] = json::array({{{"label", labels[1]},
                                 {"rank", 1},
                                 {"mean", 0.0},
                                 {"ci95", {0.0, 0.0}},
                                 {"tiedWith", json::array()}}});
  for (json& p : results["pairs"])
    if (p["scene"] == scene && p["label"] == labels[1]) p["keepsHistory"] = false;
  std::ostringstream first;
  cli::printStudyTables(first, test::typed(results));
  EXPECT_NE(first.str().find("  " + labels[1] + " at rank 1 keep(s) no history between frames"),
            std::string::npos)
      << first.str();
}

// Nothing is called best without something to be best among, and the order of two times is no
// rank correlation: a scene ranking one method says it was not compared; with two methods timed,
// the Spearman figure is not given (it can only be +-1).
TEST(StudySummary, ALoneMethodIsNotCalledBestAndTwoTimesGiveNoCorrelation) {
  json results = worstDefaultStudy();
  const std::string scene = results["scenes"].begin().key();
  json& st = results["statistics"]["scenes"][scene];
  const std::string lone = st["ranking"][0]["label"];
  st["ranking"] = json::array({{{"label", lone},
                                {"rank", 1},
                                {"mean", 1e-3},
                                {"ci95", {0.0, 2e-3}},
                                {"tiedWith", json::array()}}});
  st["pairs"] = json::array();
  st["resolvedPairs"] = 0;
  st["totalPairs"] = 0;
  int timed = 0;
  for (json& p : results["pairs"])
    if (p["scene"] == scene && timed < 2)
      p["timing"] = {
          {"msMedian", 1.0 + timed},
          {"clock", "cpu"},
          {"gpuPredicted",
           {{"devices", json::array({{{"device", "H200"}, {"msMedian", 0.1 * ++timed}}})}}}};
  std::ostringstream out;
  cli::printStudySummary(out, test::typed(results), {"r.json", "r.db", "index.html", 1});
  const std::string text = out.str();
  EXPECT_EQ(occurrences(text, "only " + lone + " ranked: not compared"), 1u) << text;
  EXPECT_EQ(occurrences(text, "not given for 2 methods"), 1u) << text;
  EXPECT_EQ(occurrences(text, "no interval"), 1u) << text;
  EXPECT_EQ(occurrences(text, "(1 by definition)"), 1u) << "the overall baseline (temporal)\n"
                                                        << text;
}

// The speed orders say what the CPU times are (this machine, the scenes' sizes, the load at the
// start), print two times that look alike as equal rather than ordered, and name the methods the
// cost model does not price rather than drop them silently.
TEST(StudySummary, TheSpeedOrdersSayWhatTheirTimesAre) {
  json results = worstDefaultStudy();
  results["environment"]["loadAverage"] = {2.5, 1.0, 0.5};
  for (auto& [name, info] : results["scenes"].items())
    info.update({{"width", 256}, {"height", 144}});
  const std::string scene = results["scenes"].begin().key();
  std::vector<std::string> labels;
  for (json& p : results["pairs"]) {
    if (p["scene"] != scene) {
      p["timing"] = {{"clock", "cpu"}};  // untimed elsewhere: one scene's times make the orders
      continue;
    }
    const double cpu[] = {1.0, 1.00001, 2.0};
    const size_t k = labels.size();
    labels.push_back(p["label"]);
    p["timing"] = {{"msMedian", k < 3 ? cpu[k] : 5.0}, {"clock", "cpu"}};
    if (k < 3)
      p["timing"]["gpuPredicted"] = {
          {"devices",
           json::array({{{"device", "H200"}, {"msMedian", k == 1 ? 0.105 : 0.1 * double(k + 1)}}})},
          {"orderTolerance", 0.1}};
  }
  ASSERT_GE(labels.size(), 4u);
  std::ostringstream out;
  cli::printStudySummary(out, test::typed(results), {"r.json", "r.db", "index.html", 1});
  const std::string text = out.str();
  EXPECT_NE(text.find("  CPU measured here (256x144, load 2.5 at the start): " + labels[0] +
                      " 1 = " + labels[1] + " 1 < " + labels[2] + " 2\n"),
            std::string::npos)
      << text;
  // Predicted times less than 10% apart are not ordered by the model.
  const size_t gpu = text.find("  GPU predicted, H200 1080p");
  ASSERT_NE(gpu, std::string::npos) << text;
  const std::string gpuLine = text.substr(gpu, text.find('\n', gpu) - gpu);
  EXPECT_NE(gpuLine.find(labels[0] + " 0.1 ≈ " + labels[1] + " 0.1"), std::string::npos) << gpuLine;
  EXPECT_NE(gpuLine.find(" < " + labels[2] + " 0.3"), std::string::npos) << gpuLine;
  EXPECT_NE(gpuLine.find("≈: less than 10% above the first of its group"), std::string::npos)
      << gpuLine;
  // A run whose predictions record no tolerance (before 2026-12-07) is ordered as its report is:
  // every time.
  for (json& p : results["pairs"])
    if (p["timing"].contains("gpuPredicted")) p["timing"]["gpuPredicted"].erase("orderTolerance");
  std::ostringstream older;
  cli::printStudySummary(older, test::typed(results), {"r.json", "r.db", "index.html", 1});
  EXPECT_NE(older.str().find(labels[0] + " 0.1 < " + labels[1] + " 0.1"), std::string::npos)
      << older.str();
  EXPECT_EQ(older.str().find("≈"), std::string::npos) << older.str();
  const size_t unpriced = text.find("  not in these orders (no predicted GPU time): ");
  ASSERT_NE(unpriced, std::string::npos) << text;
  const std::string line = text.substr(unpriced, text.find('\n', unpriced) - unpriced);
  EXPECT_NE(line.find(labels[3]), std::string::npos) << line;
  EXPECT_EQ(line.find(labels[0]), std::string::npos) << line;
}

// A sweep's labels carry their parameters and run longer than the label column: the column widens
// to the longest label, so every line's figures start in one column.
// The columns (in characters, not bytes) where each ranking line's interval starts, over the
// lines of `text` from the one starting with `heading` to the next blank line.
std::set<size_t> intervalColumns(const std::string& text, const std::string& heading, int& rows) {
  std::istringstream lines(text.substr(text.find(heading)));
  std::set<size_t> columns;
  rows = 0;
  std::string line;
  std::getline(lines, line);  // the heading
  for (; std::getline(lines, line) && !line.empty();) {
    if (line.rfind("  ", 0) != 0 || line.find("not ranked") != std::string::npos ||
        line.find("the noisy input itself") != std::string::npos)
      continue;
    const size_t at = std::min(line.find('['), line.find("(1 by"));
    if (at == std::string::npos) continue;
    columns.insert(displayWidth(line.substr(0, at)));
    ++rows;
  }
  return columns;
}

TEST(StudySummary, LongLabelsKeepTheRankingsColumnsAligned) {
  json results = worstDefaultStudy();
  // Longer than the 26-character column, and with a two-byte character.
  const std::string longLabel = "svgf(alphaColor=0.05,sigmaLuminance=4,sigmaNormal=128,σ=2)";
  results["statistics"]["overall"]["ranking"][1]["label"] = longLabel;
  std::ostringstream overall;
  cli::printOverallRanking(overall, test::typed(results));
  int rows = 0;
  EXPECT_EQ(intervalColumns(overall.str(), "overall:", rows).size(), 1u) << overall.str();
  EXPECT_GE(rows, 2) << overall.str();
  // A scene's ranking: its second method renamed, in the ranking and in the pairs that name it.
  const std::string scene = results["scenes"].begin().key();
  json& st = results["statistics"]["scenes"][scene];
  const std::string renamed = st["ranking"][1]["label"];
  const std::string text = st.dump();
  std::string replaced;
  for (size_t p = 0, q; p <= text.size(); p = q + renamed.size() + 2) {
    q = text.find("\"" + renamed + "\"", p);
    if (q == std::string::npos) {
      replaced += text.substr(p);
      break;
    }
    replaced += text.substr(p, q - p) + "\"" + longLabel + "\"";
  }
  st = json::parse(replaced);
  std::ostringstream tables;
  cli::printStudyTables(tables, test::typed(results));
  EXPECT_EQ(intervalColumns(tables.str(), scene + ": ", rows).size(), 1u) << tables.str();
  EXPECT_GE(rows, 2) << tables.str();
}

// A method that read extra paths is marked in the rankings, with a line saying what the mark
// means, and the columns stay aligned.
TEST(StudySummary, AMethodThatReadExtraPathsIsMarkedInTheRankings) {
  json results = worstDefaultStudy();
  results["statistics"]["overall"]["ranking"][0]["extraPathsPerPixel"] = 0.1;
  const std::string label = results["statistics"]["overall"]["ranking"][0]["label"];
  std::ostringstream overall;
  cli::printOverallRanking(overall, test::typed(results));
  EXPECT_NE(overall.str().find(label + " (+paths)"), std::string::npos) << overall.str();
  EXPECT_NE(overall.str().find("(+paths): read paths beyond the frame's 1-spp ones"),
            std::string::npos);
  int rows = 0;
  EXPECT_EQ(intervalColumns(overall.str(), "overall:", rows).size(), 1u) << overall.str();
  results["statistics"]["overall"]["ranking"][0].erase("extraPathsPerPixel");
  std::ostringstream plain;
  cli::printOverallRanking(plain, test::typed(results));
  EXPECT_EQ(plain.str().find("(+paths)"), std::string::npos) << plain.str();
}

// What a reader would otherwise take for a measured tie or a fair time: a scene's best tied with
// a method of the same output bits says so, the best that read extra paths is marked, the speed
// order gives extra paths' tracing time beside the time it orders (CPU only: the GPU model prices
// none), and a ranking that lists a method above a lower mean says why.
// A large sweep: a method tied with a hundred others names ten and counts the rest (lines of 2,800
// characters); identical outputs are grouped in the run's order, not the checksums'.
TEST(StudySummary, LargeSweepsPrintReadableTiesAndGroups) {
  RankedMethod m;
  for (const char* name :
       {"p0", "p1", "p2", "p3", "p4", "p5", "p6", "p7", "p8", "p9", "p10", "p11"})
    m.tiedWith.push_back(name);
  EXPECT_EQ(
      cli::tiedText(m),
      "tied with p0, p1, p2, p3, p4, p5, p6, p7, p8, p9 and 2 more (results.json, the report)");
  m.tiedWith.resize(10);
  EXPECT_EQ(cli::tiedText(m).find("more"), std::string::npos);
  json results = worstDefaultStudy();
  const std::string scene = results["scenes"].begin().key();
  std::vector<std::string> order;
  for (json& p : results["pairs"])
    if (p["scene"] == scene) {
      order.push_back(p["label"]);
      // Checksums sorting against the run's order: z for the first two, a for the next two.
      p["outputChecksum"] = order.size() <= 2 ? "z" : order.size() <= 4 ? "a" : p["label"];
    }
  ASSERT_GE(order.size(), 4u);
  std::ostringstream expected;
  expected << order[0] << " = " << order[1] << "; " << order[2] << " = " << order[3];
  EXPECT_EQ(cli::identicalOutputsText(test::typed(results), scene), expected.str());
}

// A metric with no value on a pair (not finite on every frame: a new metric's bug) is printed by
// the run (only relMSE's absences were); an absence already said (relMSE's own reason on that
// scene) is not repeated.
TEST(StudySummary, OtherMetricsAbsentSummariesArePrintedOnce) {
  json results = worstDefaultStudy();
  const std::string scene = results["scenes"].begin().key();
  EXPECT_TRUE(cli::otherAbsentSummaryLines(test::typed(results)).empty());
  int warned = 0;
  for (json& p : results["pairs"]) {
    p["warnings"] = json::array();
    if (p["scene"] != scene) continue;
    p["summary"]["lumMae"] = {
        {"frames", 8}, {"nonFinite", 8}, {"absent", "its value is not finite on 8 of 8 frames"}};
    if (warned++ < 2) p["warnings"] = json::array({"one", "two"});
  }
  const std::vector<std::string> lines = cli::otherAbsentSummaryLines(test::typed(results));
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].rfind(scene + ": lumMae absent in ", 0), 0u) << lines[0];
  EXPECT_NE(lines[0].find("pair(s): its value is not finite on 8 of 8 frames"), std::string::npos);
  // The same reason as relMSE's on that scene: said once, with relMSE's line.
  for (json& p : results["pairs"])
    if (p["scene"] == scene)
      p["summary"]["relMse"] = {
          {"frames", 8}, {"nonFinite", 8}, {"absent", "its value is not finite on 8 of 8 frames"}};
  EXPECT_TRUE(cli::otherAbsentSummaryLines(test::typed(results)).empty());
  const cli::PairWarningCount w = cli::countPairWarnings(test::typed(results));
  EXPECT_EQ(w.warnings, 4u);
  EXPECT_EQ(w.pairs, 2u);
}

TEST(StudySummary, IdenticalOutputsExtraPathsAndRanksAboveALowerMeanAreSaid) {
  json results = worstDefaultStudy();
  const std::string scene = results["scenes"].begin().key();
  json& st = results["statistics"]["scenes"][scene];
  const std::string best = st["ranking"][0]["label"], second = st["ranking"][1]["label"];
  st["ranking"][0]["extraPathsPerPixel"] = 0.1;
  int timed = 0;
  for (json& p : results["pairs"]) {
    if (p["scene"] != scene) continue;
    if (p["label"] == best || p["label"] == second) p["outputChecksum"] = "abc";
    if (timed < 3) {
      p["timing"] = {
          {"msMedian", 1.0 + timed},
          {"clock", "cpu"},
          {"gpuPredicted",
           {{"devices", json::array({{{"device", "H200"}, {"msMedian", 0.1 * (1 + timed)}}})}}}};
      if (p["label"] == best) p["summary"]["tracingMs"] = {{"mean", 2.5}, {"median", 2.0}};
      ++timed;
    }
  }
  std::ostringstream out;
  cli::printStudySummary(out, test::typed(results), {"r.json", "r.db", "index.html", 1});
  const std::string text = out.str();
  EXPECT_NE(text.find(best + " (+paths) 0.001 "), std::string::npos) << text;
  EXPECT_EQ(occurrences(text, "; identical outputs: " + best + " = " + second + "\n"), 1u) << text;
  EXPECT_NE(text.find(best + " 1 (+paths: 2 tracing)"), std::string::npos) << text;
  EXPECT_NE(text.find(best + " 0.1 (+paths)"), std::string::npos) << text;
  EXPECT_EQ(occurrences(text, "(+paths: T tracing): read paths beyond"), 1u) << text;
  EXPECT_EQ(cli::identicalOutputsText(test::typed(results), "no such scene"), "");
  // Ranked above a lower mean: the method ranked 1 with the higher mean.
  std::swap(st["ranking"][0]["mean"], st["ranking"][5]["mean"]);
  std::ostringstream tables;
  cli::printStudyTables(tables, test::typed(results));
  EXPECT_EQ(occurrences(tables.str(), "a method above one with a lower mean has fewer methods"), 1u)
      << tables.str();
  EXPECT_EQ(occurrences(tables.str(),
                        "identical outputs (bit for bit, every frame): " + best + " = " + second),
            1u);
}

// The overall scores on the other metrics (1 - SSIM, the FLIPs) are printed beside relMSE's: a row
// per method in relMSE's order, each metric's rank (ties "=") and score; a method a metric did not
// rank is "-"; another baseline and another exclusion are said. The study's summary names each
// metric's first (the full table is --verbose's).
TEST(StudySummary, TheOtherMetricsOverallScoresArePrintedBesideRelMses) {
  json results = worstDefaultStudy();
  json& byMetric = results["statistics"]["overallByMetric"];
  const std::string second = results["statistics"]["overall"]["ranking"][1]["label"];
  json& ldr = byMetric["ldrFlip"]["ranking"];
  ldr[0]["tiedWith"] = {ldr[1]["label"]};
  ldr[1]["tiedWith"] = {ldr[0]["label"]};
  ldr[1]["rank"] = 1;
  const std::string ldrFirsts =
      ldr[0]["label"].get<std::string>() + ", " + ldr[1]["label"].get<std::string>();
  json& hdr = byMetric["hdrFlip"];
  for (size_t k = 0; k < hdr["ranking"].size(); ++k)
    if (hdr["ranking"][k]["label"] == second) hdr["ranking"].erase(k);
  hdr["excluded"] = second + ": no HDR-FLIP on every scene";
  hdr["baseline"] = "eaw";
  std::ostringstream out;
  cli::printOtherOverallScores(out, test::typed(results));
  const std::string text = out.str();
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  ASSERT_GE(lines.size(), 4u) << text;
  EXPECT_NE(lines[1].find("overall on the other metrics"), std::string::npos) << text;
  // The header names the metrics in order; the rows follow relMSE's ranking.
  EXPECT_LT(lines[2].find("dssim"), lines[2].find("hdrFlip")) << text;
  EXPECT_LT(lines[2].find("hdrFlip"), lines[2].find("ldrFlip")) << text;
  const size_t n = results["statistics"]["overall"]["ranking"].size();
  ASSERT_GE(lines.size(), 3 + n);
  for (size_t k = 0; k < n; ++k)
    EXPECT_EQ(
        lines[3 + k].rfind(
            "  " + results["statistics"]["overall"]["ranking"][k]["label"].get<std::string>() + " ",
            0),
        0u)
        << lines[3 + k];
  // The first row (relMSE's best) is last on every metric here: rank n, score 0.2 n.
  EXPECT_NE(lines[3].find(cli::figureText(0.2 * double(n))), std::string::npos) << lines[3];
  EXPECT_EQ(occurrences(lines[4], " -"), 1u) << "the second is not ranked on hdrFlip: " << lines[4];
  EXPECT_EQ(occurrences(text, "1= "), 2u) << "a tie is marked on both methods: " << text;
  EXPECT_EQ(occurrences(text, "hdrFlip: relative to eaw"), 1u) << text;
  EXPECT_EQ(occurrences(text, "not ranked overall on hdrFlip: " + second + ": no HDR-FLIP"), 1u)
      << text;
  EXPECT_EQ(occurrences(text, "ldrFlip: relative to"), 0u) << text;
  // The summary: one line, each metric's rank 1.
  std::ostringstream summary;
  cli::printStudySummary(summary, test::typed(results), {"r.json", "r.db", "index.html", 1});
  const std::string dssimFirst = byMetric["dssim"]["ranking"][0]["label"];
  EXPECT_EQ(occurrences(summary.str(),
                        "rank 1 overall on the other metrics: dssim " + dssimFirst + "; hdrFlip "),
            1u)
      << summary.str();
  // A temporal metric is named for what it measures.
  const std::string tRmaeFirst = byMetric["tRmae"]["ranking"][0]["label"];
  EXPECT_NE(summary.str().find("; ldrFlip " + ldrFirsts + "; tRmae (flicker) " + tRmaeFirst +
                               " (--verbose"),
            std::string::npos)
      << summary.str();
  std::ostringstream tables;
  cli::printStudyTables(tables, test::typed(results));
  EXPECT_EQ(occurrences(tables.str(), "overall on the other metrics"), 1u);
  // Without them, nothing.
  results["statistics"].erase("overallByMetric");
  std::ostringstream none;
  cli::printOtherOverallScores(none, test::typed(results));
  EXPECT_EQ(none.str(), "");
  EXPECT_EQ(cli::otherOverallFirstsText(test::typed(results)), "");
}

// A scene whose references stopped at their sample cap: the warning is the scene's, stored once in
// results.scenes.<scene>.warnings (not on each of its pairs) and printed once.
TEST(StudySummary, AWarningAboutASceneIsStoredAndPrintedOncePerScene) {
  RunConfig c;
  c.name = "capped";
  c.out = test::freshDir("printout_capped_run");
  c.cache = test::freshDir("printout_capped_cache");
  c.render = test::tinySettings(24, 16, 3, 8);
  c.render.referenceMinSpp = 8;
  c.render.referenceSpp = 16;
  c.render.referenceRelError = 1e-5;  // unreachable at 16 spp: every reference is capped
  c.scenes = {test::shippedScene("cornell_static")};
  c.denoisers = {{"eaw", {}, ""}, {"svgf", {}, ""}};  // with the two baselines: four pairs
  c.warmup = 1;
  c.flip = "none";
  c.keepFrames = "none";
  const json results = runMatrix(c);
  ASSERT_EQ(results["pairs"].size(), 4u);
  const json sceneWarnings = results["scenes"]["cornell_static"]["warnings"];
  // The capped references, and the two frames after the warm-up (kept with the results too).
  ASSERT_EQ(sceneWarnings.size(), 2u) << sceneWarnings;
  const std::string warning = sceneWarnings[0];
  EXPECT_NE(warning.find("stopped at the sample cap"), std::string::npos) << warning;
  EXPECT_EQ(sceneWarnings[1].get<std::string>().rfind("only 2 frames follow the warm-up of 1", 0),
            0u)
      << sceneWarnings;
  for (const json& p : results["pairs"])
    for (const json& w : p.value("warnings", json::array()))
      EXPECT_EQ(w.get<std::string>().find("sample cap"), std::string::npos) << p["label"] << ": " << w;
  std::ostringstream out;
  cli::printStudySummary(out, test::typed(results), {"r.json", "r.db", "index.html", 1});
  EXPECT_EQ(occurrences(out.str(), warning), 1u) << out.str();

  // The speed axis's predicted GPU time (issue 31): every built-in that counted traffic carries one
  // per device; svgf runs temporal's accumulation and five à-trous iterations more, so it costs
  // more; passthrough counts nothing and has none. The summary prints both orders.
  std::map<std::string, double> titan;
  for (const json& p : results["pairs"]) {
    const json timing = p["timing"];
    if (p["label"] == "passthrough") {
      EXPECT_FALSE(timing.contains("gpuPredicted"));
      continue;
    }
    ASSERT_TRUE(timing.contains("gpuPredicted")) << p["label"];
    EXPECT_EQ(timing["gpuPredicted"]["resolution"], json({1920, 1080}));
    EXPECT_EQ(timing["gpuPredicted"]["devices"][0]["device"], "TITAN RTX");
    titan[p["label"]] = timing["gpuPredicted"]["devices"][0]["msMedian"].get<double>();
  }
  EXPECT_GT(titan["temporal"], 0.0);
  EXPECT_GT(titan["svgf"], titan["temporal"]);
  // The methods that carry nothing between frames are recorded as such (the report marks none of
  // their event figures best); the others say nothing.
  for (const json& p : results["pairs"])
    EXPECT_EQ(p.value("keepsHistory", true), p["label"] != "passthrough" && p["label"] != "eaw")
        << p["label"];
  // results.db holds them too, a row per pair and device (README: every number).
  int devices = 0;
  for (const json& p : results["pairs"])
    if (p["timing"].contains("gpuPredicted"))
      devices += int(p["timing"]["gpuPredicted"]["devices"].size());
  EXPECT_GT(devices, 0);
  EXPECT_EQ(test::countRows(c.out / "results.db", "gpu_predicted"), devices);
  EXPECT_DOUBLE_EQ(test::queryNumber(c.out / "results.db",
                                     "SELECT ms_median FROM gpu_predicted WHERE label = 'svgf' AND "
                                     "device = 'TITAN RTX' AND width = 1920 AND height = 1080"),
                   titan["svgf"]);
  EXPECT_GT(test::queryNumber(c.out / "results.db",
                              "SELECT working_set_mib FROM gpu_predicted WHERE label = 'svgf'"),
            0.0);
  // At this tiny size the scaled footprint skips à-trous iterations a 1080p frame runs: the
  // prediction prices them as that frame's and records how many (the report says so under the
  // GPU axis).
  for (const json& p : results["pairs"]) {
    if (p["label"] == "svgf") {
      EXPECT_GT(p["timing"]["gpuPredicted"].value("skippedHere", 0), 0)
          << p["timing"]["gpuPredicted"];
    } else if (p["label"] == "temporal") {
      EXPECT_FALSE(p["timing"]["gpuPredicted"].contains("skippedHere"));
    }
  }
  // A model's times, with two digits and what they are for.
  EXPECT_NE(
      out.str().find("GPU predicted, TITAN RTX 1080p (a model, 2 digits: it misses its validation "
                     "goal, so read an order of magnitude and an order of methods, not a budget"),
      std::string::npos)
      << out.str();
  char temporal[32];
  std::snprintf(temporal, sizeof temporal, "%.2g", titan["temporal"]);
  EXPECT_NE(out.str().find("): temporal " + std::string(temporal) + " < "), std::string::npos)
      << out.str();
}

}  // namespace
}  // namespace arena
