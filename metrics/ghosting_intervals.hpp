#pragma once
// 95% intervals of the event-window figures (metrics.md, "Ghosting and lag": lag energy, response,
// peak excess, ghost energy, signed bias, E_ss around scripted events; recovery and old-view leak
// after camera cuts), and their paired differences and ranks with ties between methods.
//
// Why not the per-frame summaries' crossed bootstrap (metrics/statistics.hpp): an event figure is
// a function of one fixed window of frames after one event (the bias curve from t0 on, a maximum,
// a first-crossing time). Its frames are not exchangeable samples of a stationary series -- frame
// t0 + 1 and frame t0 + 40 play different roles -- so resampling frame blocks would build curves
// that no event can produce (a lag tail before its peak). Space is the replicated dimension: every
// window frame's b_M(t), E_M(t), relMSE and leak is a mean over pixels, and the pixels of the
// changed region (or of the frame, for cuts) fall into the image's 4x4 tiles (metrics/tiles.hpp,
// the same tiles as the summaries: larger than the filter footprints that correlate neighbouring
// pixels). A replicate draws the tiles with replacement *once for the whole window* (the same
// draw in every frame, so each tile keeps its own trajectory through the event, noise and lag
// alike), recomputes the curves from the drawn tiles' sums and then the figures exactly as the run
// did. The chromaticity error is of M's summed colours (a ratio of sums, not a mean of per-pixel
// terms), so each tile keeps its summed output and reference colour, R, G, B apart: a replicate's
// chromaticity curve is that of the drawn tiles' sums, and chromaPre / chromaLagEnergy follow. 1000 replicates, seeded by scene and event, so reruns and `arena merge` of shards give the
// same intervals, and every method of a scene is resampled with the same draws: differences
// between methods are paired. Percentile intervals, widened for the small number of tiles (below)
// and cut at 0 for figures that cannot be negative. (Basic "reverse percentile" intervals were
// tried: they remove a bias the noise puts into maxima and clipped sums, but at the boundary -- a
// method with no lag, lag energy 0 -- they reflect every replicate below 0 and claim [0, 0].)
//
// What the interval covers: the noise realisation of the input (and of the reference) inside the
// region, and how the lag varies from one part of the region to another -- "would this figure come
// out the same on another region drawn like this one". What it does NOT cover: the timing and
// kind of the event, the window and thresholds (fixed), the changed region itself (taken as
// given), a bias the reference shares with itself, other scenes; and the estimator's own bias:
// lag energy adds max(0, |noise| - b_pre) on settled frames and peak excess is a maximum, so on a
// noisy region both sit above the noise-free figure (tests/ghosting_intervals_test.cpp measures
// coverage of the noise-free figure of a known lag, of brightness and of hue), and so do
// chromaLagEnergy and chromaPre (a distance, never negative: on a settled region chromaPre is the
// noise's own chromaticity error, and its interval covers that, not 0). Input-seed
// replicates (`--seeds K`) are not used: they exist only in some runs, and an interval whose
// meaning depends on a flag could not be compared between runs; they remain the way to check
// these intervals on a scene (README, "Uncertainty").
//
// With few tiles the bootstrap has nothing to resample: a region inside one tile would give every
// replicate the same value and a zero-width interval. An event whose region spreads over fewer
// than kMinEffectiveTiles effective tiles ((sum n_k)^2 / sum n_k^2 over the tiles' pixel counts
// n_k) has no interval, with that reason, never a fake one.
#include <array>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "metrics/ghosting.hpp"
#include "metrics/run_statistics.hpp"
#include "metrics/statistics.hpp"

namespace arena {

constexpr double kMinEffectiveTiles = 4.0;

// The per-tile data behind one event's curves (results: pair.ghosting[k].tiles), one row per
// window frame: E_M(t) as relMSE sums and sample counts in M, b_M(t) as sums of the per-pixel
// relative luminance error and mask pixel counts, and the chromaticity error's colour sums in M
// (ColourTileSums per frame, channel by channel; JSON "colour": {"denoised": [R, G, B],
// "reference": [R, G, B]}; absent in results written before it, then empty).
struct EventTiles {
  MetricTiles curve, bias;
  std::array<MetricTiles, 3> denoisedColour, referenceColour;
  void addColour(int frame, ColourTileSums sums);
  bool hasColour() const;  // all six channels hold rows
  nlohmann::json toJson() const;
  static EventTiles fromJson(const nlohmann::json& j);
};

// The per-tile data behind one camera cut (results: pair.cuts[k].tiles): the frame's relMSE sums
// for every frame of the post-cut segment, and the leak's sums (sum e D, sum D D) for cut..cut+5.
struct CutTiles {
  MetricTiles relMse, leak;
  nlohmann::json toJson() const;
  static CutTiles fromJson(const nlohmann::json& j);
};

// An event's or a cut's figures, resampled.
struct FigureReplicates {
  std::vector<std::string> figures;                       // in display order
  std::map<std::string, std::vector<double>> replicates;  // per figure (NaN: undefined there)
  std::map<std::string, std::string> absent;              // figure -> why it has no interval
  // responseFrames: "never settled" enters as this value (one more than any settled response).
  std::map<std::string, double> neverSettled;
  double effectiveTiles = 0;
  // The data spreads over fewer than kMinEffectiveTiles effective tiles (but some): no interval
  // for any figure, whatever is rerun (the event's region, not missing data).
  bool tooFewTiles = false;
  // Small-sample widening of the percentile intervals (about the replicates' median) with
  // G = effectiveTiles blocks:
  // sqrt(G / (G - 1)) t_{G-1} / z. The bootstrap's spread over G blocks is (G - 1) / G of the
  // variance it estimates, and its quantiles treat that estimate as exact, like a z interval
  // where a t interval with G - 1 degrees of freedom is due: with 16 tiles a 95% interval would
  // cover about 92% (tests/ghosting_intervals_test.cpp), widened it covers about 95%.
  double widen = 1.0;
  // The figures of the identity draw (every tile once): the stored figures, from the tiles' sums.
  std::map<std::string, double> point;
};
// The widening factor above for `blocks` (>= 2) and a two-sided confidence level.
double smallSampleWidening(double blocks, double confidence);

// Figure names: lagEnergy, responseFrames, peakExcess, ghostEnergy, signedBias, absSignedBias,
// steadyState (events); atCut, recovery1..recoveryN (recovery at cut + k), oldViewLeak (cuts).
std::vector<std::string> ghostingFigureNames();
std::vector<std::string> cutFigureNames(const GhostingConfig& c = {});
// The figures of an analysed event or cut by name (responseFrames never settled: the window's
// frame count from t0).
std::map<std::string, double> ghostingFigures(const GhostingResult& g);
std::map<std::string, double> cutFigures(const CutResult& c, const GhostingConfig& gc = {});

// `seedName` names the scene and the event (every method of the scene must use the same one).
FigureReplicates ghostingReplicates(int t0, const EventTiles& tiles, const std::string& seedName,
                                    const BootstrapConfig& cfg = {}, const GhostingConfig& gc = {});
FigureReplicates cutReplicates(int cut, int segmentEnd, const CutTiles& tiles,
                               const std::string& seedName, const BootstrapConfig& cfg = {},
                               const GhostingConfig& gc = {});
// The seed names the run uses.
std::string eventSeedName(const std::string& scene, int eventFrame);
std::string cutSeedName(const std::string& scene, int cutFrame);

// Adds to an event's or a cut's JSON: "ci95" {figure: [lo, hi]} for every figure with an interval
// (responseFrames' bounds null where they are "never settled") and "ci95Absent" {figure: reason}
// for every other figure. `point`: the figures the run reported (ghostingFigures, cutFigures).
void addFigureIntervals(nlohmann::json& j, const FigureReplicates& r,
                        const std::map<std::string, double>& point, double confidence);

// statistics.scenes.<scene>.events / .cuts: per event (matched by frame), for every figure, the
// ranking with ties and the paired differences (as metrics/statistics' SceneRanking) over the ok
// pairs that stored tile data. `pairs`: (label, pair JSON) of one scene.
struct SceneEvents {
  std::vector<EventStatistics> events, cuts;
};
SceneEvents rankSceneEvents(std::vector<std::pair<std::string, const nlohmann::json*>> pairs,
                            const std::string& scene, const BootstrapConfig& cfg = {});

// Event figures a gate can judge between two runs (`arena compare --metric ghosting.lagEnergy`):
// "ghosting.<figure>" for the figures ranked between methods (lagEnergy, responseFrames,
// peakExcess, ghostEnergy, absSignedBias, chromaLagEnergy) and "cut.<figure>" for a cut's (atCut,
// recovery1.., oldViewLeak); lower is better for all. A row judges one event: metric
// "ghosting@<frame>.<figure>" or "cut@<frame>.<figure>", as results.db names its rankings.
std::vector<std::string> gatedEventFigureNames(const GhostingConfig& gc = {});
bool isGatedEventFigure(const std::string& name);
// "ghosting@12.lagEnergy" -> "ghosting.lagEnergy"; "" for any other name.
std::string gatedEventFigureOf(const std::string& rowMetric);

// A pair's stored event's (or cut's) figures by name, as the ranking and the gate read them
// (responseFrames never settled: the window's frames from the event; absSignedBias from
// signedBias; NaN where the run has none).
std::map<std::string, double> storedFigures(const nlohmann::json& e, bool cut);
// Why a stored event or cut has no value of `figure` (the run's own reason where it wrote one:
// lagAbsent, ci95Absent, a cut's absent); "" where it has one. `value`: the figure as
// storedFigures reads it.
std::string storedFigureAbsence(const nlohmann::json& e, bool cut, const std::string& figure,
                                double value);

// One figure of one event (or cut) as two runs measured it on one scene: the pairs' stored events
// (`baseEvent`, `candEvent`, matched by frame). Both runs resample the event with the scene's seed,
// so a replicate draws the same tiles in both where their windows and tile grids agree: the
// change's interval is paired, as the summaries' are, and widened as the figures' own intervals
// are. Relative to the baseline's figure (the difference's interval divided by it, not each
// replicate's ratio: a figure of 0 in one replicate, a method that settled at once, would be a
// division by 0); where the baseline's figure is 0, a rise is beyond any relative tolerance
// (change +infinity) and resolved by the difference's interval alone.
struct EventFigureChange {
  double baseline = kUndefined, candidate = kUndefined;  // never settled: the window's frames
  std::string baselineAbsent, candidateAbsent;           // why a run has no figure
  bool baselineNever = false, candidateNever = false;    // never settled in the event's window
  double change = kUndefined;                            // (candidate - baseline) / |baseline|
  Interval changeCi;                                     // the same scale (none from a baseline 0)
  Interval difference;                                   // candidate - baseline
  double pValue = kUndefined;                            // of "no change", from the differences
  std::string noInterval;                                // why there is no interval
  // No interval by the event's design, whatever is rerun: a run's changed region spreads over
  // fewer than kMinEffectiveTiles effective tiles. Any other reason is data missing, damaged or
  // unpaired (an older run without tiles, another tile grid, too few defined replicates).
  bool noIntervalByDesign = false;
  // Where a run's stored figure disagrees with its own tiles' (a hand-edited or damaged record:
  // the change would come from the one and the interval from the other), what differs; the
  // caller names the run and refuses.
  std::string baselineDisagrees, candidateDisagrees;
};
// `figure` without its prefix ("lagEnergy"); cfg.replicates may exceed the figures' own 1000 (a
// corrected gate's p-values), the first of them drawn as the run drew its own. `cache`: the
// events' replicates at cfg, reused (one cache per cfg).
// The replicates of stored events, kept across the figures of one gate (each event is resampled
// once, not once per figure): keyed by the event's JSON, which must outlive the cache.
struct EventReplicateCache {
  std::map<const nlohmann::json*, FigureReplicates> byEvent;
  // The replicates of the stored event `e` at cfg, resampled on first use (a damaged tile record
  // is an Error then).
  const FigureReplicates& of(const nlohmann::json& e, bool cut, const std::string& scene,
                             const BootstrapConfig& cfg);
};
EventFigureChange eventFigureChange(const nlohmann::json& baseEvent,
                                    const nlohmann::json& candEvent, bool cut,
                                    const std::string& figure, const std::string& scene,
                                    const BootstrapConfig& cfg = {},
                                    EventReplicateCache* cache = nullptr);

}  // namespace arena
