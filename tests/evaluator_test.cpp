// The evaluation stage (metrics/evaluator.hpp) and the metric registry (metrics/metric_registry.hpp):
// the results of a run are bit-identical to those the harness computed before the stage existed
// (a golden recorded from that code), every registered metric is declared completely and defined
// in docs/metrics.md, and frames from anywhere -- with or without a reference -- are scored or
// refused with a clear error.
#include "metrics/evaluator.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <limits>
#include <regex>
#include <set>
#include <sstream>

#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "metrics/metric_registry.hpp"
#include "tests/evaluator_golden.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

using nlohmann::json;

// Metrics registered after the golden was recorded: the golden cannot hold them.
const std::set<std::string> kMetricsAfterGolden = {"stabilityFine", "stabilityCoarse", "errorStabilityFine",
                                                   "errorStabilityCoarse", "dssim"};

json withoutNewMetrics(json r) {
  r.erase("metrics");  // the registry's catalogue, stored since the registry exists
  r["statistics"].erase("overallByMetric");  // overall scores on other metrics than relMSE, since then
  // The overall ranking's pairs, and the reference verdict's ratio between a scene's events, are
  // stored since 2026-12-06: the golden cannot hold them (what they are read from it holds).
  if (r["statistics"].contains("overall")) r["statistics"]["overall"].erase("pairs");
  for (auto& [name, scene] : r["scenes"].items())
    if (scene.contains("referenceQuality")) scene["referenceQuality"].erase("segments");
  // Scene warnings are stored once per scene since issue 33; the golden's scenes have none (their
  // references have fixed sample counts, their inputs are finite), and no pair lost one. Since
  // then too, the events a shorter sequence does not reach are named (light_switch's at frame 24).
  for (auto& [name, scene] : r["scenes"].items()) {
    json warnings = json::array();
    for (const json& w : scene.value("warnings", json::array()))
      if (w.get<std::string>().rfind("events beyond the sequence's", 0) != 0) warnings.push_back(w);
    EXPECT_EQ(warnings, json::array()) << name;
    scene.erase("warnings");
  }
  // A ranked new metric has its own ranking per scene (statistics.scenes.*.byMetric), hashed in
  // the golden with the others': left out before the hash, the others' stay comparable.
  if (r.contains("statistics") && r["statistics"].contains("scenes"))
    for (auto& [name, scene] : r["statistics"]["scenes"].items())
      if (scene.contains("byMetric"))
        for (const std::string& m : kMetricsAfterGolden) scene["byMetric"].erase(m);
  for (json& p : r["pairs"])
    for (const std::string& m : kMetricsAfterGolden) {
      if (p.contains("summary")) p["summary"].erase(m);
      if (p.contains("tiles")) p["tiles"].erase(m);
      if (p.contains("frames"))
        for (json& f : p["frames"]) f.erase(m);
    }
  return r;
}

// The first place two documents differ, as a JSON path (for a readable failure).
std::string firstDifference(const json& a, const json& b, const std::string& path = "$") {
  // Numbers compare by value (a parsed 0 is unsigned, a written one signed); structure by kind.
  if (a.is_number() && b.is_number()) return a == b ? "" : path + ": " + a.dump() + " vs " + b.dump();
  if (a.type() != b.type()) return path + ": " + a.dump().substr(0, 80) + " vs " + b.dump().substr(0, 80);
  if (a.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it) {
      if (!b.contains(it.key())) return path + "." + it.key() + ": missing on the right";
      const std::string d = firstDifference(it.value(), b[it.key()], path + "." + it.key());
      if (!d.empty()) return d;
    }
    for (auto it = b.begin(); it != b.end(); ++it)
      if (!a.contains(it.key())) return path + "." + it.key() + ": missing on the left";
    return "";
  }
  if (a.is_array()) {
    if (a.size() != b.size()) return path + ": " + std::to_string(a.size()) + " vs " + std::to_string(b.size()) + " items";
    for (size_t i = 0; i < a.size(); ++i) {
      const std::string d = firstDifference(a[i], b[i], path + "[" + std::to_string(i) + "]");
      if (!d.empty()) return d;
    }
    return "";
  }
  return a == b ? "" : path + ": " + a.dump() + " vs " + b.dump();
}

struct SizedValue {
  int value = 0;
  size_t size = 0;
  size_t bytes() const { return size; }
};

TEST(SceneMemo, MakesEachKeysValueOnceAndKeepsWhatFitsItsBudget) {
  // What the evaluation keeps per reference (FLIP's filtered planes) is made on first use only,
  // as long as the scene's memos have bytes left; beyond that, each use makes its own.
  auto budget = std::make_shared<SceneMemo::Budget>(100);
  SceneMemo memo(budget), other(budget);
  int made = 0;
  auto make = [&](size_t size) { return [&made, size] { return SizedValue{++made, size}; }; };
  const auto first = memo.get<SizedValue>("a", make(60));
  EXPECT_EQ(first->value, 1);
  EXPECT_EQ(memo.get<SizedValue>("a", make(60)).get(), first.get());  // kept, not made again
  EXPECT_EQ(made, 1);
  EXPECT_EQ(other.get<SizedValue>("a", make(30))->value, 2);  // another reference's memo
  EXPECT_EQ(other.get<SizedValue>("a", make(30))->value, 2);
  EXPECT_EQ(budget->left, 10u);
  // 20 bytes do not fit in the 10 left: made, used and dropped at every use.
  EXPECT_EQ(memo.get<SizedValue>("b", make(20))->value, 3);
  EXPECT_EQ(memo.get<SizedValue>("b", make(20))->value, 4);
  EXPECT_EQ(budget->left, 10u);
  // A key read as another type is a programming error, never a reinterpretation.
  struct Other {
    size_t bytes() const { return 0; }
  };
  EXPECT_THROW(memo.get<Other>("a", [] { return Other{}; }), std::logic_error);
}

TEST(Evaluation, RunResultsAreBitIdenticalToTheHarnessBeforeTheStage) {
  // tests/data/evaluation_golden.json was first written by the harness that computed every metric
  // inline (commit 5767363), from test::goldenRunConfig: the same inputs and settings must give the
  // same per-frame values, summaries, intervals, event figures, floors and rankings, bit for bit.
  // A change that is meant to alter pixels (the tracer, a denoiser's defaults) records a new golden
  // with ARENA_UPDATE_GOLDEN=1 and says so in its commit; the move of the metrics altered nothing.
  // Recorded again for tracerVersion 4 (a876255) and 5 (e0c547e: hits computed from the triangle,
  // so that the golden no longer depends on which kernels Embree picks for the CPU), and for 6
  // (references stop at the tile that meets their target: the golden's references have no target,
  // so only the sequence hashes and the last bits of the references' estimated relMSE moved, summed
  // per tile now), and for references of 4 replicates instead of 8 (4dbc5e2: other draws of the
  // same references, so every value against them moved within their noise), and for 7 (shadow rays
  // end off the emitter and sphere lights are sampled by solid angle: light_switch's sphere light
  // lit its surroundings a little more; every scene's frames and references are other draws).
  // Recorded again when a run with --keep-frames none stopped recording chosenFrames (no number
  // moved: the three scenes' chosenFrames were the only difference), and when settings.ghosting
  // recorded the lag rule after an unsettled event (lagAfterUnsettled, the only difference: no
  // event of the golden's scenes meets the rule). Recorded again when --seeds' bias2 kept its
  // tiles (its intervals, now the crossed bootstrap's, were the only numbers to move) and the
  // scenes recorded their content checksums (scenes.<s>.content, new). Recorded again when
  // passthrough's output became the frame's colour layer itself rather than its remodulated
  // signals (only passthrough's values moved, by rounding: 4e-9 relative at most). Recorded again
  // when a ranking stored the methods it left out as a list beside its text (leftOut: only the
  // two events' hashes moved, no number), and when the reference verdict marked whether its
  // segments between events meet the goal (referenceQuality.segmentsMeet, new; no number moved),
  // and when settings.display cited Narkowicz's curve under its year, 2016 (the text only), and
  // when pairs of a denoiser without history recorded it (passthrough's keepsHistory, new), and
  // when the response's interval became the whole numbers inside it (two upper bounds, 3.37 -> 3
  // and 1.12 -> 1, and the event ranking's hash moved; no other number), and when replicate
  // differences within rounding counted as none (kRoundingResolution: camera_cut's oldViewLeak
  // interval of passthrough against temporal moved its lower end in the seventh digit, no verdict
  // moved), and when the widening of the event figures' intervals centred on the mean of the two
  // middle replicates (1000, an even count) rather than the upper one, so that b - a's interval is
  // a - b's negated (every event-window interval moved, by 7.3e-4 of itself at most; the two
  // event rankings' hashes moved; no verdict of the default study moved, 8352 fields compared
  // after `arena merge runs/study` with both builds), and when intervals wrote a -0 as 0 (a
  // difference of 0 negated read "[-0, 0]": only light_switch's events hash moved, no number),
  // and when frames were resampled in circular blocks, every frame drawn equally often (every
  // interval and paired difference moved, 505 values and hashes, and statistics.method's text; no
  // rank, tie or resolved difference moved).
  const std::string file = std::string(ARENA_TEST_DATA) + "/evaluation_golden.json";
  const json now = test::goldenPart(
      withoutNewMetrics(runMatrix(test::goldenRunConfig(test::freshDir("golden_run"), test::freshDir("golden_cache")))));
  if (std::getenv("ARENA_UPDATE_GOLDEN")) std::ofstream(file) << now.dump();
  const json golden = parseJsonFile(file);
  const std::string difference = firstDifference(golden, now);
  // A metric registered since the golden was recorded is missing on the left: what to do is said
  // (re-recording the golden would hide every other change it guards).
  const bool newMetric = difference.find(": missing on the left") != std::string::npos ||
                         difference.find("byMetricHash") != std::string::npos;
  EXPECT_TRUE(difference.empty())
      << difference
      << (newMetric ? " (a metric registered after the golden was recorded, or a ranked one's "
                      "ranking: add its name to kMetricsAfterGolden in tests/evaluator_test.cpp; "
                      "docs/extending.md)"
                    : "");
  // It must be able to fail: the golden holds real numbers for every pair.
  ASSERT_EQ(golden["pairs"].size(), 15u);
  EXPECT_GT(golden["pairs"][0]["summary"]["relMse"]["mean"].get<double>(), 0.0);
}

// A contributor's slips are refused when the registry is built, not found in a test run later: a
// name declared by two families (the second's values replaced the first's in every result), a
// name that is no identifier, no description; and a family that puts another family's metric.
TEST(MetricRegistry, ARegistrySlipIsAnErrorNamingTheMetric) {
  const auto family = [](std::vector<std::string> names) {
    MetricFamily f;
    for (const std::string& n : names) f.metrics.push_back({.name = n, .description = "d"});
    return f;
  };
  EXPECT_NO_THROW(checkFamilies({family({"mae"}), family({"mse2"})}));
  EXPECT_EQ(test::errorOf([&] {
              checkFamilies({family({"mse"}), family({"mae", "mse"})});
            }),
            "metric registry: 'mse' is declared twice (each metric once, by the family that "
            "computes it)");
  EXPECT_EQ(test::errorOf([&] { checkFamilies({family({"Mae"})}); }),
            "metric registry: 'Mae' is not a name (a lower-case letter, then letters and digits)");
  EXPECT_NE(test::errorOf([&] { checkFamilies({family({"m.ae"})}); }).find("is not a name"),
            std::string::npos);
  MetricFamily silent = family({"mae"});
  silent.metrics[0].description.clear();
  EXPECT_EQ(test::errorOf([&] { checkFamilies({silent}); }),
            "metric registry: 'mae' has no description (arena metrics lists it)");
  EXPECT_NO_THROW(requireOwnMetric(family({"mae", "mse"}), "mse"));
  EXPECT_EQ(test::errorOf([&] { requireOwnMetric(family({"mae"}), "relMse"); }),
            "the metric family of mae put 'relMse', which it does not declare (a family puts "
            "only its own metrics)");
  EXPECT_NE(test::errorOf([&] {
              requireOwnMetric(family({"logLumMae"}), "logLumMAE");
            }).find("put 'logLumMAE', which it does not declare (did you mean 'logLumMae'?)"),
            std::string::npos);
  // A metric of the images is put with its tile sums (a scalar's interval resamples frames only:
  // 8x too narrow in a trial); a run fact, a declared frame scalar and an undefined value are not.
  MetricFamily four = family({"image", "fact", "scalar"});
  four.metrics[1].reads = MetricInput::Run;
  four.metrics[2].frameScalar = true;
  EXPECT_NE(test::errorOf([&] {
              requireTilesWhereDeclared(four.metrics[0], 0.5, TileSums{});
            }).find("the family that puts image put it without its tile sums"),
            std::string::npos);
  EXPECT_NO_THROW(requireTilesWhereDeclared(four.metrics[0], std::nan(""), TileSums{}));
  EXPECT_NO_THROW(requireTilesWhereDeclared(four.metrics[1], 0.5, TileSums{}));
  EXPECT_NO_THROW(requireTilesWhereDeclared(four.metrics[2], 0.5, TileSums{}));
  // A metric of the images its family never put is absent with the reason, not missing; a run fact,
  // a metric that needs the reference a scene lacks, and one the options do not compute are not.
  MetricFamily declared = family({"image", "fact", "withref", "hdr"});
  declared.metrics[1].reads = MetricInput::Run;
  declared.metrics[2].needsReference = true;
  declared.metrics[3].computedUnder = [](const MetricOptions& o) { return o.flip == "all"; };
  for (MetricDefinition& m : declared.metrics)
    if (m.name != "withref") m.needsReference = false;
  json summary = {{"fact", {{"mean", 1.0}}}};
  markUnrecorded(summary, {&declared}, MetricOptions{"ldr"}, false);
  EXPECT_EQ(summary["image"].value("absent", ""),
            "no frame recorded a value of it: its family ran and never put it (undefined on every "
            "frame, or a family that does not record what it declares)");
  EXPECT_FALSE(summary.contains("withref"));
  EXPECT_FALSE(summary.contains("hdr"));
  EXPECT_EQ(summary["fact"], json({{"mean", 1.0}}));
  markUnrecorded(summary, {&declared}, MetricOptions{"all"}, true);
  EXPECT_TRUE(summary.contains("withref") && summary.contains("hdr"));
  // The registry itself passes.
  EXPECT_NO_THROW(checkFamilies(metricFamilies()));
}

TEST(MetricRegistry, EveryMetricIsDeclaredOnceAndCompletely) {
  std::set<std::string> names;
  for (const MetricDefinition* m : metricCatalog()) {
    EXPECT_TRUE(names.insert(m->name).second) << m->name << " is registered twice";
    EXPECT_FALSE(m->description.empty()) << m->name;
    EXPECT_TRUE(std::regex_match(m->name, std::regex("[a-z][A-Za-z0-9]*"))) << m->name;
    if (m->floorWarningFactor > 0) {
      EXPECT_EQ(m->floor, FloorRule::ReferenceNoise) << m->name;
    }
    if (m->gatedByDefault) {
      EXPECT_TRUE(m->ranked) << m->name;
    }
  }
  // The report's default columns and its per-frame charts' menus are read from here too.
  std::set<ReportChart> charts;
  for (const MetricDefinition* m : metricCatalog()) {
    charts.insert(m->chart);
    if (m->chart != ReportChart::None) {
      EXPECT_FALSE(m->title.empty()) << m->name << " is charted without a title";
    }
    if (m->reportColumn) {
      EXPECT_NE(m->reads, MetricInput::Run) << m->name << ": run facts have their own columns";
    }
  }
  EXPECT_TRUE(charts.count(ReportChart::Error) && charts.count(ReportChart::Temporal));
  EXPECT_TRUE(requireMetric("relMse", "test").reportColumn);
  EXPECT_EQ(metricCatalogJson()[0]["title"], "relMSE");
  // The directions that the catalogue, compare, statistics and the report all read from here.
  EXPECT_TRUE(requireMetric("relMse", "test").lowerIsBetter());
  EXPECT_FALSE(requireMetric("ssim", "test").lowerIsBetter());
  EXPECT_FALSE(requireMetric("psnr", "test").lowerIsBetter());
  EXPECT_EQ(requireMetric("rmse", "test").transform, FrameTransform::Sqrt);
  EXPECT_EQ(requireMetric("psnr", "test").transform, FrameTransform::Psnr);
  EXPECT_FALSE(requireMetric("ms", "test").needsReference);
  try {
    requireMetric("relMSE", "compare");
    FAIL() << "an unknown metric was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown metric 'relMSE'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("relMseCorrected"), std::string::npos) << e.what();
  }
  const json catalog = metricCatalogJson();
  ASSERT_EQ(catalog.size(), metricCatalog().size());
  for (const char* field : {"name", "unit", "better", "needsReference", "reads", "transform", "floor", "ranked", "meaning"})
    EXPECT_TRUE(catalog[0].contains(field)) << field;
}

TEST(MetricRegistry, EveryRegisteredMetricIsDefinedInDocsMetrics) {
  std::ifstream file(std::string(ARENA_SOURCE_DIR) + "/docs/metrics.md");
  ASSERT_TRUE(file) << "docs/metrics.md is missing";
  std::stringstream text;
  text << file.rdbuf();
  // The page's list of every registered name, and the rest of the page, where each is defined: a
  // name only in the list is listed, not defined.
  // Line breaks and runs of spaces read as one space: a rewrapped paragraph is the same text.
  std::string all;
  for (char c : text.str()) {
    const char d = c == '\n' ? ' ' : c;
    if (!(d == ' ' && !all.empty() && all.back() == ' ')) all += d;
  }
  const std::string listStart = "(a test checks each):",
                    listEnd = "and the event and cut figures above.";
  const size_t begin = all.find(listStart), end = all.find(listEnd, begin);
  ASSERT_TRUE(begin != std::string::npos && end != std::string::npos)
      << "docs/metrics.md: the list of registered names is missing (it runs from \"" << listStart
      << "\" to \"" << listEnd << "\", under Registry fields)";
  const std::string list = all.substr(begin, end - begin);
  const std::string rest = all.substr(0, begin) + all.substr(end);
  for (const MetricDefinition* m : metricCatalog()) {
    const std::string quoted = "`" + m->name + "`";
    EXPECT_NE(rest.find(quoted), std::string::npos)
        << m->name << " is registered but docs/metrics.md does not define it (write it in "
        << "backticks in its definition, not only in the list of names)";
    EXPECT_NE(list.find(quoted), std::string::npos)
        << m->name << " is registered but missing from docs/metrics.md's list of every name";
  }
}

// A sequence of `frames` flat frames (test::planeFrame) with constant colour `value`.
EvaluationInput flatInput(int w, int h, int frames, float value, bool withReference) {
  EvaluationInput in;
  in.name = "flat";
  for (int t = 0; t < frames; ++t) {
    in.frames.push_back(test::planeFrame(w, h));
    in.frames.back().get("color").fill(value);
  }
  if (withReference) {
    LayerSet ref;
    Image color(w, h, 3), var(w, h, 3);
    color.fill(value);
    var.fill(0.0f);
    ref.set("color", color);
    ref.set("colorVar", var);
    in.references.push_back(ref);
    in.referenceOfFrame.assign(size_t(frames), 0);
    in.referenceCapped = {false};
  }
  return in;
}

TEST(Evaluation, WithoutAReferenceOnlyMetricsThatNeedNoneAreRecorded) {
  EvaluationScene scene(flatInput(16, 12, 6, 0.5f, false), {2, {"all"}, ExposureMode::PerFrame});
  PairEvaluation pair(scene);
  Image out(16, 12, 3);
  out.fill(0.5f);
  for (int t = 0; t < 6; ++t) pair.add(t, out, {.milliseconds = 1.0 + t});
  const json r = pair.finish();
  ASSERT_FALSE(r["summary"].empty());
  for (auto it = r["summary"].begin(); it != r["summary"].end(); ++it)
    EXPECT_FALSE(requireMetric(it.key(), "test").needsReference) << it.key() << " was scored without a reference";
  EXPECT_DOUBLE_EQ(r["summary"]["ms"]["mean"].get<double>(), (3.0 + 4 + 5 + 6) / 4);
  EXPECT_TRUE(scene.floors().empty());
  EXPECT_TRUE(pair.lastImages().relativeError.empty());
}

TEST(Evaluation, AnOutputEqualToTheReferenceScoresZeroErrorWithItsReferenceTerms) {
  EvaluationScene scene(flatInput(16, 12, 6, 0.25f, true), {2, {"none"}, ExposureMode::PerFrame});
  PairEvaluation pair(scene);
  Image out(16, 12, 3);
  out.fill(0.25f);
  for (int t = 0; t < 6; ++t) pair.add(t, out);
  const json r = pair.finish();
  EXPECT_EQ(r["summary"]["relMse"]["mean"].get<double>(), 0.0);
  EXPECT_EQ(r["summary"]["psnr"]["mean"].get<double>(), 100.0);  // the cap, not infinity
  EXPECT_DOUBLE_EQ(r["summary"]["ssim"]["mean"].get<double>(), 1.0);
  EXPECT_FALSE(r["summary"].contains("ldrFlip"));  // --flip none
  EXPECT_EQ(r["frames"].size(), 6u);
  EXPECT_FALSE(r["frames"][0].contains("tRmae"));  // no frame before frame 0
  EXPECT_TRUE(r["frames"][1].contains("tRmae"));
}

TEST(Evaluation, FrameDifferencesAreNotTakenAcrossACameraCut) {
  // The frame before a cut shows another view: its difference measures the cut, not flicker.
  EvaluationInput in = flatInput(16, 12, 6, 0.25f, true);
  in.events.push_back({3, EventKind::CameraCut, "", -1});
  EvaluationScene scene(std::move(in), {2, {"none"}, ExposureMode::PerFrame});
  PairEvaluation pair(scene);
  for (int t = 0; t < 6; ++t) {
    Image out(16, 12, 3);
    out.fill(t % 2 ? 0.3f : 0.2f);  // flicker on every frame
    pair.add(t, out);
  }
  const json r = pair.finish();
  for (const char* name : {"tRmae", "tPsnr", "warpedFlicker", "warpedValid"}) {
    EXPECT_FALSE(r["frames"][3].contains(name)) << name << " taken across the cut";
    EXPECT_TRUE(r["frames"][2].contains(name)) << name;
    EXPECT_TRUE(r["frames"][4].contains(name)) << name;
  }
  // Frames 2..5 after the warm-up, the cut not counted.
  EXPECT_EQ(r["summary"]["tRmae"]["frames"].get<int>(), 3);
  EXPECT_EQ(r["summary"]["warpedFlicker"]["frames"].get<int>(), 3);
  // The flicker is 0.1 against a still reference on every counted frame: |0.1| / (0 + 0.01).
  EXPECT_NEAR(r["summary"]["tRmae"]["mean"].get<double>(), 0.1 / 0.01, 1e-4);
}

TEST(Evaluation, AScreeningMeasuresTheLinearErrorsAsTheFullEvaluationDoesAndNothingElse) {
  EvaluationScene scene(flatInput(16, 12, 6, 0.25f, true), {2, {"all"}, ExposureMode::PerFrame});
  PairEvaluation full(scene), screening(scene, EvaluationScope::Screening);
  for (int t = 0; t < 6; ++t) {
    Image out(16, 12, 3);
    for (size_t i = 0; i < out.raw().size(); ++i) out.raw()[i] = 0.25f + 0.01f * float((i * 7 + size_t(t) * 3) % 11);
    const FrameFacts facts{.milliseconds = 2.0 + t, .wallMilliseconds = 3.0 + t};
    full.add(t, out, facts);
    screening.add(t, out, facts);
  }
  EXPECT_THROW(screening.lastImages(), Error);  // it keeps none: images come from the full evaluation
  const json a = full.finish(), b = screening.finish();
  ASSERT_TRUE(b["summary"].contains("relMseCorrected"));
  ASSERT_TRUE(b["summary"].contains("msWall"));  // the run's times too: the pair's timing reads them back
  EXPECT_GT(b["summary"]["relMse"]["mean"].get<double>(), 0.0);  // the outputs differ from the reference
  for (auto it = b["summary"].begin(); it != b["summary"].end(); ++it) {
    EXPECT_EQ(it.value(), a["summary"][it.key()]) << it.key();
    for (size_t t = 0; t < 6; ++t) EXPECT_EQ(b["frames"][t][it.key()], a["frames"][t][it.key()]) << it.key();
  }
  // Nothing beyond the linear errors: no display, perceptual or temporal metric, no events or cuts.
  for (const char* absent : {"ssim", "ldrFlip", "tRmae", "stabilityFine"}) {
    EXPECT_TRUE(a["summary"].contains(absent)) << absent;
    EXPECT_FALSE(b["summary"].contains(absent)) << absent;
  }
  EXPECT_FALSE(b.contains("ghosting"));
  EXPECT_FALSE(b.contains("cuts"));
}

// A scene whose references stopped at their sample cap says how many and which frames they serve;
// none capped, no warning; capped references that only warm-up frames no figure reads use (the
// study's refinement leaves those) change no number and are not said.
TEST(Evaluation, CappedReferencesAreNamedWithTheFramesTheyServe) {
  EvaluationInput in = flatInput(8, 6, 9, 0.5f, true);
  in.references.resize(5, in.references.front());
  in.referenceOfFrame = {0, 1, 2, 2, 3, 4, 4, 4, 4};
  in.referenceCapped = {true, true, false, true, false};
  EvaluationOptions early;
  early.warmup = 2;  // frames 2-8 summarised; the temporal metrics read frames 0-1 too
  const std::vector<std::string> warnings = EvaluationScene(in, early).warnings();
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("3 of 5 reference(s) stopped at the sample cap above their target "
                             "relMSE (frames 0-1, 4;"),
            std::string::npos)
      << warnings[0];
  // What to do about it: the verdict says whether it matters, and how to refine.
  EXPECT_NE(warnings[0].find("Whether that matters is the scene's reference-quality verdict"),
            std::string::npos)
      << warnings[0];
  // A capped reference no frame reads (the evaluation's input may carry one) is counted, not
  // listed.
  // With a warm-up of 8, frames 0-4 are read by no figure (the lags reach back to 5): their capped
  // references are not said, unless an event's window reaches back to them.
  EvaluationOptions late;
  late.warmup = 8;
  in.referenceCapped = {true, true, false, true, false};
  EXPECT_TRUE(EvaluationScene(in, late).warnings().empty());
  in.referenceCapped = {true, true, false, false, true};  // frames 5-8: summarised
  EXPECT_EQ(EvaluationScene(in, late).warnings().size(), 1u);
  in.referenceCapped = {true, true, false, true, false};
  in.events = {{8, EventKind::LightOff, "lamp", -1}};  // its window begins at 8 - 5 = 3
  EXPECT_EQ(EvaluationScene(in, late).warnings().size(), 1u);
  in.events = {{5, EventKind::CameraCut, "", -1}};  // the old view: frame 4
  EXPECT_EQ(EvaluationScene(in, late).warnings().size(), 1u);
  in.events.clear();
  in.referenceOfFrame = {0, 1, 1, 1, 1, 1, 1, 1, 1};
  in.referenceCapped = {false, false, true, false, false};
  const std::vector<std::string> unread = EvaluationScene(in, early).warnings();
  ASSERT_EQ(unread.size(), 1u);
  EXPECT_NE(
      unread[0].find(
          "1 of 5 reference(s) stopped at the sample cap above their target relMSE (no frame reads "
          "them;"),
      std::string::npos)
      << unread[0];
  in.referenceCapped.assign(5, false);
  EXPECT_TRUE(EvaluationScene(in, {}).warnings().empty());
}

// An output that is the reference value for value, where the input is not, scores a perfect 0 no
// denoiser computes: the pair says so (a stored output wired to the reference), and fails where
// that is every frame scored. Where the input is
// the reference too, there is nothing to say; one NaN pixel of the input leaves its error finite
// (it is measured as the denoisers read it: the NaN as 0).
TEST(Evaluation, AnOutputThatIsTheReferenceIsWarnedOf) {
  EvaluationInput in = flatInput(8, 6, 5, 0.5f, true);
  for (int t : {1, 2, 4}) in.frames[size_t(t)].get("color").fill(0.4f);  // noisy on these frames
  in.frames[2].get("color").at(3, 3, 1) = std::numeric_limits<float>::quiet_NaN();
  EvaluationScene scene(in, {0, {"relMse"}, ExposureMode::PerFrame});
  EXPECT_TRUE(std::isfinite(scene.describe()["noisyRelMse"][2].get<double>()))
      << scene.describe()["noisyRelMse"];
  PairEvaluation pair(scene);
  Image ref(8, 6, 3), off(8, 6, 3);
  ref.fill(0.5f);
  off.fill(0.45f);
  for (int t = 0; t < 5; ++t) pair.add(t, t == 4 ? off : ref);  // measured on frame 4
  const json r = pair.finish();
  ASSERT_FALSE(r["warnings"].empty());
  EXPECT_EQ(r["warnings"][0],
            "the output equals its reference value for value on frames 1-2 while the input does "
            "not: a perfect score there that no denoiser computes from its input (is the reference "
            "wired in as the output?)");
  // On every frame scored where the input differs: no measurement of a denoiser, the pair fails.
  PairEvaluation wired(scene);
  for (int t = 0; t < 5; ++t) wired.add(t, ref);
  EXPECT_NE(test::errorOf([&] { wired.finish(); })
                .find("the output equals its reference value for value on every frame scored "
                      "(frames 1-2, 4) while the input does not"),
            std::string::npos)
      << test::errorOf([&] { wired.finish(); });
  PairEvaluation near(scene);  // one value off on every frame: a measurement, however good
  ref.at(0, 0, 0) = 0.50001f;
  for (int t = 0; t < 5; ++t) near.add(t, ref);
  const json nearResults = near.finish();  // held: a loop over a temporary's member dangles
  for (const json& w : nearResults["warnings"])
    EXPECT_EQ(w.get<std::string>().find("equals its reference"), std::string::npos) << w;
}

TEST(Evaluation, FramesOutOfOrderOrOfAnotherSizeAreErrorsNamingThem) {
  EvaluationScene scene(flatInput(8, 6, 4, 0.5f, true), {});
  PairEvaluation pair(scene);
  Image out(8, 6, 3), wrong(9, 6, 3);
  pair.add(0, out);
  EXPECT_THROW(pair.add(2, out), Error);
  try {
    pair.add(1, wrong);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("9x6x3"), std::string::npos) << e.what();
  }
  try {
    pair.finish();  // frames 1..3 never arrived: no summary from half a sequence
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("1 of 4 frames"), std::string::npos) << e.what();
  }
  EvaluationInput noFrames;
  noFrames.name = "empty";
  EXPECT_THROW(EvaluationScene(noFrames, {}), Error);
}

}  // namespace
}  // namespace arena
