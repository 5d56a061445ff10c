// The cost model's arithmetic (harness/gpu_cost.hpp) and the measured set's reading and counting.
// No timings here: the model's validation against published numbers is `arena bench gpu-model`,
// against timings measured on a GPU `arena bench gpu-measured` (docs/gpu-cost.md).
#include "harness/gpu_cost.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>

#include "core/error.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "test_util.hpp"

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
  // Undefined, never a number from no data: one value, none, or one side all tied.
  EXPECT_TRUE(std::isnan(spearman({1}, {2})));
  EXPECT_TRUE(std::isnan(spearman({}, {})));
  EXPECT_TRUE(std::isnan(spearman({1, 2, 3}, {4, 4, 4})));
  EXPECT_EQ(spearmanText(spearman({1}, {2}), 1), "undefined (fewer than two values)");
  EXPECT_EQ(spearmanText(spearman({1, 2, 3}, {4, 4, 4}), 3),
            "undefined (every value of one side tied)");
  EXPECT_EQ(spearmanText(-1.0, 4), "-1.00");
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

// The study's GPU axis: a frame's passes with the signals' instances merged per pass (the G-buffer
// read once), scaled from the sequence's resolution to 1920x1080 and priced with the stored model;
// a run whose passes counted nothing (an external denoiser) has no prediction at all.
TEST(GpuCostModel, AFrameIsItsPassesMergedAcrossSignalsAndScaledTo1080p) {
  PassTraffic filter;
  {
    TrafficScope scope(&filter);
    gpu::dispatch(480, 270);
    gpu::read(gpu_buffers::kDepth, 480, 270, 9);
    gpu::read(gpu_buffers::kRadiance, 480, 270, 9);
    gpu::write(gpu_buffers::kRadiance, 480, 270);
  }
  const std::vector<PassStats> passes = {{"diffuse/filter", 1.0, 9.0, 0.0, filter},
                                         {"specular/filter", 1.0, 9.0, 0.0, filter}};
  const GpuDevice& titan = gpuDevice("TITAN RTX");
  const double expected = predictPass(scaleTraffic(mergeSignals(filter, filter), 16.0), titan, boxAtrousModel()).totalMs();
  EXPECT_NEAR(predictFrameMs(passes, titan, boxAtrousModel(), 16.0), expected, 1e-12);
  // The merge reads the depth once: less than two separate instances.
  EXPECT_LT(expected, 2.0 * predictPass(scaleTraffic(filter, 16.0), titan, boxAtrousModel()).totalMs());
  GpuFrameCost cost(480, 270);
  for (int t = 0; t < 4; ++t) cost.add(passes);
  const nlohmann::json s = cost.summary(1);
  ASSERT_TRUE(s.is_object());
  EXPECT_EQ(s["devices"][0]["device"], "TITAN RTX");
  EXPECT_NEAR(s["devices"][0]["msMedian"].get<double>(), expected, 1e-12);
  EXPECT_EQ(s["devices"].size(), gpuDevices().size());
  // Memory at 1080p: the history buffer this pass writes, per signal's instance (RGBA16F, 8 B).
  PassTraffic kept;
  {
    TrafficScope scope(&kept);
    gpu::dispatch(480, 270);
    gpu::read(gpu_buffers::kRadiance, 480, 270, 1);
    gpu::write(gpu_buffers::kRadianceHistory, 480, 270);
  }
  GpuFrameCost withHistory(480, 270);
  withHistory.add({{"diffuse/store", 0.1, 1.0, 0.0, kept}, {"specular/store", 0.1, 1.0, 0.0, kept}});
  const nlohmann::json memory = withHistory.summary(0)["memory"];
  const double historyMiB = 1920.0 * 1080.0 * 8.0 / (1024.0 * 1024.0);
  EXPECT_NEAR(memory["persistentMiB"].get<double>(), 2.0 * historyMiB, 1e-9);
  // The transient radiance the pass reads counts in the working set, once per instance.
  EXPECT_NEAR(memory["workingSetMiB"].get<double>(), 4.0 * historyMiB, 1e-9);
  GpuFrameCost external(480, 270);
  external.add({{"process", 5.0, 0.0, 0.0, PassTraffic{}}});
  EXPECT_TRUE(external.summary(0).is_null());
}

// The merged passes `arena bench gpu-model`'s per-pass table prints (the bench itself renders 1080p
// frames and is not run here): a pass only one signal runs (hybrid's specular median) is one of
// them, priced as the frame prices it, so such rows add up to the frame (the table left that pass
// out, and its total read hybrid 0.18 ms low on an RTX 4080).
TEST(GpuCostModel, APassOneSignalRunsIsAPassOfTheFrame) {
  PassTraffic filter, median;
  {
    TrafficScope scope(&filter);
    gpu::dispatch(480, 270);
    gpu::read(gpu_buffers::kRadiance, 480, 270, 9);
    gpu::write(gpu_buffers::kRadiance, 480, 270);
  }
  {
    TrafficScope scope(&median);
    gpu::dispatch(480, 270);
    gpu::read(gpu_buffers::kRadiance, 480, 270, 9);
    gpu::write(gpu_buffers::kRadiance, 480, 270);
  }
  const std::vector<PassStats> diffuse = {{"filter", 1.0, 9.0, 0.0, filter}};
  const std::vector<PassStats> specular = {{"median", 0.5, 9.0, 0.0, median},
                                           {"filter", 2.0, 9.0, 0.0, filter}};
  std::vector<PassStats> both = diffuse;
  both.insert(both.end(), specular.begin(), specular.end());
  const std::vector<MergedPass> merged = mergedPasses(both);
  ASSERT_EQ(merged.size(), 2u);
  EXPECT_EQ(merged[0].name, "filter");  // in the order they first ran
  EXPECT_EQ(merged[1].name, "median");
  EXPECT_DOUBLE_EQ(merged[0].cpuMs, 3.0);
  EXPECT_DOUBLE_EQ(merged[1].cpuMs, 0.5);
  const GpuDevice& device = gpuDevice("RTX 4080");
  double rows = 0;
  for (const MergedPass& p : merged)
    rows += predictPass(p.traffic, device, boxAtrousModel()).totalMs();
  EXPECT_NEAR(rows, predictFrameMs(both, device, boxAtrousModel()), 1e-12);
  EXPECT_GT(rows, predictFrameMs(diffuse, device, boxAtrousModel()) + 1e-6);
}

// Predicted totals less than the tolerance above the first of their group are not ordered: groups
// start at their fastest member, so a group's ends are less than the tolerance apart (a chain of
// neighbours each within it could span any gap), and exactly the tolerance apart is ordered.
TEST(GpuCostModel, PredictedTimesCloserThanTheToleranceAreNotOrdered) {
  using V = std::vector<std::string>;
  EXPECT_EQ(orderSeparators({4.825, 4.921}, 0.1), (V{"", " ≈ "}));
  EXPECT_EQ(orderSeparators({4.0, 4.5}, 0.1), (V{"", " < "}));
  EXPECT_EQ(orderSeparators({5.5, 5.9, 6.3}, 0.1), (V{"", " ≈ ", " < "}));
  EXPECT_EQ(orderSeparators({1.0, 1.1}, 0.1), (V{"", " < "}));
  EXPECT_EQ(orderSeparators({1.0, 1.0, 1.05, 1.2, 1.25}, 0.1), (V{"", " ≈ ", " ≈ ", " < ", " ≈ "}));
  EXPECT_EQ(orderSeparators({1.0, 1.01}, 0.0), (V{"", " < "}))
      << "no tolerance: every time ordered";
  EXPECT_TRUE(orderSeparators({}, 0.1).empty());
}

// The stored model is the bench's fit of the box/à-trous experiment: the counted à-trous iteration
// (docs/gpu-cost.md: 38 B read, 10 B written, 46 fetches and 91 fetch cycles per pixel, one
// full-screen dispatch) fitted on the six published points gives it back, in both forms.
TEST(GpuCostModel, TheStoredModelIsTheFitOfTheBoxAtrousExperiment) {
  PassTraffic iteration;
  {
    TrafficScope scope(&iteration);
    const int w = 1920, h = 1080;
    gpu::dispatch(w, h);
    gpu::read(GpuBuffer{"position", GpuFormat::RGBA32Float}, w, h, 9);  // 16 B, 36 cycles
    gpu::read({gpu_buffers::kRadiance, gpu_buffers::kLobes}, w, h, 9);  // 16 B, 36 cycles
    gpu::read({gpu_buffers::kMeshId, gpu_buffers::kVariance}, w, h, 9);  // 4 B, 18 cycles
    gpu::read(gpu_buffers::kFilteredVariance, w, h, 1);                 // 2 B, 1 cycle
    gpu::write({gpu_buffers::kRadiance, gpu_buffers::kVariance}, w, h);  // 10 B
  }
  const double px = 1920.0 * 1080.0;
  ASSERT_DOUBLE_EQ(iteration.bytesRead() / px, 38.0);
  ASSERT_DOUBLE_EQ(iteration.fetches() / px, 46.0);
  ASSERT_DOUBLE_EQ(iteration.fetchCycles() / px, 91.0);
  const std::vector<FitPoint> points = {{"3x3 box", iteration, 0.52},
                                        {"A-Trous x1", iteration, 0.42},
                                        {"7x7 box", scaleGather(iteration, 49.0 / 9.0), 1.65},
                                        {"A-Trous x2", repeatPass(iteration, 2), 0.86},
                                        {"15x15 box", scaleGather(iteration, 225.0 / 9.0), 7.20},
                                        {"A-Trous x3", repeatPass(iteration, 3), 1.16}};
  for (FixedCost form : {FixedCost::PerDispatch, FixedCost::PerThread}) {
    const GpuCostModel fit = fitModel(points, gpuDevice("TITAN RTX"), form);
    const GpuCostModel stored = boxAtrousModel(form);
    EXPECT_NEAR(fit.fetchEfficiency, stored.fetchEfficiency, 1e-9);
    EXPECT_NEAR(fit.dispatchMs, stored.dispatchMs, 1e-9);
    EXPECT_EQ(stored.fixed, form);
  }
  EXPECT_EQ(boxAtrousModel().fixed, FixedCost::PerThread);  // the measured set's choice
}

// The kernels of bench/gpu/pass_timing.cu counted as the CUDA code moves them: the SVGF step by the
// very block the denoisers use (the hand count of gpu_traffic_test), a box, a format.
TEST(GpuMeasured, KernelsAreCountedAsTheCudaKernelsMoveThem) {
  const PassTraffic svgf = measuredKernelTraffic("svgf-atrous-5x5-step8", 32, 16);
  const double px = 32.0 * 16.0;
  EXPECT_EQ(svgf.dispatches.size(), 1u);
  EXPECT_DOUBLE_EQ(svgf.bytesRead() / px, 30.0);
  EXPECT_DOUBLE_EQ(svgf.bytesWritten() / px, 10.0);
  EXPECT_DOUBLE_EQ(svgf.fetches() / px, 127.0);
  EXPECT_DOUBLE_EQ(svgf.fetchCycles() / px, 153.0);
  const PassTraffic box = measuredKernelTraffic("box-7x7", 20, 10);
  EXPECT_DOUBLE_EQ(box.fetches() / 200.0, 49.0);
  EXPECT_DOUBLE_EQ((box.bytesRead() + box.bytesWritten()) / 200.0, 16.0);
  EXPECT_DOUBLE_EQ(measuredKernelTraffic("copy-1x1", 20, 10).fetches() / 200.0, 1.0);
  const PassTraffic wide = measuredKernelTraffic("format-7x7-R32G32B32A32_FLOAT", 20, 10);
  EXPECT_DOUBLE_EQ(wide.bytesRead() / 200.0, 16.0);
  EXPECT_DOUBLE_EQ(wide.fetchCycles() / 200.0, 4.0 * 49.0);
  EXPECT_DOUBLE_EQ(measuredKernelTraffic("format-7x7-R8_UINT", 20, 10).fetchCycles() / 200.0, 49.0);
}

void writeFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

using test::errorOf;

TEST(GpuMeasured, BadFilesAndKernelsAreErrorsNamingWhatIsWrong) {
  const auto dir = test::freshDir("gpu_measured_contract");
  const std::string row = R"({"kernel": "box-3x3", "width": 64, "height": 32, "medianMs": 0.01})";
  auto file = [&](const std::string& name, const std::string& text) {
    writeFile(dir / name, text);
    return (dir / name).string();
  };
  EXPECT_NE(errorOf([&] { readMeasuredSet(file("no_time.json", R"({"device": "X", "rows": [{"kernel": "box-3x3", "width": 64, "height": 32}]})")); })
                .find("medianMs"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { readMeasuredSet(file("negative.json", R"({"device": "X", "rows": [{"kernel": "box-3x3", "width": 64, "height": 32, "medianMs": -1}]})")); })
                .find("positive time"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { readMeasuredSet(file("empty.json", R"({"device": "X", "rows": []})")); }).find("empty.json"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { readMeasuredSet(file("typo.json", R"({"device": "X", "rowz": [], "rows": [)" + row + "]}")); })
                .find("rowz"),
            std::string::npos);
  EXPECT_NE(
      errorOf([&] {
        readMeasuredSet(
            file("twice.json", R"({"device": "X", "rows": [)" + row + "," + row + "]}"));
      }).find("rows[1].kernel: one row per kernel and size; 'box-3x3' at 64x32 is already a row"),
      std::string::npos)
      << errorOf([&] { readMeasuredSet((dir / "twice.json").string()); });
  // A spread that is not around the median is a file written wrong.
  const std::string spread =
      R"({"device": "X", "rows": [{"kernel": "box-3x3", "width": 64, "height": 32, "medianMs": 0.01, )";
  EXPECT_NE(errorOf([&] {
              readMeasuredSet(file("p5.json", spread + R"("p5Ms": 0.02}]})"));
            }).find("rows[0].p5Ms: expected at most the row's medianMs (0.01)"),
            std::string::npos)
      << errorOf([&] { readMeasuredSet((dir / "p5.json").string()); });
  EXPECT_NE(errorOf([&] {
              readMeasuredSet(file("p95.json", spread + R"("p95Ms": 0.005}]})"));
            }).find("rows[0].p95Ms: expected at least"),
            std::string::npos);
  EXPECT_NE(errorOf([&] {
              readMeasuredSet(file("b2b.json", spread + R"("backToBackMs": 0}]})"));
            }).find("backToBackMs: expected a positive time"),
            std::string::npos);
  EXPECT_EQ(
      readMeasuredSet(
          file("ok.json", spread + R"("p5Ms": 0.009, "p95Ms": 0.01, "backToBackMs": 0.02}]})"))
          .rows.size(),
      1u);
  EXPECT_NE(errorOf([&] { measuredKernelTraffic("gaussian-9x9", 8, 8); }).find("gaussian-9x9"), std::string::npos);
  EXPECT_NE(errorOf([&] { measuredKernelTraffic("format-7x7-BC7", 8, 8); }).find("BC7"), std::string::npos);
  const std::string unknownDevice = file("unknown_device.json", R"({"device": "Some GPU", "rows": [)" + row + "]}");
  EXPECT_NE(errorOf([&] { benchGpuMeasured(unknownDevice, "", [](const std::string&) {}); }).find("Some GPU"),
            std::string::npos);
  // Priced on a named specification it runs, and says the GPU is not that one.
  std::string printedText;
  benchGpuMeasured(unknownDevice, "H200",
                   [&](const std::string& line) { printedText += line + "\n"; });
  EXPECT_NE(printedText.find("warning: the set's GPU is not the H200"), std::string::npos)
      << printedText;
  // A set timed on a GPU the model knows is not priced on another's specification.
  const std::string h200 = file("h200.json", R"({"device": "NVIDIA H200", "rows": [)" + row + "]}");
  EXPECT_NE(errorOf([&] {
              benchGpuMeasured(h200, "RTX 4080", [](const std::string&) {});
            }).find("which is the H200; priced on the RTX 4080's specification"),
            std::string::npos)
      << errorOf([&] { benchGpuMeasured(h200, "RTX 4080", [](const std::string&) {}); });
  // A kernel the model cannot count and a size it cannot hold are the file's errors, with the row.
  const std::vector<std::array<std::string, 3>> rows = {
      {"kernel.json", R"("foo-9x9", "width": 8, "height": 8)",
       "kernel.json: $.rows[0].kernel: measured kernel 'foo-9x9' is not one the model can count"},
      {"huge.json", R"("box-3x3", "width": 4096, "height": 16384)",
       "$.rows[0].height: at most 7680x4320's pixels"},
      {"wide.json", R"("box-3x3", "width": 16384, "height": 4096)",
       "$.rows[0].width: at most 7680x4320's pixels"},
      {"box.json", R"("box-99999999999x99999999999", "width": 8, "height": 8)",
       "$.rows[0].kernel: measured kernel 'box-99999999999x99999999999': a size the count cannot "
       "hold"}};
  for (const auto& [name, row, expected] : rows) {
    const std::string path =
        file(name, R"({"device": "X", "rows": [{"kernel": )" + row + R"(, "medianMs": 0.01}]})");
    const std::string error = errorOf([&] { readMeasuredSet(path); });
    EXPECT_NE(error.find(expected), std::string::npos) << error;
  }
}

// Measured times made by the per-thread model itself: that form fits them exactly, the other not,
// and the bench says so.
TEST(GpuMeasured, TheFormThatMadeTheTimesIsTheOneChosen) {
  const auto dir = test::freshDir("gpu_measured_choice");
  const GpuCostModel perThread = boxAtrousModel(FixedCost::PerThread);
  std::string rows;
  for (const char* kernel : {"svgf-atrous-5x5-step1", "box-15x15", "copy-1x1"})
    for (int w : {1920, 240}) {
      const int h = w * 9 / 16;
      const double ms = predictPass(measuredKernelTraffic(kernel, w, h), gpuDevice("H200"), perThread).totalMs();
      rows += std::string(rows.empty() ? "" : ",") + R"({"kernel": ")" + kernel + R"(", "width": )" +
              std::to_string(w) + R"(, "height": )" + std::to_string(h) + R"(, "medianMs": )" + std::to_string(ms) + "}";
    }
  const auto path = dir / "made.json";
  writeFile(path, R"({"device": "NVIDIA H200", "rows": [)" + rows + "]}");
  const nlohmann::json out = benchGpuMeasured(path.string(), "", [](const std::string&) {});
  EXPECT_EQ(out["pricedAs"], "H200");
  EXPECT_EQ(out["chosenForm"], "per thread");
  EXPECT_LT(out["forms"][1]["residual"].get<double>(), 1e-6);  // std::to_string keeps 6 decimals
  EXPECT_EQ(out["forms"][1]["within2x"], 6);
  EXPECT_GT(out["forms"][0]["residual"].get<double>(), 1.0);
}

}  // namespace
}  // namespace arena
