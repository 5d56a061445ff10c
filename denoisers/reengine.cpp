// `reengine`: CAPCOM RE ENGINE's 2023 denoiser ("Advances in Ray Tracing", seed 004), the
// successor of the pipeline `hybrid` follows. The talk's "Aggressive Filtering" slide (28) gives
// the order, and every stage below is a switch:
//   0. filter space: linear (slides 24-27: Reinhard-compressed filtering ghosts under exposure and
//      light changes); `space=reinhard` is the ablation,
//   1. spatial propagation: a geometry-guided Poisson-disk gather of the 1-spp signal, wide where
//      the history is short, that also yields the neighbourhood moments (mean, second moment)
//      every later clamp uses,
//   2. temporal filter: EMA with alpha = 1/h; history corrected by the luminance of a stabilised
//      one-frame result (slide 29); roughness policy (slides 30-31): diffuse and specular above
//      the roughness threshold use geometry motion and the diffuse rules, smooth specular uses
//      geometry and planar virtual motion merged by the moments, with its colour clamped to the
//      moment box (slide 34),
//   3. spatial propagation again, over the temporal result, which becomes the history,
//   4. variance check: the relative noise of each pixel's mean,
//   5. spatial merge: the small scale (the propagated result) and a large scale (a mip level,
//      bilaterally upsampled) blended by that noise; smooth specular keeps the small scale,
//   6. deflicker: fireflies clamped to their 3x3 neighbours, then a light EMA clamped to the
//      3x3 box (slide 26: "デフリッカーロジックを追加して、firefliesを除去"),
//   7. spatial upscaling: where the history is short, the sequence's low-resolution many-sample
//      buffer (the "disocclusion rays", slides 19-21) is reconstructed at full resolution and
//      blended in; the low-resolution paths read are charged as rays per pixel,
//   8. spatial filter: one 3x3 edge-aware (depth, normal, luminance) à-trous pass -- the talk
//      dropped the wavelet cascade (slide 43: "ウェーブレットフィルターのロジックは削除").
// With every optional stage off (space linear, both propagations, rejection, colour clamp,
// variance check, merge, deflicker, disocclusion rays and spatial filter off, specularMotion
// geometry) it is plain reprojected accumulation with alpha = 1/h: `temporal` at the same
// maxHistory, bit for bit (tested).
//
// What the slides leave open, and what we chose (each a parameter; denoisers/FIDELITY.md goes
// through the talk slide by slide):
// - Propagation (1, 3): the slides name the passes but not their kernel. A Poisson-disk gather
//   with geometry-only weights (ReBLUR's, poisson_blur.hpp) "propagates" light without a
//   luminance term that would stop at the noise; radius 16 px (pass 1) and 8 px (pass 3) at
//   h = 1, shrinking as 1/sqrt(h); smooth specular's radius further scaled by roughness /
//   threshold (slide 31: small-scale filter below the threshold). Pixels, like the merge's mip
//   level, follow the one footprint policy (footprint.hpp: pixels at 1080 lines, scaled).
// - The stabilised one-frame result (slide 29): the propagated current frame, EMA with
//   alpha 0.5 over the previous one-frame result clamped to the current moments' box (stable
//   under noise, yet it follows a light change within the frame); the rejection rule is the
//   shared luminance_rejection.hpp, its gap in standard errors of the one-frame value (3, full
//   at 6; `rejectionMode=relative` is the first version, tau 0.5 relative, which fired on the
//   noise of sparse signals: the slide-24 caveat).
// - "Moment based merge" of geometry and virtual motion (slide 34): each candidate history is
//   weighted by how well its luminance fits the current moments, exp(-d^2 / 2 mergeSigma^2),
//   d = |L(history) - L(mean)| / sigma_L.
// - "Specular clamps the colour, diffuse clamps the history" (slide 34): smooth specular's
//   history is clamped per channel to mean +- 1.5 sigma; diffuse (and rough specular) histories
//   are corrected only by the luminance rejection.
// - Variance check and merge: the slides give neither; noise = sqrt(Var(L) / (n h)) / L, the
//   relative noise of a mean of h frames of pass 1's n distinct pixels, relative to
//   varianceTarget 0.25, clamped to [0, 1], is the large scale's share; the large scale is mip
//   level 3 (8x8 px at 1080 lines).
// - Disocclusion rays: read where h < 4, blend weight 0.9 at h = 1 falling linearly to 0 at
//   h = 4, times the reconstruction's confidence; the blend enters the history (lowresFeedback).
//   Charged per signal: RE ENGINE traces diffuse and specular rays separately (slide 42), so a
//   texel both signals read costs twice.
#include "denoisers/reengine.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "denoisers/common/atrous.hpp"
#include "denoisers/common/filter_space.hpp"
#include "denoisers/common/history_clamp.hpp"
#include "denoisers/common/luminance_rejection.hpp"
#include "denoisers/common/temporal_accumulation.hpp"
#include "denoisers/variants.hpp"

namespace arena {

namespace {
constexpr float kLuma[3] = {0.2126f, 0.7152f, 0.0722f};
}  // namespace

ReEngine::ReEngine(const ReEngineSettings& settings, SignalKind kind) : s_(settings), kind_(kind) {
  if (kind_ == SignalKind::Specular) {
    s_.weights.hitDistance = true;
    s_.weights.roughness = true;
  }
}

std::vector<std::string> ReEngine::requiredChannels() const {
  std::vector<std::string> channels = {"depth", "normal", "meshId", "motion", "position"};
  if (kind_ == SignalKind::Specular) {
    channels.push_back("roughness");
    channels.push_back("specHitDist");
  }
  return channels;
}

void ReEngine::setup(int width, int height) {
  width_ = width;
  height_ = height;
  footprintScale_ = s_.footprint.scale(height);
  mergeLevel_ = scaledMipLevel(s_.mergeLevels, footprintScale_);
  derivatives_ = Image(width, height, kGeometryDerivativeChannels);
  surface_.setup(width, height);
  virtual_.setup(width, height);
  previousGBuffer_.setup(width, height);
  mips_.setup(width, height, mergeLevel_, 3);
  for (Image* image : {&colorHistory_, &oneFrameHistory_, &deflickerHistory_, &signal_, &oneFrame_,
                       &temporal_, &propagated2_, &large_, &merged_, &fireflyClamped_,
                       &reprojectedDeflicker_, &deflickered_, &upscaled_, &upscaledBlend_, &final_})
    *image = Image(width, height, 3);
  for (Image* image : {&lengthHistory_, &share_, &valid_, &radius_, &historyLength_, &rejection_,
                       &noise_,
                       &lumVariance_, &filteredVariance_, &need_, &confidence_, &lowWeight_})
    *image = Image(width, height, 1);
  // Colour, its per-channel square and the luminance's square (the luminance variance keeps the
  // channels' covariance: per-channel variances weighted by luma^2 give 0.56x it for grey noise).
  momentInput_ = Image(width, height, 7);
  propagated_ = Image(width, height, 7);
  noiseMoments_ = Image(width, height, 7);
  noiseRadius_ = Image(width, height, 1);
  gatherCount_ = Image(width, height, 2);  // distinct pixels: pass 1's gather, the noise gather
  momentsHistory_ = Image(width, height, 2);
  moments_ = Image(width, height, 2);
  taps_.setup(height);
  hasHistory_ = false;
}

void ReEngine::reset() {
  hasHistory_ = false;
}

void ReEngine::denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) {
  if (ctx.reset) reset();
  gbuffer_ = GBufferView::fromFrame(in.frame, requiredChannels(), "reengine");
  const bool specular = kind_ == SignalKind::Specular;
  roughness_ = specular ? in.frame.get("roughness", "reengine").plane(0) : nullptr;
  hitDistance_ = specular ? in.frame.get("specHitDist", "reengine").plane(0) : nullptr;
  if (s_.disocclusionRays == ReEngineSettings::DisocclusionRays::On && in.lowres == nullptr)
    throw Error(
        "reengine: disocclusionRays=on needs the sequence's low-resolution buffer; render it "
        "with --lowres-factor 8 --lowres-spp 16, or use disocclusionRays=auto or off");
  toFilterSpace(in.signal);
  reproject(ctx);
  spatialPropagation1(ctx);
  temporalFilter();
  spatialPropagation2(ctx);
  varianceCheck();
  spatialMerge();
  deflicker();
  spatialUpscaling(s_.disocclusionRays == ReEngineSettings::DisocclusionRays::Off ? nullptr
                                                                                  : in.lowres);
  spatialFilter();
  fromFilterSpace(output);
  storeHistory();
}

// ---- 0. Filter space (slides 24-27): linear by default; the Reinhard ablation compresses here
// and expands at the end (filter_space.hpp).
void ReEngine::toFilterSpace(const Image& signal) {
  ScopedPass pass(this, "filter space", 0);
  if (s_.space == FilterSpace::Reinhard)
    reinhardCompress(signal, signal_);
  else
    parallelCopy(signal, signal_);
}

// Same mesh and normals within ~37 degrees (n.n' >= 0.8): the edge-aware median's rule.
bool ReEngine::sameSurface3x3(size_t p, size_t q) const {
  if (gbuffer_.meshId[p] != gbuffer_.meshId[q]) return false;
  float cosine = 0.0f;
  for (size_t c = 0; c < 3; ++c) cosine += gbuffer_.normal[c][p] * gbuffer_.normal[c][q];
  return cosine >= 0.8f;
}

bool ReEngine::diffuseLike(size_t i) const {
  // Slide 30: "ほとんどの条件では、荒いスペキュラはディフューズと同じポリシーでデノイズできます".
  return kind_ == SignalKind::Diffuse ||
         (s_.roughAsDiffuse && roughness_[i] > s_.roughnessThreshold);
}

float ReEngine::historyAt(size_t i, const float* plane) const {
  if (valid_.plane(0)[i] == 0.0f) return 0.0f;
  const float s = share_.plane(0)[i];
  if (s == 0.0f) return surface_.sample(i, plane);
  if (s == 1.0f) return virtual_.sample(i, plane);
  return (1.0f - s) * surface_.sample(i, plane) + s * virtual_.sample(i, plane);
}

// Geometry motion for every pixel; planar virtual motion (hit-point reprojection, slide 34:
// "バーチャル・モーションは平面的なものだけ") for smooth specular. The share of each is decided in
// the temporal filter, where the moments are known; here only which sources exist, and the
// history length that sets the propagation radius.
void ReEngine::reproject(const FrameContext& ctx) {
  ScopedPass pass(this, "reprojection", 4);
  computeGeometryDerivatives(gbuffer_, derivatives_);
  useVirtual_ = kind_ == SignalKind::Specular &&
                s_.specularMotion != ReEngineSettings::SpecularMotion::Geometry;
  if (hasHistory_) {
    const GBufferView previous = previousGBuffer_.view();
    surface_.compute(gbuffer_, derivatives_, previous, s_.reprojection, &ctx.camera,
                     &ctx.previousCamera);
    if (useVirtual_)
      virtual_.compute(gbuffer_, hitDistance_, ctx.camera, ctx.previousCamera, previous,
                       s_.hitPointTests);
  } else {
    surface_.invalidateAll();
    virtual_.invalidateAll();
  }
  const bool virtualOnly = s_.specularMotion == ReEngineSettings::SpecularMotion::Virtual;
  if (gpu::recording()) {  // which motion, h and the propagation radius per pixel
    using namespace gpu_buffers;
    gpu::dispatch(width_, height_);
    gpu::read(kRecord, width_, height_);
    if (useVirtual_) gpu::read(kVirtualRecord, width_, height_);
    if (roughness_) gpu::read(kRoughness, width_, height_);
    gpu::read(kHistoryLengthHistory, width_, height_, surface_.readTapsPerPixel());
    gpu::write({kMask, kHistoryLength}, width_, height_);
  }
  parallelRows(height_, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      const size_t i = size_t(y) * size_t(width_) + size_t(x);
      const bool smoothSpecular = useVirtual_ && !diffuseLike(i);
      const bool geometry = surface_.valid(i) && !(smoothSpecular && virtualOnly);
      const bool virtualMotion = smoothSpecular && virtual_.valid(i);
      // Provisional: the share is refined by the moment-based merge in the temporal filter.
      share_.plane(0)[i] = geometry ? 0.0f : 1.0f;
      valid_.plane(0)[i] = geometry || virtualMotion ? 1.0f : 0.0f;
      const float h = nextHistoryLength(
          valid_.plane(0)[i] != 0.0f, historyAt(i, lengthHistory_.plane(0)), float(s_.maxHistory));
      float scale = std::max(1.0f / std::sqrt(h), s_.minRadius / s_.propagationRadius);
      // Slide 31: below the roughness threshold, a small-scale filter.
      if (kind_ == SignalKind::Specular && !diffuseLike(i))
        scale *= std::clamp(roughness_[i] / std::max(s_.roughnessThreshold, 1e-3f), 0.1f, 1.0f);
      radius_.plane(0)[i] = scale;
    }
  });
}

bool ReEngine::needsMoments() const {
  return s_.propagation1 || s_.lumaRejection || s_.specularColorClamp || useVirtual_ ||
         s_.varianceCheck || s_.disocclusionRays != ReEngineSettings::DisocclusionRays::Off;
}

// ---- 1. Spatial propagation: the Poisson-disk gather (poisson_blur.hpp) of the signal and its
// square, so one pass gives the propagated colour and the moments mean, E[x^2] per channel.
void ReEngine::spatialPropagation1(const FrameContext& ctx) {
  ScopedPass pass(this, "spatial propagation 1", needsMoments() ? 2 * kPoissonTaps : 0);
  std::fill(gatherCount_.raw().begin(), gatherCount_.raw().end(), 1.0f);
  if (!needsMoments()) return;
  parallelRows(height_, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      const size_t i = size_t(y) * size_t(width_) + size_t(x);
      for (int c = 0; c < 3; ++c) {
        const float v = signal_.plane(c)[i];
        momentInput_.plane(c)[i] = v;
        momentInput_.plane(c + 3)[i] = v * v;
      }
      const float l = luminance(signal_.plane(0)[i], signal_.plane(1)[i], signal_.plane(2)[i]);
      momentInput_.plane(6)[i] = l * l;
    }
  });
  PoissonBlurSettings blur;
  blur.radius = s_.propagationRadius * footprintScale_;
  blur.weights = s_.weights;
  const float rotation = poissonRotation(ctx.frameIndex);
  poissonDiskBlur(momentInput_, SurfaceGuide{gbuffer_, roughness_, hitDistance_}, blur, rotation,
                  &radius_, propagated_);
  // The distinct pixels the gather read (the centre and the taps that round to other pixels; a
  // small radius puts several taps on one pixel): the nominal sample count of the mean, which
  // the rejection and the variance check divide the 1-spp variance by. Geometry weights and taps
  // dropped at edges make the true count smaller: the estimate errs towards rejecting.
  // The noise statistics: the same gather with its radius floored at kNoiseRadius px, so the
  // clamp boxes, the luminance variance and the moment clamp never rest on fewer than about nine
  // pixels. Under the scaled footprint a converged pixel's pass-1 gather shrinks to the pixel
  // itself (16 px / sqrt(32) at 144 lines is 0.4 px), and a box of one sample collapses onto it:
  // every history then looked rejected, which reset the moments, which kept it so.
  constexpr float kNoiseRadius = 2.0f;
  PoissonBlurSettings noiseBlur = blur;
  noiseBlur.radius = std::max(blur.radius, kNoiseRadius);
  for (size_t i = 0; i < noiseRadius_.pixelCount(); ++i)
    noiseRadius_.plane(0)[i] =
        std::max(blur.radius * radius_.plane(0)[i], kNoiseRadius) / noiseBlur.radius;
  poissonDiskBlur(momentInput_, SurfaceGuide{gbuffer_, roughness_, hitDistance_}, noiseBlur,
                  rotation, &noiseRadius_, noiseMoments_);
  const auto disk = poissonDisk(rotation);
  parallelRows(height_, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      const size_t i = size_t(y) * size_t(width_) + size_t(x);
      const float radii[2] = {blur.radius * radius_.plane(0)[i],
                              noiseBlur.radius * noiseRadius_.plane(0)[i]};
      for (int g = 0; g < 2; ++g) {
        long offsets[kPoissonTaps + 1];
        int count = 0;
        offsets[count++] = 0;
        for (const auto& tap : disk) {
          const long dx = std::lround(tap[0] * radii[g]), dy = std::lround(tap[1] * radii[g]);
          const long key = dy * 65536 + dx;
          if (std::find(offsets, offsets + count, key) == offsets + count) offsets[count++] = key;
        }
        gatherCount_.plane(g)[i] = float(count);
      }
    }
  });
}

float ReEngine::spatialLumaVariance(size_t i) const {
  const float lm = luminance(noiseMoments_.plane(0)[i], noiseMoments_.plane(1)[i],
                             noiseMoments_.plane(2)[i]);
  return std::max(0.0f, noiseMoments_.plane(6)[i] - lm * lm);
}

float ReEngine::samplesPerFrame(size_t i) const {
  return s_.propagation1 ? gatherCount_.plane(0)[i] : 1.0f;
}

// ---- 2. Temporal filter.
void ReEngine::temporalFilter() {
  ScopedPass pass(this, "temporal filter", useVirtual_ ? 8 : 4);
  const bool moments = needsMoments();
  const bool merge = s_.specularMotion == ReEngineSettings::SpecularMotion::Merge;
  const float maxHistory = float(s_.maxHistory);
  if (gpu::recording()) {  // the current moments box, then each history through its taps
    using namespace gpu_buffers;
    const double taps = surface_.readTapsPerPixel() * (useVirtual_ ? 2.0 : 1.0);
    gpu::dispatch(width_, height_);
    gpu::read({kSignal, kRecord, kMask, kHistoryLength}, width_, height_);
    if (useVirtual_) gpu::read(kVirtualRecord, width_, height_);
    if (roughness_) gpu::read(kRoughness, width_, height_);
    // Pass 1's mean, and the noise statistics' mean and second moments (seven channels: two
    // buffers) for the clamp's sigma.
    if (moments) gpu::read({kRadiance, kSecondMoments, kExtraChannels}, width_, height_);
    gpu::read({kRadianceHistory, kMomentsHistory}, width_, height_, taps);
    if (s_.lumaRejection) {
      gpu::read(kOneFrameHistory, width_, height_, taps);
      gpu::write(kOneFrameHistory, width_, height_);
    }
    gpu::write({kRadiance, kMoments, kHistoryLength}, width_, height_);
  }
  parallelRows(height_, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      const size_t i = size_t(y) * size_t(width_) + size_t(x);
      float current[3], mean[3], sigma[3], history[3], result[3];
      for (int c = 0; c < 3; ++c) {
        current[c] = s_.propagation1 ? propagated_.plane(c)[i] : signal_.plane(c)[i];
        mean[c] = moments ? propagated_.plane(c)[i] : current[c];
        // Sigma from the noise statistics (at least ~9 pixels), centred on pass 1's mean.
        const float wideMean = noiseMoments_.plane(c)[i];
        sigma[c] = moments ? std::sqrt(std::max(0.0f, noiseMoments_.plane(c + 3)[i] -
                                                          wideMean * wideMean))
                           : 0.0f;
      }
      const bool smoothSpecular = useVirtual_ && !diffuseLike(i);
      // Slide 34, "Moment based merge": where both motions find a history, weight each by how
      // well its luminance fits the current moments.
      if (smoothSpecular && merge && surface_.valid(i) && virtual_.valid(i)) {
        float geometry[3], reflected[3];
        for (int c = 0; c < 3; ++c) {
          geometry[c] = surface_.sample(i, colorHistory_.plane(c));
          reflected[c] = virtual_.sample(i, colorHistory_.plane(c));
        }
        const float lm = luminance(mean[0], mean[1], mean[2]);
        const float ls =
            kLuma[0] * sigma[0] + kLuma[1] * sigma[1] + kLuma[2] * sigma[2] + 1e-3f * lm + 1e-6f;
        auto fit = [&](const float* h) {
          const float d = (luminance(h[0], h[1], h[2]) - lm) / (ls * s_.mergeSigma);
          return std::exp(-0.5f * d * d);
        };
        const float wg = fit(geometry), wv = fit(reflected);
        share_.plane(0)[i] = wg + wv > 1e-12f ? wv / (wg + wv) : 0.5f;
      }
      const bool valid = valid_.plane(0)[i] != 0.0f;
      float h = nextHistoryLength(valid, historyAt(i, lengthHistory_.plane(0)), maxHistory);
      // Slide 29: the stabilised one-frame result -- the propagated frame, lightly accumulated
      // over its own history clamped to the current moments (stable under noise, yet at a light
      // change it follows within the frame, so the rejection below can act at once).
      // Its frame value is the noise statistics' mean (at least ~9 pixels): under the scaled
      // footprint pass 1 alone may hold one pixel, and one 1-spp sample cannot tell a light
      // switched off from noise (issue 34).
      if (s_.lumaRejection)
        for (int c = 0; c < 3; ++c) {
          const float frameValue = moments ? noiseMoments_.plane(c)[i] : mean[c];
          const float previous = std::clamp(historyAt(i, oneFrameHistory_.plane(c)),
                                            frameValue - s_.clampGamma * sigma[c],
                                            frameValue + s_.clampGamma * sigma[c]);
          oneFrame_.plane(c)[i] = valid ? s_.oneFrameAlpha * frameValue +
                                              (1.0f - s_.oneFrameAlpha) * previous
                                        : frameValue;
        }
      // The moments follow the value the EMA averages (pass 1's mean, or the 1-spp signal with
      // propagation off), so their variance is that of one frame's contribution to the mean.
      const float l = luminance(current[0], current[1], current[2]);
      float rho = 0.0f;  // the share of the history the luminance rejection replaced
      if (valid) {
        for (int c = 0; c < 3; ++c) history[c] = historyAt(i, colorHistory_.plane(c));
        if (s_.lumaRejection) {
          const float stabilised[3] = {oneFrame_.plane(0)[i], oneFrame_.plane(1)[i],
                                       oneFrame_.plane(2)[i]};
          if (s_.rejectionMode == ReEngineSettings::RejectionMode::Relative) {
            rho = rejectHistoryLuminance(history, stabilised, s_.rejectionTau);
          } else {
            // The 1-spp luminance variance s^2: the larger of this frame's (E[l^2] - E[l]^2 of
            // the noise statistics, covariance kept) and the history's, from its temporal
            // moments of values that each averaged n pixels -- nine equal samples (all zero on a
            // sparse signal) cannot tell a switched-off light from a miss; the history's spread
            // can. The gap's variance: the stabilised value's, an EMA (a = oneFrameAlpha) of
            // means of the noise gather's n' pixels, a / (2 - a) s^2 / n', plus the history's,
            // a mean of h frames of n pixels, s^2 / (n h).
            const float n = samplesPerFrame(i), wide = gatherCount_.plane(1)[i];
            const float m1 = historyAt(i, momentsHistory_.plane(0));
            const float variance = std::max(spatialLumaVariance(i),
                                            (historyAt(i, momentsHistory_.plane(1)) - m1 * m1) * n);
            const float a = s_.oneFrameAlpha;
            const float gapVariance = variance * (a / (2.0f - a) / wide + 1.0f / (n * h));
            rho = rejectHistoryLuminanceSigma(history, stabilised, std::sqrt(gapVariance),
                                              s_.rejectionSigma);
          }
          h = std::max(1.0f, h * (1.0f - rho));
        }
        if (smoothSpecular && s_.specularColorClamp) {  // slide 34: specular clamps the colour
          float lo[3], hi[3];
          for (int c = 0; c < 3; ++c) {
            lo[c] = mean[c] - s_.clampGamma * sigma[c];
            hi[c] = mean[c] + s_.clampGamma * sigma[c];
          }
          clampToBox(history, lo, hi, 3);
        }
        // The EMA written as `temporal` writes it, so the all-off pipeline matches it exactly.
        const float a = blendAlpha(h, 0.0f);
        for (int c = 0; c < 3; ++c) result[c] = a * current[c] + (1.0f - a) * history[c];
        for (int m = 0; m < 2; ++m)
          moments_.plane(m)[i] =
              a * (m == 0 ? l : l * l) + (1.0f - a) * historyAt(i, momentsHistory_.plane(m));
      } else {
        for (int c = 0; c < 3; ++c) result[c] = current[c];
        moments_.plane(0)[i] = l;
        moments_.plane(1)[i] = l * l;
      }
      for (int c = 0; c < 3; ++c) temporal_.plane(c)[i] = result[c];
      historyLength_.plane(0)[i] = h;
      rejection_.plane(0)[i] = rho;
    }
  });
}

// ---- 3. Spatial propagation over the temporal result (radius per the new h); it is the history.
void ReEngine::spatialPropagation2(const FrameContext& ctx) {
  ScopedPass pass(this, "spatial propagation 2", s_.propagation2 ? kPoissonTaps : 0);
  if (!s_.propagation2) {
    parallelCopy(temporal_, propagated2_);
    return;
  }
  const float minScale = s_.minRadius / s_.propagation2Radius;
  for (size_t i = 0; i < historyLength_.pixelCount(); ++i) {
    float scale = std::max(1.0f / std::sqrt(historyLength_.plane(0)[i]), minScale);
    if (kind_ == SignalKind::Specular && !diffuseLike(i))
      scale *= std::clamp(roughness_[i] / std::max(s_.roughnessThreshold, 1e-3f), 0.1f, 1.0f);
    radius_.plane(0)[i] = scale;
  }
  PoissonBlurSettings blur;
  blur.radius = s_.propagation2Radius * footprintScale_;
  blur.weights = s_.weights;
  poissonDiskBlur(temporal_, SurfaceGuide{gbuffer_, roughness_, hitDistance_}, blur,
                  poissonRotation(ctx.frameIndex + 1), &radius_, propagated2_);
}

// ---- 4. Variance check: the relative noise of each pixel's mean. Once h >= 4 the variance of
// one frame's value (the temporal moments of what the EMA averages: pass 1's mean) over the
// frames the EMA holds (h, or 2h - 1 at the cap, where alpha = 1/h is an EMA); before, pass 1's
// spatial estimate: the 1-spp E[l^2] - E[l]^2 (channels' covariance kept) over its n distinct
// pixels and h frames. (Issue 34: the raw 1-spp variance over h alone left sigma about 3-4x too
// high, so the large scale took 70-100 % even on converged pixels.) Pass 3's gather is not
// counted: its taps lie inside pass 1's footprints, so their errors are correlated.
void ReEngine::varianceCheck() {
  ScopedPass pass(this, "variance check", 0);
  const bool spatial = needsMoments();
  const float maxHistory = float(s_.maxHistory);
  if (gpu::recording()) {
    using namespace gpu_buffers;
    gpu::dispatch(width_, height_);
    gpu::read({kHistoryLength, kMoments, kRadiance}, width_, height_);
    if (spatial) gpu::read(kSecondMoments, width_, height_);
    gpu::write({kVariance, kNoise}, width_, height_);
  }
  parallelRows(height_, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      const size_t i = size_t(y) * size_t(width_) + size_t(x);
      const float h = historyLength_.plane(0)[i];
      const float frames = h < maxHistory ? h : 2.0f * h - 1.0f;
      float meanVariance =
          std::max(0.0f, moments_.plane(1)[i] - moments_.plane(0)[i] * moments_.plane(0)[i]) /
          frames;
      if (h < 4.0f && spatial) meanVariance = spatialLumaVariance(i) / (samplesPerFrame(i) * h);
      lumVariance_.plane(0)[i] = meanVariance;
      const float l =
          luminance(propagated2_.plane(0)[i], propagated2_.plane(1)[i], propagated2_.plane(2)[i]);
      noise_.plane(0)[i] =
          s_.varianceCheck
              ? std::clamp(std::sqrt(meanVariance) / (std::abs(l) + 1e-3f) / s_.varianceTarget,
                           0.0f, 1.0f)
              : s_.mergeWeight;
    }
  });
}

// ---- 5. Spatial merge (slide 31: "Large scale filter / Small scale filter -> Upscale -> Merge"):
// the large scale is a mip level of the propagated result brought back by bilateral upsampling;
// its share is the variance check's noise, and 0 for smooth specular (small scale only).
void ReEngine::spatialMerge() {
  ScopedPass pass(this, "spatial merge", s_.spatialMerge ? 4 : 0);
  if (!s_.spatialMerge) {
    parallelCopy(propagated2_, merged_);
    return;
  }
  mips_.build(propagated2_, gbuffer_);
  // A 1080p frame (the GPU prediction's) under the same policy can build a deeper chain.
  mips_.priceLevelsBeyond(scaledMipLevel(s_.mergeLevels, s_.footprint.scale(1080)));
  mips_.upsample(mips_.levels(), nullptr, gbuffer_, {}, large_);
  if (gpu::recording()) {  // the blend by the noise (a shader would fuse it into the upsample)
    using namespace gpu_buffers;
    gpu::dispatch(width_, height_);
    gpu::read({kRadiance, kNoise}, width_, height_);
    gpu::write(kRadiance, width_, height_);
  }
  parallelRows(height_, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      const size_t i = size_t(y) * size_t(width_) + size_t(x);
      const float t = diffuseLike(i) ? noise_.plane(0)[i] : 0.0f;
      for (int c = 0; c < 3; ++c)
        merged_.plane(c)[i] =
            propagated2_.plane(c)[i] + t * (large_.plane(c)[i] - propagated2_.plane(c)[i]);
    }
  });
}

// ---- 6. Deflicker (slide 26): linear colour keeps its fireflies, which Reinhard used to hide.
// A pixel brighter than every 3x3 neighbour is scaled down to the brightest of them (NRD ReLAX's
// firefly suppression kind); then a light EMA over the deflicker's own reprojected output,
// clamped to the 3x3 box of the current value so it cannot ghost.
void ReEngine::deflicker() {
  ScopedPass pass(this, "deflicker", s_.deflicker ? 18 : 0);
  if (!s_.deflicker) {
    parallelCopy(merged_, deflickered_);
    return;
  }
  if (gpu::recording()) {  // fireflies against the 3x3, then the stabiliser's history
    using namespace gpu_buffers;
    gpu::dispatch(width_, height_);
    gpu::read({kRadiance, kMeshId}, width_, height_, 9);
    if (s_.deflickerEdgeAware) gpu::read(kNormal, width_, height_, 9);  // sameSurface3x3
    gpu::read({kMask, kRecord}, width_, height_);
    gpu::read(kStabilizerHistory, width_, height_, surface_.readTapsPerPixel());
    gpu::write(kRadiance, width_, height_);
  }
  parallelRows(height_, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      const size_t p = size_t(y) * size_t(width_) + size_t(x);
      float brightest = -1.0f;
      forEachNeighbour3x3(x, y, width_, height_, &gbuffer_, true, [&](size_t q) {
        // Edge-aware (the median's rule, median.hpp): a neighbour across an edge says nothing
        // of p's brightness, so a one-pixel-wide lit feature is not a firefly.
        if (s_.deflickerEdgeAware && !sameSurface3x3(p, q)) return;
        brightest = std::max(
            brightest, luminance(merged_.plane(0)[q], merged_.plane(1)[q], merged_.plane(2)[q]));
      });
      const float l = luminance(merged_.plane(0)[p], merged_.plane(1)[p], merged_.plane(2)[p]);
      const float scale =
          brightest >= 0.0f && l > brightest && !gbuffer_.isSky(p) ? brightest / l : 1.0f;
      for (int c = 0; c < 3; ++c) fireflyClamped_.plane(c)[p] = merged_.plane(c)[p] * scale;
      for (int c = 0; c < 3; ++c)
        reprojectedDeflicker_.plane(c)[p] = valid_.plane(0)[p] != 0.0f
                                                ? historyAt(p, deflickerHistory_.plane(c))
                                                : fireflyClamped_.plane(c)[p];
    }
  });
  clampHistory(reprojectedDeflicker_, fireflyClamped_, &gbuffer_,
               {HistoryClampMode::Clamp, 1, s_.deflickerGamma}, reprojectedDeflicker_, taps_);
  const float a = s_.deflickerAlpha;
  for (size_t k = 0; k < deflickered_.raw().size(); ++k)
    deflickered_.raw()[k] =
        a * fireflyClamped_.raw()[k] + (1.0f - a) * reprojectedDeflicker_.raw()[k];
}

// ---- 7. Spatial upscaling of the disocclusion rays (slides 19-21): where the history is short,
// the low-resolution buffer is reconstructed (lowres_upsample.hpp: bilateral upsampling, SH
// projection of the mean direction onto the normal, moment clamp) and blended in.
void ReEngine::spatialUpscaling(const LowresInputs* lowres) {
  ScopedPass pass(this, "spatial upscaling", lowres ? 4 : 0);
  raysPerPixel_ = 0;
  parallelCopy(deflickered_, upscaledBlend_);
  std::fill(lowWeight_.raw().begin(), lowWeight_.raw().end(), 0.0f);
  if (!lowres) return;
  const float cutoff = float(s_.lowresMaxHistory);
  for (size_t i = 0; i < need_.pixelCount(); ++i)
    need_.plane(0)[i] = historyLength_.plane(0)[i] < cutoff && diffuseLike(i) ? 1.0f : 0.0f;
  if (lowres->factor != upsamplerFactor_) {  // allocated on the first frame that reads it
    upsampler_.setup(width_, height_, lowres->factor);
    upsamplerFactor_ = lowres->factor;
  }
  const bool diffuse = kind_ == SignalKind::Diffuse;
  const Image& color =
      lowres->layers.get(diffuse ? "diffuse" : "specular", "reengine low-resolution buffer");
  const Image* direction =
      diffuse ? &lowres->layers.get("direction", "reengine low-resolution buffer") : nullptr;
  Image lowColor;
  if (s_.space == FilterSpace::Reinhard) {  // the buffer joins the signal in its filter space
    lowColor = Image(color.width(), color.height(), 3);
    reinhardCompress(color, lowColor);
  }
  const LowresBuffer buffer{s_.space == FilterSpace::Reinhard ? lowColor : color, direction,
                            lowres->factor, lowres->spp};
  upsampler_.reconstruct(buffer, gbuffer_, &noiseMoments_, need_, s_.upsample, upscaled_,
                         confidence_);
  raysPerPixel_ = upsampler_.raysPerPixel();
  pass.setRays(raysPerPixel_);
  for (size_t i = 0; i < need_.pixelCount(); ++i) {
    if (need_.plane(0)[i] == 0.0f) continue;
    const float young =
        cutoff > 1.0f ? (cutoff - historyLength_.plane(0)[i]) / (cutoff - 1.0f) : 1.0f;
    const float w = s_.lowresWeight * std::clamp(young, 0.0f, 1.0f) * confidence_.plane(0)[i];
    lowWeight_.plane(0)[i] = w;
    for (int c = 0; c < 3; ++c)
      upscaledBlend_.plane(c)[i] += w * (upscaled_.plane(c)[i] - upscaledBlend_.plane(c)[i]);
  }
}

// ---- 8. Spatial filter: one 3x3 à-trous pass with depth, normal and variance-scaled luminance
// stopping (the talk keeps a bilateral after dropping the wavelet cascade, slides 42-43).
void ReEngine::spatialFilter() {
  ScopedPass pass(this, "spatial filter", s_.spatialFilter ? 18 : 0);
  if (!s_.spatialFilter) {
    parallelCopy(upscaledBlend_, final_);
    return;
  }
  prefilterVariance3x3(lumVariance_, gbuffer_, filteredVariance_);
  AtrousSettings a;
  a.kernel = AtrousKernel::Compact3x3;
  // SVGF's depth and normal terms at the SVGF paper's sigmas (eq. 3: sigma_z 1; eq. 4: sigma_n
  // 128), the luminance term at the parameter sigmaL, and never across meshes.
  EdgeStoppingSettings& e = a.edges;
  e.depth = true;
  e.sigmaZ = 1.0f;
  e.normal = true;
  e.normalForm = NormalWeightForm::CosinePower;
  e.sigmaN = 128.0f;
  e.luminance = true;
  e.sigmaL = s_.sigmaL;
  e.id = true;
  const AtrousGuide guide{gbuffer_, &derivatives_, &filteredVariance_, nullptr, 1.0f};
  atrousIteration(0, a, guide, 1.0f, upscaledBlend_, final_);
}

void ReEngine::fromFilterSpace(Image& output) {
  ScopedPass pass(this, "output space", 0);
  if (s_.space == FilterSpace::Reinhard)
    reinhardExpand(final_, output);
  else
    parallelCopy(final_, output);
}

void ReEngine::storeHistory() {
  ScopedPass pass(this, "store history", 0);
  // The second propagation's result is the history; with lowresFeedback the disocclusion rays'
  // blend enters it too, so the next frame starts from the better estimate.
  if (s_.lowresFeedback && raysPerPixel_ > 0) {
    if (gpu::recording()) {  // a blend, not a buffer swap: the propagated and upscaled values
      using namespace gpu_buffers;
      gpu::dispatch(width_, height_);
      gpu::read({kRadiance, kUpscaled}, width_, height_);  // propagated, upscaled: two images
      // The blend's weight: the upscaling's confidence and how young the history is.
      gpu::read({kConfidence, kHistoryLength}, width_, height_);
      gpu::write(kRadianceHistory, width_, height_);
    }
    for (size_t i = 0; i < colorHistory_.pixelCount(); ++i) {
      const float w = lowWeight_.plane(0)[i];
      for (int c = 0; c < 3; ++c)
        colorHistory_.plane(c)[i] =
            propagated2_.plane(c)[i] + w * (upscaled_.plane(c)[i] - propagated2_.plane(c)[i]);
    }
  } else {
    parallelCopy(propagated2_, colorHistory_);
  }
  parallelCopy(historyLength_, lengthHistory_);
  parallelCopy(moments_, momentsHistory_);
  if (s_.lumaRejection) parallelCopy(oneFrame_, oneFrameHistory_);
  if (s_.deflicker) parallelCopy(deflickered_, deflickerHistory_);
  previousGBuffer_.store(gbuffer_);
  hasHistory_ = true;
}

std::vector<std::pair<std::string, const Image*>> ReEngine::passOutputs() const {
  return {{"filter space", &signal_},
          {"spatial propagation 1", &propagated_},
          {"noise statistics", &noiseMoments_},
          {"temporal filter", &temporal_},
          {"spatial propagation 2", &propagated2_},
          {"variance check", &noise_},
          {"spatial merge", &merged_},
          {"deflicker", &deflickered_},
          {"spatial upscaling", &upscaledBlend_},
          {"spatial filter", &final_},
          {"history length", &historyLength_},
          {"luminance rejection", &rejection_},
          {"luminance variance", &lumVariance_},
          {"low-resolution weight", &lowWeight_}};
}

const ParamTable<ReEngineSettings>& reEngineParams() {
  using S = ReEngineSettings;
  static const ParamTable<S> table =
      ParamTable<S>()
          .choice("space", &S::space, "linear",
                  {{"linear", FilterSpace::Linear}, {"reinhard", FilterSpace::Reinhard}},
                  "filter in linear space (the talk's fix) or Reinhard-compressed (their old "
                  "path)")
          .boolean("propagation1", &S::propagation1, true,
                   "spatial propagation before the temporal filter (slide 28)")
          .real("propagationRadius", &S::propagationRadius, 16, 0, 256,
                "pass-1 Poisson radius at h = 1, px at footprintHeight; / sqrt(h) (ours)")
          .real("propagation2Radius", &S::propagation2Radius, 8, 0, 256,
                "pass-3 Poisson radius at h = 1, px at footprintHeight; / sqrt(h) (ours)")
          .real("minRadius", &S::minRadius, 1, 0, 64,
                "smallest propagation radius, px at footprintHeight (ours)")
          .integer("maxHistory", &S::maxHistory, 32, 1, 4096,
                   "cap of h, alpha = 1/h (ours; Falcor 32)")
          .boolean("lumaRejection", &S::lumaRejection, true,
                   "temporal luminance rejection from the stabilised one-frame result (slide 29)")
          .choice("rejectionMode", &S::rejectionMode, "sigma",
                  {{"sigma", S::RejectionMode::Sigma}, {"relative", S::RejectionMode::Relative}},
                  "luminance gap in standard errors of the one-frame value (ours, as hybrid's "
                  "lumaMode=sigma) or relative to the larger luminance (the first version)")
          .real("rejectionSigma", &S::rejectionSigma, 3, 1e-6, 1e6,
                "rejectionMode=sigma: standard errors tolerated; full rejection at twice (ours)")
          .real("rejectionTau", &S::rejectionTau, 0.5, 1e-6, 1e6,
                "rejectionMode=relative: relative luminance gap tolerated (ours)")
          .real("oneFrameAlpha", &S::oneFrameAlpha, 0.5, 0, 1,
                "new-frame weight of the stabilised one-frame EMA (ours)")
          .real("roughnessThreshold", &S::roughnessThreshold, 0.3, 0, 1,
                "specular: diffuse policy above it (slide 30: 0.3)")
          .boolean("roughAsDiffuse", &S::roughAsDiffuse, true,
                   "rough specular filtered like diffuse at the larger scale (slides 30-31)")
          .choice("specularMotion", &S::specularMotion, "merge",
                  {{"merge", S::SpecularMotion::Merge},
                   {"geometry", S::SpecularMotion::Geometry},
                   {"virtual", S::SpecularMotion::Virtual}},
                  "smooth specular history: moment-based merge of geometry and planar virtual "
                  "motion (slide 34), or one of them")
          .real("mergeSigma", &S::mergeSigma, 1, 1e-6, 1e6,
                "moment-based merge: luminance fit in sigma (ours)")
          .boolean("specularColorClamp", &S::specularColorClamp, true,
                   "clamp smooth specular's history colour to the moments (slide 34)")
          .real("clampGamma", &S::clampGamma, 1.5, 0, 100,
                "colour clamp box half-width in sigma (ours)")
          .boolean("propagation2", &S::propagation2, true,
                   "spatial propagation after the temporal filter (slide 28)")
          .boolean("varianceCheck", &S::varianceCheck, true,
                   "the noise of each mean sets the large scale's share (slide 28)")
          .real("varianceTarget", &S::varianceTarget, 0.25, 1e-6, 1e6,
                "relative noise that takes the large scale fully (ours)")
          .boolean("spatialMerge", &S::spatialMerge, true,
                   "merge a small and a large (mip) scale (slides 28, 31)")
          .integer("mergeLevels", &S::mergeLevels, 3, 1, 8,
                   "large scale: mip level at footprintHeight (3 = 8x8 px) (ours)")
          .real("mergeWeight", &S::mergeWeight, 0.5, 0, 1,
                "large-scale share when the variance check is off (ours)")
          .boolean("deflicker", &S::deflicker, true,
                   "firefly clamp + clamped light EMA (slides 26, 28)")
          .real("deflickerAlpha", &S::deflickerAlpha, 0.5, 0, 1,
                "deflicker EMA new-frame weight (ours)")
          .real("deflickerGamma", &S::deflickerGamma, 1, 0, 100,
                "deflicker 3x3 clamp box in sigma (ours)")
          .boolean("deflickerEdgeAware", &S::deflickerEdgeAware, true,
                   "firefly clamp against same-mesh neighbours of a similar normal only (ours, "
                   "the edge-aware median's rule; false: every neighbour, the first version)")
          .choice("disocclusionRays", &S::disocclusionRays, "auto",
                  {{"auto", S::DisocclusionRays::Auto},
                   {"on", S::DisocclusionRays::On},
                   {"off", S::DisocclusionRays::Off}},
                  "read the sequence's low-resolution buffer where h is short (slides 19-21); "
                  "auto: when the sequence has one (every arena run, sweep and study renders it "
                  "for a denoiser that reads it, unless --lowres-factor 0), on: required")
          .integer("lowresMaxHistory", &S::lowresMaxHistory, 4, 1, 4096,
                   "read the low-resolution buffer where h < this (ours)")
          .real("lowresWeight", &S::lowresWeight, 0.9, 0, 1,
                "low-resolution blend weight at h = 1 (ours)")
          .boolean("lowresFeedback", &S::lowresFeedback, true,
                   "the low-resolution blend enters the history (ours)")
          .boolean("directionalUpscale", member(&S::upsample, &LowresUpsampleSettings::directional),
                   true,
                   "re-project low-resolution colour to each normal with L1 SH of the mean "
                   "direction (slide 21)")
          .boolean("momentClamp", member(&S::upsample, &LowresUpsampleSettings::momentClamp), true,
                   "clamp the upscaled luminance to the full-resolution moments (slide 21)")
          .boolean("spatialFilter", &S::spatialFilter, true,
                   "final 3x3 edge-aware à-trous pass (slides 28, 43)")
          .real("sigmaL", &S::sigmaL, 4, 0, 1e6, "spatial filter luminance term sigma_l (SVGF 4)")
          .include(surfaceWeightParams(), &S::weights)
          .include(reprojectionParams(), &S::reprojection)
          .include(footprintParams(), &S::footprint)
          .fixed([](S& s) {
            // The upsampling's plane and normal tests between a pixel and a texel's anchor are
            // the propagations' (its hit-distance and roughness terms stay off).
            s.upsample.weights = s.weights;
          });
  return table;
}

DenoiserInfo reEngineInfo() {
  return {
      "reengine",
      "CAPCOM RE ENGINE 2023: spatial propagation, temporal filter with luminance rejection and "
      "virtual specular motion, propagation, variance check, merge, deflicker, disocclusion-ray "
      "upscaling, spatial filter (seed 004)",
      reEngineParams().schema(), [](const ParamSet& params, SignalKind kind) {
        return std::make_unique<ReEngine>(reEngineParams().settings(params, "reengine"), kind);
      }};
}

}  // namespace arena
