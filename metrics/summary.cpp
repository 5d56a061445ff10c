#include "metrics/summary.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"

namespace arena {

using nlohmann::json;

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return kUndefined;
  std::sort(v.begin(), v.end());
  double pos = p / 100.0 * double(v.size() - 1);
  size_t lo = size_t(std::floor(pos)), hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - double(lo)) * (v[hi] - v[lo]);
}

Summary summarize(const std::vector<double>& perFrame, int warmup) {
  std::vector<double> v;
  for (size_t t = size_t(std::max(warmup, 0)); t < perFrame.size(); ++t)
    if (!std::isnan(perFrame[t])) v.push_back(perFrame[t]);
  Summary s;
  s.frames = int(v.size());
  if (v.empty()) return s;
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / double(v.size());
  s.median = percentile(v, 50);
  s.p5 = percentile(v, 5);
  s.p95 = percentile(v, 95);
  return s;
}

json Summary::toJson() const {
  if (empty()) return {{"frames", 0}, {"absent", "no frame to summarise"}};
  return {{"mean", mean}, {"median", median}, {"p5", p5}, {"p95", p95}, {"frames", frames}};
}

void PairSeries::record(const std::string& metric, int frame, double value, TileSums tiles,
                        FrameTransform transform) {
  if (frame < 0 || frame >= frames_)
    throw Error("metric " + metric + ": frame " + std::to_string(frame) + " out of range");
  Series& s = series_[metric];
  if (s.values.empty()) {
    s.values.assign(size_t(frames_), kUndefined);
    s.tiles.transform = transform;
  }
  s.values[size_t(frame)] = std::isfinite(value) ? value : std::numeric_limits<double>::infinity();
  if (frame < warmup_ || !std::isfinite(value)) return;
  if (tiles.empty())
    s.tiles.addScalar(frame, value);
  else
    s.tiles.add(frame, std::move(tiles));
}

std::vector<double> PairSeries::values(const std::string& metric) const {
  auto it = series_.find(metric);
  if (it == series_.end()) return std::vector<double>(size_t(frames_), kUndefined);
  std::vector<double> v = it->second.values;
  for (double& x : v)
    if (std::isinf(x)) x = kUndefined;  // non-finite frames are counted in summaries, not values
  return v;
}

json PairSeries::summaries(const std::string& seedName, const BootstrapConfig& cfg) const {
  json out = json::object();
  for (const auto& [name, s] : series_) {
    int defined = 0, nonFinite = 0, firstNonFinite = -1;
    for (size_t t = size_t(warmup_); t < s.values.size(); ++t) {
      if (std::isnan(s.values[t])) continue;
      ++defined;
      if (std::isinf(s.values[t]) && nonFinite++ == 0) firstNonFinite = int(t);
    }
    if (defined == 0) {
      out[name] = {
          {"frames", 0},
          {"absent", frames_ <= warmup_ ? "no frame after the warm-up: the sequence has " +
                                              std::to_string(frames_) + " frames, the warm-up is " +
                                              std::to_string(warmup_)
                                        : "undefined on every frame after the warm-up"}};
      continue;
    }
    if (nonFinite > 0) {
      std::string why =
          "its value is not finite (NaN or Inf) on ";  // appended: GCC 12 warns falsely on +
      why += std::to_string(nonFinite);
      why += " of ";
      why += std::to_string(defined);
      why += " frames after the warm-up, first frame ";
      why += std::to_string(firstNonFinite);
      why +=
          " (the images it reads are checked finite before: the metric's own arithmetic failed "
          "there, e.g. a division by 0 or an overflow)";
      out[name] = {{"frames", defined}, {"nonFinite", nonFinite}, {"absent", why}};
      continue;
    }
    json j = summarize(values(name), warmup_).toJson();
    j["ci95"] = meanInterval(s.tiles, seedName, cfg).toJson();
    out[name] = j;
  }
  return out;
}

json PairSeries::tilesJson() const {
  json out = json::object();
  for (const auto& [name, s] : series_)
    if (!s.tiles.empty()) out[name] = s.tiles.toJson();
  return out;
}

}  // namespace arena
