// Metric throughput on 1280x720 frames: LDR-FLIP and HDR-FLIP (the per-frame cost of scoring a
// denoised sequence). Images are deterministic "random-ish": smooth structure plus fixed-seed
// noise, so the timings do not depend on a scene render.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "metrics/flip.hpp"

namespace {

constexpr int kWidth = 1280, kHeight = 720;

// LDR reference in [0.1, 0.9] with edges and gradients; the test adds noise of amplitude 0.05.
arena::Image ldrFrame(unsigned noiseSeed, float noise) {
  arena::Image img(kWidth, kHeight, 3);
  std::mt19937 rng(noiseSeed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        const float checker = ((x / 64 + y / 48) % 2) ? 0.25f : 0.0f;
        const float ramp = 0.5f * float(x + c * 200) / float(kWidth + 400);
        img.at(x, y, c) = 0.1f + checker + ramp + 0.05f * std::sin(0.05f * float(y + 7 * c)) + noise * u(rng);
      }
  return img;
}

// HDR reference spanning about 9 stops (a 0.02 .. 2 ramp plus bright rectangles of 10), so
// HDR-FLIP runs a realistic number of exposures: ceil(log2(Y_max / Y_median)) = 6 here.
arena::Image hdrFrame(unsigned noiseSeed, float noise) {
  arena::Image img(kWidth, kHeight, 3);
  std::mt19937 rng(noiseSeed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        const float base = 0.02f * std::exp2(6.0f * float(x) / float(kWidth)) * (1.0f + 0.3f * float(c));
        const float light = ((x / 160 + y / 120) % 5 == 0) ? 10.0f : 0.0f;
        const float v = base + light;
        img.at(x, y, c) = v * (1.0f + noise * u(rng));
      }
  return img;
}

void BM_LdrFlip720p(benchmark::State& state) {
  const arena::Image ref = ldrFrame(1, 0.0f), test = ldrFrame(2, 0.05f);
  for (auto _ : state) benchmark::DoNotOptimize(arena::ldrFlip(ref, test).mean);
  state.SetItemsProcessed(state.iterations() * int64_t(kWidth) * kHeight);
}
BENCHMARK(BM_LdrFlip720p)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_HdrFlip720p(benchmark::State& state) {
  const arena::Image ref = hdrFrame(1, 0.0f), test = hdrFrame(2, 0.2f);
  for (auto _ : state) benchmark::DoNotOptimize(arena::hdrFlip(ref, test).mean);
  state.SetItemsProcessed(state.iterations() * int64_t(kWidth) * kHeight);
}
BENCHMARK(BM_HdrFlip720p)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
