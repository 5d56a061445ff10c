#pragma once
// Sequence summaries (metrics.md): over frames t >= W (warm-up, default 8) -- mean, median, p95.
#include <nlohmann/json.hpp>
#include <vector>

namespace arena {

constexpr int kDefaultWarmup = 8;

struct Summary {
  double mean = 0, median = 0, p5 = 0, p95 = 0;
  int frames = 0;
  nlohmann::json toJson() const { return {{"mean", mean}, {"median", median}, {"p5", p5}, {"p95", p95}, {"frames", frames}}; }
};
// Percentiles by linear interpolation between order statistics. NaN entries (a metric undefined
// on a frame, e.g. flicker on frame 0) are skipped.
Summary summarize(const std::vector<double>& perFrame, int warmup);
double percentile(std::vector<double> values, double p);

}  // namespace arena
