#include "metrics/ghosting.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "metrics/summary.hpp"

namespace arena {

Image changedRegion(const Image& r0, const Image& rBefore, const GhostingConfig& c) {
  if (!r0.sameShape(rBefore)) throw Error("changed region: references differ in size");
  Image mask(r0.width(), r0.height(), 1);
  for (size_t i = 0; i < r0.pixelCount(); ++i) {
    double l0 = luminance(r0.plane(0)[i], r0.plane(1)[i], r0.plane(2)[i]);
    double l1 = luminance(rBefore.plane(0)[i], rBefore.plane(1)[i], rBefore.plane(2)[i]);
    mask.plane(0)[i] = std::abs(l0 - l1) > c.tau * (l1 + c.eps) ? 1.0f : 0.0f;
  }
  return mask;
}

void addTrail(Image& mask, int objectId, const std::vector<const Image*>& previous, const Image& current) {
  for (size_t i = 0; i < mask.pixelCount(); ++i) {
    if (int(current.plane(0)[i]) == objectId) continue;
    for (const Image* p : previous)
      if (int(p->plane(0)[i]) == objectId) {
        mask.plane(0)[i] = 1.0f;
        break;
      }
  }
}

double signedBias(const Image& d, const Image& r, const Image& mask, double eps) {
  double s = 0, n = 0;
  for (size_t i = 0; i < d.pixelCount(); ++i) {
    if (mask.plane(0)[i] == 0) continue;
    double ld = luminance(d.plane(0)[i], d.plane(1)[i], d.plane(2)[i]);
    double lr = luminance(r.plane(0)[i], r.plane(1)[i], r.plane(2)[i]);
    s += (ld - lr) / (lr + eps);
    n += 1;
  }
  return n > 0 ? s / n : 0.0;
}

GhostingResult analyseGhosting(int t0, int begin, const std::vector<double>& curve, const std::vector<double>& bias,
                               const GhostingConfig& c) {
  GhostingResult g;
  g.eventFrame = t0;
  g.windowBegin = begin;
  g.windowEnd = begin + int(curve.size()) - 1;
  g.curve = curve;
  g.bias = bias;
  if (curve.empty()) return g;
  const size_t n = curve.size();
  const size_t steadyFrom = n > size_t(c.steadyFrames) ? n - size_t(c.steadyFrames) : 0;
  g.steadyState = percentile(std::vector<double>(curve.begin() + long(steadyFrom), curve.end()), 50);
  const size_t first = size_t(std::clamp(t0 - begin, 0, int(n) - 1));
  double peak = *std::max_element(curve.begin() + long(first), curve.end());
  g.peakExcess = peak - g.steadyState;
  const double threshold = g.steadyState + 0.1 * g.peakExcess;
  // The first frame after which the curve stays under the threshold for good.
  size_t settle = n;
  for (size_t i = n; i-- > first;) {
    if (curve[i] > threshold) break;
    settle = i;
  }
  g.responseFrames = settle == n ? int(n - first) : int(settle - first);
  for (size_t i = first; i < n; ++i) g.ghostEnergy += std::max(0.0, curve[i] - g.steadyState);
  double b = 0;
  int k = 0;
  for (size_t i = first; i < std::min(n, first + 5); ++i, ++k) b += i < bias.size() ? bias[i] : 0.0;
  g.signedBias = k > 0 ? b / k : 0.0;
  return g;
}

nlohmann::json GhostingResult::toJson() const {
  return {{"eventFrame", eventFrame}, {"windowBegin", windowBegin}, {"windowEnd", windowEnd},
          {"curve", curve}, {"bias", bias}, {"steadyState", steadyState}, {"peakExcess", peakExcess},
          {"responseFrames", responseFrames}, {"ghostEnergy", ghostEnergy}, {"signedBias", signedBias},
          {"maskFraction", maskFraction}};
}

}  // namespace arena
