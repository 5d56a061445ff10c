// The GPU traffic the shared blocks count (denoisers/common/gpu_traffic.hpp) against counts done
// by hand.
#include "denoisers/common/gpu_traffic.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "denoisers/common/atrous.hpp"
#include "denoisers/common/footprint.hpp"
#include "denoisers/svgf.hpp"
#include "test_util.hpp"

namespace arena {
namespace {
using namespace test;

const BufferTraffic* find(const PassTraffic& t, const std::string& name, bool write) {
  for (const BufferTraffic& b : t.buffers)
    if (b.name == name && b.write == write) return &b;
  return nullptr;
}

// One SVGF à-trous step, 5x5 B3 kernel, depth + normal + luminance terms, variance propagated, on
// a 16x8 frame. By hand, per pixel: radiance 25 taps of RGBA16F (8 B), meshId 25 of R16_UINT (2 B),
// depth 25 of R32F (4 B), normal 25 of R10G10B10A2 (4 B), the derivatives once (RGBA16F, 8 B), the
// prefiltered variance once (R16F, 2 B), the propagated variance 25 taps (R16F, 2 B): 30 B read
// once each (the taps hit the cache), 127 fetches, 50 + 25 + 25 + 25 + 2 + 1 + 25 = 153 fetch
// cycles; written: radiance 8 B and variance 2 B.
TEST(GpuTraffic, OneAtrousStepCountsWhatAHandCountGives) {
  const int w = 16, h = 8;
  const LayerSet frame = planeFrame(w, h);
  const GBufferView g =
      GBufferView::fromFrame(frame, {"depth", "normal", "meshId", "motion", "position"}, "test");
  Image derivatives(w, h, kGeometryDerivativeChannels);
  computeGeometryDerivatives(g, derivatives);
  Image variance(w, h, 1, 0.1f), filtered(w, h, 1, 0.1f), varianceOut(w, h, 1);
  Image in(w, h, 3, 0.5f), out(w, h, 3);
  // B3 5x5 with SVGF's depth, normal and luminance terms at its defaults.
  const AtrousSettings settings = svgfParams().defaults().atrous;
  ASSERT_TRUE(settings.edges.depth && settings.edges.normal && settings.edges.luminance);
  ASSERT_FALSE(settings.edges.position || settings.edges.color);

  PassTraffic t;
  {
    TrafficScope scope(&t);
    atrousIteration(0, settings, {g, &derivatives, &filtered}, 1.0f, in, out, &variance,
                    &varianceOut);
  }
  const double pixels = w * h;
  ASSERT_EQ(t.dispatches.size(), 1u);
  EXPECT_EQ(t.dispatches[0][0], w);
  EXPECT_EQ(t.dispatches[0][1], h);
  EXPECT_DOUBLE_EQ(t.bytesRead() / pixels, 30.0);
  EXPECT_DOUBLE_EQ(t.bytesWritten() / pixels, 10.0);
  EXPECT_DOUBLE_EQ(t.fetches() / pixels, 127.0);
  EXPECT_DOUBLE_EQ(t.fetchCycles() / pixels, 153.0);
  const BufferTraffic* radiance = find(t, "radiance", false);
  ASSERT_NE(radiance, nullptr);
  EXPECT_EQ(radiance->format, GpuFormat::RGBA16Float);
  EXPECT_DOUBLE_EQ(radiance->fetches / pixels, 25.0);
  EXPECT_DOUBLE_EQ(radiance->texels, pixels);
  const BufferTraffic* depth = find(t, "depth (input)", false);
  ASSERT_NE(depth, nullptr);
  EXPECT_DOUBLE_EQ(depth->fetches / pixels, 25.0);
  ASSERT_NE(find(t, "variance", true), nullptr);

  // The compact 3x3 kernel with only the id term: 9 taps of radiance and meshId.
  AtrousSettings compact;
  compact.kernel = AtrousKernel::Compact3x3;
  compact.edges.depth = compact.edges.normal = compact.edges.luminance = false;
  compact.edges.id = true;
  PassTraffic c;
  {
    TrafficScope scope(&c);
    atrousIteration(0, compact, {g}, 1.0f, in, out);
  }
  EXPECT_DOUBLE_EQ(c.bytesRead() / pixels, 8.0 + 2.0);
  EXPECT_DOUBLE_EQ(c.fetches() / pixels, 18.0);
  EXPECT_DOUBLE_EQ(c.fetchCycles() / pixels, 9.0 * 2.0 + 9.0 * 1.0);
}

TEST(GpuTraffic, NothingIsRecordedOutsideAPassOrForASkippedIteration) {
  const int w = 8, h = 8;
  const LayerSet frame = planeFrame(w, h);
  const GBufferView g = GBufferView::fromFrame(frame, {"depth", "normal", "meshId"}, "test");
  Image in(w, h, 3, 0.5f), out(w, h, 3);
  AtrousSettings settings;
  settings.edges.depth = settings.edges.normal = settings.edges.luminance = false;
  EXPECT_FALSE(gpu::recording());
  atrousIteration(0, settings, {g}, 1.0f, in, out);  // no scope: a no-op for the recorder
  // Step 2^3 x 1e-4 rounds to 0 here, and at 1080 lines (x 1080 / 8) too: skipped everywhere.
  settings.footprintScale = 1e-4f;
  PassTraffic t;
  {
    TrafficScope scope(&t);
    EXPECT_TRUE(gpu::recording());
    atrousIteration(3, settings, {g}, 1.0f, in, out);
  }
  EXPECT_FALSE(gpu::recording());
  EXPECT_TRUE(t.empty());
}

// An iteration the footprint skips at this height but a 1080p frame runs (step 2^3 x 0.01 rounds
// to 0 at 8 lines, to 11 at 1080) is not run here, and is priced as that frame's iteration: the
// same traffic per pixel as the iteration run, counted in skippedHere.
TEST(GpuTraffic, AnIterationSkippedHereThatA1080pFrameRunsIsPricedAsRun) {
  const int w = 8, h = 8;
  const LayerSet frame = planeFrame(w, h);
  const GBufferView g = GBufferView::fromFrame(frame, {"depth", "normal", "meshId"}, "test");
  Image in(w, h, 3, 0.5f), out(w, h, 3);
  in.at(3, 3, 0) = 2.0f;
  AtrousSettings settings;
  settings.edges.depth = settings.edges.luminance = false;
  PassTraffic run, skipped;
  {
    TrafficScope scope(&run);
    atrousIteration(3, settings, {g}, 1.0f, in, out);
  }
  EXPECT_EQ(run.skippedHere, 0);
  settings.footprintScale = 0.01f;
  ASSERT_EQ(atrousStep(3, settings.footprintScale), 0);
  ASSERT_TRUE(atrousRunsAt1080p(3, settings.footprintScale, h));
  {
    TrafficScope scope(&skipped);
    atrousIteration(3, settings, {g}, 1.0f, in, out);
  }
  EXPECT_EQ(skipped.skippedHere, 1);
  EXPECT_EQ(out.at(3, 3, 0), 2.0f);  // not run: the identity
  EXPECT_EQ(skipped.dispatches, run.dispatches);
  EXPECT_DOUBLE_EQ(skipped.bytesRead(), run.bytesRead());
  EXPECT_DOUBLE_EQ(skipped.bytesWritten(), run.bytesWritten());
  EXPECT_DOUBLE_EQ(skipped.fetches(), run.fetches());
  EXPECT_GT(skipped.fetches(), 0.0);
}

// Every timed à-trous pass of eaw records one full-screen dispatch whose radiance fetches are
// the taps the pass already reports.
TEST(GpuTraffic, DenoiserPassesCarryTheirTraffic) {
  const int w = 24, h = 16;
  const LayerSet frame = planeFrame(w, h);
  auto eaw = createDenoiser("eaw", {{"footprint", "native"}});
  eaw->setup(w, h);
  Image out(w, h, 3);
  const Image& signal = frame.get("diffuse");
  eaw->denoise(stillCameraContext(0, w, h), {signal, frame}, out);
  int atrousPasses = 0;
  for (const PassStats& p : eaw->lastPasses()) {
    if (p.name.rfind("atrous", 0) != 0) continue;
    ++atrousPasses;
    ASSERT_EQ(p.traffic.dispatches.size(), 1u) << p.name;
    const BufferTraffic* radiance = find(p.traffic, "radiance", false);
    ASSERT_NE(radiance, nullptr) << p.name;
    EXPECT_DOUBLE_EQ(radiance->fetches / (w * h), p.tapsPerPixel) << p.name;
  }
  EXPECT_EQ(atrousPasses, 5);
}

}  // namespace
}  // namespace arena
