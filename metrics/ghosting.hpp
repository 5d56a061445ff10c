#pragma once
// Ghosting and lag around scripted events (metrics.md, "Ghosting and lag").
#include <nlohmann/json.hpp>
#include <vector>

#include "core/image.hpp"

namespace arena {

struct GhostingConfig {
  double tau = 0.2;       // changed-region threshold, relative
  double eps = 0.01;
  int before = 5;         // window starts at t0 - 5
  int after = 60;         // ... and ends at t0 + 60 (clipped, see below)
  int steadyFrames = 10;  // E_ss = median of the last 10 frames of the window
  int trailFrames = 8;    // K: frames an object's trail stays in the mask
};

// Pixels where |L(r_t0) - L(r_t0-1)| > tau * (L(r_t0-1) + eps): 1 inside, 0 outside.
Image changedRegion(const Image& referenceAtEvent, const Image& referenceBefore, const GhostingConfig& c = {});
// Adds the trail of a moving object: pixels covered by `objectId` in any of `previousMeshIds` but
// not in `currentMeshId`.
void addTrail(Image& mask, int objectId, const std::vector<const Image*>& previousMeshIds, const Image& currentMeshId);

struct GhostingResult {
  int eventFrame = 0, windowBegin = 0, windowEnd = 0;  // window [begin, end], inclusive
  std::vector<double> curve;                           // E_M(t) for t in the window
  std::vector<double> bias;                            // signed bias in M per window frame
  double steadyState = 0, peakExcess = 0, ghostEnergy = 0, signedBias = 0;
  int responseFrames = 0;  // first t - t0 after which E_M stays <= E_ss + 0.1 (peak - E_ss)
  double maskFraction = 0;
  nlohmann::json toJson() const;
};
// Derives the event's numbers from its E_M(t) curve (window frames [begin, end], event at t0).
// signedBias is the mean per-frame bias over the first five frames from t0.
GhostingResult analyseGhosting(int t0, int begin, const std::vector<double>& curve, const std::vector<double>& bias,
                               const GhostingConfig& c = {});

// Signed luminance bias in the mask: mean of (L(d) - L(r)) / (L(r) + eps).
double signedBias(const Image& denoised, const Image& reference, const Image& mask, double eps = 0.01);

}  // namespace arena
