#pragma once
// Ghosting and lag around scripted events, and recovery after camera cuts (metrics.md, "Ghosting
// and lag").
#include <array>
#include <nlohmann/json.hpp>
#include <vector>

#include "core/image.hpp"
#include "metrics/tiles.hpp"

namespace arena {

struct GhostingConfig {
  double tau = 0.2;         // changed region: relative luminance change of the reference
  double chromaTau = 0.05;  // ... or a chromaticity change (Euclidean distance of (R,G,B)/(R+G+B))
  double eps = 0.01;
  double biasThreshold = 0.05;  // response time: |b_M| <= 5% relative brightness error (absolute)
  int before = 5;               // window starts at t0 - 5 (also the frames b_pre is taken over)
  int after = 60;               // ... and ends at t0 + 60 (clipped, see below)
  // E_ss = median of the last 10 frames of the window, all from t0 on: where fewer follow the
  // event (the sequence ends or another event comes), E_ss and the figures on it are absent.
  int steadyFrames = 10;
  // Fewer frames than this from t0 on leave no figure (a response and a steady state cannot be
  // told apart in fewer): absent, with the reason.
  int minFramesFromEvent = 4;
  int trailFrames = 8;          // K: frames an object's trail stays in the mask
  int recoveryFrames = 5;       // camera cuts: relMSE at cut+1..cut+5 relative to the steady state
  nlohmann::json toJson() const;
};

// Changed region M (1 inside, 0 outside): pixels where |L(r_t0) - L(r_t0-1)| > tau (L(r_t0-1) +
// eps), or where the reference's chromaticity moved by more than chromaTau while the pixel is
// brighter than eps in both frames (darker pixels have no meaningful colour). `chromaOnly`, when
// given, counts the pixels only the chromaticity criterion added.
Image changedRegion(const Image& referenceAtEvent, const Image& referenceBefore,
                    const GhostingConfig& c = {}, size_t* chromaOnly = nullptr);
// Adds the trail of a moving object: pixels covered by `objectId` in any of `previousMeshIds` but
// not in `currentMeshId`.
void addTrail(Image& mask, int objectId, const std::vector<const Image*>& previousMeshIds,
              const Image& currentMeshId);

// Signed luminance bias b_M in the mask: mean of (L(d) - L(r)) / (L(r) + eps). With `tiles`, the
// per-tile sums behind it (sum of the per-pixel term, count of mask pixels; the event intervals'
// spatial blocks, metrics/ghosting_intervals.hpp).
double signedBias(const Image& denoised, const Image& reference, const Image& mask,
                  double eps = 0.01, TileSums* tiles = nullptr);
// Per-tile colour sums in the mask, channel by channel (R, G, B): sum = the channel's sum over the
// tile's mask pixels, count = those pixels (the chromaticity lag's spatial blocks,
// metrics/ghosting_intervals.hpp).
struct ColourTileSums {
  std::array<TileSums, 3> denoised, reference;
};
// Chromaticity error in the mask: Euclidean distance between the chromaticities (R,G,B)/(R+G+B) of
// the mean colour over M of d and of r (a mean, so noise averages out as in b_M); 0 when M is
// black in the reference. With `tiles`, the per-tile colour sums behind it.
double chromaticityError(const Image& denoised, const Image& reference, const Image& mask,
                         ColourTileSums* tiles = nullptr);
// The same from the two summed colours (or means: chromaticity does not depend on the scale).
double chromaticityErrorOfSums(const std::array<double, 3>& denoised,
                               const std::array<double, 3>& reference);

struct GhostingResult {
  int eventFrame = 0, windowBegin = 0, windowEnd = 0;  // window [begin, end], inclusive
  std::vector<double> curve;                           // E_M(t) for t in the window
  std::vector<double> bias;                            // b_M(t) per window frame
  std::vector<double> chroma;                          // chromaticity error per window frame
  // Secondary (on E_M, mix lag with noise): E_ss, max E_M - E_ss, sum max(0, E_M - E_ss).
  double steadyState = 0, peakExcess = 0, ghostEnergy = 0;
  int steadyBegin = 0;       // the first frame E_ss is taken over
  std::string steadyAbsent;  // why E_ss and the two figures on it are undefined ("" when defined)
  double signedBias = 0;  // mean b_M over the first five frames from t0
  double biasPre = 0;     // b_pre: median |b_M| over the (up to) 5 frames before t0
  double lagEnergy = 0;   // sum over t >= t0 of max(0, |b_M| - b_pre), bias-frames
  double chromaPre = 0, chromaLagEnergy = 0;  // the same two on the chromaticity error
  bool settled = true;     // false: |b_M| still above the threshold at the window's last frame
  int responseFrames = 0;  // first t - t0 after which |b_M| stays <= threshold (valid if settled)
  double responseThreshold = 0.05;
  double maskFraction = 0, maskChromaFraction = 0;  // M, and its chromaticity-only part, / pixels
  nlohmann::json toJson() const;                    // responseFrames is null when not settled
};
// Why a window [.., windowEnd] leaves no figure for the event at t0 (fewer than
// c.minFramesFromEvent frames from t0 on), or "" when it does.
std::string ghostingWindowProblem(int t0, int windowEnd, const GhostingConfig& c = {});
// Why E_ss (and peakExcess, ghostEnergy on it) is undefined for that window (fewer than
// c.steadyFrames frames from t0 on), or "" when it is defined.
std::string steadyStateProblem(int t0, int windowEnd, const GhostingConfig& c = {});
// Derives the event's numbers from its curves (window frames [begin, end], event at t0). `chroma`
// may be empty.
GhostingResult analyseGhosting(int t0, int begin, const std::vector<double>& curve,
                               const std::vector<double>& bias,
                               const std::vector<double>& chroma = {},
                               const GhostingConfig& c = {});

// Old-view leak after a camera cut (ours): the least-squares coefficient a of the error
// e = d - r onto the pre-cut difference D = r_old - r, a = sum(e D) / sum(D D) over pixels and
// channels (linear RGB). 0: nothing of the old view; 1: the output still shows it entirely.
// Noise in d is uncorrelated with D and averages out. Undefined (NaN) when D vanishes: the
// references before and after the cut are one image, so no old view can show (a cut declared
// where the camera did not cut); never 0, which would read as a perfect score. With `tiles`, per
// tile sum(e D) as the sum and sum(D D) as the count, so a tile draw's leak is sum / count.
double oldViewLeak(const Image& denoised, const Image& reference, const Image& oldViewReference,
                   TileSums* tiles = nullptr);

struct CutResult {
  int cutFrame = 0;
  std::vector<int> recoveryFrames;      // cut+1 .. cut+5 (those inside the segment)
  std::vector<double> recovery;         // relMSE there / steady state
  double atCut = 0;                     // relMSE at the cut frame / steady state
  int steadyBegin = 0, steadyEnd = -1;  // steady state: median relMSE over these frames
  double steadyState = 0;
  std::vector<int> leakFrames;    // cut .. cut+5
  std::vector<double> leak;       // oldViewLeak per frame (NaN where the view did not change)
  double oldViewLeak = 0;         // max |leak| over the defined frames; NaN when none is
  nlohmann::json toJson() const;  // no ratios ("absent") when the segment has no steady frames
};
// `relMse` per frame of the whole sequence; the post-cut segment is [cut, segmentEnd]; its steady
// state is the median relMSE over [cut + recoveryFrames + 1, segmentEnd]. `leak[k]` is frame
// cut+k's.
CutResult analyseCut(int cut, int segmentEnd, const std::vector<double>& relMse,
                     const std::vector<double>& leak, const GhostingConfig& c = {});

}  // namespace arena
