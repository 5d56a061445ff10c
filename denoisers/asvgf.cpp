// `asvgf`: adaptive SVGF (Schied et al. 2018, "Gradient Estimation for Real-Time Adaptive Temporal
// Filtering"; seed 001). SVGF's pipeline (svgf.cpp) with one change: the EMA's alpha is raised per
// pixel where the shading changed, measured by temporal gradients. Per frame, in Svgf's
// adaptiveAlpha() hook (after reprojection, before accumulation):
//   1. gradient samples (tracer/render.cpp): one per 3x3 stratum of the current frame, a frame
//      i - 1 surface sample forward-projected and re-shaded at frame i with frame i - 1's random
//      numbers (§3.1-3.3). delta = l_new - l_old (eq. 2), Delta = max(l_new, l_old) (eq. 13);
//      empty strata contribute zero to both (§3.5). Both are luminances of the remodulated colour
//      while the denoiser filters a demodulated signal: only their ratio lambda is used, so the
//      mismatch of units does not matter;
//   2. stratum-resolution guides: depth, normal and depth gradient of the sample's pixel (or the
//      stratum's centre when it has no sample), and the mean and variance of the current colour's
//      luminance over the stratum's pixels (§3.4: l^(0) and Var(l^(0)));
//   3. a joint-bilateral à-trous over the strata (§3.4, eqs. 7-12): 5 iterations of a 3x3 box
//      kernel with taps 2^k strata apart, weights w = w_z w_n w_l (eqs. 8-11), the luminance and
//      its variance filtered along (variance with squared weights, as SVGF §4.4) and delta and
//      Delta with the same weights (eq. 12);
//   4. lambda = min(1, |delta^| / Delta^) (eq. 14), alpha_i = (1 - lambda) alpha + lambda (eq. 15),
//      the max over the 3x3 neighbouring strata (§3.5), each pixel taking its stratum's value; Svgf
//      blends colour and moments with max(alpha floor, alpha_i, 1/h).
// Frame 0, frames after a reset and frames without gradient samples run plain SVGF.
//
// Paper vs Q2RTX (NVIDIA's production A-SVGF, asvgf_gradient_img/_atrous/_temporal.comp):
//   - gradient.normalise=paper filters delta and Delta and divides afterwards (eq. 14);
//     =q2rtx divides per sample and squares, (|delta| / Delta)^2 ("make small changes less
//     significant"), then filters the ratio, empty strata counting as 0 (they dilute it). Both
//     use this file's joint-bilateral weights; Q2RTX's own gradient filter stops on luminance
//     only, and its final exposure/gamma remapping of the gradient is not reproduced.
//   - gradient.gain is Q2RTX's flt_antilag_hf (the paper has none: 1).
//   - gradient.shortenHistory (default on) is Q2RTX's order: the reprojected length is shortened,
//     h = h_prev (1 - lambda)^10 + 1, before alpha = lerp(max(alpha, 1/h), 1, lambda) is fixed, so
//     a rejected history restarts the 1/h ramp and SVGF's spatial variance estimate. Off is the
//     paper literally (only alpha raised): where lambda = 1 the moments are the pixel's own
//     (l, l^2), the variance is 0 and the luminance term stops the à-trous exactly where fresh
//     1-spp noise enters (issue 15, item 2).
//   - Q2RTX's current moments are a 3x3 spatial estimate (depth/normal weighted); ours stay the
//     pixel's own (SVGF), so that A-SVGF equals SVGF wherever lambda = 0.
//   - Q2RTX's minimum alphas (colour 0.02, moments 0.01) are SVGF's `alpha` and `momentsAlpha`
//     here; the defaults stay at the SVGF paper's 0.2.
//   - Q2RTX drops the 3x3 max and disables gradients on reflections; we keep the max
//     (gradient.max3x3) and apply the gradient to both signals.
#include "denoisers/asvgf.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "core/sequence.hpp"
#include "denoisers/common/footprint.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/variants.hpp"

namespace arena {

namespace {

// Channels of the stratum guide image.
enum StratumGuide : int {
  kZ,
  kDzDx,
  kDzDy,
  kNx,
  kNy,
  kNz,
  kPixelX,
  kPixelY,
  kStratumGuideChannels
};
// Channels of the filtered state: delta (paper) or the per-sample ratio (Q2RTX), Delta (paper;
// unused by Q2RTX), luminance l^(k), its variance Var(l^(k)).
enum GradientState : int {
  kGradientDelta,
  kGradientNormaliser,
  kGradientLuminance,
  kGradientVariance,
  kStateChannels
};
// Channels of the gradient layer (core/sequence.hpp).
enum GradientSample : int { kSamplePixelX, kSamplePixelY, kLumNew, kLumOld, kSampleValid };

constexpr int kStratum = kGradientStratum;  // A-SVGF's stratum side, pixels
constexpr float kLuminanceEpsilon = 1e-6f;  // eq. 11's guard (as SVGF's luminance term)

}  // namespace

Asvgf::Asvgf(const AsvgfSettings& settings) : Svgf(settings.svgf, "asvgf"), asvgf_(settings) {}

std::vector<std::string> Asvgf::requiredChannels() const {
  std::vector<std::string> channels = Svgf::requiredChannels();
  channels.push_back("color");
  return channels;
}

void Asvgf::setup(int width, int height) {
  Svgf::setup(width, height);
  strataWidth_ = (width + kStratum - 1) / kStratum;
  strataHeight_ = (height + kStratum - 1) / kStratum;
  guidePixel_.assign(size_t(strataWidth_) * size_t(strataHeight_), -1);
  guide_ = Image(strataWidth_, strataHeight_, kStratumGuideChannels);
  for (Image& image : gradient_) image = Image(strataWidth_, strataHeight_, kStateChannels);
  resultIndex_ = 0;
  blurredVariance_ = Image(strataWidth_, strataHeight_, 1);
  stratumLambda_ = Image(strataWidth_, strataHeight_, 1);
  lambda_ = Image(strataWidth_, strataHeight_, 1);
  alpha_ = Image(width, height, 1);
}

Svgf::AdaptiveAlpha Asvgf::adaptiveAlpha(const FrameContext&, const DenoiserInputs& in) {
  if (!hasHistory_ || in.gradients == nullptr) {
    // No history to keep or no samples to judge it by: plain SVGF.
    lambda_.fill(0.0f);
    return {};
  }
  buildStrata(in);
  filterGradients();
  computeAlpha();
  AdaptiveAlpha alpha;
  (asvgf_.shortenHistory ? alpha.antilag : alpha.floor) = &alpha_;
  return alpha;
}

void Asvgf::buildStrata(const DenoiserInputs& in) {
  ScopedPass pass(this, "gradient strata", 1);  // each pixel's colour read once
  const Image& color = in.frame.get("color", name_);
  const Image& samples = in.gradients->get("gradient", name_ + " gradient samples");
  if (samples.width() != strataWidth_ || samples.height() != strataHeight_ ||
      samples.channels() != 5)
    throw Error(name_ + ": gradient samples are " + std::to_string(samples.width()) + "x" +
                std::to_string(samples.height()) + "x" + std::to_string(samples.channels()) +
                ", expected " + std::to_string(strataWidth_) + "x" + std::to_string(strataHeight_) +
                "x5 (one per 3x3 stratum)");
  const int w = gbuffer_.width, h = gbuffer_.height;
  const bool q2rtx = asvgf_.normalisation == GradientNormalisation::Q2rtx;
  Image& state = gradient_[0];
  if (gpu::recording()) {  // one thread per stratum: its 3x3 pixels' colour and its sample
    using namespace gpu_buffers;
    gpu::dispatch(strataWidth_, strataHeight_);
    gpu::read(kColor, w, h, kStratum * kStratum);
    gpu::read(kMeshId, w, h, kStratum * kStratum);
    gpu::read(kGradients, strataWidth_, strataHeight_, 1);
    gpu::write(kGradientImage, strataWidth_, strataHeight_);
  }
  parallelRows(strataHeight_, [&](int sy) {
    for (int sx = 0; sx < strataWidth_; ++sx) {
      const size_t s = size_t(sy) * size_t(strataWidth_) + size_t(sx);
      const int x0 = sx * kStratum, y0 = sy * kStratum, x1 = std::min(x0 + kStratum, w),
                y1 = std::min(y0 + kStratum, h);
      // §3.4: l^(0) the mean, Var(l^(0)) the variance of the stratum's shading samples.
      double sum = 0, sumSquares = 0;
      int count = 0, firstSurface = -1;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const size_t i = size_t(y) * size_t(w) + size_t(x);
          if (gbuffer_.isSky(i)) continue;
          const float l = luminance(color.plane(0)[i], color.plane(1)[i], color.plane(2)[i]);
          sum += l;
          sumSquares += double(l) * l;
          ++count;
          if (firstSurface < 0) firstSurface = int(i);
        }
      const bool valid = samples.plane(kSampleValid)[s] != 0.0f;
      // The guide pixel: the sample's own pixel, else the stratum's centre, else any surface.
      int pixel = -1;
      if (valid) {
        const int px = std::clamp(int(samples.plane(kSamplePixelX)[s]), x0, x1 - 1);
        const int py = std::clamp(int(samples.plane(kSamplePixelY)[s]), y0, y1 - 1);
        pixel = py * w + px;
      } else {
        pixel = std::min(y0 + 1, y1 - 1) * w + std::min(x0 + 1, x1 - 1);
      }
      if (gbuffer_.isSky(size_t(pixel))) pixel = firstSurface;
      guidePixel_[s] = pixel;
      for (int c = 0; c < kStateChannels; ++c) state.plane(c)[s] = 0.0f;
      if (pixel < 0) continue;  // only sky: never gathered from, lambda 0
      const size_t p = size_t(pixel);
      guide_.plane(kZ)[s] = gbuffer_.depth[p];
      guide_.plane(kDzDx)[s] = derivatives_.plane(kDepthDx)[p];
      guide_.plane(kDzDy)[s] = derivatives_.plane(kDepthDy)[p];
      for (int c = 0; c < 3; ++c) guide_.plane(kNx + c)[s] = gbuffer_.normal[size_t(c)][p];
      guide_.plane(kPixelX)[s] = float(pixel % w);
      guide_.plane(kPixelY)[s] = float(pixel / w);
      const double mean = sum / count;
      state.plane(kGradientLuminance)[s] = float(mean);
      state.plane(kGradientVariance)[s] = float(std::max(0.0, sumSquares / count - mean * mean));
      if (!valid) continue;  // empty stratum: zero gradient, zero normaliser (§3.5)
      const float lumNew = samples.plane(kLumNew)[s], lumOld = samples.plane(kLumOld)[s];
      const float normaliser = std::max(lumNew, lumOld);  // eq. 13
      if (q2rtx) {
        const float ratio = normaliser > 0.0f ? std::abs(lumNew - lumOld) / normaliser : 0.0f;
        state.plane(kGradientDelta)[s] = ratio * ratio;
      } else {
        state.plane(kGradientDelta)[s] = lumNew - lumOld;  // eq. 2
        state.plane(kGradientNormaliser)[s] = normaliser;
      }
    }
  });
}

void Asvgf::filterGradients() {
  int source = 0;
  const float sigmaZ = asvgf_.gradientSigmaZ, sigmaN = asvgf_.gradientSigmaN;
  const float sigmaL = asvgf_.gradientSigmaL;
  const int sw = strataWidth_, sh = strataHeight_;
  for (int k = 0; k < asvgf_.gradientIterations; ++k) {
    // Taps 2^k strata apart, or the footprint policy's step (footprint.hpp; 0: skipped). An
    // iteration skipped here that a 1080p frame runs is a pass of no work here whose traffic is
    // that frame's, for the GPU prediction (PassTraffic::skippedHere).
    const int step = atrousStep(k, settings_.atrous.footprintScale);
    const bool onlyAt1080p =
        step == 0 && atrousRunsAt1080p(k, settings_.atrous.footprintScale, gbuffer_.height);
    if (step == 0 && !onlyAt1080p) continue;
    // Taps per full-resolution pixel: 9 per stratum, a ninth of the pixels' count.
    const double taps = asvgf_.gradientLuminance ? 2.0 : 1.0;
    ScopedPass pass(this, "gradient atrous " + std::to_string(k + 1), onlyAt1080p ? 0.0 : taps);
    if (gpu::recording()) {  // 3x3 strata, guided by the stratum pixels' depth and normal
      using namespace gpu_buffers;
      gpu::dispatch(sw, sh);
      gpu::read(kGradientImage, sw, sh, asvgf_.gradientLuminance ? 18 : 9);
      gpu::read(kDepth, sw, sh, 9);  // only one pixel per stratum is read
      gpu::read(kNormal, sw, sh, 9);
      gpu::write(kGradientImage, sw, sh);
      if (onlyAt1080p) gpu::skippedHere();
    }
    if (onlyAt1080p) continue;
    const Image& in = gradient_[source];
    Image& out = gradient_[1 - source];
    const float* variance = in.plane(kGradientVariance);
    if (asvgf_.gradientLuminance) {
      // eq. 11: g3x3, the variance blurred by a 3x3 Gaussian, drives the luminance weight only.
      constexpr float kGauss[3] = {0.25f, 0.5f, 0.25f};
      float* blurred = blurredVariance_.plane(0);
      parallelRows(sh, [&](int sy) {
        for (int sx = 0; sx < sw; ++sx) {
          const size_t p = size_t(sy) * size_t(sw) + size_t(sx);
          float sum = 0, weightSum = 0;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const int qx = sx + dx, qy = sy + dy;
              if (qx < 0 || qy < 0 || qx >= sw || qy >= sh) continue;
              const size_t q = size_t(qy) * size_t(sw) + size_t(qx);
              if (guidePixel_[q] < 0) continue;
              const float g = kGauss[dx + 1] * kGauss[dy + 1];
              sum += g * variance[q];
              weightSum += g;
            }
          blurred[p] = weightSum > 0 ? sum / weightSum : variance[p];
        }
      });
    }
    const int32_t* guidePixel = guidePixel_.data();
    const float* z = guide_.plane(kZ);
    const float* pixelX = guide_.plane(kPixelX);
    const float* pixelY = guide_.plane(kPixelY);
    const float* luminance = in.plane(kGradientLuminance);
    const bool normalTerm = asvgf_.gradientNormal && sigmaN != 0.0f;
    // Eight strata at a time, the taps in the order of the per-stratum loop (dy, then dx), so the
    // sums round as that loop's would; a dropped tap adds exactly 0.
    parallelRows(sh, [&](int sy) {
      for (int x0 = 0; x0 < sw; x0 += 8) {
        const size_t p = size_t(sy) * size_t(sw) + size_t(x0);
        const LaneMask8 x = laneIndex(Lanes8{}) + x0;
        const LaneMask8 inRow = x < sw;
        const LaneMask8 centreValid = inRow & (loadIntLanes(guidePixel + p, inRow) >= 0);
        const Lanes8 zp = loadLanes(z + p, inRow);
        const Lanes8 dzdx = loadLanes(guide_.plane(kDzDx) + p, inRow);
        const Lanes8 dzdy = loadLanes(guide_.plane(kDzDy) + p, inRow);
        const Lanes8 xp = loadLanes(pixelX + p, inRow), yp = loadLanes(pixelY + p, inRow);
        const Lanes8 lp = loadLanes(luminance + p, inRow);
        const Lanes8 deviation =
            sqrtLanes(maxFloat(Lanes8{}, loadLanes(blurredVariance_.plane(0) + p, inRow)));
        const Lanes8 inverseLuminanceDenominator = 1.0f / (sigmaL * deviation + kLuminanceEpsilon);
        // eq. 10's guard (1e-30: 0/0 where the depth is 0).
        const Lanes8 depthEpsilon = asvgf_.depthEpsilon * absFloat(zp) + 1e-30f;
        Lanes8 n[3];
        for (int c = 0; c < 3; ++c) n[c] = loadLanes(guide_.plane(kNx + c) + p, inRow);
        Lanes8 sumDelta{}, sumNormaliser{}, sumLuminance{}, sumVariance{}, sumWeight{};
        // eq. 7/12: h^(k) a 3x3 box with taps 2^k strata apart, explicitly renormalised.
        for (int dy = -1; dy <= 1; ++dy) {
          const int qy = sy + dy * step;
          if (qy < 0 || qy >= sh) continue;
          for (int dx = -1; dx <= 1; ++dx) {
            const size_t q = p + size_t(std::ptrdiff_t(dy * step) * sw + dx * step);
            LaneMask8 use = centreValid & (x + dx * step >= 0) & (x + dx * step < sw);
            use &= loadIntLanes(guidePixel + q, use) >= 0;
            Lanes8 weight = Lanes8{} + 1.0f;  // the centre
            if (dx != 0 || dy != 0) {
              // eq. 8: w = w_z w_n w_l as one exponential: the exponents of eqs. 10 and 11
              // summed, eq. 9's power as sigma_n log(n(p).n(q)). eq. 10's offset p - q is in
              // pixels between the two strata's guide pixels.
              Lanes8 exponent{};
              if (asvgf_.gradientDepth) {
                const Lanes8 offsetX = loadLanes(pixelX + q, use) - xp;
                const Lanes8 offsetY = loadLanes(pixelY + q, use) - yp;
                exponent += absFloat(zp - loadLanes(z + q, use)) /
                            (sigmaZ * absFloat(dzdx * offsetX + dzdy * offsetY) + depthEpsilon);
              }
              if (asvgf_.gradientLuminance)
                exponent +=
                    absFloat(lp - loadLanes(luminance + q, use)) * inverseLuminanceDenominator;
              if (normalTerm) {
                Lanes8 dot{};
                for (int c = 0; c < 3; ++c) dot += n[c] * loadLanes(guide_.plane(kNx + c) + q, use);
                use &= dot > 0.0f;  // facing away: max(0, n.n')^sigma_n = 0
                exponent -= sigmaN * logPositive(minFloat(maxFloat(dot, Lanes8{} + 1e-30f),
                                                          Lanes8{} + 1.0f));
              }
              weight = expNonPositive(-exponent);  // core/fast_math.hpp: ~1e-7 relative
            }
            weight = selectFloat(use, weight, Lanes8{});
            sumDelta += weight * loadLanes(in.plane(kGradientDelta) + q, use);
            sumNormaliser += weight * loadLanes(in.plane(kGradientNormaliser) + q, use);
            sumLuminance += weight * loadLanes(luminance + q, use);
            sumVariance += weight * weight * loadLanes(in.plane(kGradientVariance) + q, use);
            sumWeight += weight;
          }
        }
        const Lanes8 inverse = 1.0f / sumWeight;  // the centre counts: sumWeight >= 1
        const Lanes8 results[kStateChannels] = {sumDelta * inverse, sumNormaliser * inverse,
                                                sumLuminance * inverse,
                                                sumVariance * inverse * inverse};
        for (int c = 0; c < kStateChannels; ++c)  // a stratum without a guide passes through
          storeLanes(out.plane(c) + p,
                     selectFloat(centreValid, results[c], loadLanes(in.plane(c) + p, inRow)),
                     inRow);
      }
    });
    source = 1 - source;
  }
  resultIndex_ = source;
}

void Asvgf::computeAlpha() {
  ScopedPass pass(this, "gradient alpha", asvgf_.max3x3 ? 2.0 : 1.0);
  const Image& g = gradient_[resultIndex_];
  const int sw = strataWidth_, sh = strataHeight_;
  const bool q2rtx = asvgf_.normalisation == GradientNormalisation::Q2rtx;
  const float gain = asvgf_.antilagGain;
  if (gpu::recording()) {  // lambda per stratum (max over its 3x3), alpha per pixel
    using namespace gpu_buffers;
    gpu::dispatch(gbuffer_.width, gbuffer_.height);
    gpu::read(kGradientImage, sw, sh, asvgf_.max3x3 ? 9 : 1);
    gpu::write(kAlpha, gbuffer_.width, gbuffer_.height);
  }
  for (size_t s = 0; s < guidePixel_.size(); ++s) {
    float lambda = 0.0f;
    if (guidePixel_[s] >= 0) {
      if (q2rtx) {
        lambda = std::clamp(gain * g.plane(kGradientDelta)[s], 0.0f, 1.0f);
      } else {
        const float normaliser = g.plane(kGradientNormaliser)[s];  // 0 where no sample reached
        if (normaliser > 0.0f)
          lambda =
              std::min(1.0f, gain * std::abs(g.plane(kGradientDelta)[s]) / normaliser);  // eq. 14
      }
    }
    stratumLambda_.plane(0)[s] = lambda;
  }
  // §3.5: "the max alpha_i over a 3x3 neighbourhood" against the reconstruction's errors;
  // alpha_i grows with lambda, so the max of lambda gives it.
  for (int sy = 0; sy < sh; ++sy)
    for (int sx = 0; sx < sw; ++sx) {
      float lambda = stratumLambda_.at(sx, sy);
      if (asvgf_.max3x3)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int qx = sx + dx, qy = sy + dy;
            if (qx >= 0 && qy >= 0 && qx < sw && qy < sh)
              lambda = std::max(lambda, stratumLambda_.at(qx, qy));
          }
      lambda_.at(sx, sy) = lambda;
    }
  // Per pixel from its stratum: Q2RTX's order hands lambda itself to the accumulation (h
  // shortened, then alpha lerped towards 1); the paper's eq. 15 the floor alpha_i. Where
  // lambda = 0 both leave Svgf's floors (alpha for colour, momentsAlpha for moments) exactly as
  // in plain SVGF.
  const float base = settings_.alpha;
  const bool q2rtxOrder = asvgf_.shortenHistory;
  const int w = alpha_.width();
  parallelRows(alpha_.height(), [&](int y) {
    for (int x = 0; x < w; ++x) {
      const float lambda = lambda_.at(x / kStratum, y / kStratum);
      alpha_.at(x, y) =
          q2rtxOrder ? lambda : (lambda > 0.0f ? (1.0f - lambda) * base + lambda : 0.0f);
    }
  });
}

const ParamTable<AsvgfSettings>& asvgfParams() {
  using S = AsvgfSettings;
  static const ParamTable<S> table =
      ParamTable<S>()
          .include(svgfParams(), &S::svgf)
          .extendMeaning("alpha",
                         "; A-SVGF eq. 15's base alpha (Q2RTX flt_min_alpha_color_hf 0.02)")
          .extendMeaning("momentsAlpha",
                         "; raised by the same alpha_i (Q2RTX flt_min_alpha_moments_hf 0.01)")
          .integer("gradient.iterations", &S::gradientIterations, 5, 0, 10,
                   "joint-bilateral à-trous iterations over the 3x3 strata (A-SVGF §3.4: 5, a "
                   "3x3 box with taps 2^k strata apart)")
          .boolean("gradient.edge.depth", &S::gradientDepth, true,
                   "gradient filter depth term (A-SVGF eq. 10)")
          .boolean("gradient.edge.normal", &S::gradientNormal, true,
                   "gradient filter normal term (A-SVGF eq. 9)")
          .boolean("gradient.edge.luminance", &S::gradientLuminance, true,
                   "gradient filter variance-scaled luminance term (A-SVGF eq. 11)")
          .real("gradient.sigmaZ", &S::gradientSigmaZ, 1.0, 0.0, 1e6,
                "gradient filter sigma_z (A-SVGF eq. 10)")
          .real("gradient.sigmaN", &S::gradientSigmaN, 128.0, 0.0, 1e4,
                "gradient filter normal exponent sigma_n (A-SVGF eq. 9)")
          .real("gradient.sigmaL", &S::gradientSigmaL, 4.0, 0.0, 1e6,
                "gradient filter luminance sigma_l (A-SVGF eq. 11)")
          .choice(
              "gradient.normalise", &S::normalisation, "paper",
              {{"paper", GradientNormalisation::Paper}, {"q2rtx", GradientNormalisation::Q2rtx}},
              "paper: filter delta and Delta, then lambda = |delta^|/Delta^ (eq. 14); q2rtx: "
              "filter the per-sample (|delta|/Delta)^2 (Q2RTX)")
          .real("gradient.gain", &S::antilagGain, 1.0, 0.0, 1e3,
                "lambda = min(1, gain * ratio) (paper 1; Q2RTX flt_antilag_hf)")
          .boolean("gradient.max3x3", &S::max3x3, true,
                   "alpha_i = max over the 3x3 neighbouring strata (A-SVGF §3.5)")
          .boolean("gradient.shortenHistory", &S::shortenHistory, true,
                   "Q2RTX order: h = h_prev (1 - lambda)^10 + 1 first, then alpha = "
                   "lerp(max(alpha, 1/h), 1, lambda), restarting 1/h and the spatial variance "
                   "where the history was rejected; false = the paper's eq. 15 literally");
  return table;
}

DenoiserInfo asvgfInfo() {
  return {"asvgf",
          "Adaptive SVGF: SVGF whose temporal alpha is raised by reconstructed temporal gradients "
          "(Schied et al. 2018)",
          asvgfParams().schema(), [](const ParamSet& params, SignalKind) {
            return std::make_unique<Asvgf>(asvgfParams().settings(params, "asvgf"));
          }};
}

}  // namespace arena
