#include "metrics/summary.hpp"

#include <algorithm>
#include <cmath>

namespace arena {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
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

}  // namespace arena
