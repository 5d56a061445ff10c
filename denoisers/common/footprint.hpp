#pragma once
// One footprint policy for every spatial filter (issue 15, item 1), chosen here and recorded with
// every result through each variant's parameters `footprint` and `footprintHeight`:
//   - scaled (the default): the published pixel constants are pixels at `footprintHeight` (1080:
//     the resolution NRD and the SVGF paper tune for) and shrink or grow with the image height h
//     by s = h / footprintHeight, so a quick 256x144 run filters the same fraction of the screen
//     as a 1080p run would: Poisson radii and strides are multiplied by s, à-trous iteration i
//     takes taps round(2^i s) px apart and is skipped (the identity) where that rounds to 0 --
//     except the first iteration, which always runs with step 1 so a filter never vanishes. The
//     variance of the cascade, sum_i step_i^2, follows s^2 sum_i 4^i to within a few per cent.
//   - native: every pixel constant is used as published -- à-trous taps 2^i px apart, ReBLUR's
//     Poisson radii and history-fix stride in px -- at whatever resolution the sequence has. This
//     is what the reference implementations do (Falcor SVGFPass, Q2RTX, NRD take their radii in
//     pixels of the image they filter).
// Why scaled is the default: the study runs small images to stand for the 1080p+ frames engines
// ship. Under native a radius tuned at 1080p (NRD's 30-60 px) covers a fifth to a third of a
// 144-line frame, which no 1080p filter does (ReBLUR's mottle under small coloured lights,
// denoisers/FIDELITY.md); scaled keeps each filter's screen-space extent. The trade-off: scaled
// keeps the extent, native keeps the number of samples a footprint gathers (at 144 lines a scaled
// footprint covers (1080/144)^2 = 56x fewer pixels, so 1-spp samples, than a native one: it
// removes less noise than the filter does at 1080p; native removes as much but over 7.5x more of
// the screen).
// Data flows one way: a denoiser reads its scale once in setup(); nothing else knows the policy.
#include <string>
#include <vector>

#include "denoisers/param_table.hpp"

namespace arena {

enum class FootprintPolicy { Native, Scaled };

// Parameters "footprint" (the policy; default scaled) and "footprintHeight": default, range and
// meaning in footprintParams() (footprint.cpp), the only place they are declared.
struct Footprint {
  FootprintPolicy policy;
  float referenceHeight;
  // Pixels per published pixel at this image height: 1 (native) or height / referenceHeight.
  float scale(int height) const;
};

// The step in pixels of à-trous iteration `iteration` (0-based; 2^iteration published pixels)
// under scale s: 2^iteration exactly when s = 1, else round(2^iteration s), 0 meaning "skip", and
// never 0 for the first iteration.
int atrousStep(int iteration, float scale);
// Whether a 1920x1080 frame under the same policy runs à-trous iteration `iteration`, which an
// image `height` lines high filters under `scale`: 1080 lines scale the footprint by 1080 / height
// times this one. The GPU prediction prices an iteration skipped here but run there
// (gpu_traffic.hpp, PassTraffic::skippedHere).
bool atrousRunsAt1080p(int iteration, float scale, int height);

// The mip level that stands for published level `level` (2^level px blocks) under scale s:
// `level` exactly when s = 1, else round(level + log2 s), never below 1 -- like the first à-trous
// iteration, a coarse scale never vanishes (at 144 lines a 1080p 8x8 block is one pixel).
int scaledMipLevel(int level, float scale);

// `footprint` (native | scaled) and `footprintHeight`: included in every spatial variant's table;
// footprintParams().defaults() is the default policy.
const ParamTable<Footprint>& footprintParams();

}  // namespace arena
