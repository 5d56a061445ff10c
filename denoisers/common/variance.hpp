#pragma once
// Per-pixel luminance variance (SVGF §4.2): the first and second moments of luminance are
// accumulated over time with the colour's reprojection, Var = max(0, mu2 - mu1^2); where fewer
// than 4 frames have been accumulated the variance is estimated spatially instead, by a 7x7
// bilateral filter of the moments (weights as in Falcor's SVGFFilterMoments). Falcor's pass also
// replaces a young pixel's colour by the same bilateral mean (estimateVariance's youngColorMean and
// replaceYoungColor below); the paper estimates only the variance spatially.
#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/common/temporal_accumulation.hpp"

namespace arena {

// moments (2 channels: mu1, mu2 of luminance) = EMA of (l, l^2) of `signal` with the reprojected
// momentsHistory; alpha = max(alpha.at(i), 1/h) as for the colour (SVGF: moments alpha 0.2).
void accumulateMoments(const Reprojection& reprojection, const Image& signal,
                       const Image& momentsHistory, const Image& historyLength,
                       const AccumulationAlpha& alpha, Image& moments);

// updateHistoryLength, accumulateTemporally (colour) and accumulateMoments in one sweep that
// decodes each pixel's history taps once; the results are exactly those of the three calls.
void accumulateColorAndMoments(const Reprojection& reprojection, const Image& previousHistoryLength,
                               float maxHistory, const Image& signal, const Image& colorHistory,
                               const Image& momentsHistory, const AccumulationAlpha& colorAlpha,
                               const AccumulationAlpha& momentsAlpha, Image& historyLength,
                               Image& accumulated, Image& moments);

struct VarianceSettings {
  float minHistory = 4.0f;  // SVGF §4.2: spatial estimate while fewer than 4 frames accumulated
  int radius = 3;           // SVGF §4.2: 7x7
  // Spatial weight, Falcor: exp(-|l(p)-l(q)| / phiColor - |z(p)-z(q)| / (phiDepth max|grad z|
  // |p-q|)) * max(0, n(p).n(q))^phiNormal. The paper names only depth and normal; Falcor adds
  // the (unscaled) luminance term.
  float phiColor = 10.0f;    // Falcor gPhiColor 10
  float phiNormal = 128.0f;  // Falcor gPhiNormal 128
  float phiDepth = 3.0f;     // Falcor: 3 x depth gradient
  // Falcor: "boost" the spatial estimate of a young history, var *= 4 / h.
  bool boostYoungHistory = true;
};

// A young pixel: not sky, h < minHistory (the spatial estimate runs there).
inline bool isYoungPixel(const GBufferView& gbuffer, const float* historyLength, size_t p,
                         const VarianceSettings& settings) {
  return !gbuffer.isSky(p) && historyLength[p] < settings.minHistory;
}

// variance (1 channel) from `moments` where h >= minHistory, else the spatial estimate around p
// over `moments` and the luminance of `color` (the accumulated colour). Sky pixels get 0.
// With `youngColorMean` (3 channels), each young pixel there receives the bilateral mean of
// `color` under the same weights (Falcor SVGFFilterMoments filters the illumination with the
// moments); its other pixels are not written. Returns the neighbour taps read per pixel (49 where
// the spatial estimate ran).
double estimateVariance(const Image& moments, const Image& historyLength, const Image& color,
                        const GBufferView& gbuffer, const Image& derivatives,
                        const VarianceSettings& settings, Image& variance, RowTapCounter& taps,
                        Image* youngColorMean = nullptr);

// color := youngColorMean at every young pixel (the à-trous then starts from Falcor's filtered
// colour there); the other pixels keep theirs.
void replaceYoungColor(const Image& youngColorMean, const Image& historyLength,
                       const GBufferView& gbuffer, const VarianceSettings& settings, Image& color);

}  // namespace arena
