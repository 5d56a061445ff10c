// Metric throughput on 1280x720 frames: relMSE, SSIM, LDR-FLIP, HDR-FLIP, tRMAE and warped flicker
// (the per-frame cost of scoring a denoised sequence). Images are deterministic "random-ish": smooth structure plus fixed-seed
// noise, so the timings do not depend on a scene render.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "core/display.hpp"
#include "metrics/error.hpp"
#include "metrics/flip.hpp"
#include "metrics/temporal.hpp"

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

void BM_RelMse720p(benchmark::State& state) {
  const arena::Image ref = hdrFrame(1, 0.0f), test = hdrFrame(2, 0.2f), var(kWidth, kHeight, 3, 0.001f);
  for (auto _ : state) benchmark::DoNotOptimize(arena::linearError(test, ref, &var).relMse);
}
BENCHMARK(BM_RelMse720p)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Ssim720p(benchmark::State& state) {
  const arena::Image ref = ldrFrame(1, 0.0f), test = ldrFrame(2, 0.05f);
  for (auto _ : state) benchmark::DoNotOptimize(arena::ssim(ref, test));
}
BENCHMARK(BM_Ssim720p)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DisplayTransform720p(benchmark::State& state) {
  const arena::Image hdr = hdrFrame(1, 0.0f);
  const arena::DisplayTransform t = arena::DisplayTransform::fromReference(hdr);
  for (auto _ : state) benchmark::DoNotOptimize(t.apply(hdr).raw().data());
}
BENCHMARK(BM_DisplayTransform720p)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_TemporalRelativeMae720p(benchmark::State& state) {
  const arena::Image r0 = hdrFrame(1, 0.0f), r1 = hdrFrame(3, 0.01f), d0 = hdrFrame(2, 0.2f), d1 = hdrFrame(4, 0.2f);
  for (auto _ : state) benchmark::DoNotOptimize(arena::temporalRelativeMae(d1, d0, r1, r0));
}
BENCHMARK(BM_TemporalRelativeMae720p)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_WarpedFlicker720p(benchmark::State& state) {
  const arena::Image e0 = ldrFrame(5, 0.05f), e1 = ldrFrame(6, 0.05f);
  arena::LayerSet g;
  arena::Image normal(kWidth, kHeight, 3), motion(kWidth, kHeight, 2, -1.5f);
  for (size_t i = 0; i < normal.pixelCount(); ++i) normal.plane(2)[i] = 1.0f;
  g.set("depth", arena::Image(kWidth, kHeight, 1, 3.0f));
  g.set("normal", normal);
  g.set("meshId", arena::Image(kWidth, kHeight, 1, 1.0f));
  g.set("motion", motion);
  for (auto _ : state) benchmark::DoNotOptimize(arena::warpedFlicker(e1, e0, g, g).value);
}
BENCHMARK(BM_WarpedFlicker720p)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
