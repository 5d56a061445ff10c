#pragma once
// Uncertainty of every summary (docs/metrics.md, "Uncertainty"): 95% intervals, paired
// differences between methods and ranks with ties.
//
// Method: a crossed ("pigeonhole", Owen 2007) bootstrap. Frames are resampled in circular blocks
// of consecutive frames (block length round(n^(1/3)), the usual rate for the moving-block
// bootstrap, Künsch 1989; wrapping from the last frame to the first, Politis and Romano 1992, so
// that every frame is drawn equally often), because errors persist through a denoiser's history;
// independently, the image's
// tiles (metrics/tiles.hpp) are resampled with replacement, because filter footprints correlate
// neighbouring pixels. A replicate's value is the summary recomputed from the chosen frames and
// tiles; intervals are the percentile interval of the replicates. The crossed bootstrap counts
// frame-to-frame and tile-to-tile variation both, which errs wide where content varies between
// tiles; it errs narrow where few frames follow the warm-up (kFewSummarisedFrames) and where one
// error is common to every tile (a light switched: docs/statistics.md measures both). A "tie"
// means "not resolved by this sequence", never "equal".
//
// Every pair of a scene is resampled with the same plan (the same frames and tiles in replicate b),
// so differences are paired: content that is hard for every method cancels, and so does the
// reference's own noise, which adds the same Var(r_hat) term to every method's expected squared
// error. Paired differences of relMSE are therefore unbiased even against a noisy reference.
#include <cstdint>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "metrics/tiles.hpp"

namespace arena {

constexpr double kUndefined = std::numeric_limits<double>::quiet_NaN();

// How a frame's value follows from the mean of its tiles: the metric itself (relMSE, SSIM, FLIP,
// tRMAE), its square root (RMSE, warped flicker) or 10 log10(1 / x) capped like PSNR (PSNR, tPSNR
// from a display MSE).
enum class FrameTransform { Mean, Sqrt, Psnr };
const char* transformName(FrameTransform t);
FrameTransform parseTransform(const std::string& name);

// One metric of one pair after warm-up: a row per frame, each with its tile sums. Metrics without
// a spatial decomposition (time, effective spp) have one tile per frame.
struct MetricTiles {
  FrameTransform transform = FrameTransform::Mean;
  std::vector<int> frames;
  std::vector<TileSums> rows;
  void add(int frame, TileSums tiles);
  void addScalar(int frame, double value);
  bool empty() const { return frames.empty(); }
  int tileCount() const { return rows.empty() ? 0 : int(rows.front().sum.size()); }
  // The frame values (transform of each row's total) and their mean: the summary's point estimate.
  std::vector<double> frameValues() const;
  // Row `row`'s value under a tile draw (tile indices, repeats allowed); NaN when the drawn tiles
  // hold no data.
  double valueUnder(size_t row, const std::vector<int>& tiles) const;
  double mean() const;
  // Rows kept only for the given frames (in that order); frames missing here are an error.
  MetricTiles restrictedTo(const std::vector<int>& frames) const;
  nlohmann::json toJson() const;  // compact: frames, transform, float32 sums and counts in base64
  static MetricTiles fromJson(const nlohmann::json& j);
};

struct Interval {
  double lo = kUndefined, hi = kUndefined;
  bool valid() const { return lo == lo && hi == hi; }
  bool containsZero() const { return valid() && lo <= 0 && hi >= 0; }
  nlohmann::json toJson() const;
  // What toJson writes, read back: [low, high], or null for no interval. Anything else: nullopt
  // (the caller names the file and path).
  static std::optional<Interval> fromJson(const nlohmann::json& j);
};

struct BootstrapConfig {
  int replicates = 1000;
  double confidence = 0.95;
  TileGrid grid;
};

// Replicate b uses frameRows(b) (indices into the aligned frame list, n of them) and tiles(b)
// (tile indices, one draw per tile of the grid). Seeded from a name (the scene's), so reruns are
// identical and every pair of the scene shares the plan.
class ResamplingPlan {
 public:
  ResamplingPlan(int frames, int tiles, const std::string& seedName,
                 const BootstrapConfig& cfg = {});
  int replicates() const { return int(frameRows_.size()); }
  int blockLength() const { return blockLength_; }
  const std::vector<int>& frameRows(int b) const { return frameRows_[size_t(b)]; }
  const std::vector<int>& tiles(int b) const { return tiles_[size_t(b)]; }

 private:
  int blockLength_ = 1;
  std::vector<std::vector<int>> frameRows_, tiles_;
};

// The metric recomputed under each replicate of the plan (NaN where no tile had data).
std::vector<double> replicateValues(const MetricTiles& m, const ResamplingPlan& plan);
// Percentile interval of replicate values (NaN replicates dropped; fewer than 20 finite: invalid).
Interval percentileInterval(std::vector<double> replicates, double confidence);
// The percentile interval with both half-widths scaled by `widen` about the replicates' median
// (a small-sample correction of the spread, metrics/ghosting_intervals.hpp); widen 1 = plain.
Interval widenedInterval(const std::vector<double>& replicates, double confidence, double widen);
// The replicates themselves scaled by `widen` about their median (NaN kept): what a p-value of a
// widened interval counts, so that the test and the interval say the same (an interval holding 0
// with p < 0.05 let a corrected gate fail on what its own interval called noise).
std::vector<double> widenedReplicates(std::vector<double> replicates, double widen);
// The interval of one metric's summary mean.
Interval meanInterval(const MetricTiles& m, const std::string& seedName,
                      const BootstrapConfig& cfg = {});

// At most this many frames after the warm-up, the frames' variation is hardly sampled (one frame:
// not at all, only its tiles) and the intervals are too narrow: the run keeps a warning with the
// scene's results (harness/scene_selection.hpp), and the gate does not judge a difference resolved
// on so few (metrics/compare.hpp): noise alone failed 6 of 8 reruns of a gate at one frame.
inline constexpr int kFewSummarisedFrames = 7;

// How near two replicate values count as one number: a difference within this fraction of the
// larger is rounding (the tile sums are float32, about seven significant digits), and counts as
// none, so that two outputs alike but for rounding tie rather than be "resolved" by the sign of a
// rounding error (pairedDifference, pairedRelativeChange, the overall ranking's log ratios).
constexpr double kRoundingResolution = 1e-6;
// a - b replicate by replicate, 0 where the two differ by rounding alone (within
// kRoundingResolution of the larger, or within `floor` for values near 0 whose difference is itself
// relative, as log ratios are).
std::vector<double> replicateDifferences(const std::vector<double>& a, const std::vector<double>& b,
                                         double floor = 0);

// a - b on the frames both have, with its interval.
struct PairedDifference {
  double diff = kUndefined;
  Interval ci;
  bool resolved() const { return ci.valid() && !ci.containsZero(); }
};
PairedDifference pairedDifference(const MetricTiles& a, const MetricTiles& b,
                                  const std::string& seedName, const BootstrapConfig& cfg = {});

// 2 (min(#{c <= 0}, #{c >= 0}) + 1) / (R + 1) over the finite replicates of a change, at most 1;
// NaN without any.
double changePValue(const std::vector<double>& changes);

// (a - b) / |b| on the frames both have, with its interval: the percentile interval of each
// replicate's own relative change, so it keeps to the metric's range (a relMSE cannot fall by more
// than 100%), which pairedDifference's interval divided by b's point value did not. Its sign in
// each replicate is the difference's, so it is resolved where pairedDifference is, but for an end
// interpolated between two replicates of opposite signs (a boundary case). `a` and `b` are
// the means over `frames`, the frames both have.
//
// `pValue`: the two-sided bootstrap p-value of "no change" from the same replicates,
// 2 (min(#{change <= 0}, #{change >= 0}) + 1) / (R + 1), at most 1 (below 0.05 where the 95%
// interval excludes zero, up to the interpolation at its ends); NaN without replicates. It cannot
// fall below 2 / (R + 1): pairedChangePValue draws more replicates where a smaller one matters.
struct PairedChange {
  double change = kUndefined, a = kUndefined, b = kUndefined;
  Interval ci;
  double pValue = kUndefined;
  std::vector<int> frames;
};
PairedChange pairedRelativeChange(const MetricTiles& a, const MetricTiles& b,
                                  const std::string& seedName, const BootstrapConfig& cfg = {});
// PairedChange::pValue from at least `replicates` replicates, drawn in plans of cfg.replicates each
// (the first seeded by `seedName`, as pairedRelativeChange's, the k-th by "seedName#k"), so the
// memory stays that of one plan: how a family-wise correction over m rows tells p-values down to
// (1 - confidence) / m.
double pairedChangePValue(const MetricTiles& a, const MetricTiles& b, const std::string& seedName,
                          const BootstrapConfig& cfg, int replicates);

// Holm's step-down procedure over a family of two-sided p-values at family-wise level `alpha`:
// rejected[i] when p-value i is rejected (sorted ascending, the k-th smallest is rejected while
// every smaller one was and it is <= alpha / (m - k), m the number of finite p-values). NaN
// p-values are not in the family and never rejected. The chance that any true "no change" is
// rejected stays <= alpha whatever the p-values' dependence.
std::vector<bool> holmRejections(const std::vector<double>& pValues, double alpha);

// Frames present in every series (sorted).
std::vector<int> commonFrames(const std::vector<const MetricTiles*>& series);

// Ranks with ties for the methods of one scene on one metric. rank = 1 + the number of methods
// resolved better; tiedWith = the methods whose difference is not resolved.
struct RankedMethod {
  std::string label;
  int rank = 0;
  double value = kUndefined;  // the summary mean on the common frames
  Interval ci;
  std::vector<std::string> tiedWith;
  // Paths per pixel per frame the method read beyond the frame's own 1-spp paths (RunStatistics::
  // extraPathsPerPixel); NaN: none.
  double extraPathsPerPixel = kUndefined;
  // The oracle layers it read (RunStatistics::oracleLayers): data no real-time engine has.
  std::vector<std::string> oracleLayers;
};
// The methods a ranking left out, each with its reason: `leftOut` (results: "leftOut", [{label,
// why}]) and the same joined for reading ("excluded": "a: why; b: why"). Results written before
// "leftOut" was stored hold only the text; reasonFor reads it from there.
struct LeftOutMethods {
  std::string excluded;
  std::vector<std::pair<std::string, std::string>> leftOut;
  void leaveOut(const std::string& label, const std::string& why);
  // The reason given for `label`, "" where it is not left out. From text alone, a reason runs to
  // the next "; <label>: " of `labels` (the run's labels: a reason may hold "; ").
  std::string reasonFor(const std::string& label, const std::vector<std::string>& labels) const;
  void writeTo(nlohmann::json& j) const;  // "excluded" and "leftOut", where any
};
struct SceneRanking : LeftOutMethods {
  std::string metric;
  std::vector<RankedMethod> ranking;  // best first
  struct Pair {
    std::string a, b;
    PairedDifference d;
  };
  std::vector<Pair> pairs;
  int resolvedPairs = 0;
  std::map<std::string, std::vector<double>> replicates;  // per label, for the overall ranking
  std::string scene;  // the scene ranked (rankScene's seed name), for the overall ranking's reasons
  nlohmann::json toJson() const;
};
SceneRanking rankScene(const std::string& metric, bool lowerIsBetter,
                       const std::vector<std::pair<std::string, const MetricTiles*>>& methods,
                       const std::string& seedName, const BootstrapConfig& cfg = {});
// The same from point values and replicates already drawn with one shared plan (replicate b of
// every method under the same resample), e.g. the event figures of metrics/ghosting_intervals.
SceneRanking rankReplicates(const std::string& metric, bool lowerIsBetter,
                            const std::vector<std::string>& labels,
                            const std::vector<double>& values,
                            const std::vector<std::vector<double>>& replicates,
                            double confidence = 0.95, double widen = 1.0);

// Across scenes: each method's score is the geometric mean over scenes of its ratio to a baseline's
// value on that scene, so no scene dominates by its scale. (The ordering does not depend on which
// baseline: the geometric mean of ratios is the ratio of geometric means.) Differences are the
// mean over scenes of log ratios, with intervals from the scenes' replicates.
struct OverallRanking : LeftOutMethods {
  std::string normalisation, baseline;
  std::vector<RankedMethod> ranking;  // value = score
  // Every pair of ranked methods: diff = log(score_a / score_b), the mean over scenes of the log
  // ratios, with its interval on the same scale (resolved: excludes 0); the ties above read from
  // these. Results written before they were stored have none.
  std::vector<SceneRanking::Pair> pairs;
  nlohmann::json toJson() const;
};
// The baseline is the first of `preferredBaselines` ranked on every scene (else the first such
// label in sorted order).
OverallRanking rankOverall(const std::vector<const SceneRanking*>& scenes,
                           const std::vector<std::string>& preferredBaselines, bool lowerIsBetter,
                           double confidence = 0.95);

}  // namespace arena
