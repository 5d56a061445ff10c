// Intervals of the event-window figures (metrics/ghosting_intervals.hpp): coverage of a known
// synthetic lag, determinism (same seed, same interval; shards merged = one run), and the
// contract that a figure without data is absent with its reason, never a fake interval.
#include "metrics/ghosting_intervals.hpp"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <array>
#include <cmath>
#include <fstream>
#include <random>

#include "core/error.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/results.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// One synthetic event: 16 tiles of 50 mask pixels, window frames 0..35, event at t0 = 5. Tile k's
// bias after the event is A_k 0.6^(t - t0) with A_k = 0.8 (1 + 0.25 z_k) (the lag varies over the
// region), plus the tile mean of independent pixel noise (sd `noise` per tile and frame); E_M is
// 0.01 + 0.5 A_k 0.7^(t - t0) with multiplicative noise. Tiles are drawn afresh every trial.
constexpr int kTiles = 16, kFrames = 36, kT0 = 5;
constexpr double kPixels = 50;

EventTiles syntheticEvent(std::mt19937_64& rng, double noise) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<double> amplitude(kTiles);
  for (double& a : amplitude) a = 0.8 * (1 + 0.25 * n(rng));
  EventTiles e;
  for (int t = 0; t < kFrames; ++t) {
    TileSums bias, curve;
    for (int k = 0; k < kTiles; ++k) {
      const double lag = t < kT0 ? 0.0 : amplitude[size_t(k)] * std::pow(0.6, t - kT0);
      const double spike = t < kT0 ? 0.0 : 0.5 * amplitude[size_t(k)] * std::pow(0.7, t - kT0);
      bias.sum.push_back(kPixels * (lag + noise * n(rng)));
      bias.count.push_back(kPixels);
      curve.sum.push_back(kPixels * (0.01 + spike) * std::exp(0.3 * n(rng) - 0.045));
      curve.count.push_back(kPixels);
    }
    e.bias.add(t, std::move(bias));
    e.curve.add(t, std::move(curve));
  }
  return e;
}

// The figures of the noise-free population (mean amplitude 0.8, no noise): the truth.
std::map<std::string, double> truth() {
  std::vector<double> bias, curve;
  for (int t = 0; t < kFrames; ++t) {
    bias.push_back(t < kT0 ? 0.0 : 0.8 * std::pow(0.6, t - kT0));
    curve.push_back(0.01 + (t < kT0 ? 0.0 : 0.4 * std::pow(0.7, t - kT0)));
  }
  return ghostingFigures(analyseGhosting(kT0, 0, curve, bias));
}

std::vector<double> valuesOf(const MetricTiles& m) {
  return m.frameValues();
}

// Trial set: 200 independent synthetic events (fresh tiles, lag and noise), 400 replicates each.
// The 95% interval of lag energy, peak excess and signed bias must cover the noise-free figure in
// at least 93% of the trials (binomial sd at 95% over 200 trials: 1.5%), and not always (an
// interval that always covers could be uselessly wide: its mean width is printed beside the
// figure's spread over trials).
TEST(EventIntervals, CoverTheNoiseFreeFigureOfAKnownLag) {
  std::mt19937_64 rng(14);
  BootstrapConfig cfg;
  cfg.replicates = 400;
  const auto exact = truth();
  const std::vector<std::string> checked = {"lagEnergy", "peakExcess", "signedBias"};
  std::map<std::string, int> covered;
  std::map<std::string, double> width, sum, sum2;
  const int trials = 200;
  for (int trial = 0; trial < trials; ++trial) {
    const EventTiles e = syntheticEvent(rng, 0.04);
    const auto point =
        ghostingFigures(analyseGhosting(kT0, 0, valuesOf(e.curve), valuesOf(e.bias)));
    const FigureReplicates r = ghostingReplicates(kT0, e, "trial" + std::to_string(trial), cfg);
    json j;
    addFigureIntervals(j, r, point, cfg.confidence);
    for (const std::string& f : checked) {
      ASSERT_TRUE(j["ci95"].contains(f)) << j.dump();
      const double lo = j["ci95"][f][0], hi = j["ci95"][f][1];
      covered[f] += lo <= exact.at(f) && exact.at(f) <= hi;
      width[f] += (hi - lo) / trials;
      sum[f] += point.at(f) / trials;
      sum2[f] += point.at(f) * point.at(f) / trials;
    }
  }
  for (const std::string& f : checked) {
    const double sd = std::sqrt(std::max(0.0, sum2[f] - sum[f] * sum[f]));
    std::printf(
        "%-11s truth %.4f, mean estimate %.4f (sd %.4f over trials): coverage %d/%d, mean "
        "width %.4f (2 x 1.96 sd = %.4f)\n",
        f.c_str(), exact.at(f), sum[f], sd, covered[f], trials, width[f], 2 * 1.96 * sd);
    EXPECT_GE(covered[f], 186) << f;  // 93%
    EXPECT_LE(covered[f], 199) << f;
    EXPECT_LT(width[f], 2 * 2 * 1.96 * sd) << f << ": interval much wider than the spread";
  }
}

// The peak excess is a maximum over frames that hold the steady state's own, so never below 0,
// and neither is its interval: a peak in one tile of 16 (absent from a third of the replicates)
// gives a percentile interval from 0, which the small-sample widening about the median would
// push below 0; it is cut there.
TEST(EventIntervals, ThePeakExcessAndItsIntervalAreNeverNegative) {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> n(0.0, 1.0);
  EventTiles e;
  for (int t = 0; t < kFrames; ++t) {
    TileSums bias, curve;
    for (int k = 0; k < kTiles; ++k) {
      bias.sum.push_back(kPixels * 0.04 * n(rng));
      bias.count.push_back(kPixels);
      curve.sum.push_back(kPixels * (k == 0 && t == kT0 ? 1.0 : 0.01));
      curve.count.push_back(kPixels);
    }
    e.bias.add(t, std::move(bias));
    e.curve.add(t, std::move(curve));
  }
  const GhostingResult g = analyseGhosting(kT0, 0, valuesOf(e.curve), valuesOf(e.bias));
  EXPECT_NEAR(g.peakExcess, 0.99 / kTiles, 1e-9);
  const auto point = ghostingFigures(g);
  json j;
  addFigureIntervals(j, ghostingReplicates(kT0, e, "one tile"), point, 0.95);
  ASSERT_TRUE(j["ci95"].contains("peakExcess")) << j.dump();
  EXPECT_EQ(j["ci95"]["peakExcess"][0].get<double>(), 0.0) << j["ci95"].dump();
  EXPECT_GT(j["ci95"]["peakExcess"][1].get<double>(), g.peakExcess);
}

TEST(EventIntervals, SameSeedSameIntervalAnotherSeedAnother) {
  std::mt19937_64 rng(3);
  const EventTiles e = syntheticEvent(rng, 0.04);
  const auto point = ghostingFigures(analyseGhosting(kT0, 0, valuesOf(e.curve), valuesOf(e.bias)));
  auto intervals = [&](const std::string& seed) {
    json j;
    addFigureIntervals(j, ghostingReplicates(kT0, e, seed), point, 0.95);
    return j;
  };
  const json a = intervals(eventSeedName("scene", kT0)), b = intervals(eventSeedName("scene", kT0));
  EXPECT_EQ(a, b);
  EXPECT_NE(a["ci95"]["lagEnergy"], intervals(eventSeedName("other", kT0))["ci95"]["lagEnergy"]);
  // Through JSON (float32 tile sums in base64) the interval is the same to float precision.
  const EventTiles back = EventTiles::fromJson(e.toJson());
  json c;
  addFigureIntervals(c, ghostingReplicates(kT0, back, eventSeedName("scene", kT0)), point, 0.95);
  for (const char* f : {"lagEnergy", "peakExcess", "signedBias"})
    for (int i = 0; i < 2; ++i)
      EXPECT_NEAR(c["ci95"][f][i].get<double>(), a["ci95"][f][i].get<double>(),
                  1e-5 * (1 + std::abs(a["ci95"][f][i].get<double>())))
          << f;
}

TEST(EventIntervals, NoDataOrTooFewTilesIsAbsentWithAReason) {
  const auto point = ghostingFigures(GhostingResult{});
  // No tile data at all (an older run, or an event without a window).
  json none;
  addFigureIntervals(none, ghostingReplicates(kT0, EventTiles{}, "s"), point, 0.95);
  EXPECT_TRUE(none["ci95"].empty());
  for (const std::string& f : ghostingFigureNames())
    EXPECT_EQ(none["ci95Absent"].value(f, ""), "no per-tile data for this event") << f;
  // A changed region inside one tile: every replicate would repeat that tile -> no interval.
  std::mt19937_64 rng(1);
  EventTiles one = syntheticEvent(rng, 0.04);
  for (MetricTiles* m : {&one.bias, &one.curve})
    for (TileSums& row : m->rows)
      for (int k = 1; k < kTiles; ++k) row.sum[size_t(k)] = 0, row.count[size_t(k)] = 0;
  json j;
  addFigureIntervals(j, ghostingReplicates(kT0, one, "s"), point, 0.95);
  EXPECT_TRUE(j["ci95"].empty()) << j.dump();
  EXPECT_NE(j["ci95Absent"]["lagEnergy"].get<std::string>().find("1.0 effective tiles"),
            std::string::npos)
      << j.dump();
  // An empty changed region.
  for (MetricTiles* m : {&one.bias, &one.curve})
    for (TileSums& row : m->rows) row.sum[0] = 0, row.count[0] = 0;
  json empty;
  addFigureIntervals(empty, ghostingReplicates(kT0, one, "s"), point, 0.95);
  EXPECT_EQ(empty["ci95Absent"].value("lagEnergy", ""), "the changed region is empty");
  // No colour sums (results written before they were stored): the chromaticity figures are
  // absent with their reason, never borrowed; the other figures keep theirs.
  std::mt19937_64 rng2(2);
  json full;
  addFigureIntervals(full, ghostingReplicates(kT0, syntheticEvent(rng2, 0.04), "s"), point, 0.95);
  EXPECT_TRUE(full["ci95"].contains("lagEnergy"));
  for (const char* f : {"chromaLagEnergy", "chromaPre"}) {
    EXPECT_FALSE(full["ci95"].contains(f));
    EXPECT_NE(full["ci95Absent"].value(f, "").find("no per-tile colour sums"), std::string::npos)
        << full.dump();
  }
  // Inconsistent tile data is an error naming what is wrong.
  EventTiles shifted = syntheticEvent(rng2, 0.04);
  shifted.bias.frames[3] = 40;
  EXPECT_THROW(ghostingReplicates(kT0, shifted, "s"), Error);
  EXPECT_THROW(ghostingReplicates(50, syntheticEvent(rng2, 0.04), "s"), Error);
}

// A colour change at equal brightness (the changed region's second criterion, metrics.md): the
// reference turns from warm A to cool B at t0 with the same luminance. Tile k's output keeps the
// old hue for 3 frames, then its share m_k(t) of A decays as a_k 0.5^(t - t0 - 3) with
// a_k = 0.6 (1 + 0.25 z_k) (the lag varies over the region); tile brightness L_k = e^(0.3 z),
// mean 1. Noise: independent tile means of sd `noise` L_k per channel in the output, a quarter
// of it in the reference. `lag` = false: an output without lag (m = 0).
constexpr std::array<double, 3> kWarm = {1.0, 0.5, 0.25};
// Cool, scaled to the warm colour's luminance (Rec. 709 weights, core/image's luminance).
const std::array<double, 3> kCool = [] {
  const double s = luminance(1.0, 0.5, 0.25) / luminance(0.25, 0.5, 1.0);
  return std::array<double, 3>{0.25 * s, 0.5 * s, 1.0 * s};
}();

double hueShare(int t, double a, bool lag) {
  if (!lag || t < kT0) return 0.0;
  return t < kT0 + 3 ? 1.0 : a * std::pow(0.5, t - kT0 - 3);
}

std::array<double, 3> colourAt(int t, double share) {
  const auto& now = t < kT0 ? kWarm : kCool;
  std::array<double, 3> c;
  for (size_t i = 0; i < 3; ++i) c[i] = (1 - share) * now[i] + share * kWarm[i];
  return c;
}

// Adds colour sums to `e` (whose curve and bias stay as given): one output, or `outputs` outputs
// sharing the reference's tiles and noise (as the methods of one run do).
std::vector<EventTiles> withColour(std::mt19937_64& rng, const EventTiles& e, double noise,
                                   const std::vector<bool>& lags) {
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<double> amplitude(kTiles), brightness(kTiles);
  for (int k = 0; k < kTiles; ++k) {
    amplitude[size_t(k)] = 0.6 * (1 + 0.25 * n(rng));
    brightness[size_t(k)] = std::exp(0.3 * n(rng) - 0.045);
  }
  std::vector<EventTiles> out(lags.size(), e);
  for (int t = 0; t < kFrames; ++t) {
    std::vector<ColourTileSums> sums(lags.size());
    ColourTileSums reference;
    for (int k = 0; k < kTiles; ++k) {
      const double l = brightness[size_t(k)];
      const auto r = colourAt(t, 0.0);
      for (size_t c = 0; c < 3; ++c) {
        reference.reference[c].sum.push_back(kPixels * l * (r[c] + 0.25 * noise * n(rng)));
        reference.reference[c].count.push_back(kPixels);
      }
      for (size_t m = 0; m < lags.size(); ++m) {
        const auto d = colourAt(t, hueShare(t, amplitude[size_t(k)], lags[m]));
        for (size_t c = 0; c < 3; ++c) {
          sums[m].denoised[c].sum.push_back(kPixels * l * (d[c] + noise * n(rng)));
          sums[m].denoised[c].count.push_back(kPixels);
        }
      }
    }
    for (size_t m = 0; m < lags.size(); ++m) {
      sums[m].reference = reference.reference;
      out[m].addColour(t, std::move(sums[m]));
    }
  }
  return out;
}

// The run's chromaticity curve from the stored sums (all tiles).
std::vector<double> chromaOf(const EventTiles& e) {
  std::vector<double> out;
  for (size_t r = 0; r < e.bias.rows.size(); ++r) {
    std::array<double, 3> d, ref;
    for (size_t c = 0; c < 3; ++c) {
      d[c] = e.denoisedColour[c].rows[r].totalSum();
      ref[c] = e.referenceColour[c].rows[r].totalSum();
    }
    out.push_back(chromaticityErrorOfSums(d, ref));
  }
  return out;
}

GhostingResult analysed(const EventTiles& e) {
  return analyseGhosting(kT0, 0, valuesOf(e.curve), valuesOf(e.bias), chromaOf(e));
}

// Trial set: 200 independent synthetic colour events (fresh tiles, lag amplitudes, brightness and
// noise of sd 0.04), 400 replicates each. The 95% interval of the chromaticity lag energy must
// cover the noise-free figure (the population's mean colour, mean amplitude 0.6, no noise) in at
// least 93% of the trials, and not always.
TEST(EventIntervals, ChromaticityLagCoversTheNoiseFreeFigureOfAKnownHueLag) {
  std::mt19937_64 rng(41);
  BootstrapConfig cfg;
  cfg.replicates = 400;
  std::vector<double> noiseFree;
  for (int t = 0; t < kFrames; ++t)
    noiseFree.push_back(
        chromaticityErrorOfSums(colourAt(t, hueShare(t, 0.6, true)), colourAt(t, 0.0)));
  const std::vector<double> flat(kFrames, 0.0);
  const double exact = analyseGhosting(kT0, 0, flat, flat, noiseFree).chromaLagEnergy;
  // 3 frames at the full hue distance, then the decaying share (a known lag, not a fitted one).
  EXPECT_GT(exact, 3 * noiseFree[kT0]);
  int covered = 0;
  double width = 0, sum = 0, sum2 = 0;
  const int trials = 200;
  for (int trial = 0; trial < trials; ++trial) {
    const EventTiles e = withColour(rng, syntheticEvent(rng, 0.04), 0.04, {true})[0];
    const auto point = ghostingFigures(analysed(e));
    json j;
    addFigureIntervals(j, ghostingReplicates(kT0, e, "trial" + std::to_string(trial), cfg), point,
                       cfg.confidence);
    ASSERT_TRUE(j["ci95"].contains("chromaLagEnergy")) << j.dump();
    ASSERT_TRUE(j["ci95"].contains("chromaPre")) << j.dump();
    const double lo = j["ci95"]["chromaLagEnergy"][0], hi = j["ci95"]["chromaLagEnergy"][1];
    const double v = point.at("chromaLagEnergy");
    covered += lo <= exact && exact <= hi;
    width += (hi - lo) / trials;
    sum += v / trials;
    sum2 += v * v / trials;
  }
  const double sd = std::sqrt(std::max(0.0, sum2 - sum * sum));
  std::printf(
      "chromaLagEnergy truth %.4f, mean estimate %.4f (sd %.4f over trials): coverage %d/%d, "
      "mean width %.4f (2 x 1.96 sd = %.4f)\n",
      exact, sum, sd, covered, trials, width, 2 * 1.96 * sd);
  EXPECT_GE(covered, 186);  // 93%
  EXPECT_LE(covered, 199);
  EXPECT_LT(width, 2 * 2 * 1.96 * sd) << "interval much wider than the spread";
}

// Pair JSON as the run writes it (the figures the ranking reads, and the tiles).
json pairWithEvent(const std::string& label, const EventTiles& e) {
  json g = analysed(e).toJson();
  g["tiles"] = e.toJson();
  return {{"label", label}, {"scene", "s"}, {"ghosting", json::array({g})}};
}

// Two methods with the same output are tied on the chromaticity lag (paired: the same tile draws,
// a zero difference); a method without the hue lag is resolved better than both.
TEST(EventIntervals, IdenticalMethodsTieOnTheChromaticityLagALagFreeOneIsResolved) {
  std::mt19937_64 rng(8);
  const EventTiles base = syntheticEvent(rng, 0.04);
  const std::vector<EventTiles> m = withColour(rng, base, 0.04, {true, false});
  const json a = pairWithEvent("a", m[0]), b = pairWithEvent("b", m[0]),
             c = pairWithEvent("c", m[1]);
  const SceneEvents st = rankSceneEvents({{"a", &a}, {"b", &b}, {"c", &c}}, "s");
  ASSERT_EQ(st.events.size(), 1u);
  const json r = st.events[0].byFigure.at("chromaLagEnergy").toJson();
  ASSERT_EQ(r["ranking"].size(), 3u) << r.dump();
  EXPECT_EQ(r["ranking"][0]["label"], "c");
  EXPECT_EQ(r["ranking"][0]["rank"], 1);
  for (int i : {1, 2}) {
    EXPECT_EQ(r["ranking"][i]["rank"], 2) << r.dump();
    EXPECT_EQ(r["ranking"][i]["tiedWith"].size(), 1u) << r.dump();
  }
  for (const json& x : r["pairs"]) {
    const bool same = (x["a"] == "a" && x["b"] == "b") || (x["a"] == "b" && x["b"] == "a");
    EXPECT_EQ(x["resolved"].get<bool>(), !same) << x.dump();
    if (same) {
      EXPECT_EQ(x["diff"].get<double>(), 0.0);
    }
  }
  // Each method's own interval in results.json comes from the same replicates (of the stored,
  // float32 sums).
  json own;
  addFigureIntervals(
      own, ghostingReplicates(kT0, EventTiles::fromJson(m[0].toJson()), eventSeedName("s", kT0)),
      ghostingFigures(analysed(m[0])), 0.95);
  EXPECT_EQ(own["ci95"]["chromaLagEnergy"], r["ranking"][1]["ci95"]) << r.dump();
}

// Colour sums that do not match the window, and malformed colour JSON.
TEST(EventIntervals, ColourTileContract) {
  std::mt19937_64 rng(9);
  const EventTiles good = withColour(rng, syntheticEvent(rng, 0.04), 0.04, {true})[0];
  const auto point = ghostingFigures(analysed(good));
  // Colour rows for fewer frames than the window: absent with what does not match.
  EventTiles short_ = good;
  short_.referenceColour[1] = good.referenceColour[1].restrictedTo({0, 1, 2});
  json j;
  addFigureIntervals(j, ghostingReplicates(kT0, short_, "s"), point, 0.95);
  EXPECT_TRUE(j["ci95"].contains("lagEnergy"));
  EXPECT_FALSE(j["ci95"].contains("chromaLagEnergy"));
  EXPECT_EQ(j["ci95Absent"].value("chromaLagEnergy", ""),
            "the reference colour's G tile sums cover 3 frames x 16 tiles, the event's window 36 "
            "x 16: not resampled");
  // Older results: no "colour" in the tiles -> read, the chromaticity figures absent.
  json old = good.toJson();
  old.erase("colour");
  const EventTiles back = EventTiles::fromJson(old);
  EXPECT_FALSE(back.hasColour());
  EXPECT_EQ(ghostingReplicates(kT0, back, "s").absent.count("chromaLagEnergy"), 1u);
  // Round trip keeps the colour sums.
  EXPECT_TRUE(EventTiles::fromJson(good.toJson()).hasColour());
  // Malformed: the error names the field.
  auto errorOf = [](const json& tiles) {
    try {
      EventTiles::fromJson(tiles);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  json twoChannels = good.toJson();
  twoChannels["colour"]["denoised"].erase(2);
  EXPECT_EQ(errorOf(twoChannels),
            "event tile data: colour.denoised: expected an array of 3 channels' tile sums (R, G, "
            "B)");
  json badSum = good.toJson();
  badSum["colour"]["reference"][2]["sum"] = "AAAA";
  EXPECT_NE(errorOf(badSum).find("event tile data: colour.reference[2] (B): "), std::string::npos)
      << errorOf(badSum);
  json noReference = good.toJson();
  noReference["colour"].erase("reference");
  EXPECT_NE(errorOf(noReference).find("colour.reference"), std::string::npos);
}

TEST(CutIntervals, NoSteadyStateMeansNoRecoveryInterval) {
  // Cut at 4, segment to 9: the steady state would start at 10 -> recovery figures undefined,
  // the leak still has an interval.
  CutTiles c;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int t = 4; t <= 9; ++t) {
    TileSums rel, leak;
    for (int k = 0; k < kTiles; ++k) {
      rel.sum.push_back(100 * (0.01 + 0.001 * n(rng)));
      rel.count.push_back(100);
      leak.sum.push_back(0.05 * n(rng));
      leak.count.push_back(1.0);
    }
    c.relMse.add(t, std::move(rel));
    c.leak.add(t, std::move(leak));
  }
  const FigureReplicates r = cutReplicates(4, 9, c, cutSeedName("s", 4));
  std::map<std::string, double> point = {{"oldViewLeak", 0.01}};
  json j;
  addFigureIntervals(j, r, point, 0.95);
  EXPECT_TRUE(j["ci95"].contains("oldViewLeak")) << j.dump();
  EXPECT_TRUE(j["ci95Absent"].contains("atCut")) << j.dump();
  EXPECT_TRUE(j["ci95Absent"].contains("recovery1"));
}

// light_switch: temporal accumulation never settles after the light goes off at frame 12, and
// meets the switch-on at 24 still far off (|b_M| near 3). Its error after 24 never rises above
// that offset, so its lag energy read 0 and ranked first. Now it has none there, with the reason,
// and the ranking leaves it out; its figures at 12, and a method that settled, keep theirs.
TEST(EventIntervalsEndToEnd, ALagMeasuredAgainstAnEarlierLagIsNotRanked) {
  RunConfig c = contract::tinyRun("lag_on_lag");  // no baselines, no FLIP, no frames kept
  c.render = test::tinySettings(48, 27, 36, 16);
  c.scenes = {test::shippedScene("light_switch")};
  c.denoisers = {{"temporal", {}, ""}, {"asvgf", {}, ""}};
  c.warmup = 8;
  const json run = runMatrix(c);
  ASSERT_TRUE(failedPairs(run).empty());
  std::map<std::string, json> events;  // "label@frame"
  for (const json& p : run["pairs"])
    for (const json& g : p["ghosting"])
      events[p["label"].get<std::string>() + "@" + std::to_string(g["eventFrame"].get<int>())] = g;
  ASSERT_EQ(events.size(), 4u);
  const json& before = events["temporal@12"];
  EXPECT_FALSE(before["settled"].get<bool>());
  EXPECT_TRUE(before["lagEnergy"].is_number());
  const json& after = events["temporal@24"];
  EXPECT_GT(after["biasPre"].get<double>(), 0.05);
  EXPECT_TRUE(after["lagEnergy"].is_null()) << after["lagEnergy"];
  EXPECT_TRUE(after["chromaLagEnergy"].is_null());
  const std::string why = after.value("lagAbsent", "");
  EXPECT_NE(why.find("the method never settled after the event at frame 12, and |b_M| before "
                     "this one was"),
            std::string::npos)
      << why;
  EXPECT_EQ(after["ci95Absent"]["lagEnergy"], why);
  EXPECT_FALSE(after["ci95"].contains("lagEnergy"));
  // Its other figures stand: the response is still measured (never settled, here).
  EXPECT_FALSE(after["settled"].get<bool>());
  EXPECT_TRUE(after["peakExcess"].is_number());
  // A method that settled after 12 keeps its lag figures at 24.
  EXPECT_TRUE(events["asvgf@12"]["settled"].get<bool>());
  EXPECT_TRUE(events["asvgf@24"]["lagEnergy"].is_number());
  EXPECT_FALSE(events["asvgf@24"].contains("lagAbsent"));
  const json& ranked = run["statistics"]["scenes"]["light_switch"]["events"];
  ASSERT_EQ(ranked.size(), 2u);
  const json& lag = ranked[1]["byFigure"]["lagEnergy"];
  ASSERT_EQ(lag["ranking"].size(), 1u) << lag.dump().substr(0, 400);
  EXPECT_EQ(lag["ranking"][0]["label"], "asvgf");
  EXPECT_NE(lag.value("excluded", "").find("temporal: " + why), std::string::npos)
      << lag.value("excluded", "");
}

// End to end on tiny sequences with a light switched off (light_switch, frame 12) and a camera cut
// (camera_cut, frame 8): every figure has an interval or a reason, the point lies in it, the
// statistics rank each figure, results.db holds them, and two shards merged give exactly the
// unsharded run's intervals and rankings.
TEST(EventIntervalsEndToEnd, IntervalsRankingsAndShardsMergedEqualOneRun) {
  const fs::path cache = test::freshDir("event_ci_cache");
  auto run = [&](const std::string& name, int shard, int shards) {
    RunConfig c;
    c.name = "events";
    c.out = test::freshDir("event_ci_" + name);
    c.cache = cache;
    c.render = test::tinySettings(40, 24, 18, 16);
    c.scenes = {test::shippedScene("light_switch"), test::shippedScene("camera_cut")};
    c.denoisers = {{"svgf", {}, ""}};
    c.warmup = 4;
    c.flip = "none";
    c.keepFrames = "none";
    c.shardIndex = shard;
    c.shardCount = shards;
    return std::make_pair(runMatrix(c), c.out);
  };
  const auto [whole, wholeDir] = run("whole", 0, 1);
  ASSERT_TRUE(failedPairs(whole).empty());
  int events = 0, cuts = 0;
  for (const json& p : whole["pairs"]) {
    for (const json& g : p["ghosting"]) {
      ++events;
      for (const std::string& f : ghostingFigureNames())
        EXPECT_NE(g["ci95"].contains(f), g.value("ci95Absent", json::object()).contains(f))
            << p["label"] << " " << f << ": an interval or a reason, exactly one";
      ASSERT_TRUE(g["ci95"].contains("lagEnergy")) << g.value("ci95Absent", json()).dump();
      // The warm ceiling light goes off, the cool lamp stays: a change of hue in M.
      ASSERT_TRUE(g["ci95"].contains("chromaLagEnergy")) << g.value("ci95Absent", json()).dump();
      EXPECT_TRUE(g["tiles"].contains("colour"));
      const double c = g["chromaLagEnergy"], clo = g["ci95"]["chromaLagEnergy"][0],
                   chi = g["ci95"]["chromaLagEnergy"][1];
      EXPECT_TRUE(0 <= clo && clo <= chi) << clo << " " << chi;
      EXPECT_LT(chi - clo, 10 * (c + 1e-3)) << p["label"];
      EXPECT_TRUE(g.contains("tiles"));
      EXPECT_LE(g["ci95"]["lagEnergy"][0].get<double>(), g["ci95"]["lagEnergy"][1].get<double>());
      // The signed bias is a mean over the region: its interval brackets it.
      const double v = g["signedBias"], lo = g["ci95"]["signedBias"][0],
                   hi = g["ci95"]["signedBias"][1];
      EXPECT_TRUE(lo <= v && v <= hi) << p["label"] << " " << v << " [" << lo << ", " << hi << "]";
    }
    for (const json& c : p["cuts"]) {
      ++cuts;
      ASSERT_TRUE(c["ci95"].contains("oldViewLeak")) << c.dump();
      ASSERT_TRUE(c["ci95"].contains("recovery1")) << c.value("ci95Absent", json()).dump();
    }
  }
  EXPECT_EQ(events, 3);  // passthrough, temporal, svgf on light_switch
  EXPECT_EQ(cuts, 3);
  const json& st = whole["statistics"]["scenes"];
  ASSERT_EQ(st["light_switch"]["events"].size(), 1u);
  const json& lag = st["light_switch"]["events"][0]["byFigure"]["lagEnergy"];
  EXPECT_EQ(lag["totalPairs"], 3);
  EXPECT_EQ(lag["ranking"].size(), 3u);
  const json& chromaLag = st["light_switch"]["events"][0]["byFigure"]["chromaLagEnergy"];
  EXPECT_EQ(chromaLag["totalPairs"], 3) << chromaLag.dump();
  ASSERT_EQ(st["camera_cut"]["cuts"].size(), 1u);
  EXPECT_EQ(st["camera_cut"]["cuts"][0]["byFigure"]["oldViewLeak"]["totalPairs"], 3);
  // The temporal filter (history dropped at the cut, one sample) is resolved worse at cut+1 than
  // the noisy input, whose error does not move at the cut.
  bool temporalWorse = false;
  for (const json& x : st["camera_cut"]["cuts"][0]["byFigure"]["recovery1"]["pairs"])
    if ((x["a"] == "passthrough" && x["b"] == "temporal") ||
        (x["a"] == "temporal" && x["b"] == "passthrough"))
      temporalWorse =
          x["resolved"].get<bool>() && (x["a"] == "temporal") == (x["diff"].get<double>() > 0);
  EXPECT_TRUE(temporalWorse) << st["camera_cut"]["cuts"][0]["byFigure"]["recovery1"].dump();

  const auto [s0, dir0] = run("shard0", 0, 2);
  const auto [s1, dir1] = run("shard1", 1, 2);
  const json merged = mergeRuns({dir0, dir1}, test::freshDir("event_ci_merged"));
  auto byKey = [](const json& r) {
    std::map<std::string, json> out;
    for (const json& p : r["pairs"])
      out[p["scene"].get<std::string>() + "/" + p["label"].get<std::string>()] = p;
    return out;
  };
  const auto a = byKey(whole), b = byKey(merged);
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [key, p] : a) {
    for (const char* kind : {"ghosting", "cuts"})
      for (size_t k = 0; k < p[kind].size(); ++k) {
        EXPECT_EQ(p[kind][k]["ci95"], b.at(key)[kind][k]["ci95"]) << key;
        EXPECT_EQ(p[kind][k]["tiles"], b.at(key)[kind][k]["tiles"]) << key;
      }
  }
  for (const char* scene : {"light_switch", "camera_cut"})
    for (const char* kind : {"events", "cuts"})
      EXPECT_EQ(whole["statistics"]["scenes"][scene].value(kind, json()),
                merged["statistics"]["scenes"][scene].value(kind, json()))
          << scene << " " << kind;
  // Shards written before the colour sums were stored still merge: the chromaticity lag is left
  // out of the ranking with the reason, every other figure ranks as before.
  for (const fs::path& dir : {dir0, dir1}) {
    json r = loadResults(dir).toJson();
    for (json& p : r["pairs"])
      for (json& g : p["ghosting"]) g["tiles"].erase("colour");
    std::ofstream(dir / "results.json") << r.dump();
  }
  const json old = mergeRuns({dir0, dir1}, test::freshDir("event_ci_merged_old"));
  const json& oldEvent = old["statistics"]["scenes"]["light_switch"]["events"][0]["byFigure"];
  EXPECT_EQ(oldEvent["lagEnergy"], st["light_switch"]["events"][0]["byFigure"]["lagEnergy"]);
  EXPECT_TRUE(oldEvent["chromaLagEnergy"]["ranking"].empty()) << oldEvent["chromaLagEnergy"];
  EXPECT_NE(oldEvent["chromaLagEnergy"].value("excluded", "").find("no per-tile colour sums"),
            std::string::npos)
      << oldEvent["chromaLagEnergy"];
  // Shards whose event figures were measured under another ghosting definition (an older build,
  // without minFramesFromEvent) are not merged: the statistics would be recomputed under this one.
  for (const fs::path& dir : {dir0, dir1}) {
    json r = loadResults(dir).toJson();
    r["settings"]["ghosting"].erase("minFramesFromEvent");
    std::ofstream(dir / "results.json") << r.dump();
  }
  const fs::path refused = test::freshDir("event_ci_merged_other_definition");
  fs::remove_all(refused);
  const std::string e = test::errorOf([&d0 = dir0, &d1 = dir1, &refused] {
    mergeRuns({d0, d1}, refused);
  });
  EXPECT_NE(e.find("settings.ghosting differ from this build's"), std::string::npos) << e;
  EXPECT_FALSE(fs::exists(refused)) << "nothing written";
  // results.db: the figures' rankings and paired differences, named by event and figure.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open_v2((wholeDir / "results.db").c_str(), &db, SQLITE_OPEN_READONLY, nullptr),
            SQLITE_OK);
  auto count = [&](const char* sql) {
    sqlite3_stmt* s = nullptr;
    int n = -1;
    if (sqlite3_prepare_v2(db, sql, -1, &s, nullptr) == SQLITE_OK && sqlite3_step(s) == SQLITE_ROW)
      n = sqlite3_column_int(s, 0);
    sqlite3_finalize(s);
    return n;
  };
  EXPECT_EQ(count("SELECT COUNT(*) FROM rankings WHERE metric = 'ghosting@12.lagEnergy' AND ci_lo "
                  "IS NOT NULL"),
            3);
  EXPECT_EQ(count("SELECT COUNT(*) FROM paired WHERE metric = 'cut@8.oldViewLeak'"), 3);
  EXPECT_EQ(count("SELECT COUNT(*) FROM rankings WHERE metric = 'ghosting@12.chromaLagEnergy' AND "
                  "ci_lo IS NOT NULL"),
            3);
  // A method that never settled has no number of frames: NULL, as its figure is null in the JSON
  // (its rank orders it last); one that settled has its figure.
  int never = 0, settled = 0;
  for (const json& p : whole["pairs"])
    for (const json& g : p["ghosting"]) {
      const std::string where =
          "FROM rankings WHERE scene = 'light_switch' AND metric = "
          "'ghosting@12.responseFrames' AND label = '" +
          p["label"].get<std::string>() + "'";
      // A bound is NULL exactly where results.json's is null ("never"), settled or not.
      const json ci = g["ci95"].value("responseFrames", json());
      // A response is a whole number of frames, and so are its interval's bounds.
      for (const json& bound : ci.is_array() ? ci : json::array()) {
        if (bound.is_number()) {
          EXPECT_EQ(bound.get<double>(), std::round(bound.get<double>()))
              << p["label"] << " " << ci;
        }
      }
      if (ci.is_array())
        for (const char* column : {"ci_lo", "ci_hi"}) {
          const bool null = ci[std::string(column) == "ci_lo" ? 0 : 1].is_null();
          const std::string sql =
              "SELECT COUNT(*) " + where + " AND " + column + (null ? " IS NULL" : " IS NOT NULL");
          EXPECT_EQ(count(sql.c_str()), 1) << p["label"] << " " << column;
        }
      if (!g["settled"].get<bool>()) {
        ++never;
        EXPECT_EQ(count(("SELECT COUNT(*) " + where + " AND value IS NULL").c_str()), 1)
            << p["label"];
      } else {
        ++settled;
        const std::string sql = "SELECT COUNT(*) " + where +
                                " AND value = " + std::to_string(g["responseFrames"].get<int>());
        EXPECT_EQ(count(sql.c_str()), 1) << p["label"];
      }
    }
  EXPECT_GE(never, 1) << "the case this part is for: temporal does not settle in 6 frames";
  EXPECT_GE(settled, 1);
  // And every overall score, relMSE's and the other metrics' (scene "*").
  const json& overallByMetric = whole["statistics"]["overallByMetric"];
  ASSERT_FALSE(overallByMetric.empty());
  for (const auto& [metric, overall] : overallByMetric.items()) {
    ASSERT_FALSE(overall["ranking"].empty()) << metric;
    const std::string sql =
        "SELECT COUNT(*) FROM rankings WHERE scene = '*' AND metric = '" + metric + "'";
    EXPECT_EQ(count(sql.c_str()), int(overall["ranking"].size())) << metric;
    // And its pairs (log ratios of the scores), from which the ties are read.
    const size_t n = overall["ranking"].size();
    const std::string pairsSql =
        "SELECT COUNT(*) FROM paired WHERE scene = '*' AND metric = '" + metric + "'";
    EXPECT_EQ(count(pairsSql.c_str()), int(n * (n - 1) / 2)) << metric;
  }
  sqlite3_close(db);
}

}  // namespace
}  // namespace arena
