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
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "core/image.hpp"
#include "harness/denoise_run.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"
#include "tracer/scene.hpp"

namespace arena {
namespace {

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
