#pragma once
// Sequence summaries (metrics.md): over frames t >= W (warm-up, default 8) -- mean, median, p95,
// and the mean's 95% interval (metrics/statistics.hpp). A summary over no valid data is *absent*
// with its reason, never 0 or a perfect score.
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "metrics/statistics.hpp"

namespace arena {

constexpr int kDefaultWarmup = 8;

struct Summary {
  double mean = kUndefined, median = kUndefined, p5 = kUndefined, p95 = kUndefined;
  int frames = 0;
  bool empty() const { return frames == 0; }
  nlohmann::json toJson() const;
};
// Percentiles by linear interpolation between order statistics. NaN entries (a metric undefined
// on a frame, e.g. flicker on frame 0) are skipped; no entry left gives an empty summary.
Summary summarize(const std::vector<double>& perFrame, int warmup);
double percentile(std::vector<double> values, double p);

// Every metric of one pair, frame by frame, with the tile sums behind each value; then their
// summaries. A metric's frame is either undefined (not recorded: flicker on frame 0, warped flicker
// without a consistent pixel) or a value; a non-finite value makes the summary absent (counted
// and named), so a NaN frame can never vanish from a mean unnoticed.
class PairSeries {
 public:
  PairSeries(int frames, int warmup) : frames_(frames), warmup_(std::max(warmup, 0)) {}
  // Empty `tiles`: a scalar per frame (time, effective spp), resampled by frame blocks alone.
  void record(const std::string& metric, int frame, double value, TileSums tiles,
              FrameTransform transform);
  // Per frame, NaN where undefined.
  std::vector<double> values(const std::string& metric) const;
  // metric -> {mean, median, p5, p95, frames, ci95} or {frames, nonFinite?, absent}.
  nlohmann::json summaries(const std::string& seedName, const BootstrapConfig& cfg = {}) const;
  // metric -> MetricTiles json of the frames after the warm-up (for paired comparisons later).
  nlohmann::json tilesJson() const;

 private:
  struct Series {
    std::vector<double> values;
    MetricTiles tiles;
  };
  int frames_, warmup_;
  std::map<std::string, Series> series_;
};

}  // namespace arena
