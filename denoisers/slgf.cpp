// `slgf`: Spatiotemporal Luminance-Guided Filtering, OUR INTERPRETATION. SLGF was shown with
// Luminous Engine's real-time ray-tracing demo (CEDEC 2019); there is no paper or public code. The
// only description we have is the CEDEC 2021 talk (seed 000):
//   - slide "3.3 SLGF Spatiotemporal Luminance-Guided Filter" (各種デノイザー紹介3): "estimate
//     the luminance from the ray-tracing result and adjust temporal accumulation with the
//     luminance a pixel can take" (レイトレーシングの結果から輝度推定を行いピクセルの取りうる輝度で
//     Temporal Accumulation を調節), without A-SVGF's gradient samples or variance parameters;
//   - slide "4.2.5 動的な光源" (dynamic lights, アルゴリズム解説と実装4): "obtain the current
//     frame's estimated luminance and correct the temporal accumulation result with it (SLGF);
//     the pre-spatial accumulation can serve as the current frame's estimated luminance".
// What we build from that, every choice a parameter:
//   1. luminance estimation (the talk's "pre-spatial accumulation"): `estimator.iterations`
//      edge-aware à-trous iterations (5x5 B3 kernel, SVGF's depth/normal/id/position terms, no
//      luminance term: the input is raw 1-spp noise) of the current frame's demodulated signal,
//      filtering its luminance l and l^2 together. From the two moments: the local mean mu and
//      spread sigma = sqrt(E[l^2] - mu^2). `estimator.spread=mean` divides sigma by the square
//      root of the filter's effective sample count (the spread of mu itself: the à-trous
//      propagates a unit variance with squared weights, SVGF §4.4); `=sample` keeps the spread of
//      the noisy samples (variance clipping as in the talk's hybrid);
//   2. SVGF's temporal accumulation; then, where the reprojected history's luminance lies outside
//      [mu - k sigma, mu + k sigma] (`k`), the history is corrected into it -- `correction=
//      rescale` scales its colour (chroma kept), `=clamp` clamps each channel to the per-channel
//      box of the same estimator -- and its moments are rescaled alike; alpha is raised by
//      lambda = min(1, gain * |l_H - l_H'| / max(l_H, l_H')) (`alphaGain`), alpha' = (1 - lambda)
//      alpha + lambda (the form of A-SVGF eq. 15, for colour and moments), and the EMA re-blended
//      with the corrected history. Inside the box nothing changes;
//   3. SVGF's variance estimate and variance-guided à-trous (the shared blocks), iteration
//      `feedbackTap`'s output as the history.
// The correction runs in Svgf's correctAccumulation() hook (after accumulate(), before the
// variance), since the history must be changed before the blend, which adaptiveAlpha() cannot do.
#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "denoisers/common/atrous.hpp"
#include "denoisers/common/history_clamp.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/temporal_accumulation.hpp"
#include "denoisers/svgf.hpp"
#include "denoisers/variants.hpp"

namespace arena {

namespace {

enum class HistoryCorrection { Rescale, Clamp };
enum class EstimatorSpread { Mean, Sample };

// Set from slgfParams() below, which declares each default, range and meaning once.
struct SlgfSettings {
  SvgfSettings svgf;
  int estimatorIterations;  // "estimator.iterations": B3 iterations of the luminance estimate
  EstimatorSpread spread;   // "estimator.spread"
  // Box half-width in spreads. Ours 4: with the spread of the mean, k = 2 clipped converged
  // histories often enough to cost 10 % relMSE on cornell_static (1-spp luminance is skewed, so the
  // estimated spread is too small); k = 4 matches SVGF there and still corrects a switched light.
  float k;
  HistoryCorrection correction;
  float alphaGain;  // lambda = min(1, gain * relative distance outside the box)
  // Q2RTX's anti-lag history shortening, h' = (h - 1)(1 - lambda)^10 + 1 (see asvgf.cpp).
  bool shortenHistory;  // ours on: without it the first frame after a switch-on is noisy
};

class Slgf final : public Svgf {
 public:
  explicit Slgf(const SlgfSettings& settings) : Svgf(settings.svgf, "slgf"), slgf_(settings) {
    estimator_.kernel = AtrousKernel::B3Spline5x5;
    estimator_.edges = settings.svgf.atrous.edges;
    estimator_.edges.luminance = false;  // 1-spp input: luminance differences are noise
    estimator_.edges.color = false;
  }

  void setup(int width, int height) override {
    Svgf::setup(width, height);
    estimator_.footprintScale = settings_.atrous.footprintScale;
    for (Image& image : estimate_) image = Image(width, height, 3);
    for (Image& image : colorMoments_) image = Image(width, height, 3);
    for (Image& image : meanVariance_) image = Image(width, height, 1);
  }

 protected:
  void correctAccumulation(const FrameContext&, const DenoiserInputs& in,
                           const Image* alpha) override {
    if (!hasHistory_) return;  // nothing reprojected: nothing to correct
    estimateLuminance(in.signal);
    correctHistory(in.signal, alpha);
  }

 private:
  // 1. The pre-filtered current frame: [l, l^2, 0] (rescale) or also [r, g, b] and
  // [r^2, g^2, b^2] (clamp), with the unit variance propagated through the same weights.
  void estimateLuminance(const Image& signal) {
    const bool clamp = slgf_.correction == HistoryCorrection::Clamp;
    {
      ScopedPass pass(this, "luminance estimate input", 0);
      Image& m = estimate_[0];
      Image& c = colorMoments_[0];
      const int w = signal.width();
      parallelRows(signal.height(), [&](int y) {
        for (size_t i = size_t(y) * size_t(w); i < size_t(y + 1) * size_t(w); ++i) {
          const float r = signal.plane(0)[i], g = signal.plane(1)[i], b = signal.plane(2)[i];
          const float l = luminance(r, g, b);
          if (clamp) {  // per channel: means in estimate_, second moments in colorMoments_
            m.plane(0)[i] = r;
            m.plane(1)[i] = g;
            m.plane(2)[i] = b;
            c.plane(0)[i] = r * r;
            c.plane(1)[i] = g * g;
            c.plane(2)[i] = b * b;
          } else {
            m.plane(0)[i] = l;
            m.plane(1)[i] = l * l;
            m.plane(2)[i] = 0.0f;
          }
        }
      });
      meanVariance_[0].fill(1.0f);
    }
    const AtrousGuide guide{gbuffer_, &derivatives_, nullptr};
    source_ = 0;
    for (int k = 0; k < slgf_.estimatorIterations; ++k) {
      const int taps = atrousIterationTaps(k, estimator_);
      ScopedPass pass(this, "luminance estimate " + std::to_string(k + 1), clamp ? 2 * taps : taps);
      const int target = 1 - source_;
      atrousIteration(k, estimator_, guide, 1.0f, estimate_[source_], estimate_[target],
                      &meanVariance_[source_], &meanVariance_[target]);
      if (clamp)  // the weights do not depend on the filtered values: the same weights
        atrousIteration(k, estimator_, guide, 1.0f, colorMoments_[source_], colorMoments_[target]);
      source_ = target;
    }
  }

  // 2. History correction and re-blend, per pixel with a reprojected history.
  void correctHistory(const Image& signal, const Image* alpha) {
    ScopedPass pass(this, "history correction", 2 * reprojection_.readTapsPerPixel());
    const bool clamp = slgf_.correction == HistoryCorrection::Clamp;
    const bool meanSpread = slgf_.spread == EstimatorSpread::Mean;
    const Image& first = estimate_[source_];
    const Image& second = colorMoments_[source_];
    const float* meanVariance = meanVariance_[source_].plane(0);
    float* length = historyLength_.plane(0);
    const int w = accumulated_.width();
    if (gpu::recording()) {  // the history through its taps, corrected by the estimate
      using namespace gpu_buffers;
      const int h = accumulated_.height();
      gpu::dispatch(w, h);
      gpu::read(kRadianceHistory, w, h, reprojection_.readTapsPerPixel());
      // The estimate (mean; second moments when clamping) and its variance.
      gpu::read({kRecord, kRadiance, kVariance, kHistoryLength, kSignal}, w, h);
      if (clamp) gpu::read(kSecondMoments, w, h);
      if (alpha) gpu::read(kAlpha, w, h);
      gpu::write({kRadiance, kHistoryLength}, w, h);
    }
    parallelRows(accumulated_.height(), [&](int y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = size_t(y) * size_t(w) + size_t(x);
        if (!reprojection_.valid(i)) continue;
        const float spreadScale = meanSpread ? std::sqrt(std::max(0.0f, meanVariance[i])) : 1.0f;
        float history[3], corrected[3];
        for (int c = 0; c < 3; ++c) history[c] = reprojection_.sample(i, colorHistory_.plane(c));
        const float historyLuminance = luminance(history[0], history[1], history[2]);
        float target = historyLuminance;
        if (clamp) {
          float lo[3], hi[3];
          for (int c = 0; c < 3; ++c) {
            const float mu = first.plane(c)[i];
            const float sigma =
                std::sqrt(std::max(0.0f, second.plane(c)[i] - mu * mu)) * spreadScale;
            lo[c] = std::max(0.0f, mu - slgf_.k * sigma);
            hi[c] = mu + slgf_.k * sigma;
            corrected[c] = history[c];
          }
          clampToBox(corrected, lo, hi, 3);
          if (corrected[0] == history[0] && corrected[1] == history[1] &&
              corrected[2] == history[2])
            continue;
          target = luminance(corrected[0], corrected[1], corrected[2]);
        } else {
          const float mu = first.plane(0)[i];
          const float sigma = std::sqrt(std::max(0.0f, first.plane(1)[i] - mu * mu)) * spreadScale;
          target = std::clamp(historyLuminance, std::max(0.0f, mu - slgf_.k * sigma),
                              mu + slgf_.k * sigma);
          if (target == historyLuminance) continue;  // inside the box: SVGF's blend stands
          if (historyLuminance > 0.0f) {
            for (int c = 0; c < 3; ++c) corrected[c] = history[c] * (target / historyLuminance);
          } else {
            // A black history has no chroma to keep: take the current sample's, else grey.
            const float l = luminance(signal.plane(0)[i], signal.plane(1)[i], signal.plane(2)[i]);
            for (int c = 0; c < 3; ++c)
              corrected[c] = l > 0.0f ? signal.plane(c)[i] * (target / l) : target;
          }
        }
        const float largest = std::max(historyLuminance, target);
        const float distance =
            largest > 0.0f ? std::abs(historyLuminance - target) / largest : 0.0f;
        const float lambda = std::min(1.0f, slgf_.alphaGain * distance);
        // A corrected history counts for fewer frames -- shortened before this frame's alphas
        // are fixed, Q2RTX's order (asvgf.cpp), so 1/h and the spatial variance restart at once
        // (before issue 34 it was shortened after the blend: the blend still used the old 1/h).
        if (slgf_.shortenHistory && lambda > 0.0f)
          length[i] = (length[i] - 1.0f) * std::pow(1.0f - lambda, 10.0f) + 1.0f;
        // The alphas SVGF used (temporal_accumulation.hpp), raised as A-SVGF eq. 15 does.
        const float floorPixel = alpha ? alpha->plane(0)[i] : 0.0f;
        const float a = blendAlpha(length[i], std::max(settings_.alpha, floorPixel));
        const float am = blendAlpha(length[i], std::max(settings_.momentsAlpha, floorPixel));
        const float colorAlpha = (1.0f - lambda) * a + lambda;
        const float momentsAlpha = (1.0f - lambda) * am + lambda;
        for (int c = 0; c < 3; ++c)
          accumulated_.plane(c)[i] =
              colorAlpha * signal.plane(c)[i] + (1.0f - colorAlpha) * corrected[c];
        // The moments history follows the colour: l -> s l, l^2 -> s^2 l^2.
        float m1 = reprojection_.sample(i, momentsHistory_.plane(0));
        float m2 = reprojection_.sample(i, momentsHistory_.plane(1));
        if (historyLuminance > 0.0f) {
          const float s = target / historyLuminance;
          m1 *= s;
          m2 *= s * s;
        } else {
          m1 = target;
          m2 = target * target;
        }
        const float l = luminance(signal.plane(0)[i], signal.plane(1)[i], signal.plane(2)[i]);
        moments_.plane(0)[i] = momentsAlpha * l + (1.0f - momentsAlpha) * m1;
        moments_.plane(1)[i] = momentsAlpha * l * l + (1.0f - momentsAlpha) * m2;
      }
    });
  }

  SlgfSettings slgf_;
  AtrousSettings estimator_;
  // Pre-filter ping-pong: luminance moments (or channel means), channel second moments (clamp),
  // the propagated unit variance (1 / effective sample count).
  Image estimate_[2], colorMoments_[2], meanVariance_[2];
  int source_ = 0;
};

const ParamTable<SlgfSettings>& slgfParams() {
  using S = SlgfSettings;
  static const ParamTable<S> table =
      ParamTable<S>()
          .include(svgfParams(), &S::svgf)
          .integer("estimator.iterations", &S::estimatorIterations, 2, 1, 6,
                   "à-trous iterations of the luminance estimate (the talk's pre-spatial pass; "
                   "ours: 2, a 13x13 px footprint)")
          .choice("estimator.spread", &S::spread, "mean",
                  {{"mean", EstimatorSpread::Mean}, {"sample", EstimatorSpread::Sample}},
                  "box half-width unit: the spread of the local mean (sample spread / "
                  "sqrt(effective count); ours) or of the 1-spp samples (variance clipping)")
          .real("k", &S::k, 4.0, 0.0, 100.0,
                "history box [mu - k sigma, mu + k sigma] (ours 4 with spread=mean; variance "
                "clipping with spread=sample uses 1..2)")
          .choice("correction", &S::correction, "rescale",
                  {{"rescale", HistoryCorrection::Rescale}, {"clamp", HistoryCorrection::Clamp}},
                  "rescale: scale the history colour to the box's luminance (chroma kept); "
                  "clamp: clamp each channel to its own box")
          .real("alphaGain", &S::alphaGain, 1.0, 0.0, 1e3,
                "alpha' = (1 - lambda) alpha + lambda, lambda = min(1, gain * relative distance "
                "of the history outside the box) (ours 1)")
          .boolean("shortenHistory", &S::shortenHistory, true,
                   "h' = (h - 1)(1 - lambda)^10 + 1 where corrected (Q2RTX's anti-lag): restarts "
                   "1/h and the spatial variance estimate");
  return table;
}

}  // namespace

DenoiserInfo slgfInfo() {
  return {"slgf",
          "Spatiotemporal luminance-guided filtering (our interpretation of Luminous Engine's "
          "SLGF, CEDEC 2019/2021 talk): SVGF with the history corrected by a current-frame "
          "luminance estimate",
          slgfParams().schema(), [](const ParamSet& params, SignalKind) {
            return std::make_unique<Slgf>(slgfParams().settings(params, "slgf"));
          }};
}

}  // namespace arena
