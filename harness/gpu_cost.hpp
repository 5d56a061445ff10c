#pragma once
// A GPU cost model over the traffic the passes count (denoisers/common/gpu_traffic.hpp), checked
// against published timings (docs/gpu-cost.md):
//   t(pass) = max(bytes / bandwidth, k * fetchCycles / texelRate) + c * (dispatches or threads)
// bandwidth and texelRate come from each device's specification; k (how many texture-unit cycles
// a counted fetch cycle really costs) and c (fixed ms per dispatch) are the only fitted
// constants, fitted on one published set (the CEDEC 2021 box-filter vs à-trous experiment) and
// judged on the sets they never saw. `arena bench gpu-model` prints the validation tables.
#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/denoiser.hpp"
#include "tracer/render.hpp"

namespace arena {

struct GpuDevice {
  std::string name;
  double bandwidthGBs = 0;  // DRAM bandwidth, GB/s (1e9 bytes)
  double texelRateGTs = 0;  // 32-bit bilinear texels per second, 1e9 (TMUs x boost clock)
  std::string source;       // where the two numbers come from
};
const std::vector<GpuDevice>& gpuDevices();  // TITAN RTX, RTX 4080, PS5, H200
const GpuDevice& gpuDevice(const std::string& name);  // throws an Error naming the known ones

// The fixed term, two forms fitted alike and both reported (docs/gpu-cost.md): per dispatch
// (launch, barrier, a wave's ramp) or per thread (the ALU work of the weights, which grows with
// the pixels a dispatch covers); per thread, c is quoted per 1920x1080 dispatch. On another
// device c scales with the fit device's texel rate over its own (a chip with more units does the
// same work sooner).
enum class FixedCost { PerDispatch, PerThread };
struct GpuCostModel {
  double fetchEfficiency = 1.0;  // k
  double dispatchMs = 0.0;       // c
  FixedCost fixed = FixedCost::PerDispatch;
  double fitTexelRateGTs = 0;  // the fit device's; 0: c used as is
};

struct PassPrediction {
  double memoryMs = 0, fetchMs = 0, fixedMs = 0;
  double totalMs() const { return std::max(memoryMs, fetchMs) + fixedMs; }
  bool fetchBound() const { return fetchMs >= memoryMs; }
};
PassPrediction predictPass(const PassTraffic& traffic, const GpuDevice& device,
                           const GpuCostModel& model);

// The traffic of a pass at `pixelFactor` times the pixels (per-pixel counts kept, dispatches
// kept): the same pass at another resolution, where its taps do not depend on the resolution.
PassTraffic scaleTraffic(const PassTraffic& traffic, double pixelFactor);
// One dispatch serving two signals (the way the talk's and NRD's passes read diffuse and specular
// together): the G-buffer inputs are read once, every other buffer for each signal.
PassTraffic mergeSignals(const PassTraffic& a, const PassTraffic& b);
// The same pass gathering `factor` times the taps of every buffer it gathers (> 1 tap per
// thread): a 3x3 à-trous iteration turned into a box of factor x 9 taps.
PassTraffic scaleGather(const PassTraffic& traffic, double factor);
// `copies` dispatches of the same pass in a row.
PassTraffic repeatPass(const PassTraffic& traffic, int copies);

// The model every prediction outside `arena bench gpu-model` uses: the bench's fit on the
// box/à-trous experiment (k, c), stored so that a study need not render 1080p frames to fit it
// (the bench prints whether its fit still gives these), with the fixed term per thread -- the
// form the measured set (bench/gpu/pass_timing.cu on an H200, docs/gpu-cost.md) chose, a set the
// fit never saw.
GpuCostModel boxAtrousModel(FixedCost fixed = FixedCost::PerThread);

// A frame's passes as a GPU would dispatch them: in the order they first ran (over every signal's
// instance), each pass's signals merged into one dispatch (mergeSignals), "signal/pass" names
// read as "pass". A pass only one signal runs (hybrid's specular median) is there too.
struct MergedPass {
  std::string name;
  PassTraffic traffic;
  double cpuMs = 0;  // the instances' measured times of the pass, summed
};
std::vector<MergedPass> mergedPasses(const std::vector<PassStats>& passes);

// One frame of a denoiser priced: `passes` as a run reports them (each signal's instance its own
// list, or one list with "signal/pass" names), every pass's signals merged into one dispatch
// (mergeSignals: the G-buffer read once), scaled by `pixelFactor`, priced and summed.
double predictFrameMs(const std::vector<PassStats>& passes, const GpuDevice& device,
                      const GpuCostModel& model, double pixelFactor = 1.0);

// GPU-format memory of one instance from the buffers its passes touched: each buffer the denoiser
// owns once, at its largest size (a mip chain: its levels summed); persistent = the history ones
// (read next frame); a transient buffer some dispatch both reads and writes needs two (ping-pong).
// Engine inputs ("(input)": G-buffer, noisy signal) are not the denoiser's, as in NRD's table.
struct GpuMemory {
  double persistent = 0, transient = 0;  // bytes
};
GpuMemory gpuMemory(const std::vector<PassStats>& passes);

// The study's GPU axis (docs/gpu-cost.md section 7): each frame's passes priced at 1920x1080
// on every known device with boxAtrousModel(). The counts come from the sequence's resolution and
// are scaled (scaleTraffic); taps that depend on the data are those of this sequence.
class GpuFrameCost {
 public:
  GpuFrameCost(int width, int height);
  void add(const std::vector<PassStats>& passes);
  // {"resolution", "model", "devices": [{device, msMedian, msP5, msP95, msMean}], "memory":
  // {persistentMiB, workingSetMiB}, "orderTolerance" (kGpuOrderTolerance: the report orders the
  // times with it)} over the frames after `warmup` (memory: the last frame's
  // buffers at 1920x1080, every signal's instance summed); null when no pass counted any traffic
  // (an external denoiser: nothing to price).
  nlohmann::json summary(int warmup) const;

 private:
  double pixelFactor_;
  bool counted_ = false;
  std::vector<PassStats> last_;  // the last frame's passes (summary() scales their memory)
  std::vector<std::vector<double>> ms_;  // per device, per frame
};

struct FitPoint {
  std::string name;
  PassTraffic traffic;
  double publishedMs = 0;
};
// k and c minimising sum(log(predicted / published)^2) over the points (a grid search: k on a
// log grid 0.05..20, c on 0..0.5 ms), for the fixed term's form given.
GpuCostModel fitModel(const std::vector<FitPoint>& points, const GpuDevice& device,
                      FixedCost fixed = FixedCost::PerDispatch);

// Predicted times of two methods less than 10% apart are not ordered by the model: within its
// error (single passes off by 2-6x on the measured set, docs/gpu-cost.md) the order of two such
// totals is no finding. A run records it (GpuFrameCost's "orderTolerance") for whoever orders its
// times.
inline constexpr double kGpuOrderTolerance = 0.10;
// The separators of an ascending order of times: " ≈ " joins a time less than `tolerance`
// (relative) above the first, fastest, of its group; " < " starts the next group (so 5.5 ≈ 5.9
// < 6.3: the ends of a group are less than the tolerance apart). The first separator is "".
std::vector<std::string> orderSeparators(const std::vector<double>& ascendingMs, double tolerance);

// Spearman's rank correlation (ties get their mean rank); NaN (JSON null) where it is undefined:
// fewer than 2 values, or every value of one side tied. spearmanText says which, or "%.2f".
double spearman(const std::vector<double>& a, const std::vector<double>& b);
std::string spearmanText(double rho, size_t values);

// `arena bench gpu-model`.
struct GpuModelBench {
  std::string sceneFile;
  std::vector<std::string> denoisers;  // the per-denoiser table and the memory table
  // Their parameters where not the defaults (denoiser -> name -> value), as --param gives them.
  std::map<std::string, std::map<std::string, std::string>> params;
  std::string device = "TITAN RTX";
  int width = 1920, height = 1080, frames = 5;  // the last counted: h >= 4 by then
};
nlohmann::json benchGpuModel(const GpuModelBench& bench, const ProgressFn& progress);

// `arena bench gpu-measured FILE`: the kernels of a measured set (the JSON that
// bench/gpu/pass_timing.cu prints) priced by the model on `device` and compared with their
// measured median, for both forms of the fixed term. Their traffic is counted with the blocks
// and the recorder the denoisers use (the SVGF step by atrousIteration itself).
struct MeasuredKernel {
  std::string kernel;
  int width = 0, height = 0;
  double medianMs = 0;
};
struct MeasuredSet {
  std::string device;  // as the GPU named itself
  std::vector<MeasuredKernel> rows;
};
// Throws an Error naming the file, the row and the field that is missing or wrong.
MeasuredSet readMeasuredSet(const std::string& path);
// Throws an Error naming a kernel it does not know.
PassTraffic measuredKernelTraffic(const std::string& kernel, int width, int height);
// `device`: a name of gpuDevices(); empty: the one whose name the file's device contains.
nlohmann::json benchGpuMeasured(const std::string& path, const std::string& device,
                                const ProgressFn& progress);

}  // namespace arena
