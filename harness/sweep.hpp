#pragma once
// A sweep: one denoiser over the Cartesian product of a parameter grid, as one run (ablations). The
// grid and the fixed parameters are recorded in the run ("sweep"), committed with it.
#include <map>
#include <string>
#include <vector>

#include "harness/run_matrix.hpp"

namespace arena {

// `run` with one request of `denoiser` per grid point. `grids` are "NAME=[v1,v2,...]" (NAME may
// carry the "denoiser." prefix); `fixed` holds the parameters every point shares. Errors name the
// --grid text: a malformed grid, an unknown parameter (listing the valid ones), an axis given
// twice or also fixed, no values, a value listed twice, more than `maxPoints` points (a grid of six
// axes of ten values is a million runs of every scene: refused before anything is planned).
constexpr size_t kDefaultMaxSweepPoints = 1000;
RunConfig sweepRun(RunConfig run, const std::string& denoiser,
                   const std::map<std::string, std::string>& fixed,
                   const std::vector<std::string>& grids,
                   size_t maxPoints = kDefaultMaxSweepPoints);

}  // namespace arena
