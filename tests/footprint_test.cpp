// Issue 15, item 1: one footprint policy for every denoiser. The 90%-energy radius of each
// denoiser's impulse response keeps its ratio to SVGF's between 256x144 and 1280x720, under the
// default (scaled) and the native policy; the policy is a recorded parameter of every variant.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "denoisers/common/footprint.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

using Params = std::map<std::string, std::string>;

// Every registered built-in variant that filters in space: all but the two baselines, which read
// one pixel (issue 34: a variant added without a footprint parameter fails both tests below).
std::vector<std::string> spatialVariants() {
  std::vector<std::string> names;
  for (const std::string& name : DenoiserRegistry::instance().names())
    if (name != "passthrough" && name != "temporal" &&
        DenoiserRegistry::instance().find(name).origin.empty())
      names.push_back(name);
  return names;
}

// ---------------------------------------------------------------------------------------------
// 1. Footprints

TEST(FidelityFootprint, AtrousStepsFollowTheScale) {
  for (int i = 0; i < 6; ++i) EXPECT_EQ(atrousStep(i, 1.0f), 1 << i);
  // 256x144 against 1080: s = 0.133; steps 0.13 -> 1 (the first never vanishes), 0.27 -> 0
  // (skipped), 0.53 -> 1, 1.07 -> 1, 2.13 -> 2.
  const float s = 144.0f / 1080.0f;
  const int expected[5] = {1, 0, 1, 1, 2};
  double variance = 0, target = 0;
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(atrousStep(i, s), expected[i]) << i;
    variance += double(atrousStep(i, s)) * atrousStep(i, s);
    target += std::pow(double(s) * std::ldexp(1.0, i), 2.0);
  }
  // The cascade's spread (sum of squared steps) within 20 % of the scaled one.
  EXPECT_NEAR(std::sqrt(variance / target), 1.0, 0.2);
  Footprint f = footprintParams().defaults();  // the default policy: scaled (footprint.cpp)
  EXPECT_EQ(f.policy, FootprintPolicy::Scaled);
  EXPECT_FLOAT_EQ(f.scale(720), 720.0f / 1080.0f);
  f.policy = FootprintPolicy::Native;
  EXPECT_EQ(f.scale(144), 1.0f);
}

// The radius around the impulse holding 90 % of the output's (non-negative) energy.
double energyRadius90(const Image& out, int cx, int cy) {
  std::vector<std::pair<double, double>> byDistance;  // (distance, value)
  double total = 0;
  for (int y = 0; y < out.height(); ++y)
    for (int x = 0; x < out.width(); ++x) {
      const double v = std::max(0.0f, out.at(x, y, 0));
      if (v == 0) continue;
      byDistance.push_back({std::hypot(double(x - cx), double(y - cy)), v});
      total += v;
    }
  std::sort(byDistance.begin(), byDistance.end());
  double sum = 0;
  for (const auto& [d, v] : byDistance) {
    sum += v;
    if (sum >= 0.9 * total) return d;
  }
  return byDistance.empty() ? 0.0 : byDistance.back().first;
}

// Frame 0 (no history: the spatial filter alone) of a unit impulse at the centre of a flat plane
// that spans the same world width at every resolution. The data-dependent terms are off
// (luminance, colour, the hybrid's median, ReBLUR's anti-firefly: each would treat the impulse as
// a firefly), so the response is the filter's geometric footprint.
double impulseRadius(const std::string& name, const std::string& policy, int w, int h) {
  Params params = {{"footprint", policy}};
  if (name == "svgf" || name == "asvgf" || name == "slgf") params["edge.luminance"] = "false";
  // The position terms measure world distance, which a pixel policy does not touch: off too.
  if (name == "eaw") {
    params["edge.color"] = "false";
    params["edge.position"] = "false";
  }
  if (name == "hybrid") {
    params["edge.luminance"] = "false";
    params["edge.position"] = "false";
    params["median"] = "false";
  }
  if (name == "reblur") params["antiFirefly"] = "false";
  if (name == "reengine") {
    // Geometry only: no firefly clamp, a fixed large-scale share, no luminance term.
    params["deflicker"] = "false";
    params["varianceCheck"] = "false";
    params["spatialFilter"] = "false";
    params["disocclusionRays"] = "off";
  }
  auto denoiser = test::createDenoiser(name, params);
  denoiser->setup(w, h);
  const LayerSet frame = test::planeFrame(w, h, 2.56f / float(w));
  Image signal(w, h, 3), output(w, h, 3);
  const int cx = w / 2, cy = h / 2;
  for (int c = 0; c < 3; ++c) signal.at(cx, cy, c) = 1.0f;
  denoiser->denoise(test::stillCameraContext(0, w, h), {signal, frame, nullptr}, output);
  return energyRadius90(output, cx, cy);
}

TEST(FidelityFootprint, ImpulseRadiiKeepTheirRatioToSvgfAcrossResolutions) {
  const std::vector<std::string> names = spatialVariants();
  ASSERT_GE(names.size(), 7u);  // eaw, svgf, asvgf, slgf, reblur, hybrid, reengine
  for (const std::string policy : {"native", "scaled"}) {
    std::map<std::string, double> small, large;
    for (const std::string& name : names) {
      small[name] = impulseRadius(name, policy, 256, 144);
      large[name] = impulseRadius(name, policy, 1280, 720);
    }
    for (const std::string& name : names) {
      const double ratioSmall = small[name] / small["svgf"];
      const double ratioLarge = large[name] / large["svgf"];
      std::printf(
          "%s %-7s r90 %6.2f px at 256x144, %6.2f px at 1280x720; ratio to svgf %.3f vs %.3f\n",
          policy.c_str(), name.c_str(), small[name], large[name], ratioSmall, ratioLarge);
      // Before the policy ReBLUR alone scaled by height / 1080: its ratio moved 5x. A footprint
      // that scales below ~2 px cannot shrink further (taps are whole pixels and the first
      // à-trous iteration always runs): the hybrid's 3x3 cascade, 7 px at 1080 lines, would be
      // 1.1 px at 144 -- it stays at its one-step minimum there instead.
      const double expectedSmall = large[name] * 144.0 / 720.0;
      if (policy == "scaled" && expectedSmall < 2.0) {
        EXPECT_LE(small[name], 3.0) << name;
        continue;
      }
      EXPECT_NEAR(ratioSmall / ratioLarge, 1.0, 0.25) << policy << " " << name;
    }
    if (policy == "native") {
      EXPECT_NEAR(small["svgf"] / large["svgf"], 1.0, 0.1);  // pixel footprints at any size
    } else {
      EXPECT_NEAR(large["svgf"] / small["svgf"], 5.0, 1.0);  // the resolution ratio
      EXPECT_NEAR(large["reblur"] / small["reblur"], 5.0, 1.0);
    }
  }
}

TEST(FidelityFootprint, PolicyIsRecordedInEverySpatialVariantsParameters) {
  for (const std::string& name : spatialVariants()) {
    ASSERT_NO_THROW(
        DenoiserRegistry::instance().find(name).schema.resolve({{"footprint", "native"}}, name))
        << name << " has no footprint parameter";
    const ParamSet p = DenoiserRegistry::instance().find(name).schema.resolve({}, name);
    EXPECT_EQ(p.getChoice("footprint"), "scaled") << name;  // the default (footprint.hpp)
    EXPECT_EQ(p.getFloat("footprintHeight"), 1080.0f) << name;
    EXPECT_THROW(
        DenoiserRegistry::instance().find(name).schema.resolve({{"footprint", "wide"}}, name),
        Error);
  }
}

}  // namespace
}  // namespace arena
