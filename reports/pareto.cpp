#include "reports/pareto.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace arena {

std::vector<size_t> paretoFront(const std::vector<ParetoPoint>& points) {
  std::vector<size_t> order;
  for (size_t i = 0; i < points.size(); ++i)
    if (std::isfinite(points[i].time) && std::isfinite(points[i].error)) order.push_back(i);
  // Sweep from the fastest point: after sorting by (time, error), a point is non-dominated exactly
  // when its error is below every error seen so far, or equals the best one at the same time.
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (points[a].time != points[b].time) return points[a].time < points[b].time;
    return points[a].error < points[b].error;
  });
  std::vector<size_t> front;
  for (size_t i : order) {
    if (front.empty()) {
      front.push_back(i);
      continue;
    }
    const ParetoPoint& best = points[front.back()];
    const ParetoPoint& p = points[i];
    if (p.error < best.error || (p.error == best.error && p.time == best.time)) front.push_back(i);
  }
  return front;
}

}  // namespace arena
