// `hybrid`: the CEDEC 2021 talk's denoiser (seed 000, section 5.1 "デノイザーの処理フロー"):
//   0. (CAPCOM ablation) optionally move into Reinhard-compressed space,
//   1. metadata, gathered once: depth/normal derivatives and every pixel's specular lobe,
//   2. disocclusion pass: reprojection consistency (on screen, mesh id, depth, normal) writes the
//      mask and the history length h; optionally the mask is blurred where the region grows,
//   3. pre-spatial: one 3x3 à-trous over the signal and its second moment (variance clipping's
//      box and the disocclusion fill), optionally a 2-level mip chain for a wider fill and one of
//      its moments for a wider clip box,
//   4. temporal: motion or hit-point reprojection chosen by roughness (specular), EMA with
//      alpha = 1/h, h <= 24; variance clipping of the history to the pre-spatial mu +- k sigma;
//      disoccluded pixels take the pre-spatial value; the luminance threshold replaces the
//      accumulated value by the pre-filtered one where they differ by more than tau; (CAPCOM)
//      a temporal luminance rejection against a stabilised one-frame result; the temporal result
//      is the history (the post-spatial result is not recurrent),
//   5. post-spatial: 3 à-trous iterations (3x3, spacing 1, 2, 4), a 3x3 median before the first
//      (fireflies; never fed back), optionally a mip level bilaterally upsampled,
//   6. optionally a light second EMA as the temporal stabiliser (the talk leaves it to TAA).
// Edge-stopping everywhere: world position, specular lobe, luminance, mesh id (each switchable).
// With every optional stage off it is temporal accumulation followed by à-trous.
#include "denoisers/hybrid.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "denoisers/common/filter_space.hpp"
#include "denoisers/common/luminance_rejection.hpp"
#include "denoisers/common/median.hpp"
#include "denoisers/variants.hpp"

namespace arena {

Hybrid::Hybrid(const HybridSettings& settings, SignalKind kind) : s_(settings), kind_(kind) {}

std::vector<std::string> Hybrid::requiredChannels() const {
  std::vector<std::string> channels = {"depth", "normal", "meshId", "motion", "position"};
  if (kind_ == SignalKind::Specular) {
    channels.push_back("roughness");
    channels.push_back(s_.hitDistanceChannel);
  }
  return channels;
}

void Hybrid::setup(int width, int height) {
  footprintScale_ = s_.footprint.scale(height);
  derivatives_ = Image(width, height, kGeometryDerivativeChannels);
  lobes_ = Image(width, height, kSpecularLobeChannels);
  surface_.setup(width, height);
  virtual_.setup(width, height);
  previousGBuffer_.setup(width, height);
  preMips_.setup(width, height, s_.preMipLevels, 3);
  postMips_.setup(width, height, s_.postMipLevels, 3);
  clipMips_.setup(width, height, s_.clipMipLevel, 6);
  clipBase_ = Image(width, height, 6);
  clipWide_ = Image(width, height, 6);
  for (Image* image : {&colorHistory_, &oneFrameHistory_, &stabilizerHistory_, &signal_,
                       &preSpatial_, &preWide_, &temporal_, &oneFrame_, &median_, &atrous_[0],
                       &atrous_[1], &atrous_[2], &post_, &reprojectedStabilizer_, &stabilized_})
    *image = Image(width, height, 3);
  for (Image* image : {&lengthHistory_, &mask_, &blurredMask_, &historyLength_, &variance_,
                       &filteredVariance_, &levels_, &variancePingPong_[0], &variancePingPong_[1]})
    *image = Image(width, height, 1);
  momentsHistory_ = Image(width, height, 2);
  preSquared_ = Image(width, height, 4);
  preMoments_ = Image(width, height, 4);
  moments_ = Image(width, height, 2);
  taps_.setup(height);
  hasHistory_ = false;
}

void Hybrid::reset() {
  hasHistory_ = false;
}

void Hybrid::denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) {
  if (ctx.reset) reset();
  gbuffer_ = GBufferView::fromFrame(in.frame, requiredChannels(), "hybrid");
  roughness_ =
      kind_ == SignalKind::Specular ? in.frame.get("roughness", "hybrid").plane(0) : nullptr;
  hitDistance_ = kind_ == SignalKind::Specular
                     ? in.frame.get(s_.hitDistanceChannel, "hybrid").plane(0)
                     : nullptr;
  toFilterSpace(in.signal);
  metadata(ctx);
  disocclusion(ctx);
  preSpatial();
  temporal();
  postSpatial();
  stabilize();
  fromFilterSpace(output);
  storeHistory();
}

// ---- 0. Filter space. CAPCOM (seed 004, "Removing Reinhard Curves"): filtering a Reinhard-
// compressed signal ghosts under exposure changes; linear is their fix. space=reinhard filters
// y = c / (1 + L(c)) and expands the result with c = y / (1 - L(y)) -- the ablation.
void Hybrid::toFilterSpace(const Image& signal) {
  ScopedPass pass(this, "filter space", 0);
  if (s_.space == FilterSpace::Linear) {
    signal_ = signal;
    return;
  }
  reinhardCompress(signal, signal_);
}

// ---- 1. Metadata (the talk's "Metadata" pass: depth, normal, motion, roughness, id organised
// once): screen-space derivatives for the consistency tests and every pixel's specular lobe.
void Hybrid::metadata(const FrameContext& ctx) {
  ScopedPass pass(this, "metadata", 4);
  computeGeometryDerivatives(gbuffer_, derivatives_);
  if (s_.edgeLobe)
    computeSpecularLobes(gbuffer_, roughness_, ctx.camera, kind_ == SignalKind::Specular, s_.lobe,
                         lobes_);
}

int Hybrid::historySource(size_t i) const {
  // The talk: "lerp(UV_motion, UV_hitpt, roughness > threshold)" -- a switch, not a blend;
  // hit point for smooth surfaces ("スムースな鏡面反射では Hit Point Reprojection を使います").
  // A failed hit-point reprojection falls back to surface motion where that is valid (as ReBLUR
  // here and NRD do): only a pixel neither finds is disoccluded (issue 15, item 6).
  if (useVirtual_ && roughness_[i] < s_.hitPointRoughness && virtual_.valid(i)) return 2;
  return surface_.valid(i) ? 1 : 0;
}

float Hybrid::historySample(size_t i, const float* plane) const {
  switch (historySource(i)) {
    case 1:
      return surface_.sample(i, plane);
    case 2:
      return virtual_.sample(i, plane);
    default:
      return 0.0f;
  }
}

// ---- 2. Disocclusion (the talk p. "4.2.4"): "bSuccess = in screen && depth && normal && id";
// mask = !bSuccess, h = bSuccess ? min(h + 1, MAX) : 1. The optional blur spreads the mask only
// outwards ("領域の広がる方向にのみ"): mask' = max(mask, 3x3 mean), a soft border for the fill.
void Hybrid::disocclusion(const FrameContext& ctx) {
  ScopedPass pass(this, "disocclusion", 4);
  useVirtual_ = kind_ == SignalKind::Specular && s_.hitPoint;
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
  const float maxHistory = float(s_.maxHistory);
  const int w = gbuffer_.width, h = gbuffer_.height;
  if (gpu::recording()) {  // mask and h from the reprojection's records (the talk's "検出")
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    gpu::read(kRecord, w, h);
    if (useVirtual_) gpu::read({kVirtualRecord, kRoughness}, w, h);
    gpu::read(kHistoryLengthHistory, w, h, surface_.readTapsPerPixel());
    gpu::write({kMask, kHistoryLength}, w, h);
  }
  for (size_t i = 0; i < gbuffer_.pixelCount(); ++i) {
    const bool valid = historySource(i) != 0;
    mask_.plane(0)[i] = valid ? 0.0f : 1.0f;
    historyLength_.plane(0)[i] =
        valid ? std::min(historySample(i, lengthHistory_.plane(0)) + 1.0f, maxHistory) : 1.0f;
  }
  blurredMask_ = mask_;
  if (!s_.maskBlur) return;
  if (gpu::recording()) {
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    gpu::read(kMask, w, h, 9);
    gpu::read(kMeshId, w, h, 9);
    gpu::write(kBlurredMask, w, h);
  }
  parallelRows(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      float sum = 0;
      int count = 0;
      forEachNeighbour3x3(x, y, w, h, &gbuffer_, false, [&](size_t q) {
        sum += mask_.plane(0)[q];
        ++count;
      });
      if (count > 0) blurredMask_.plane(0)[p] = std::max(mask_.plane(0)[p], sum / float(count));
    }
  });
  pass.setTaps(13);
}

bool Hybrid::usesMedian() const {
  return s_.median && (kind_ == SignalKind::Specular || s_.medianSignals == MedianSignals::Both);
}

bool Hybrid::usesPreSpatial() const {
  return s_.disocclusionFill || s_.varianceClip || s_.lumaThreshold || s_.capcomRejection;
}

namespace {
AtrousSettings hybridAtrous(const HybridSettings& s, bool luminance, float footprintScale) {
  AtrousSettings a;
  a.footprintScale = footprintScale;
  a.kernel = AtrousKernel::Compact3x3;  // the talk's 3x3 à-trous (9 fetches per iteration)
  EdgeStoppingSettings& e = a.edges;
  e.depth = false;  // the talk: 3D position stands in for depth ("3次元の空間位置は深度項の代わり")
  e.normal = false;  // ... and the specular lobe for the normal
  e.color = false;
  e.position = s.edgePosition;
  e.sigmaX = s.sigmaX;
  e.luminance = luminance && s.edgeLuminance;
  e.sigmaL = s.sigmaL;
  e.id = s.edgeId;
  return a;
}
}  // namespace

// ---- 3. Pre-spatial (à-trous x1 over the signal and its second moment, p. "5.1": "事前 Spatial
// Accumulation ... Disocclusion補完 / Variance Clipping"); the luminance term is off here: no
// variance exists yet. Optional mip chain: a wider estimate for the fill and the luminance
// threshold, level MaxMipLevel * roughness for the specular signal (p. "5.1").
void Hybrid::preSpatial() {
  if (!usesPreSpatial()) return;
  {
    ScopedPass pass(this, "pre-spatial à-trous x1", 9);
    for (size_t i = 0; i < signal_.pixelCount(); ++i) {
      for (int c = 0; c < 3; ++c)
        preSquared_.plane(c)[i] = signal_.plane(c)[i] * signal_.plane(c)[i];
      const float l = luminance(signal_.plane(0)[i], signal_.plane(1)[i], signal_.plane(2)[i]);
      preSquared_.plane(3)[i] = l * l;
    }
    const AtrousGuide guide{gbuffer_, &derivatives_, nullptr, s_.edgeLobe ? &lobes_ : nullptr,
                            s_.lobeBeta};
    atrousIterationWithMoments(0, hybridAtrous(s_, false, footprintScale_), guide, 1.0f, signal_,
                               preSpatial_, preSquared_, preMoments_);
  }
  clipMoments();
  ScopedPass pass(this, "pre-spatial mip", s_.preMip ? 4 : 0);
  if (!s_.preMip) {
    preWide_ = preSpatial_;
    return;
  }
  preMips_.build(preSpatial_, gbuffer_);
  const float maxLevel = float(preMips_.levels());
  for (size_t i = 0; i < gbuffer_.pixelCount(); ++i)
    levels_.plane(0)[i] = roughness_ ? maxLevel * roughness_[i] : maxLevel;
  preMips_.upsample(preMips_.levels(), &levels_, gbuffer_, {}, preWide_);
}

// The variance-clipping box over a wider support (`clipSupport=mip`): the pre-spatial mean and
// second moment, per channel, averaged over 2^L x 2^L blocks of the talk's mip chain ("必要に応じて
// フィルタ結果の Mipmap を生成 / より強いフィルタ結果として利用する") and bilaterally upsampled.
// Why: the 3x3 box holds nine 1-spp samples. Under sparse light (several small lights, each
// sample picking one) they often all miss or all hit one light, so the box's mean is too dark or
// wrongly coloured and its sigma near 0; the clip then pulls the history onto that one-frame
// estimate every frame: a dark, blotchy cast (issue 15 item 14; denoisers/FIDELITY.md). The
// averaged moments hold ~(2^L + 2)^2 samples. The number of samples is what the box needs, so L
// is not scaled by the footprint policy (a 1080p frame's 3x3 box has the same nine samples).
void Hybrid::clipMoments() {
  ScopedPass pass(this, "clip-box mip",
                  s_.varianceClip && s_.clipSupport == ClipSupport::Mip ? 4 : 0);
  if (!s_.varianceClip || s_.clipSupport != ClipSupport::Mip) return;
  for (int c = 0; c < 3; ++c) {
    parallelCopy(preSpatial_.plane(c), preSpatial_.pixelCount(), clipBase_.plane(c));
    parallelCopy(preMoments_.plane(c), preMoments_.pixelCount(), clipBase_.plane(3 + c));
  }
  clipMips_.build(clipBase_, gbuffer_);
  clipMips_.upsample(clipMips_.levels(), nullptr, gbuffer_, {}, clipWide_);
}

// ---- 4. Temporal accumulation (p. "4.2"): X = alpha x + (1 - alpha) X_prev, alpha = 1/h.
void Hybrid::temporal() {
  ScopedPass pass(this, "temporal", useVirtual_ ? 8 : 4);
  const int w = gbuffer_.width;
  const HistoryClampMode clipMode = s_.clipMode;
  if (gpu::recording()) {  // one pixel's EMA, clip box, fill and threshold: every input once
    using namespace gpu_buffers;
    const int h = gbuffer_.height;
    const double taps = surface_.readTapsPerPixel();
    gpu::dispatch(w, h);
    gpu::read({kSignal, kRecord, kMeshId, kHistoryLength}, w, h);
    if (useVirtual_) gpu::read({kVirtualRecord, kRoughness}, w, h);
    if (usesPreSpatial()) gpu::read({kRadiance, kSecondMoments}, w, h);
    if (usesPreSpatial() && s_.preMip) gpu::read(kPreWide, w, h);
    if (s_.disocclusionFill) gpu::read(s_.maskBlur ? kBlurredMask : kMask, w, h);
    gpu::read({kRadianceHistory, kMomentsHistory}, w, h, taps);
    if (s_.capcomRejection) {
      gpu::read(kOneFrameHistory, w, h, taps);
      gpu::write(kOneFrameHistory, w, h);
    }
    gpu::write({kRadiance, kMoments, kVariance, kHistoryLength}, w, h);
  }
  parallelRows(gbuffer_.height, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      float current[3], history[3], result[3];
      for (int c = 0; c < 3; ++c) current[c] = signal_.plane(c)[i];
      const float l = luminance(current[0], current[1], current[2]);
      const bool valid = historySource(i) != 0;
      float h = historyLength_.plane(0)[i];
      float pre[3] = {0, 0, 0}, wide[3] = {0, 0, 0};
      if (usesPreSpatial())
        for (int c = 0; c < 3; ++c) {
          pre[c] = preSpatial_.plane(c)[i];
          wide[c] = preWide_.plane(c)[i];
        }
      // CAPCOM's one-frame estimate, stabilised by a 2-frame EMA of the pre-filtered signal.
      if (s_.capcomRejection)
        for (int c = 0; c < 3; ++c)
          oneFrame_.plane(c)[i] =
              valid ? 0.5f * pre[c] + 0.5f * historySample(i, oneFrameHistory_.plane(c)) : pre[c];
      if (valid) {
        for (int c = 0; c < 3; ++c) history[c] = historySample(i, colorHistory_.plane(c));
        if (s_.varianceClip && !gbuffer_.isSky(i)) {
          // Variance clipping (Salvi 2016; the talk p. "4.2.3"): the box is the pre-spatial
          // mu +- k sigma, sigma^2 = E[x^2] - E[x]^2 per channel (of its 3x3, or of the mip
          // average: clipMoments()). Clip moves the history toward mu (the box centre, so the
          // segment always enters the box).
          float mu[3], lo[3], hi[3];
          for (int c = 0; c < 3; ++c) {
            mu[c] = s_.clipSupport == ClipSupport::Mip ? clipWide_.plane(c)[i] : pre[c];
            const float second = s_.clipSupport == ClipSupport::Mip ? clipWide_.plane(3 + c)[i]
                                                                    : preMoments_.plane(c)[i];
            const float sigma = std::sqrt(std::max(0.0f, second - mu[c] * mu[c]));
            lo[c] = mu[c] - s_.clipGamma * sigma;
            hi[c] = mu[c] + s_.clipGamma * sigma;
          }
          if (clipMode == HistoryClampMode::Clip)
            clipToBox(history, mu, lo, hi, 3);
          else
            clampToBox(history, lo, hi, 3);
        }
        if (s_.capcomRejection) {
          // CAPCOM (seed 004, "Temporal Luminance Rejection": "安定化した1フレームの結果は、履歴を
          // 修正するために使用されます"): where the history's luminance strays from the stabilised
          // one-frame result by more than tau (relative), pull it there and shorten h.
          const float s[3] = {oneFrame_.plane(0)[i], oneFrame_.plane(1)[i], oneFrame_.plane(2)[i]};
          const float rho = rejectHistoryLuminance(history, s, s_.capcomTau);
          h = std::max(1.0f, h * (1.0f - rho));
          historyLength_.plane(0)[i] = h;
        }
        const float alpha = 1.0f / std::max(h, 1.0f);
        for (int c = 0; c < 3; ++c) result[c] = alpha * current[c] + (1.0f - alpha) * history[c];
        for (int m = 0; m < 2; ++m) {
          const float value = m == 0 ? l : l * l;
          moments_.plane(m)[i] =
              alpha * value + (1.0f - alpha) * historySample(i, momentsHistory_.plane(m));
        }
      } else {
        for (int c = 0; c < 3; ++c) result[c] = current[c];
        moments_.plane(0)[i] = l;
        moments_.plane(1)[i] = l * l;
      }
      // Disocclusion fill (p. "4.2.4"): X' = X (1 - beta) + g(x) beta, beta = the (blurred) mask.
      if (s_.disocclusionFill) {
        const float beta = blurredMask_.plane(0)[i];
        for (int c = 0; c < 3; ++c) result[c] = result[c] * (1.0f - beta) + wide[c] * beta;
      }
      // Luminance threshold (p. "4.2.5"): "luminanceDiff = abs(Luma(filtered) - Luma(accumulated));
      // resultColor = lerp(accumulated, filtered, luminanceDiff > threshold)". The talk's tau is
      // absolute (it depends on exposure). Ours, by default, is in units of the local luminance
      // sigma: the larger of the pre-spatial spread (E[l^2] - E[l]^2 of its 3x3) and the
      // history's temporal spread (its moments, before this frame) -- one frame of 3x3 samples
      // cannot tell a switched-off light from a neighbourhood whose sparse samples all missed,
      // the history's spread can. `lumaMode=relative` keeps |lf - la| > tau max(lf, la). Where
      // it fires the pre-filtered value is a one-frame history: h restarts at 1.
      if (s_.lumaThreshold && !gbuffer_.isSky(i)) {
        const float lf = luminance(wide[0], wide[1], wide[2]);
        const float la = luminance(result[0], result[1], result[2]);
        float threshold = s_.lumaTau * std::max({lf, la, 1e-6f});
        if (s_.lumaMode == LumaMode::Sigma) {
          const float lp = luminance(pre[0], pre[1], pre[2]);
          float spread = std::max(0.0f, preMoments_.plane(3)[i] - lp * lp);
          if (valid) {
            const float m1 = historySample(i, momentsHistory_.plane(0));
            spread = std::max(spread, historySample(i, momentsHistory_.plane(1)) - m1 * m1);
          }
          // (1 % of the luminance at least: a noise-free region must not fire on rounding.)
          threshold = std::max(s_.lumaSigma * std::sqrt(spread), 0.01f * std::max(lf, la));
        }
        if (std::abs(lf - la) > threshold) {
          for (int c = 0; c < 3; ++c) result[c] = wide[c];
          h = 1.0f;
          historyLength_.plane(0)[i] = h;
        }
      }
      for (int c = 0; c < 3; ++c) temporal_.plane(c)[i] = result[c];
      // Luminance variance for the edge-stopping term: temporal from the moments once h >= 4,
      // the pre-spatial (spatial) estimate before (the talk p. "4.1.5").
      float variance =
          std::max(0.0f, moments_.plane(1)[i] - moments_.plane(0)[i] * moments_.plane(0)[i]);
      if (h < 4.0f && usesPreSpatial()) {
        // E[l^2] - E[l]^2 of the pre-spatial taps: the channels' covariance included.
        const float lp = luminance(pre[0], pre[1], pre[2]);
        variance = std::max(0.0f, preMoments_.plane(3)[i] - lp * lp);
      }
      variance_.plane(0)[i] = variance;
    }
  });
}

// ---- 5. Post-spatial (p. "5.1": "A-Trous x3", median in the first pass for fireflies, optional
// mip + upsampling). Its result is never fed back.
void Hybrid::postSpatial() {
  const Image* input = &temporal_;
  if (usesMedian()) {
    ScopedPass pass(this, "post-spatial median", 9);
    median3x3(temporal_, &gbuffer_, median_, s_.medianEdgeAware);
    input = &median_;
  }
  const AtrousGuide guide{gbuffer_, &derivatives_, &filteredVariance_,
                          s_.edgeLobe ? &lobes_ : nullptr, s_.lobeBeta};
  const AtrousSettings settings = hybridAtrous(s_, true, footprintScale_);
  // The luminance term's variance: propagated through every iteration with squared weights (SVGF
  // §4.3, the default) or the temporal stage's variance for all three (`postVariance=fixed`, the
  // first version here: later iterations then over-estimate the noise of an already filtered
  // signal and blur more).
  const bool propagate = s_.edgeLuminance && s_.postVariance == PostVariance::Propagate;
  const Image* variance = &variance_;
  lastPostVariance_ = -1;
  for (int i = 0; i < s_.postIterations; ++i) {
    lastPostVariance_ = variance == &variance_ ? -1 : int(variance - variancePingPong_);
    if (s_.edgeLuminance && (i == 0 || propagate)) {
      ScopedPass pass(this, "variance prefilter " + std::to_string(i + 1), 9);
      prefilterVariance3x3(*variance, gbuffer_, filteredVariance_);
    }
    ScopedPass pass(this, "post-spatial à-trous " + std::to_string(i + 1), 9);
    Image* varianceOut = propagate ? &variancePingPong_[size_t(i % 2)] : nullptr;
    atrousIteration(i, settings, guide, 1.0f, *input, atrous_[i], propagate ? variance : nullptr,
                    varianceOut);
    if (propagate) variance = varianceOut;
    input = &atrous_[i];
  }
  ScopedPass pass(this, "post-spatial mip + upsample", s_.postMip ? 4 : 0);
  if (!s_.postMip) {
    post_ = *input;
    return;
  }
  postMips_.build(*input, gbuffer_);
  const float maxLevel = float(postMips_.levels());
  for (size_t i = 0; i < gbuffer_.pixelCount(); ++i)
    levels_.plane(0)[i] = roughness_ ? maxLevel * roughness_[i] : maxLevel;
  postMips_.upsample(postMips_.levels(), &levels_, gbuffer_, {}, post_);
}

// ---- 6. Temporal stabiliser (p. "4.3.1": "追加で軽い Temporal Accumulation を行って時間的な安定性
// を上げる"): a second EMA with a large alpha over the stabiliser's own reprojected history,
// clamped to the 3x3 box of the post-spatial result (TAA-style) so it cannot ghost.
void Hybrid::stabilize() {
  ScopedPass pass(this, "stabilizer", s_.stabilizer ? 9 : 0);
  if (!s_.stabilizer) {
    stabilized_ = post_;
    return;
  }
  for (size_t i = 0; i < gbuffer_.pixelCount(); ++i)
    for (int c = 0; c < 3; ++c)
      reprojectedStabilizer_.plane(c)[i] =
          historySource(i) != 0 ? historySample(i, stabilizerHistory_.plane(c)) : post_.plane(c)[i];
  clampHistory(reprojectedStabilizer_, post_, &gbuffer_, {HistoryClampMode::Clamp, 1, 1.0f},
               reprojectedStabilizer_, taps_);
  const float a = s_.stabilizerAlpha;
  for (size_t k = 0; k < post_.raw().size(); ++k)
    stabilized_.raw()[k] = a * post_.raw()[k] + (1.0f - a) * reprojectedStabilizer_.raw()[k];
}

void Hybrid::fromFilterSpace(Image& output) {
  ScopedPass pass(this, "output space", 0);
  if (s_.space == FilterSpace::Linear) {
    output = stabilized_;
    return;
  }
  reinhardExpand(stabilized_, output);
}

void Hybrid::storeHistory() {
  ScopedPass pass(this, "store history", 0);
  parallelCopy(temporal_, colorHistory_);  // the temporal result is the history (p. "5.1")
  parallelCopy(historyLength_, lengthHistory_);
  parallelCopy(moments_, momentsHistory_);
  if (s_.capcomRejection) parallelCopy(oneFrame_, oneFrameHistory_);
  if (s_.stabilizer) parallelCopy(stabilized_, stabilizerHistory_);
  previousGBuffer_.store(gbuffer_);
  hasHistory_ = true;
}

std::vector<std::pair<std::string, const Image*>> Hybrid::passOutputs() const {
  std::vector<std::pair<std::string, const Image*>> out = {{"filter space", &signal_},
                                                           {"disocclusion mask", &blurredMask_},
                                                           {"pre-spatial", &preSpatial_},
                                                           {"pre-spatial wide", &preWide_},
                                                           {"temporal", &temporal_}};
  if (usesMedian()) out.push_back({"median", &median_});
  out.push_back({"post-spatial", &post_});
  out.push_back({"stabilizer", &stabilized_});
  return out;
}

const ParamTable<HybridSettings>& hybridParams() {
  using S = HybridSettings;
  static const ParamTable<S> table =
      ParamTable<S>()
          .boolean("edge.position", &S::edgePosition, true,
                   "world-position stopping term (the talk)")
          .boolean("edge.lobe", &S::edgeLobe, true,
                   "specular-lobe stopping term (Tokuyoshi 2016; the talk)")
          .boolean("edge.luminance", &S::edgeLuminance, true,
                   "variance-scaled luminance term (SVGF; the talk)")
          .boolean("edge.id", &S::edgeId, true, "mesh-id term: poster vs wall (the talk)")
          .real("sigmaX", &S::sigmaX, 0.05, 1e-9, 1e9,
                "position term exp(-|dx|^2/sigmaX), world units^2 (ours)")
          .real("lobeBeta", &S::lobeBeta, 1, 0, 1e4,
                "exponent on the lobe similarity (the talk's beta; 1 = Tokuyoshi)")
          .real("lobeDiffuseSharpness", member(&S::lobe, &SpecularLobeSettings::diffuseSharpness),
                64, 0, 1e6,
                "diffuse signal: SG sharpness of the normal lobe (ours: 64 gives 0.61 at 10 "
                "degrees, 0.01 at 30)")
          .real("sigmaL", &S::sigmaL, 4, 0, 1e6, "luminance term sigma_l (SVGF 4)")
          .boolean("maskBlur", &S::maskBlur, true,
                   "disocclusion: grow and soften the mask by a 3x3 mean (the talk)")
          .boolean("preMip", &S::preMip, false,
                   "pre-spatial: 2-level mip chain for the fill (the talk, optional)")
          .integer("preMipLevels", &S::preMipLevels, 2, 1, 8,
                   "pre-spatial mip levels (the talk: Mip Gen x2)")
          .boolean("hitPoint", &S::hitPoint, true,
                   "specular: hit-point reprojection below hitPointRoughness (the talk)")
          .include(hitDistanceParams(), &S::hitDistanceChannel)
          .real("hitPointRoughness", &S::hitPointRoughness, 0.3, 0, 1,
                "roughness threshold of hit-point reprojection (ours)")
          .integer("maxHistory", &S::maxHistory, 24, 1, 4096,
                   "cap of h, alpha = 1/h (the talk: 24-30)")
          .boolean("disocclusionFill", &S::disocclusionFill, true,
                   "disoccluded pixels take the pre-spatial value (the talk)")
          .boolean("varianceClip", &S::varianceClip, true,
                   "clip the history to the pre-spatial mu +- k sigma (the talk)")
          .choice("clipSupport", &S::clipSupport, "3x3",
                  {{"3x3", ClipSupport::Box3x3}, {"mip", ClipSupport::Mip}},
                  "variance box: the pre-spatial 3x3's mean and sigma (the talk) or both from its "
                  "moments averaged over mip level clipMipLevel (the talk's mip chain; less "
                  "mottle under sparse light, more lag: FIDELITY.md)")
          .integer("clipMipLevel", &S::clipMipLevel, 2, 1, 6,
                   "clipSupport=mip: the level (2^level px blocks; ours)")
          .choice("clipMode", &S::clipMode, "clip",
                  {{"clip", HistoryClampMode::Clip}, {"clamp", HistoryClampMode::Clamp}},
                  "variance box: clip (talk) or per-channel clamp")
          .real("clipGamma", &S::clipGamma, 1.5, 0, 100,
                "variance box half-width k in sigma (ours; Salvi 1..2)")
          .boolean("lumaThreshold", &S::lumaThreshold, true,
                   "use the pre-filtered value where its luminance differs from the accumulated "
                   "one by more than lumaTau (the talk)")
          .choice("lumaMode", &S::lumaMode, "sigma",
                  {{"sigma", LumaMode::Sigma}, {"relative", LumaMode::Relative}},
                  "luminance threshold: |lf - la| > lumaSigma x local luminance sigma (ours, "
                  "noise-aware) or > lumaTau x max(lf, la) (relative)")
          .real("lumaSigma", &S::lumaSigma, 2, 0, 1e6,
                "lumaMode=sigma: threshold in local luminance sigmas (ours)")
          .real("lumaTau", &S::lumaTau, 0.8, 0, 1e6,
                "lumaMode=relative: threshold relative to the larger luminance (ours)")
          .boolean("capcomRejection", &S::capcomRejection, false,
                   "temporal luminance rejection against a stabilised one-frame result (CAPCOM "
                   "RE ENGINE)")
          .real("capcomTau", &S::capcomTau, 0.5, 1e-6, 1e6,
                "CAPCOM rejection threshold, relative (ours)")
          .integer("postIterations", &S::postIterations, 3, 0, 3,
                   "post-spatial 3x3 à-trous iterations (the talk 3)")
          .boolean("median", &S::median, true,
                   "3x3 median before the first post iteration (the talk; not fed back)")
          .choice("postVariance", &S::postVariance, "propagate",
                  {{"propagate", PostVariance::Propagate}, {"fixed", PostVariance::Fixed}},
                  "post-spatial luminance term: variance propagated with squared weights (SVGF "
                  "§4.3) or the temporal variance for every iteration")
          .choice("medianSignals", &S::medianSignals, "specular",
                  {{"specular", MedianSignals::Specular}, {"both", MedianSignals::Both}},
                  "signals the median runs on (the talk: optional, for specular fireflies)")
          .boolean("medianEdgeAware", &S::medianEdgeAware, true,
                   "median over same-mesh, similar-normal neighbours only (ours: a 1-px feature "
                   "keeps its value)")
          .boolean("postMip", &S::postMip, false,
                   "post-spatial: mip + bilateral upsample (the talk, optional)")
          .integer("postMipLevels", &S::postMipLevels, 2, 1, 8, "post-spatial mip levels (ours)")
          .boolean("stabilizer", &S::stabilizer, false,
                   "light second EMA (the talk: TAA as stabiliser)")
          .real("stabilizerAlpha", &S::stabilizerAlpha, 0.5, 0, 1,
                "stabiliser blend weight of the new frame (ours)")
          .choice("space", &S::space, "linear",
                  {{"linear", FilterSpace::Linear}, {"reinhard", FilterSpace::Reinhard}},
                  "filter in linear or Reinhard-compressed space (CAPCOM ablation)")
          .include(reprojectionParams(), &S::reprojection)
          .include(footprintParams(), &S::footprint);
  return table;
}

DenoiserInfo hybridInfo() {
  return {
      "hybrid",
      "The CEDEC 2021 talk's denoiser: disocclusion mask, pre-spatial à-trous, motion/hit-point "
      "accumulation with variance clipping and a luminance threshold, à-trous x3 with a median "
      "(Silicon Studio 2021; CAPCOM ablations)",
      hybridParams().schema(), [](const ParamSet& params, SignalKind kind) {
        return std::make_unique<Hybrid>(hybridParams().settings(params, "hybrid"), kind);
      }};
}

}  // namespace arena
