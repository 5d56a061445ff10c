#pragma once
// Multi-scale temporal stability (docs/metrics.md, "Multi-scale temporal stability"): the
// motion-compensated change of a frame against the frames 1, 2 and 3 before it, at full resolution
// and on 4x4 block means, so per-pixel flicker and low-frequency boiling can be told apart. It needs
// no reference; its twin measures the same on the error d - r.
#include <cstdint>
#include <memory>
#include <vector>

#include "core/consistency.hpp"
#include "core/exr_io.hpp"
#include "core/image.hpp"
#include "metrics/tiles.hpp"

namespace arena {

constexpr int kStabilityBlock = 4;  // the coarse scale's block size in pixels
constexpr double kStabilityEps = 0.01;

struct StabilityInput {
  const Image* current = nullptr;          // x_t (linear RGB)
  std::vector<const Image*> previous;      // x_{t-1}, x_{t-2}, ... (one per lag, at most 3)
  std::vector<const LayerSet*> guides;     // the layers of frames t, t-1, ..., t-K (K = previous.size())
  // r_t for the error twin (x = d - r): the denominator is r^2 + eps. Null: the pair's mean.
  const Image* normaliser = nullptr;
};

struct StabilityResult {
  double fine = 0, coarse = 0;  // NaN when nothing was valid at that scale
  TileSums fineTiles, coarseTiles;
  double validFraction = 0;     // of pixels valid at lag 1
};

StabilityResult temporalStability(const StabilityInput& in, const ConsistencyThresholds& thresholds = {});

// Each pixel's path back through the motion layers of frames t, t-1, ..., t-K: where it lands in
// frame t - k (lag k = 1..K) and whether every step so far was consistent (all four bilinear taps
// pass core/consistency.hpp's test). It reads only the guide layers, so a scene's pairs share it
// (the evaluation keeps it per frame), and warped flicker reads its first lag.
struct StabilityPaths {
  int width = 0, height = 0;
  struct Lag {
    std::vector<float> x, y;     // the path's position in frame t - k (valid pixels only)
    std::vector<uint8_t> valid;  // every step up to lag k consistent
  };
  std::vector<Lag> lags;  // lags[k - 1]
  double validFraction() const;  // of pixels valid at lag 1
  size_t bytes() const { return lags.size() * size_t(width) * size_t(height) * 9; }
};
// guides holds frames t, t-1, ..., t-K (K >= 1).
StabilityPaths traceStabilityPaths(const std::vector<const LayerSet*>& guides,
                                   const ConsistencyThresholds& thresholds = {});

struct FrameView;  // metrics/metric_registry.hpp
// The lags over which frame t's pixels can be followed back: the previous views there are, none
// across a camera cut, at most kMaxMetricHistory.
int followableLags(const FrameView& v);
// Frame t's paths over `lags` (>= 1) lags, from its guides and its previous views': made once and
// kept in the frame's memo where the evaluation has one.
std::shared_ptr<const StabilityPaths> motionPaths(const FrameView& v, int lags);

// Several signals over the same frames and guides (the output and its error): each pixel's path
// back through the motion layers is followed once for all of them. signals[i].guides is ignored;
// `guides` holds frames t, t-1, ..., t-K for every signal.
std::vector<StabilityResult> temporalStability(const std::vector<StabilityInput>& signals,
                                               const std::vector<const LayerSet*>& guides,
                                               const ConsistencyThresholds& thresholds = {});
// The same along paths traced before (signals[i].previous.size() must be paths.lags.size()).
std::vector<StabilityResult> temporalStability(const std::vector<StabilityInput>& signals,
                                               const StabilityPaths& paths);

}  // namespace arena
