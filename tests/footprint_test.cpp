// Issue 15, item 1: one footprint policy for every denoiser. The 90%-energy radius of each
// denoiser's impulse response keeps its ratio to SVGF's between 256x144 and 1280x720, under the
// default (scaled) and the native policy; the policy is a recorded parameter of every variant.
#include "denoisers/common/footprint.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/image.hpp"
#include "denoisers/common/atrous.hpp"
#include "harness/denoise_run.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"
#include "tracer/scene.hpp"

namespace arena {
namespace {

using Params = std::map<std::string, std::string>;

bool hasFootprint(const std::string& name) {
  return DenoiserRegistry::instance().find(name).schema.find("footprint") != nullptr;
}

// Every registered built-in variant that takes the footprint policy (docs/extending.md: every one
// that reads neighbouring pixels; Footprint.AVariantWithoutAFootprintReadsOnePixel checks the
// others read one: issue 34's variant added without a footprint parameter fails there).
std::vector<std::string> spatialVariants() {
  std::vector<std::string> names;
  for (const std::string& name : DenoiserRegistry::instance().names())
    if (DenoiserRegistry::instance().find(name).origin.empty() && hasFootprint(name))
      names.push_back(name);
  return names;
}

// The built-ins without a footprint parameter (the one-pixel baselines, a contributor's per-pixel
// variant).
std::vector<std::string> onePixelVariants() {
  std::vector<std::string> names;
  for (const std::string& name : DenoiserRegistry::instance().names())
    if (DenoiserRegistry::instance().find(name).origin.empty() && !hasFootprint(name))
      names.push_back(name);
  return names;
}

// ---------------------------------------------------------------------------------------------
// 1. Footprints

TEST(Footprint, AtrousStepsFollowTheScale) {
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
  // A skipped iteration is a copy: its pass counts no taps (the bench printed 25 taps per pixel
  // for passes that did nothing, and the GPU model priced them).
  AtrousSettings atrous;
  atrous.footprintScale = s;
  const int taps[5] = {25, 0, 25, 25, 25};
  for (int i = 0; i < 5; ++i) EXPECT_EQ(atrousIterationTaps(i, atrous), taps[i]) << i;
  atrous.kernel = AtrousKernel::Compact3x3;
  EXPECT_EQ(atrousIterationTaps(1, atrous), 0);
  EXPECT_EQ(atrousIterationTaps(2, atrous), 9);
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

// A built-in without the footprint policy must read one pixel: its response to an impulse on a
// plane, with its defaults, stays on the impulse's pixel over a few frames (passthrough and
// temporal do). One that spreads it reads neighbours, and takes the policy (docs/extending.md).
TEST(Footprint, AVariantWithoutAFootprintReadsOnePixel) {
  const std::vector<std::string> names = onePixelVariants();
  EXPECT_NE(std::find(names.begin(), names.end(), "temporal"), names.end());
  const int w = 32, h = 18, cx = w / 2, cy = h / 2;
  for (const std::string& name : names) {
    auto denoiser = test::createDenoiser(name, {});
    denoiser->setup(w, h);
    const LayerSet frame = test::planeFrame(w, h, 2.56f / float(w));
    Image signal(w, h, 3), output(w, h, 3);
    for (int c = 0; c < 3; ++c) signal.at(cx, cy, c) = 1.0f;
    int spread = 0;
    for (int t = 0; t < 3; ++t) {
      denoiser->denoise(test::stillCameraContext(t, w, h), {signal, frame, nullptr}, output);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          for (int c = 0; c < 3; ++c) spread += (x != cx || y != cy) && output.at(x, y, c) != 0.0f;
    }
    EXPECT_EQ(spread, 0)
        << name
        << " spreads an impulse to neighbouring pixels but has no footprint "
           "parameter: a filter that reads neighbours takes the footprint policy "
           "(.include(footprintParams(), &Settings::footprint), docs/extending.md)";
  }
}

TEST(Footprint, ImpulseRadiiKeepTheirRatioToSvgfAcrossResolutions) {
  const std::vector<std::string> names = spatialVariants();
  ASSERT_GE(names.size(), 7u);  // eaw, svgf, asvgf, slgf, reblur, hybrid, reengine
  for (const std::string policy : {"native", "scaled"}) {
    std::map<std::string, double> small, large;
    for (const std::string& name : names) {
      small[name] = impulseRadius(name, policy, 256, 144);
      large[name] = impulseRadius(name, policy, 1280, 720);
    }
    for (const std::string& name : names) {
      // The policy on a filter that does not spread an impulse scales nothing (a ratio of 0 / 0).
      if (small[name] == 0 && large[name] == 0) {
        ADD_FAILURE() << name
                      << " takes the footprint policy but its impulse response stays on one "
                      << "pixel (data-dependent terms this test turns off for the built-ins, or a "
                      << "one-pixel filter, which needs no footprint parameter)";
        continue;
      }
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

TEST(Footprint, PolicyIsRecordedInEverySpatialVariantsParameters) {
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


// ---- Fidelity to the paper and the reference implementation ------------------------------
// Issue 15, item 14 (second half): ReBLUR and hybrid mottle on a room lit by several small
// coloured lights (tests/data/scenes/coloured_lights.json). The measure is the low-frequency
// error: e = denoised - reference (linear colour), blurred by a Gaussian of sigma 2 px, its mean
// squared value over frames >= kWarmup. Causes (denoisers/FIDELITY.md): ReBLUR's native pixel
// footprints (NRD's 30-50 px radii over a 54-line image), removed by the default footprint policy
// (scaled); hybrid's variance clipping to the 1-spp 3x3 box (the talk's design, still the
// default), removed by the box over the mip chain's moments (clipSupport=mip) or no clipping.
// Measured (96x54, 12 frames, 256-spp references; ratio to svgf under the default policy): reblur
// 1.39, footprint=native 10.37; hybrid 9.10, clipSupport=mip 1.65 (clipMipLevel 1: 2.78, 3:
// 1.35), varianceClip=false 1.03; svgf itself at footprint=native 3.17. Should hybrid's default
// clip box change, the third expectation fails on purpose: update FIDELITY.md with it.

constexpr int kWidth = 96, kHeight = 54, kFrames = 12, kWarmup = 6;

struct Lights {
  Sequence sequence;
  std::vector<LayerSet> frames, references;
};

const Lights& lights() {
  static const Lights* l = [] {
    const auto dir = test::freshDir("coloured_lights");
    const auto seq =
        renderSequence(loadScene(std::string(ARENA_TEST_DATA) + "/scenes/coloured_lights.json"),
                       test::tinySettings(kWidth, kHeight, kFrames, 256), dir / "cache", nullptr);
    auto* r = new Lights{Sequence::open(seq), {}, {}};
    for (int t = 0; t < kFrames; ++t) {
      r->frames.push_back(r->sequence.frame(t));
      r->references.push_back(r->sequence.reference(t));
    }
    return r;
  }();
  return *l;
}

// Separable Gaussian (sigma px, truncated at 3 sigma, renormalised at the border).
std::vector<float> gaussian(const std::vector<float>& in, int w, int h, float sigma) {
  const int r = int(std::ceil(3 * sigma));
  std::vector<float> k(size_t(2 * r + 1));
  for (int i = -r; i <= r; ++i) k[size_t(i + r)] = std::exp(-0.5f * float(i * i) / (sigma * sigma));
  std::vector<float> tmp(in.size()), out(in.size());
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<float>& src = pass == 0 ? in : tmp;
    std::vector<float>& dst = pass == 0 ? tmp : out;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        float sum = 0, weight = 0;
        for (int i = -r; i <= r; ++i) {
          const int xx = pass == 0 ? x + i : x, yy = pass == 0 ? y : y + i;
          if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
          sum += k[size_t(i + r)] * src[size_t(yy * w + xx)];
          weight += k[size_t(i + r)];
        }
        dst[size_t(y * w + x)] = sum / weight;
      }
  }
  return out;
}

// Mean squared low-frequency error, relative to the reference's mean luminance squared.
double mottle(const std::string& name, const std::map<std::string, std::string>& params) {
  const Lights& l = lights();
  DenoiseRun run({name, params, name}, l.sequence);
  double energy = 0, reference = 0;
  long count = 0;
  run.run([&](int t) -> const LayerSet& { return l.frames[size_t(t)]; },
          [&](const DenoisedFrame& f) {
            if (f.frame < kWarmup) return;
            const Image& ref = l.references[size_t(f.frame)].get("color");
            for (int c = 0; c < 3; ++c) {
              std::vector<float> e(ref.pixelCount());
              for (size_t i = 0; i < e.size(); ++i) {
                e[i] = f.color.plane(c)[i] - ref.plane(c)[i];
                reference += ref.plane(c)[i];
              }
              for (float v : gaussian(e, kWidth, kHeight, 2.0f)) energy += double(v) * v;
              count += long(e.size());
            }
          });
  const double mean = reference / double(count);
  return energy / double(count) / (mean * mean);
}

TEST(ColouredLights, ReblurAndHybridMottleCausesPinned) {
  const double svgf = mottle("svgf", {});
  const double reblur = mottle("reblur", {});
  const double reblurNative = mottle("reblur", {{"footprint", "native"}});
  const double hybrid = mottle("hybrid", {});
  const double hybridMip = mottle("hybrid", {{"clipSupport", "mip"}});
  const double hybridNoClip = mottle("hybrid", {{"varianceClip", "false"}});
  std::printf(
      "coloured lights, low-frequency error / svgf: reblur %.2f, reblur footprint=native %.2f, "
      "hybrid %.2f, clipSupport=mip %.2f, varianceClip=false %.2f (svgf %.4g)\n",
      reblur / svgf, reblurNative / svgf, hybrid / svgf, hybridMip / svgf, hybridNoClip / svgf,
      svgf);
  // ReBLUR: fixed by the default footprint policy (scaled), native pinned as the cause.
  EXPECT_LT(reblur, 2.0 * svgf);
  EXPECT_GT(reblurNative, 4.0 * reblur);
  // Hybrid: the default keeps the talk's 3x3 clip box, whose excess stays (FIDELITY.md: the mip
  // box trades lag for it); the mip box and no clipping remove most of it.
  EXPECT_GT(hybrid, 4.0 * svgf);
  EXPECT_LT(hybridMip, 2.0 * svgf);
  EXPECT_LT(hybridNoClip, 1.3 * svgf);
}

}  // namespace
}  // namespace arena
