#pragma once
// The speed/accuracy Pareto front: the settings no other setting beats on both time and error.
// Computed here rather than in the page so that it is unit-tested and every chart draws the same
// one.
#include <cstddef>
#include <vector>

namespace arena {

struct ParetoPoint {
  double time = 0;   // ms per frame: lower is better
  double error = 0;  // any error metric oriented so that lower is better
};

// Indices of the points on the lower-left front, ordered by increasing time (then error).
// A point is on the front when no other point is at least as good on both axes and strictly
// better on one. Ties: exact duplicates are all kept (neither dominates the other); a point with
// the same time but a larger error, or the same error but a larger time, is dominated and
// dropped. Points with a non-finite coordinate (a failed or unmeasured setting) are ignored.
std::vector<size_t> paretoFront(const std::vector<ParetoPoint>& points);

}  // namespace arena
