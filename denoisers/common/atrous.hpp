#pragma once
// One iteration of the edge-avoiding à-trous wavelet filter (Dammertz et al. 2010; SVGF §4.3):
//   c_{i+1}(p) = sum_q h(q) w(p, q) c_i(q) / sum_q h(q) w(p, q),
// taps 2^i pixels apart, w from edge_stopping.hpp, and optionally SVGF's variance propagation
//   Var(c_{i+1}(p)) = sum_q h(q)^2 w(p, q)^2 Var(c_i(q)) / (sum_q h(q) w(p, q))^2.
// Border: taps outside the image are dropped and the rest renormalised (like a GPU filter that
// bounds-checks its taps), so with every edge term off it is exactly a B3 blur with a
// renormalised border. Sky pixels (meshId -1) are never gathered from, and pass through.
#include "core/image.hpp"
#include "denoisers/common/edge_stopping.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/param_table.hpp"

namespace arena {

enum class AtrousKernel {
  // 5x5 product of the B3 spline h = (1/16, 1/4, 3/8, 1/4, 1/16): Dammertz 2010, SVGF.
  B3Spline5x5,
  // 3x3 product of the inner three B3 taps (1/4, 3/8, 1/4) scaled to (2/3, 1, 2/3): centre 1,
  // axis 2/3, diagonal 4/9. AMD FidelityFX writes this kernel as {1, 2/3, 1/6} indexed by |offset|
  // (the 1/6 is the outer B3 tap a 3x3 never reaches); the talk uses a 3x3 à-trous too.
  Compact3x3,
};

struct AtrousSettings {
  AtrousKernel kernel{};  // the "kernel" parameter (atrousKernelParams) or set by the filter
  EdgeStoppingSettings edges;
  // footprint.hpp: iteration i's taps are atrousStep(i, footprintScale) px apart (2^i at 1); an
  // iteration whose step is 0 is the identity (colour and carried channels copied).
  float footprintScale = 1.0f;
};

// Guides of one frame. `derivatives` (computeGeometryDerivatives) is needed by the depth term,
// `luminanceVariance` (prefilterVariance3x3 of the variance) by the luminance term. `lobes`
// (computeSpecularLobes) turns on the specular-lobe similarity (Tokuyoshi 2016; the CEDEC 2021
// talk's edge-stopping term, p. "4.1.4"), raised to `lobeBeta`, as one more factor of w(p, q).
struct AtrousGuide {
  const GBufferView& gbuffer;
  const Image* derivatives = nullptr;
  const Image* luminanceVariance = nullptr;
  const Image* lobes = nullptr;
  float lobeBeta = 1.0f;
};

int atrousTapCount(AtrousKernel kernel);  // 25 or 9: neighbour fetches per pixel
// Iteration `iteration`'s fetches per pixel: atrousTapCount, or 0 where its step is 0 (the
// footprint skips it: a copy, which its ScopedPass must not count as 25 taps).
int atrousIterationTaps(int iteration, const AtrousSettings& settings);

// The "kernel" parameter ("5x5" or "3x3") of every variant that lets the user pick (included into
// its table at its AtrousSettings).
const ParamTable<AtrousSettings>& atrousKernelParams();

// Iteration `iteration` (0-based, tap spacing 2^iteration) from colorIn (3 channels) into colorOut.
// With varianceIn/varianceOut (1 channel) the luminance variance is propagated alongside.
// `colorSigma` is the colour term's sigma for this iteration (Dammertz: sigmaRt 2^-i).
void atrousIteration(int iteration, const AtrousSettings& settings, const AtrousGuide& guide,
                     float colorSigma, const Image& colorIn, Image& colorOut,
                     const Image* varianceIn = nullptr, Image* varianceOut = nullptr);

// The same iteration, carrying `momentsIn` (1 to 4 channels) through the colour's own weights into
// `momentsOut` (the talk's pre-spatial pass filters the signal and its second moment together,
// p. "4.2.3": "1次モーメントのフィルタカラー / 2次モーメント").
void atrousIterationWithMoments(int iteration, const AtrousSettings& settings,
                                const AtrousGuide& guide, float colorSigma, const Image& colorIn,
                                Image& colorOut, const Image& momentsIn, Image& momentsOut);

// The pixel kernel has an AVX2 and an AVX-512 build (simd.hpp).

// g3x3 of SVGF eq. 5: the variance blurred by a 3x3 Gaussian (1/4, 1/2, 1/4)^2, sky taps and
// off-image taps dropped and the rest renormalised. Used only to drive the luminance weight;
// the variance propagated to the next iteration stays unfiltered (SVGF §4.4).
void prefilterVariance3x3(const Image& variance, const GBufferView& gbuffer, Image& filtered);

}  // namespace arena
