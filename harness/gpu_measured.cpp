// `arena bench gpu-measured`: the cost model judged on a set it never saw, timed by us on a real
// GPU (bench/gpu/pass_timing.cu) rather than published: the SVGF à-trous step, N x N boxes, a
// copy and a format sweep at four resolutions. docs/gpu-cost.md ("A measured set") reads it.
#include <cmath>
#include <cstdio>
#include <regex>

#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/printed.hpp"
#include "core/sequence.hpp"
#include "denoisers/common/atrous.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/svgf.hpp"
#include "harness/gpu_cost.hpp"

namespace arena {

GpuCostModel boxAtrousModel(FixedCost fixed) {
  // `arena bench gpu-model`'s fit (docs/gpu-cost.md, section 4): k = 0.764, c = 0.153 ms, equal
  // for both forms because every point of the fit set is a full-screen dispatch. k is the value
  // of the fit's grid (0.05 x 400^(182/400)).
  return {0.05 * std::pow(400.0, 182.0 / 400.0), 0.153, fixed, gpuDevice("TITAN RTX").texelRateGTs};
}

MeasuredSet readMeasuredSet(const std::string& path) {
  const nlohmann::json doc = parseJsonFile(path);
  JsonReader root(doc, path);
  MeasuredSet set;
  set.device = root.string("device");
  root.integer("multiprocessors", 0);
  root.integer("l2Bytes", 0);
  for (JsonReader row : root.requiredArray("rows")) {
    MeasuredKernel k;
    k.kernel = row.string("kernel");
    k.width = row.integerIn("width", 1, 16384);
    k.height = row.integerIn("height", 1, 16384);
    // The count runs the kernel on images of the row's size: at most 8K's pixels.
    if (double(k.width) * double(k.height) > 7680.0 * 4320.0)
      row.fail(k.width > 7680 ? "width" : "height", "at most 7680x4320's pixels for the count (" +
                                                        std::to_string(k.width) + "x" +
                                                        std::to_string(k.height) + " given)");
    // A kernel the model cannot count is named with its row before anything is printed (a box
    // too wide for an int among them).
    try {
      measuredKernelTraffic(k.kernel, 8, 8);
    } catch (const std::exception& e) {
      row.fail("kernel", dynamic_cast<const Error*>(&e)
                             ? std::string(e.what())
                             : "measured kernel '" + k.kernel + "': a size the count cannot hold");
    }
    k.medianMs = row.number("medianMs");
    if (!(k.medianMs > 0) || !std::isfinite(k.medianMs)) row.fail("medianMs", "a positive time in ms");
    // The spread, where the row gives it, must be a spread around the median: a p5 above it or a
    // p95 below it is a file written wrong, not a measurement.
    for (const char* optional : {"p5Ms", "p95Ms", "backToBackMs"}) {
      if (!row.has(optional)) continue;
      const double ms = row.number(optional);
      if (!(ms > 0))
        row.fail(optional, "expected a positive time in ms");  // number() refuses non-finite
      if (std::string(optional) == "p5Ms" && ms > k.medianMs)
        row.fail(optional,
                 "expected at most the row's medianMs (" + printed("%g", k.medianMs) + ")");
      if (std::string(optional) == "p95Ms" && ms < k.medianMs)
        row.fail(optional,
                 "expected at least the row's medianMs (" + printed("%g", k.medianMs) + ")");
    }
    row.rejectUnread();
    // A kernel at one size timed twice would count twice in the fit's agreement figures.
    for (const MeasuredKernel& other : set.rows)
      if (other.kernel == k.kernel && other.width == k.width && other.height == k.height)
        row.fail("kernel", "one row per kernel and size; '" + k.kernel + "' at " +
                               std::to_string(k.width) + "x" + std::to_string(k.height) +
                               " is already a row");
    set.rows.push_back(k);
  }
  root.rejectUnread();
  if (set.rows.empty()) throw Error(path + ": $.rows is empty: a measured set needs at least one timed kernel");
  return set;
}

namespace {

// A flat frame with the guides the SVGF step reads (its taps do not depend on the content).
LayerSet flatFrame(int w, int h) {
  LayerSet frame;
  for (const LayerSpec& spec : channels::frameLayers()) frame.set(spec.name, Image(w, h, spec.channels()));
  frame.get("depth").fill(2.0f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) frame.get("normal").at(x, y, 2) = 1.0f;
  return frame;
}

// The storage formats of the format sweep, by the names pass_timing.cu gives them.
GpuFormat sweepFormat(const std::string& name, const std::string& kernel) {
  static const std::pair<const char*, GpuFormat> formats[] = {
      {"R8_UINT", GpuFormat::R8Unorm},         {"R16_FLOAT", GpuFormat::R16Float},
      {"R32_FLOAT", GpuFormat::R32Float},      {"R16G16B16A16_FLOAT", GpuFormat::RGBA16Float},
      {"R32G32_FLOAT", GpuFormat::RG32Float},  {"R32G32B32A32_FLOAT", GpuFormat::RGBA32Float}};
  for (const auto& [n, f] : formats)
    if (name == n) return f;
  throw Error("measured kernel '" + kernel + "': unknown format '" + name + "'");
}

}  // namespace

PassTraffic measuredKernelTraffic(const std::string& kernel, int w, int h) {
  PassTraffic t;
  std::smatch m;
  if (std::regex_match(kernel, m, std::regex("svgf-atrous-5x5-step([0-9]+)"))) {
    // The step as SVGF runs it: B3 5x5, depth + normal + luminance terms, variance propagated.
    const LayerSet frame = flatFrame(w, h);
    const GBufferView g = GBufferView::fromFrame(frame, {"depth", "normal", "meshId", "motion", "position"}, kernel);
    Image derivatives(w, h, kGeometryDerivativeChannels);
    computeGeometryDerivatives(g, derivatives);
    Image variance(w, h, 1, 0.1f), filtered(w, h, 1, 0.1f), varianceOut(w, h, 1), in(w, h, 3, 0.5f), out(w, h, 3);
    TrafficScope scope(&t);
    atrousIteration(0, svgfParams().defaults().atrous, {g, &derivatives, &filtered}, 1.0f, in, out, &variance, &varianceOut);
    return t;
  }
  TrafficScope scope(&t);
  if (kernel == "copy-1x1" || std::regex_match(kernel, m, std::regex("box-([0-9]+)x\\1"))) {
    const int n = kernel == "copy-1x1" ? 1 : std::stoi(m[1].str());
    gpu::dispatch(w, h);
    gpu::read(gpu_buffers::kRadiance, w, h, double(n) * n);
    gpu::write(gpu_buffers::kRadiance, w, h);
    return t;
  }
  if (std::regex_match(kernel, m, std::regex("format-7x7-([A-Z0-9_]+)"))) {
    const GpuBuffer in{"swept buffer", sweepFormat(m[1].str(), kernel)};
    gpu::dispatch(w, h);
    gpu::read(in, w, h, 49.0);
    gpu::write(GpuBuffer{"box output", GpuFormat::R32Float}, w, h);
    return t;
  }
  throw Error("measured kernel '" + kernel +
              "' is not one the model can count (svgf-atrous-5x5-stepN, copy-1x1, box-NxN, format-7x7-FORMAT)");
}

nlohmann::json benchGpuMeasured(const std::string& path, const std::string& deviceName,
                                const ProgressFn& progress) {
  const MeasuredSet set = readMeasuredSet(path);
  const GpuDevice* device = nullptr;
  if (!deviceName.empty()) device = &gpuDevice(deviceName);
  else
    for (const GpuDevice& d : gpuDevices())
      if (set.device.find(d.name) != std::string::npos) device = &d;
  // A set timed on a GPU the model knows, priced on another's specification, judges nothing.
  if (device && !deviceName.empty())
    for (const GpuDevice& d : gpuDevices())
      if (&d != device && set.device.find(d.name) != std::string::npos)
        throw Error(path + ": its times were measured on '" + set.device + "', which is the " +
                    d.name + "; priced on the " + device->name +
                    "'s specification they would judge the model on "
                    "another GPU's times (leave --device out to price on the " +
                    d.name + ")");
  if (!device) {
    std::string known;
    for (const GpuDevice& d : gpuDevices()) known += (known.empty() ? "" : ", ") + d.name;
    throw Error(path + ": device '" + set.device + "' is none of the known ones (" + known +
                "); pass --device with the one whose specification it has");
  }
  progress(printed("measured set %s: %zu kernels timed on '%s', priced on %s (%.0f GB/s, %.1f Gtexel/s)",
                   path.c_str(), set.rows.size(), set.device.c_str(), device->name.c_str(), device->bandwidthGBs,
                   device->texelRateGTs));
  if (set.device.find(device->name) == std::string::npos)
    progress("warning: the set's GPU is not the " + device->name +
             " whose specification prices it (--device): the ratios below are as good as that "
             "specification is the GPU's");
  const GpuCostModel forms[2] = {boxAtrousModel(FixedCost::PerDispatch), boxAtrousModel(FixedCost::PerThread)};
  progress(printed("model: the box/à-trous fit (k = %.3f, c = %.3f ms, scaled to this device by texel rate: "
                   "%.4f ms), never fitted on this set",
                   forms[0].fetchEfficiency, forms[0].dispatchMs,
                   forms[0].dispatchMs * forms[0].fitTexelRateGTs / device->texelRateGTs));
  progress(printed("  %-34s %9s %6s %6s %7s %9s %9s %7s %9s %7s", "kernel", "size", "B/px", "fetch", "cycles",
                   "measured", "dispatch", "ratio", "thread", "ratio"));
  nlohmann::json rows = nlohmann::json::array();
  std::vector<double> measured, predicted[2];
  double residual[2] = {0, 0};
  int within[2] = {0, 0};
  for (const MeasuredKernel& k : set.rows) {
    const PassTraffic t = measuredKernelTraffic(k.kernel, k.width, k.height);
    const double px = double(k.width) * k.height;
    double ms[2];
    for (int f = 0; f < 2; ++f) {
      ms[f] = predictPass(t, *device, forms[f]).totalMs();
      predicted[f].push_back(ms[f]);
      const double r = std::log(ms[f] / k.medianMs);
      residual[f] += r * r;
      within[f] += std::abs(r) <= std::log(2.0);
    }
    measured.push_back(k.medianMs);
    const PassPrediction roofline = predictPass(t, *device, {forms[0].fetchEfficiency, 0.0});
    progress(printed("  %-34s %4dx%-4d %6.1f %6.1f %7.1f %9.4f %9.4f %7.2f %9.4f %7.2f", k.kernel.c_str(), k.width,
                     k.height, (t.bytesRead() + t.bytesWritten()) / px, t.fetches() / px, t.fetchCycles() / px,
                     k.medianMs, ms[0], ms[0] / k.medianMs, ms[1], ms[1] / k.medianMs));
    rows.push_back({{"kernel", k.kernel},
                    {"size", {k.width, k.height}},
                    {"bytesPerPixel", (t.bytesRead() + t.bytesWritten()) / px},
                    {"fetchesPerPixel", t.fetches() / px},
                    {"fetchCyclesPerPixel", t.fetchCycles() / px},
                    {"measuredMs", k.medianMs},
                    {"rooflineMs", roofline.totalMs()},
                    {"predictedPerDispatchMs", ms[0]},
                    {"predictedPerThreadMs", ms[1]}});
  }
  nlohmann::json out = {{"file", path}, {"timedOn", set.device}, {"pricedAs", device->name}, {"rows", rows},
                        {"forms", nlohmann::json::array()}};
  for (int f = 0; f < 2; ++f) {
    const char* name = f == 0 ? "per dispatch" : "per thread";
    const double rho = spearman(predicted[f], measured);
    progress(printed("fixed cost %-12s: %d of %zu within 2x, sum(log ratio^2) = %.2f, Spearman %s",
                     name, within[f], set.rows.size(), residual[f],
                     spearmanText(rho, measured.size()).c_str()));
    out["forms"].push_back(
        {{"form", name}, {"within2x", within[f]}, {"rows", set.rows.size()}, {"residual", residual[f]}, {"spearman", rho}});
  }
  out["chosenForm"] = residual[1] < residual[0] ? "per thread" : "per dispatch";
  progress(std::string("the form with the smaller residual on this set: ") + out["chosenForm"].get<std::string>());
  return out;
}

}  // namespace arena
