#pragma once
// The benchmarks behind `arena bench`: each takes its settings, measures in this process, reports
// progress lines as it goes and returns the machine-readable result (what --json writes). Speed
// targets live here, never in timed unit tests.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tracer/render.hpp"

namespace arena {

// `bench tracer`: Mrays/s and Mpaths/s of the 1-spp frame pass of a first frame (G-buffer, mirror
// ray, path with NEE, specular ray; a first frame has no gradient samples) on a scene at size x
// size, warm-up excluded, and how many of a path's rays are occlusion rays; optionally beside
// Embree's own `pathtracer` tutorial measured in the same sitting, with and without its light.
struct TracerBench {
  std::string sceneFile;
  int size = 512, frames = 20, warmup = 3;
  bool embree = false;
};
nlohmann::json benchTracer(const TracerBench& bench, const ProgressFn& progress);

// Embree's tutorial's ray mix from two of its benchmark runs, one with its light and one without
// (each its Mrays/s and frames/s), and the rate it would report at another mix. Rays per frame are
// a run's Mrays/s over its frames/s (a count, whatever the load): the run without the light traces
// closest-hit rays alone, the rest of the lit run's are its occlusion (shadow) rays. The cost of a
// closest-hit ray is the dark run's frame time over its rays, an occlusion ray's the time the light
// adds over the rays it adds (a model: the two kinds' costs add, and the light's own evaluation
// counts with its shadow rays). `counted` is false where the rays do not add up (no share),
// `timed` false where the lit frames were not the slower ones (a load that changed between the
// runs): no costs and no rate then.
struct TutorialMix {
  bool counted = false, timed = false;
  double occlusionShare = 0;       // of the lit run's rays
  double shadowToClosestCost = 0;  // an occlusion ray's cost over a closest-hit ray's
  double mraysAtMix = 0;  // the rate it would report where `share` of the rays are occlusion rays
};
TutorialMix tutorialMix(double litMrays, double litFps, double darkMrays, double darkFps,
                        double share);

// `bench denoise`: every contender on the same rendered frames, in an order rotated frame by frame;
// median ms/frame, bilateral units, per-pass times and taps, and each contender's paired per-frame
// time ratio to the first with a distribution-free 95% interval.
struct DenoiseBench {
  std::string sceneFile;
  std::vector<std::string> denoisers;  // registry names (ext:/plugin: already resolved)
  std::map<std::string, std::map<std::string, std::string>> params;
  int width = 1280, height = 720, frames = 20, warmup = 5, inputs = 3, lowresFactor = 8, lowresSpp = 16;
};
nlohmann::json benchDenoise(const DenoiseBench& bench, const ProgressFn& progress);

// `bench reference`: per scene, the true relMSE against an independent gold render of the
// independent sampler, Sobol and adaptive Sobol at about the same sample count, each timed, and
// their gains (relMSE x seconds ratios).
struct ReferenceBench {
  std::vector<Scene> scenes;
  RenderSettings settings;  // resolution and path length
  int spp = 128, goldFactor = 32, frame = 0, replicates = RenderSettings().referenceReplicates;
  // Independent repeats of each compared estimator (own seed each, the gold shared): the gain is the
  // median over repeats with its 95% interval.
  int repeats = 8;
};
nlohmann::json benchReference(const ReferenceBench& bench, const ProgressFn& progress);

// `bench rank-agreement`: whether two runs of the same scenes (the quick preset and a larger
// resolution: scripts/bench_rank_agreement.sh) rank the methods alike -- per scene Kendall's tau-b
// on the ranks with ties and on the values, and the pairs resolved in both runs in opposite orders
// (metrics/rank_agreement.hpp). Each run's directory holds its results.json.
nlohmann::json benchRankAgreement(const std::string& runA, const std::string& runB, const ProgressFn& progress);

// One "bilateral unit" (BU): the median time of cv::bilateralFilter(src, dst, 5, 0.1, 2.0) on a
// width x height CV_32FC3 image, measured in this process.
double bilateralUnitMs(int width, int height, int repetitions);

// The median of the per-frame ratios a[i] / b[i] of two contenders timed on the same frames (pairs
// with b[i] > 0), and a distribution-free 95% interval for it (order statistics at the binomial(n,
// 1/2) 2.5% and 97.5% points, normal approximation); none (NaN bounds) under 6 pairs, where even
// the whole range covers less than 95% (5 pairs: 94%, 1 pair: nothing), and no median without a
// pair. ciText: "95% CI lo, hi" or why there is none.
struct PairedRatio {
  double median = 0, lo = 0, hi = 0;
  size_t pairs = 0;
  std::string ciText(const char* format = "%.3f") const;
};
PairedRatio pairedRatio(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace arena
