#include "harness/gpu_cost.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>

#include "core/error.hpp"
#include "core/printed.hpp"
#include "metrics/summary.hpp"

namespace arena {

const std::vector<GpuDevice>& gpuDevices() {
  // Texel rate = TMUs x boost clock (the fill-rate line of a spec sheet: 32-bit bilinear texels).
  static const std::vector<GpuDevice> devices = {
      {"TITAN RTX", 672.0, 288 * 1.770,
       "NVIDIA launch specification (Dec 2018): 384-bit GDDR6 at 14 Gbps = 672 GB/s; full TU102, "
       "288 TMUs, 1770 MHz boost"},
      {"RTX 4080", 716.8, 304 * 2.505,
       "NVIDIA specification: 256-bit GDDR6X at 22.4 Gbps = 716.8 GB/s; AD103, 304 TMUs, "
       "2505 MHz boost"},
      {"PS5", 448.0, 144 * 2.23,
       "Sony (M. Cerny, 'The Road to PS5', 2020): 256-bit GDDR6 at 14 Gbps = 448 GB/s; 36 RDNA2 "
       "CUs x 4 TMUs, up to 2.23 GHz"},
      {"H200", 4800.0, 528 * 1.98,
       "NVIDIA H200 SXM datasheet: 4.8 TB/s HBM3e; GH100 as in H100 SXM5 (Hopper whitepaper): "
       "132 SMs x 4 = 528 texture units, 1980 MHz boost (nvidia-smi's max SM clock there)"},
  };
  return devices;
}

const GpuDevice& gpuDevice(const std::string& name) {
  std::string known;
  for (const GpuDevice& d : gpuDevices()) {
    if (d.name == name) return d;
    known += (known.empty() ? "" : ", ") + d.name;
  }
  throw Error("unknown GPU device '" + name + "'; known: " + known);
}

PassPrediction predictPass(const PassTraffic& t, const GpuDevice& d, const GpuCostModel& m) {
  PassPrediction p;
  p.memoryMs = (t.bytesRead() + t.bytesWritten()) / (d.bandwidthGBs * 1e9) * 1e3;
  p.fetchMs = m.fetchEfficiency * t.fetchCycles() / (d.texelRateGTs * 1e9) * 1e3;
  const double units = m.fixed == FixedCost::PerDispatch ? double(t.dispatches.size())
                                                         : t.threads() / (1920.0 * 1080.0);
  const double scale = m.fitTexelRateGTs > 0 ? m.fitTexelRateGTs / d.texelRateGTs : 1.0;
  p.fixedMs = m.dispatchMs * units * scale;
  return p;
}

PassTraffic scaleTraffic(const PassTraffic& traffic, double pixelFactor) {
  PassTraffic out = traffic;
  const double side = std::sqrt(pixelFactor);
  for (BufferTraffic& b : out.buffers) {
    b.texels *= pixelFactor;
    b.fetches *= pixelFactor;
    b.width = int(std::lround(b.width * side));
    b.height = int(std::lround(b.height * side));
  }
  for (auto& d : out.dispatches) {
    d[0] = int(std::lround(d[0] * side));
    d[1] = int(std::lround(d[1] * side));
  }
  return out;
}

namespace {
bool sharedInput(const BufferTraffic& b) {
  return b.name.find("(input)") != std::string::npos && b.name != gpu_buffers::kSignal.name;
}
}  // namespace

PassTraffic mergeSignals(const PassTraffic& a, const PassTraffic& b) {
  PassTraffic out = a;
  if (b.dispatches.size() > out.dispatches.size()) out.dispatches = b.dispatches;
  for (const BufferTraffic& buffer : b.buffers) {
    auto same = std::find_if(out.buffers.begin(), out.buffers.end(), [&](const BufferTraffic& o) {
      return o.name == buffer.name && o.write == buffer.write && o.dispatch == buffer.dispatch;
    });
    if (sharedInput(buffer) && same != out.buffers.end()) {
      same->fetches = std::max(same->fetches, buffer.fetches);
      continue;
    }
    out.buffers.push_back(buffer);
  }
  return out;
}

PassTraffic scaleGather(const PassTraffic& traffic, double factor) {
  PassTraffic out = traffic;
  for (BufferTraffic& b : out.buffers) {
    const auto& d = out.dispatches[size_t(b.dispatch)];
    const double threads = double(d[0]) * double(d[1]);
    if (!b.write && b.fetches > 1.5 * threads) b.fetches *= factor;
  }
  return out;
}

PassTraffic repeatPass(const PassTraffic& traffic, int copies) {
  PassTraffic out;
  for (int k = 0; k < copies; ++k) {
    const int offset = int(out.dispatches.size());
    out.dispatches.insert(out.dispatches.end(), traffic.dispatches.begin(),
                          traffic.dispatches.end());
    for (BufferTraffic b : traffic.buffers) {
      b.dispatch += offset;
      out.buffers.push_back(b);
    }
  }
  return out;
}

std::vector<std::string> orderSeparators(const std::vector<double>& ascendingMs, double tolerance) {
  std::vector<std::string> out;
  double groupStart = 0;
  for (size_t i = 0; i < ascendingMs.size(); ++i) {
    const bool joins = i > 0 && tolerance > 0 && ascendingMs[i] < groupStart * (1 + tolerance);
    out.push_back(i == 0 ? "" : joins ? " ≈ " : " < ");
    if (!joins) groupStart = ascendingMs[i];
  }
  return out;
}

std::vector<MergedPass> mergedPasses(const std::vector<PassStats>& passes) {
  std::vector<MergedPass> merged;
  for (const PassStats& p : passes) {
    const size_t slash = p.name.find('/');
    const std::string name = slash == std::string::npos ? p.name : p.name.substr(slash + 1);
    auto it = std::find_if(merged.begin(), merged.end(),
                           [&](const MergedPass& m) { return m.name == name; });
    if (it == merged.end()) {
      merged.push_back({name, p.traffic, p.milliseconds});
    } else {
      it->traffic = mergeSignals(it->traffic, p.traffic);
      it->cpuMs += p.milliseconds;
    }
  }
  return merged;
}

double predictFrameMs(const std::vector<PassStats>& passes, const GpuDevice& device,
                      const GpuCostModel& model, double pixelFactor) {
  double ms = 0;
  for (const MergedPass& p : mergedPasses(passes))
    if (!p.traffic.empty())
      ms += predictPass(scaleTraffic(p.traffic, pixelFactor), device, model).totalMs();
  return ms;
}

GpuMemory gpuMemory(const std::vector<PassStats>& passes) {
  struct Owned {
    double bytes = 0;
    bool history = false, pingPong = false;
  };
  std::map<std::string, Owned> owned;
  for (const PassStats& p : passes) {
    std::map<std::string, double> levels;  // this pass's writes per name: mip levels add up
    for (const BufferTraffic& b : p.traffic.buffers) {
      if (b.name.find("(input)") != std::string::npos) continue;
      const double bytes = double(b.width) * double(b.height) * gpuFormatBytes(b.format);
      Owned& o = owned[b.name];
      o.history = o.history || b.history;
      if (b.write && b.name.find("mip") != std::string::npos) levels[b.name] += bytes;
      o.bytes = std::max(o.bytes, bytes);
      for (const BufferTraffic& c : p.traffic.buffers)
        if (c.name == b.name && c.dispatch == b.dispatch && c.write != b.write) o.pingPong = true;
    }
    for (const auto& [name, bytes] : levels) owned[name].bytes = std::max(owned[name].bytes, bytes);
  }
  GpuMemory m;
  for (const auto& [name, o] : owned)
    (o.history ? m.persistent : m.transient) += o.bytes * (o.pingPong && !o.history ? 2.0 : 1.0);
  return m;
}

GpuFrameCost::GpuFrameCost(int width, int height)
    : pixelFactor_(1920.0 * 1080.0 / (double(width) * double(height))), ms_(gpuDevices().size()) {}

void GpuFrameCost::add(const std::vector<PassStats>& passes) {
  for (const PassStats& p : passes) counted_ = counted_ || !p.traffic.empty();
  for (size_t d = 0; d < gpuDevices().size(); ++d)
    ms_[d].push_back(predictFrameMs(passes, gpuDevices()[d], boxAtrousModel(), pixelFactor_));
  last_ = passes;
}

nlohmann::json GpuFrameCost::summary(int warmup) const {
  if (!counted_) return nullptr;
  // No frame after the warm-up (a capture no longer than it): no prediction, rather than NaN times.
  if (ms_.empty() || summarize(ms_.front(), warmup).empty()) return nullptr;
  nlohmann::json devices = nlohmann::json::array();  // in gpuDevices()'s order
  for (size_t d = 0; d < gpuDevices().size(); ++d) {
    const Summary s = summarize(ms_[d], warmup);
    devices.push_back({{"device", gpuDevices()[d].name}, {"msMedian", s.median}, {"msP5", s.p5}, {"msP95", s.p95},
                       {"msMean", s.mean}});
  }
  // Memory: each signal's instance owns its buffers ("diffuse/...", "specular/..." passes).
  std::map<std::string, std::vector<PassStats>> instances;
  for (PassStats p : last_) {
    const size_t slash = p.name.find('/');
    p.traffic = scaleTraffic(p.traffic, pixelFactor_);
    instances[slash == std::string::npos ? "" : p.name.substr(0, slash)].push_back(p);
  }
  double persistent = 0, working = 0;
  for (const auto& [signal, passes] : instances) {
    const GpuMemory m = gpuMemory(passes);
    persistent += m.persistent;
    working += m.persistent + m.transient;
  }
  constexpr double kMiB = 1024.0 * 1024.0;
  const GpuCostModel m = boxAtrousModel();
  int skipped = 0;  // on the last frame: the same on every frame (the footprint is per resolution)
  for (const PassStats& p : last_) skipped += p.traffic.skippedHere;
  nlohmann::json out = {
      {"resolution", {1920, 1080}},
      {"memory", {{"persistentMiB", persistent / kMiB}, {"workingSetMiB", working / kMiB}}},
      {"model",
       "max(bytes / bandwidth, k x fetch cycles / texel rate) + c x threads / 1920x1080; " +
           printed("k = %.3f, c = %.3f ms", m.fetchEfficiency, m.dispatchMs) +
           " (docs/gpu-cost.md)"},
      {"devices", devices},
      // How its times are read: two less than this apart (relative) are not ordered by the model.
      {"orderTolerance", kGpuOrderTolerance}};
  if (skipped > 0) out["skippedHere"] = skipped;
  return out;
}

GpuCostModel fitModel(const std::vector<FitPoint>& points, const GpuDevice& device,
                      FixedCost fixed) {
  GpuCostModel best;
  best.fixed = fixed;
  best.fitTexelRateGTs = device.texelRateGTs;
  double bestError = INFINITY;
  for (int i = 0; i <= 400; ++i) {
    const double k = 0.05 * std::pow(400.0, i / 400.0);  // 0.05 .. 20
    for (int j = 0; j <= 500; ++j) {
      const GpuCostModel m{k, 0.001 * j, fixed, device.texelRateGTs};  // c: 0 .. 0.5 ms
      double error = 0;
      for (const FitPoint& p : points) {
        const double r = std::log(predictPass(p.traffic, device, m).totalMs() / p.publishedMs);
        error += r * r;
      }
      if (error < bestError) {
        bestError = error;
        best = m;
      }
    }
  }
  return best;
}

namespace {
std::vector<double> ranks(const std::vector<double>& v) {
  std::vector<size_t> order(v.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return v[a] < v[b]; });
  std::vector<double> r(v.size());
  for (size_t i = 0; i < order.size();) {
    size_t j = i;
    while (j + 1 < order.size() && v[order[j + 1]] == v[order[i]]) ++j;
    for (size_t k = i; k <= j; ++k) r[order[k]] = 0.5 * double(i + j) + 1.0;
    i = j + 1;
  }
  return r;
}
}  // namespace

double spearman(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size() || a.size() < 2) return std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> ra = ranks(a), rb = ranks(b);
  const double n = double(a.size());
  const double ma = std::accumulate(ra.begin(), ra.end(), 0.0) / n;
  const double mb = std::accumulate(rb.begin(), rb.end(), 0.0) / n;
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < ra.size(); ++i) {
    sab += (ra[i] - ma) * (rb[i] - mb);
    saa += (ra[i] - ma) * (ra[i] - ma);
    sbb += (rb[i] - mb) * (rb[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : std::numeric_limits<double>::quiet_NaN();
}

std::string spearmanText(double rho, size_t values) {
  if (std::isfinite(rho)) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", rho);
    return buf;
  }
  return values < 2 ? "undefined (fewer than two values)"
                    : "undefined (every value of one side tied)";
}

}  // namespace arena
