#pragma once
// Renders a scene's sequence (core/sequence.hpp): per frame the noise-free G-buffer, the 1-spp
// signals and A-SVGF gradient samples; per distinct animation state a converged reference with the
// variance of its mean, estimated from independent replicates and refined in adaptive rounds.
// What is rendered into the cache, and what the cache trusts, is tracer/sequence_cache.hpp's.
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "core/exr_io.hpp"
#include "tracer/tracer.hpp"

namespace arena {

struct RenderSettings {
  std::string preset = "quick";
  int width = 0, height = 0;     // 0: the scene's own resolution
  int frames = 0;                // 0: the scene's own frame count
  int referenceSpp = 1024;       // maximum samples per pixel of a reference
  int referenceMinSpp = 64;      // adaptive stopping never stops before this
  double referenceRelError = 0;  // > 0: stop when the reference's estimated relMSE <= this^2
  int maxBounces = 0;            // 0: the scene's own
  // 0: the scene's seed. Otherwise the 1-spp frames and gradient samples are another noise
  // realisation of the same sequence (`arena run --seeds K`, compare's noise test); references do
  // not depend on it and are shared (referenceDir).
  uint32_t inputSeed = 0;
  // The references' sampler: "sobol" (padded Owen-scrambled Sobol, tracer/sampler.hpp) or
  // "independent" (the frames' hash sampler); the 1-spp frames always use the independent one.
  std::string referenceSampler = "sobol";
  // Independent randomisations per reference: the variance of the mean is estimated from the
  // spread of their means (honest for QMC, whose per-sample variance overstates its error). The
  // sample count is a multiple of this (rounded up). Fewer replicates stratify more samples
  // together: 4 against 8 raised the equal-time gain 1.08-1.24x (7-19% less error at equal time),
  // the estimate as honest (docs/performance.md, 2026-11-27, fifth entry); 8 until then.
  int referenceReplicates = 4;
  // Adaptive allocation (with a target): samples go to tiles of this many pixels square, in
  // proportion to their estimated error (nextReferenceAllocation). 0: one tile, i.e. every pixel
  // gets the same count (the doubling schedule of issue 13's first version).
  int referenceTile = 8;
  // Optional low-resolution, many-sample buffer per frame (CAPCOM 2023 "disocclusion rays"):
  // one texel per lowresFactor x lowresFactor block, lowresSpp paths each. 0: none (hashed only
  // when on, so caches rendered without it stay valid).
  int lowresFactor = 0;
  int lowresSpp = 16;

  // Presets: quick (the scene's resolution, references of 64-512 spp with adaptive stopping) and
  // paper (1280x720, 4096 spp references).
  static RenderSettings fromPreset(const std::string& name);
  // The settings that change pixels, for the cache hash and sequence.json.
  nlohmann::json pixelSettings(const Scene& scene) const;
  int resolvedWidth(const Scene& s) const { return width > 0 ? width : s.width; }
  int resolvedHeight(const Scene& s) const { return height > 0 ? height : s.height; }
  int resolvedFrames(const Scene& s) const { return frames > 0 ? frames : s.frames; }
  int resolvedMaxBounces(const Scene& s) const {
    return maxBounces > 0 ? maxBounces : s.maxBounces;
  }
};

// What a reference needs to be extended: per pixel and replicate, the sums of (colour, diffuse,
// specular) x RGB over that replicate's samples 0..n-1, accumulated in sample order (so extending
// n -> 2n gives the same bits as rendering 2n at once). Samples are allocated per tile of
// tileSize x tileSize pixels: every replicate of every pixel of tile T has tileSamples[T] samples
// (equal counts across replicates keep their means identically distributed, so their spread stays
// an honest error estimate).
struct ReferenceSums {
  static constexpr int kValues = 9;
  int width = 0, height = 0, replicates = 0;
  int firstReplicate = 0;  // these are replicates firstReplicate.. (a shard may hold a slice)
  int tileSize = 1;
  std::vector<int> tileSamples;  // per tile, row-major: samples per replicate of its pixels
  // A round of the adaptive schedule that stopped at its target part way (continueReference): the
  // counts it was taking its tiles to. Empty, or equal to tileSamples, when no round is pending.
  std::vector<int> roundTarget;
  std::vector<double> sum;       // [(pixel * replicates + r) * kValues + j]

  int tilesX() const { return (width + tileSize - 1) / tileSize; }
  int tilesY() const { return (height + tileSize - 1) / tileSize; }
  int tileOf(int x, int y) const { return (y / tileSize) * tilesX() + x / tileSize; }
  int samplesOfPixel(size_t i) const {
    return tileSamples[size_t(tileOf(int(i % size_t(width)), int(i / size_t(width))))];
  }
  struct TileRect {
    int x0, y0, x1, y1;  // pixels [x0, x1) x [y0, y1)
  };
  TileRect tileRect(int tile) const;  // tiles at the right and bottom edges may be partial
  int tilePixels(int tile) const;
  // Mean samples per pixel over every replicate held (the frame's cost), rounded in spp().
  double meanSpp() const;
  int spp() const { return int(std::lround(meanSpp())); }
  int minPerReplicate() const;
  int maxPerReplicate() const;
  bool roundPending() const;  // some tile is below roundTarget
};
// Means (color, diffuse, specular), the variance of each mean from the spread of the replicate
// means, Var = sum_r (m_r - m)^2 / (K (K - 1)), and colorHalf (the mean of replicates 0..K/2-1).
LayerSet referenceLayersFromSums(const ReferenceSums& sums);
// How much each round of the adaptive schedule grows the frame's samples. A round extends its tiles
// one at a time, in order of the error each saves per sample added, and a reference stops at the
// first tile after which it meets its target: its samples overshoot what it needed by about one
// tile's extension, not by up to a round (1.21x on average for sqrt(2) when a reference could stop
// only between rounds, as until 2026-11-27). Tile counts stay powers of two (whole Sobol nets): a
// round doubles the tiles whose doubling lowers the estimate most, about 1 / (g - 1) rounds per
// doubling.
inline constexpr double kReferenceRoundGrowth = 1.4142135623730951;
// The next round of the adaptive schedule: tile counts for `growth` x the frame's samples, minimising
// the estimated relMSE under that budget. With e_T the tile's share of the estimate at its n_T
// samples per replicate and P_T its pixels, error ~ u_T / n with u_T = e_T n_T, so the optimum is
// n_T proportional to sqrt(u_T / P_T) (the Neyman allocation), clamped to [n_T, maxPerReplicate]
// and rounded to a power of two (whole Sobol nets). Tiles without estimated error keep their
// count. Returns the current counts when no tile with error can grow. Bias: the counts depend on
// the samples already taken, which stay in the mean; with a tile's decision resting on its 64+
// pixels x 3 channels x K replicates, that correlation is weak (measured: `arena bench reference`
// compares the true error against a uniform gold).
// maxMeanPerReplicate > 0 caps the round's budget at that mean count per pixel and replicate
// (`arena bench reference`: equal samples).
std::vector<int> nextReferenceAllocation(const ReferenceSums& sums, int maxPerReplicate,
                                         double growth = kReferenceRoundGrowth, double maxMeanPerReplicate = 0);
// The reference's relMSE as metrics.md estimates it: mean over pixels and colour channels of
// Var(mean) / (mean^2 + 0.01), with the replicate variance above. Summed per tile, then over the
// tiles in order (referenceTileShares), so that the estimate after extending one tile is the same
// number however the tiles before it were reached.
double estimatedReferenceRelMse(const ReferenceSums& sums);
// Each tile's share of that estimate before the division by pixels x 3: the sum over its pixels,
// row by row, and colour channels of Var(mean) / (mean^2 + 0.01).
std::vector<double> referenceTileShares(const ReferenceSums& sums);
double referenceTileShare(const ReferenceSums& sums, int tile);

// The scene under another seed, so its references are an independent randomisation of the same
// integral: what a reference is measured against (a "gold") must not share its samples. A gold of
// N samples per pixel that contains a reference's n correlates with it: their difference's variance
// is (1 - n/N) Var(ref), and after the gold-noise correction the measured error falls to about
// (1 - 2n/N) of the true one (0.5 at N = 4n), which flatters the reference.
Scene withIndependentSeed(Scene scene);

// A rendered reference and whether it met its target.
struct ReferenceResult {
  LayerSet layers;
  int spp = 0;                 // mean samples per pixel
  int sppMin = 0, sppMax = 0;  // over the tiles
  double estimatedRelMse = 0;  // estimatedReferenceRelMse
  double targetRelMse = 0;     // referenceRelError^2; 0 when there is no target
  bool capped = false;         // stopped at the sample cap with its estimate above the target
  RayCounts counts;
};

// Renders one scene frame by frame, keeping the Embree scenes of the current and previous frame.
class SequenceRenderer {
 public:
  SequenceRenderer(const Scene& scene, const RenderSettings& settings);
  ~SequenceRenderer();

  int width() const { return width_; }
  int height() const { return height_; }
  int frames() const { return frames_; }
  const Scene& scene() const { return scene_; }

  struct FrameResult {
    LayerSet frame;      // core/sequence.hpp channels::frameLayers()
    LayerSet gradients;  // frames >= 1: channels::gradientLayers()
    RayCounts counts;
  };
  FrameResult renderFrame(int t);
  // A reference for the animation state of frame t: samples per replicate double from
  // referenceMinSpp / K until the estimated relMSE meets the target or referenceSpp is reached.
  ReferenceResult renderReference(int t);
  // Adds samples to `sums` (of frame t's state) until each replicate has `perReplicate` samples;
  // a fresh `sums` (replicates 0) is sized from the settings.
  void extendReference(int t, ReferenceSums& sums, int perReplicate, RayCounts& counts);
  // The same per tile: until every pixel of tile T has tileSamples[T] samples per replicate.
  void extendReference(int t, ReferenceSums& sums, const std::vector<int>& tileSamples, RayCounts& counts);
  // Empty sums of replicates first..first+count-1, with the settings' tiles.
  ReferenceSums emptyReferenceSums(int firstReplicate, int count) const;
  // The adaptive schedule: a uniform pilot of referenceMinSpp, then rounds that each grow the
  // frame's samples by kReferenceRoundGrowth, planned by nextReferenceAllocation and carried out
  // tile by tile in order of the error each tile saves per sample added (its share / (P_T x its new
  // count)), until the estimated relMSE <= targetRelMse after some tile, or no tile may grow (maxSpp
  // per pixel): then `capped`. A round stopped part way stays in sums.roundTarget; continuing (`arena
  // refine`) finishes it first, in the same order, since the tiles it has not reached are unchanged.
  // Without a target (0), every pixel gets maxSpp. Neither the rounds nor the order depend on the
  // target, only where they stop does, so continuing from a stop gives the same bits as one
  // uninterrupted run (with the same maxSpp).
  ReferenceResult continueReference(int t, ReferenceSums& sums, double targetRelMse, int maxSpp);
  int referenceReplicates() const;
  // The low-resolution buffer of frame t (channels::lowresLayers()); settings.lowresFactor > 0.
  LayerSet renderLowres(int t, RayCounts& counts);
  uint64_t stateHash(int t) const;
  const FrameScene& frameScene(int t);

 private:
  Scene scene_;  // a copy, with settings (bounces) applied
  RenderSettings settings_;
  // The seed of the 1-spp frame and gradient samples (RenderSettings::inputSeed).
  uint32_t frameSeed() const;
  // Reference samples begin..end-1 of every replicate of pixel (x, y), added to sums.
  void extendPixel(int t, const FrameScene& cur, ReferenceSums& sums, int x, int y, int begin, int end,
                   RayCounts& counts) const;
  // Tile `tile` of sums to `perReplicate` samples, its pixels in parallel (sums already checked).
  void extendTile(int t, ReferenceSums& sums, int tile, int perReplicate, RayCounts& counts);
  int width_, height_, frames_;
  EmbreeDevice device_;
  std::vector<MeshData> meshes_;
  std::map<int, std::unique_ptr<FrameScene>> cache_;
};

using ProgressFn = std::function<void(const std::string& line)>;

}  // namespace arena
