#pragma once
// A-SVGF, adaptive spatiotemporal variance-guided filtering (Schied et al. 2018, "Gradient
// Estimation for Real-Time Adaptive Temporal Filtering"; seed 001). SVGF whose temporal alpha is
// raised per pixel by a temporal gradient: Svgf's pipeline unchanged, plus the gradient
// reconstruction this class supplies through Svgf::adaptiveAlpha(). See asvgf.cpp.
#include <string>
#include <vector>

#include "denoisers/svgf.hpp"

namespace arena {

// Where the gradient is normalised (A-SVGF eq. 14 vs Q2RTX's asvgf_gradient_img).
enum class GradientNormalisation {
  // Paper: filter delta and Delta separately, lambda = min(1, |delta^| / Delta^) afterwards;
  // empty strata count as zero in both and cancel in the ratio.
  Paper,
  // Q2RTX: each sample's ratio (|delta| / Delta)^2 first ("make small changes less
  // significant"), then the ratios are filtered; empty strata count as ratio 0 and dilute it.
  Q2rtx,
};

// The gradient fields are set from asvgfParams() (asvgf.cpp; "gradient.iterations" ->
// gradientIterations, "gradient.edge.depth" -> gradientDepth, "gradient.normalise" ->
// normalisation, "gradient.gain" -> antilagGain, ...), which declares each default, range and
// meaning once.
struct AsvgfSettings {
  SvgfSettings svgf;  // alpha is A-SVGF's base alpha (eq. 15), momentsAlpha the moments' floor
  // Gradient reconstruction (A-SVGF §3.4) at stratum resolution.
  int gradientIterations;  // joint-bilateral à-trous iterations
  bool gradientDepth, gradientNormal, gradientLuminance;
  float gradientSigmaZ;        // eq. 10 sigma_z
  float gradientSigmaN;        // eq. 9 sigma_n
  float gradientSigmaL;        // eq. 11 sigma_l
  float depthEpsilon = 1e-3f;  // eq. 10's guard, relative to z(p) (as the shared depth term)
  GradientNormalisation normalisation;
  float antilagGain;  // lambda multiplier: 1 in the paper; Q2RTX flt_antilag_hf
  bool max3x3;        // §3.5: the max alpha over the 3x3 neighbouring strata
  // Q2RTX asvgf_temporal's order (default): the reprojected history length is shortened first,
  // h = h_prev (1 - lambda)^10 + 1, then alpha = lerp(max(alpha, 1/h), 1, lambda) -- a rejected
  // history restarts 1/h and SVGF's spatial variance estimate. false: the paper literally,
  // alpha = max((1 - lambda) alpha + lambda, 1/h) with h unchanged, whose moments then hold the
  // pixel's own (l, l^2) where lambda = 1 and the variance collapses to 0 (issue 15, item 2).
  bool shortenHistory;
};

// SVGF's parameters (svgfParams()) followed by the gradient's, each bound to its field.
const ParamTable<AsvgfSettings>& asvgfParams();

class Asvgf final : public Svgf {
 public:
  explicit Asvgf(const AsvgfSettings& settings);

  // SVGF's guides plus "color": the gradient samples are luminances of the remodulated colour,
  // so the per-stratum luminance guide (§3.4) is taken from the same colour.
  std::vector<std::string> requiredChannels() const override;
  bool needsGradients() const override { return true; }
  void setup(int width, int height) override;

  // Of the last frame, at stratum resolution (ceil(w/3) x ceil(h/3)); zero when the frame had no
  // gradients. Plane 0: delta^, plane 1: Delta^ (paper) or the filtered ratio (Q2RTX), after
  // the last iteration.
  const Image& lastGradient() const { return gradient_[resultIndex_]; }
  // lambda per stratum after the optional 3x3 max (eq. 14, §3.5).
  const Image& lastLambda() const { return lambda_; }

 protected:
  AdaptiveAlpha adaptiveAlpha(const FrameContext& ctx, const DenoiserInputs& in) override;

 private:
  void buildStrata(const DenoiserInputs& in);
  void filterGradients();
  void computeAlpha();

  AsvgfSettings asvgf_;
  int strataWidth_ = 0, strataHeight_ = 0;
  // Per stratum: the pixel whose G-buffer guides it (-1: only sky), its guides
  // (z, dz/dx, dz/dy, n, pixel x, y), and the filter state (delta, Delta, l, Var(l)) ping-pong.
  std::vector<int> guidePixel_;
  Image guide_;
  Image gradient_[2];
  int resultIndex_ = 0;  // which of gradient_ holds the last iteration's output
  Image blurredVariance_;
  Image stratumLambda_, lambda_;
  Image alpha_;  // per pixel, handed to Svgf: alpha_i (paper) or lambda (Q2RTX order)
};

}  // namespace arena
