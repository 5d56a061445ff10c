// The cost model's arithmetic (harness/gpu_cost.hpp). No timings here: the model's validation
// against published numbers is `arena bench gpu-model` (docs/gpu-cost.md).
#include <gtest/gtest.h>

#include "denoisers/common/gpu_traffic.hpp"
#include "harness/gpu_cost.hpp"

namespace arena {
namespace {

PassTraffic syntheticPass(double bytesPerPixel, double cyclesPerPixel, int dispatches) {
  PassTraffic t;
  for (int d = 0; d < dispatches; ++d) t.dispatches.push_back({1000, 1000});
  BufferTraffic read;  // RGBA32F: 16 B a texel, 4 fetch cycles a fetch
  read.name = "x";
  read.format = GpuFormat::RGBA32Float;
  read.texels = 1e6 * bytesPerPixel / 16.0;
  read.fetches = 1e6 * cyclesPerPixel / 4.0;
  t.buffers.push_back(read);
  return t;
}

TEST(GpuCostModel, RooflinePlusDispatchArithmetic) {
  const GpuDevice device{"test", 100.0, 50.0, "made up"};  // 100 GB/s, 50 Gtexel/s
  // 1e6 px x 64 B = 64 MB at 100 GB/s = 0.64 ms; 1e6 x 16 cycles at 50 G/s = 0.32 ms.
  const PassTraffic t = syntheticPass(64.0, 16.0, 2);
  const PassPrediction p = predictPass(t, device, {1.0, 0.01});
  EXPECT_NEAR(p.memoryMs, 0.64, 1e-12);
  EXPECT_NEAR(p.fetchMs, 0.32, 1e-12);
  EXPECT_NEAR(p.totalMs(), 0.64 + 0.02, 1e-12);
  EXPECT_FALSE(p.fetchBound());
  EXPECT_NEAR(predictPass(t, device, {3.0, 0.0}).totalMs(), 0.96, 1e-12);
  // Four times the pixels: four times each roofline term, the same dispatches.
  EXPECT_NEAR(predictPass(scaleTraffic(t, 4.0), device, {1.0, 0.0}).memoryMs, 2.56, 1e-9);
}

TEST(GpuCostModel, FitRecoversTheConstantsThatMadeTheData) {
  const GpuDevice device{"test", 100.0, 50.0, "made up"};
  const GpuCostModel truth{2.5, 0.05};
  std::vector<FitPoint> points;
  for (double cycles : {10.0, 40.0, 160.0, 640.0})
    for (int dispatches : {1, 3}) {
      FitPoint p{"p", syntheticPass(8.0, cycles, dispatches), 0};
      p.publishedMs = predictPass(p.traffic, device, truth).totalMs();
      points.push_back(p);
    }
  const GpuCostModel fit = fitModel(points, device);
  EXPECT_NEAR(fit.fetchEfficiency, truth.fetchEfficiency, 0.05);
  EXPECT_NEAR(fit.dispatchMs, truth.dispatchMs, 0.002);
}

TEST(GpuCostModel, SpearmanAndSignalMerging) {
  EXPECT_DOUBLE_EQ(spearman({1, 2, 3, 4}, {10, 20, 30, 40}), 1.0);
  EXPECT_DOUBLE_EQ(spearman({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0);
  EXPECT_DOUBLE_EQ(spearman({1, 1, 2}, {5, 5, 9}), 1.0);
  // Two signals in one dispatch: the G-buffer read once, the radiance twice.
  PassTraffic a;
  {
    TrafficScope scope(&a);
    gpu::dispatch(4, 4);
    gpu::read(gpu_buffers::kDepth, 4, 4, 9);
    gpu::read(gpu_buffers::kRadiance, 4, 4, 9);
  }
  const PassTraffic both = mergeSignals(a, a);
  EXPECT_EQ(both.dispatches.size(), 1u);
  EXPECT_DOUBLE_EQ(both.bytesRead(), 16.0 * (4 + 2 * 8));
  EXPECT_DOUBLE_EQ(scaleGather(a, 25.0 / 9.0).fetches(), 2.0 * 25.0 * 16.0);
  EXPECT_EQ(repeatPass(a, 3).dispatches.size(), 3u);
}

}  // namespace
}  // namespace arena
