// `reblur`: recurrent blur (Zhdan, GTC 2020 "Fast Denoising with Self Stabilizing Recurrent
// Blurs"; NVIDIA NRD's REBLUR; the CEDEC 2021 talk p. "3.4" and p. "4.1.2"). Per frame:
//   1. pre-blur: an 8-tap Poisson disk rotated every frame (geometry weights only),
//   2. temporal accumulation with an accumulated-frame counter N (max 30) and a fast history
//      (max 6 frames) kept for clamping; the specular signal blends hit-point (virtual)
//      reprojection with surface motion by roughness,
//   3. history fix while N < 3: a wide sparse reconstruction (NRD v4: 20 taps of a 5x5 grid at
//      stride 14 / (2 + N); or the 2020 version's mip chain), then anti-firefly (luminance
//      clamped to the 3x3 neighbours' range) and the fast-history clamp of the recurrent signal,
//   4. blur with radius max(minRadius, maxRadius / (1 + N_prev)) (NRD), then post-blur at twice it,
//   5. the post-blurred result becomes the history (recurrent; `recurrent=false` stores the
//      temporal result instead),
//   6. temporal stabilisation with anti-lag: the stabilised history is clamped to mu +- 2 sigma
//      of this frame's post-blurred 3x3 (NRD), and N shortens by how far it had to move:
//      N' = N / (1 + d N / 3), d = |h - hc| / max(h, hc) (luminance).
// No luminance-variance stopping anywhere (NRD: plane distance, normal/lobe, hit distance).
// Re-modulation is the harness's.
#include "denoisers/reblur.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "denoisers/variants.hpp"

namespace arena {

namespace {
float smoothstep(float edge0, float edge1, float x) {
  const float t = std::clamp((x - edge0) / std::max(edge1 - edge0, 1e-12f), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}
}  // namespace

Reblur::Reblur(const ReblurSettings& settings, SignalKind kind) : s_(settings), kind_(kind) {}

std::vector<std::string> Reblur::requiredChannels() const {
  std::vector<std::string> channels = {"depth", "normal", "meshId", "motion", "position"};
  if (kind_ == SignalKind::Specular) {
    channels.push_back("roughness");
    channels.push_back(s_.hitDistanceChannel);
  }
  return channels;
}

void Reblur::setup(int width, int height) {
  derivatives_ = Image(width, height, kGeometryDerivativeChannels);
  surface_.setup(width, height);
  virtual_.setup(width, height);
  virtualAmount_ = Image(width, height, 1);
  previousGBuffer_.setup(width, height);
  mips_.setup(width, height, std::max(1, s_.historyFixFrames), 3);
  for (Image* image : {&slowHistory_, &fastHistory_, &stabilizedHistory_, &preBlurred_, &temporal_,
                       &fast_, &fixed_, &fireflyFree_, &blurred_, &postBlurred_, &stabilized_})
    *image = Image(width, height, 3);
  for (Image* image : {&accumulatedFramesHistory_, &accumulatedFrames_, &previousFrames_,
                       &radiusScale_, &blurredHitDistance_})
    *image = Image(width, height, 1);
  preBlurIn_ = Image(width, height, 4);
  preBlurOut_ = Image(width, height, 4);
  youngPerRow_.setup(height);
  pixelScale_ = s_.footprint.scale(height);
  hasHistory_ = false;
}

void Reblur::reset() {
  hasHistory_ = false;
}

void Reblur::denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) {
  if (ctx.reset) reset();
  gbuffer_ = GBufferView::fromFrame(in.frame, requiredChannels(), "reblur");
  roughness_ =
      kind_ == SignalKind::Specular ? in.frame.get("roughness", "reblur").plane(0) : nullptr;
  hitDistance_ = kind_ == SignalKind::Specular
                     ? in.frame.get(s_.hitDistanceChannel, "reblur").plane(0)
                     : nullptr;
  reproject(ctx);
  preBlurPass(in, ctx.frameIndex);
  reprojectVirtual(ctx);
  temporalAccumulation();
  historyFixPass();
  antiFireflyPass();
  blurPasses(ctx.frameIndex);
  stabilize(output);
  storeRecurrentHistory();
  storeHistory();
}

// ---- 0. Reprojection: surface motion (SVGF-style per-tap tests); the virtual point of the
// specular signal follows the pre-blur (reprojectVirtual), as NRD computes its virtual motion in
// the temporal accumulation from the pre-pass's hit distance.
void Reblur::reproject(const FrameContext& ctx) {
  ScopedPass pass(this, "reproject", 4);
  useVirtual_ = kind_ == SignalKind::Specular && s_.hitPoint;
  if (!hasHistory_) {
    surface_.invalidateAll();
    virtual_.invalidateAll();
    return;
  }
  computeGeometryDerivatives(gbuffer_, derivatives_);
  surface_.compute(gbuffer_, derivatives_, previousGBuffer_.view(), s_.reprojection, &ctx.camera,
                   &ctx.previousCamera);
}

// ---- 1b. Virtual (hit-point) reprojection of the specular signal (NRD "virtual motion"; the
// talk's hit-point reprojection), from the pre-blurred hit distance when the pre-blur carries it.
void Reblur::reprojectVirtual(const FrameContext& ctx) {
  ScopedPass pass(this, "virtual reprojection", useVirtual_ && hasHistory_ ? 4 : 0);
  if (!useVirtual_ || !hasHistory_) return;
  virtual_.compute(gbuffer_, hitDistance_, ctx.camera, ctx.previousCamera, previousGBuffer_.view(),
                   s_.hitPointTests);
  // NRD trusts the virtual history more the smoother the surface (its "spec magic curve");
  // ours: 1 - smoothstep(0, hitPointRoughness, roughness).
  float* amount = virtualAmount_.plane(0);
  const int w = gbuffer_.width;
  parallelRows(gbuffer_.height, [&](int y) {
    for (size_t i = size_t(y) * size_t(w); i < size_t(y + 1) * size_t(w); ++i)
      amount[i] = 1.0f - smoothstep(0.0f, s_.hitPointRoughness, roughness_[i]);
  });
  pass.setTaps(8);
}

Reblur::HistoryBlock Reblur::history(size_t i, int count) const {
  HistoryBlock h;
  h.surface = surface_.lanes(i, count);
  if (useVirtual_) {
    h.hitPoint = virtual_.lanes(i, count);
    h.hitPointAmount = loadLanes(virtualAmount_.plane(0) + i, laneIndex(Lanes8{}) < count);
  }
  return h;
}

// ---- 1. Pre-blur (NRD prepass): Poisson disk, fixed radius, rotated per frame.
void Reblur::preBlurPass(const DenoiserInputs& in, int frameIndex) {
  ScopedPass pass(this, "pre-blur", s_.preBlur ? kPoissonTaps : 0);
  if (!s_.preBlur) {
    preBlurred_ = in.signal;
    return;
  }
  // NRD: diffusePrepassBlurRadius 30, specularPrepassBlurRadius 50.
  const float radius = kind_ == SignalKind::Specular ? s_.specularPreBlurRadius : s_.preBlurRadius;
  PoissonBlurSettings blur{radius * pixelScale_, s_.weights};
  if (!hitDistance_ || !s_.hitDistancePreBlur) {
    poissonDiskBlur(in.signal, {gbuffer_, roughness_, hitDistance_}, blur,
                    poissonRotation(frameIndex), nullptr, preBlurred_);
    return;
  }
  // Specular: the hit distance rides along as a fourth channel (NRD's pre-pass blurs it with the
  // radiance), misses capped at 1e4 like the weights cap them; every later pass -- the virtual
  // reprojection and the weights -- reads the blurred distance, not the 1-spp sample's.
  const size_t pixels = gbuffer_.pixelCount();
  parallelCopy(in.signal.raw().data(), 3 * pixels, preBlurIn_.raw().data());
  float* distance = preBlurIn_.plane(3);
  parallelRows(gbuffer_.height, [&](int y) {
    const size_t w = size_t(gbuffer_.width);
    for (size_t i = size_t(y) * w; i < size_t(y + 1) * w; ++i)
      distance[i] = std::min(hitDistance_[i], 1e4f);
  });
  poissonDiskBlur(preBlurIn_, {gbuffer_, roughness_, hitDistance_}, blur,
                  poissonRotation(frameIndex), nullptr, preBlurOut_);
  parallelCopy(preBlurOut_.raw().data(), 3 * pixels, preBlurred_.raw().data());
  parallelCopy(preBlurOut_.plane(3), pixels, blurredHitDistance_.plane(0));
  hitDistance_ = blurredHitDistance_.plane(0);
}

// ---- 2. Temporal accumulation: alpha = 1 / (1 + N_prev), N = min(N_prev + 1, 30); the fast
// history uses N capped at 6 (NRD maxFastAccumulatedFrameNum).
void Reblur::temporalAccumulation() {
  ScopedPass pass(this, "temporal accumulation", useVirtual_ ? 8 : 4);
  const int w = gbuffer_.width;
  const float maxFrames = float(s_.maxAccumulatedFrames),
              maxFast = float(s_.maxFastAccumulatedFrames);
  if (gpu::recording()) {  // slow and fast histories and N through the taps of each motion
    using namespace gpu_buffers;
    const int h = gbuffer_.height;
    const double taps = surface_.readTapsPerPixel() * (useVirtual_ ? 2.0 : 1.0);
    gpu::dispatch(w, h);
    gpu::read({kRadiance, kRecord}, w, h);  // the pre-blurred signal, the record
    if (useVirtual_) gpu::read({kVirtualRecord, kRoughness}, w, h);
    gpu::read({kRadianceHistory, kFastHistory, kHistoryLengthHistory}, w, h, taps);
    gpu::write({kRadiance, kFastRadiance, kHistoryLength}, w, h);
  }
  parallelRows(gbuffer_.height, [&](int y) {
    for (int x0 = 0; x0 < w; x0 += 8) {  // eight pixels at a time
      const size_t i = size_t(y) * size_t(w) + size_t(x0);
      const int count = std::min(8, w - x0);
      const LaneMask8 inRow = laneIndex(Lanes8{}) < count;
      const HistoryBlock history = this->history(i, count);
      LaneMask8 valid = history.valid() & inRow;
      if (gbuffer_.meshId) valid &= loadLanes(gbuffer_.meshId + i, inRow) >= 0.0f;  // not sky
      // Resampled counts may be fractional (bilinear); N_prev = 0 on disocclusion.
      const Lanes8 previous = selectFloat(
          valid, minFloat(history.apply(accumulatedFramesHistory_.plane(0)), Lanes8{} + maxFrames),
          Lanes8{});
      const Lanes8 alpha = 1.0f / (1.0f + previous);
      const Lanes8 alphaFast = 1.0f / (1.0f + minFloat(previous, Lanes8{} + maxFast));
      for (int c = 0; c < 3; ++c) {
        const Lanes8 current = loadLanes(preBlurred_.plane(c) + i, inRow);
        const Lanes8 slow = selectFloat(valid, history.apply(slowHistory_.plane(c)), current);
        const Lanes8 fastValue = selectFloat(valid, history.apply(fastHistory_.plane(c)), current);
        storeLanes(temporal_.plane(c) + i, alpha * current + (1.0f - alpha) * slow, inRow);
        storeLanes(fast_.plane(c) + i, alphaFast * current + (1.0f - alphaFast) * fastValue, inRow);
      }
      storeLanes(previousFrames_.plane(0) + i, previous, inRow);
      storeLanes(accumulatedFrames_.plane(0) + i, minFloat(previous + 1.0f, Lanes8{} + maxFrames),
                 inRow);
    }
  });
}

// ---- 3. History fix (NRD v4 HistoryFix) for young histories, N_prev < historyFixFrames: the
// 5x5 sparse grid without its corners (20 taps) whose stride shrinks as the history grows,
// 14 / (2 + N_prev): 7, 4.7 and 3.5 px for N_prev = 0, 1, 2 (`historyFixShape=ours`: all 24
// taps at 14 (F - N_prev) / F); or the 2020 version's mip chain, level F - N_prev. NRD also
// smooths N over 3x3 and weights taps by geometry, normal, roughness and hit distance; ours uses
// the blur's weights.
void Reblur::historyFixPass() {
  ScopedPass pass(this, "history fix", 0);
  historyFixed_ = &temporal_;  // unchanged unless some history is young
  if (s_.historyFix == ReblurHistoryFix::Off || s_.historyFixFrames <= 0) return;
  const int w = gbuffer_.width, h = gbuffer_.height;
  const float frames = float(s_.historyFixFrames);
  const float* previous = previousFrames_.plane(0);
  if (s_.historyFix == ReblurHistoryFix::Mip) {
    historyFixed_ = &fixed_;
    mips_.build(temporal_, gbuffer_);
    for (size_t i = 0; i < gbuffer_.pixelCount(); ++i)
      radiusScale_.plane(0)[i] = previous[i] < frames ? frames - std::floor(previous[i]) : 0.0f;
    mips_.upsample(mips_.levels(), &radiusScale_, gbuffer_, {}, fixed_);
    pass.setTaps(4);
    return;
  }
  // The sparse 5x5 grid as a sparse blur: a young surface pixel's radius is its stride, every
  // other pixel's 0 (it then passes through unchanged).
  float* stride = radiusScale_.plane(0);
  parallelRows(h, [&](int y) {
    int64_t young = 0;  // surface pixels with N_prev < F in this row
    for (size_t i = size_t(y) * size_t(w); i < size_t(y + 1) * size_t(w); ++i) {
      const bool isYoung = previous[i] < frames && gbuffer_.meshId[i] >= 0.0f;
      young += isYoung;
      const float shape = s_.historyFixShape == HistoryFixShape::Nrd
                              ? 1.0f / (2.0f + previous[i])
                              : (frames - previous[i]) / frames;
      stride[i] = isYoung ? std::max(1.0f, s_.historyFixStride * pixelScale_ * shape) : 0.0f;
    }
    youngPerRow_.set(y, young);
  });
  const double youngFraction = youngPerRow_.perPixel(gbuffer_.pixelCount());
  if (youngFraction == 0.0) return;
  historyFixed_ = &fixed_;
  auto makeGrid = [](bool corners) {
    std::vector<std::array<float, 2>> taps;
    for (int j = -2; j <= 2; ++j)
      for (int i = -2; i <= 2; ++i)
        if ((i != 0 || j != 0) && (corners || std::abs(i) + std::abs(j) != 4))
          taps.push_back({float(i), float(j)});
    return taps;
  };
  static const std::vector<std::array<float, 2>> nrdGrid = makeGrid(false),
                                                 fullGrid = makeGrid(true);
  const std::vector<std::array<float, 2>>& grid =
      s_.historyFixShape == HistoryFixShape::Nrd ? nrdGrid : fullGrid;
  sparseBlur(temporal_, {gbuffer_, roughness_, hitDistance_}, s_.weights, grid.data(),
             int(grid.size()), 1.0f, &radiusScale_, fixed_, /*mostlyIdle=*/true);
  pass.setTaps(double(grid.size()) * youngFraction);
}

// ---- 3b. Anti-firefly and the fast-history clamp (NRD v4 REBLUR_HistoryFix, after the
// reconstruction). Both act on luminance and rescale the colour (NRD's ChangeLuma):
//   - anti-firefly (NRD enableAntiFirefly): the luminance is clamped to the [min, max] of its 3x3
//     non-sky neighbours' luminances, the centre excluded, so a lone outlier cannot survive into
//     the blur (NRD clamps to m1 +- sigma of a wider ring of the fast history; ours is the
//     neighbour range of the signal itself);
//   - fast-history clamp (NRD: "clamp slow main history to responsive fast history"): the
//     luminance is clamped to [min(mu - k sigma, c), max(mu + k sigma, c)] of the fast history's
//     3x3 luminances (c its centre, k = antilagSigmaScale, NRD fastHistoryClampingSigmaScale 2),
//     then the unclamped value blended back by 1 / (1 + 2 N_prev) (NRD; `fastHistoryBlend=ours`
//     1 / (1 + N_prev)): a fresh history (N_prev = 0) keeps its own value, an old one -- whose
//     slow history can lag the fast one -- takes the clamp almost fully.
void Reblur::antiFireflyPass() {
  ScopedPass pass(this, "anti-firefly", s_.antiFirefly || s_.fastHistoryClamp ? 17 : 0);
  if (!s_.antiFirefly && !s_.fastHistoryClamp) {
    fireflyFree_ = *historyFixed_;
    return;
  }
  const int w = gbuffer_.width, h = gbuffer_.height;
  const float k = s_.antilagSigmaScale;
  const float* previous = previousFrames_.plane(0);
  if (gpu::recording()) {  // the 3x3 of the signal and of the fast history
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    gpu::read({kRadiance, kFastRadiance, kMeshId}, w, h, 9);
    gpu::read(kHistoryLength, w, h);
    gpu::write(kRadiance, w, h);
  }
  parallelRows(h, [&](int y) {
    for (int x0 = 0; x0 < w; x0 += 8) {  // eight pixels at a time
      const Neighbourhood3x3Lanes n(x0, y, w, h, gbuffer_.meshId);
      Lanes8 centre[3];
      for (int c = 0; c < 3; ++c) centre[c] = loadLanes(historyFixed_->plane(c) + n.p, n.inRow);
      const Lanes8 l = luminance(centre[0], centre[1], centre[2]);
      Lanes8 target = l;
      Lanes8 count{};
      for (int j = 0; j < 9; ++j) count += selectFloat(n.present[j], Lanes8{} + 1.0f, Lanes8{});
      if (s_.antiFirefly) {
        Lanes8 lo = Lanes8{} + 1e30f, hi = Lanes8{} - 1e30f;
        for (int j = 0; j < 9; ++j) {
          if (j == 4) continue;
          const Lanes8 v =
              luminance(loadLanes(historyFixed_->plane(0) + n.offset[j], n.present[j]),
                        loadLanes(historyFixed_->plane(1) + n.offset[j], n.present[j]),
                        loadLanes(historyFixed_->plane(2) + n.offset[j], n.present[j]));
          lo = selectFloat(n.present[j], minFloat(lo, v), lo);
          hi = selectFloat(n.present[j], maxFloat(hi, v), hi);
        }
        // Surface pixels (present centre) with at least one neighbour; the others keep theirs.
        const LaneMask8 clampHere = n.present[4] & (count > 1.0f);
        target = selectFloat(clampHere, minFloat(maxFloat(target, lo), hi), target);
      }
      if (s_.fastHistoryClamp) {
        Lanes8 sum{}, sumSquares{}, fastCentre{};
        for (int j = 0; j < 9; ++j) {
          const Lanes8 v = luminance(loadLanes(fast_.plane(0) + n.offset[j], n.present[j]),
                                     loadLanes(fast_.plane(1) + n.offset[j], n.present[j]),
                                     loadLanes(fast_.plane(2) + n.offset[j], n.present[j]));
          sum += v;
          sumSquares += v * v;
          if (j == 4) fastCentre = v;
        }
        const Lanes8 inverseCount = 1.0f / maxFloat(count, Lanes8{} + 1.0f);
        const Lanes8 mean = sum * inverseCount;
        const Lanes8 sigma =
            k * sqrtLanes(maxFloat(Lanes8{}, sumSquares * inverseCount - mean * mean));
        const Lanes8 lo = minFloat(mean - sigma, fastCentre),
                     hi = maxFloat(mean + sigma, fastCentre);
        const Lanes8 clamped = minFloat(maxFloat(target, lo), hi);
        const float blendSlope = s_.fastHistoryBlend == FastHistoryBlend::Nrd ? 2.0f : 1.0f;
        const Lanes8 young = 1.0f / (1.0f + blendSlope * loadLanes(previous + n.p, n.inRow));
        target = selectFloat(n.present[4], clamped + young * (target - clamped), target);
      }
      // ChangeLuma: the colour scaled to the target luminance (a black pixel stays black).
      const Lanes8 scale =
          selectFloat(l > 1e-12f, target / maxFloat(l, Lanes8{} + 1e-12f), Lanes8{} + 1.0f);
      for (int c = 0; c < 3; ++c)
        storeLanes(fireflyFree_.plane(c) + n.p, centre[c] * scale, n.inRow);
    }
  });
}

// ---- 4. Blur and post-blur: radius max(minRadius, maxRadius / (1 + N_prev)) (NRD; or
// radiusFalloff=sqrt) -- wide while the history is young, shrinking as it converges; the
// post-blur doubles it. The specular
// radius also shrinks with roughness (NRD scales it by a roughness factor; ours: sqrt(r)).
void Reblur::blurPasses(int frameIndex) {
  const float* frames = accumulatedFrames_.plane(0);
  const float* previousFrames = previousFrames_.plane(0);
  const float maxRadius = s_.maxBlurRadius * pixelScale_;
  const float floor = s_.minBlurRadius * pixelScale_ / std::max(maxRadius, 1e-6f);
  const SurfaceGuide guide{gbuffer_, roughness_, hitDistance_};
  // Rotations differ between the passes so they do not reuse the same directions.
  {
    ScopedPass pass(this, "blur", s_.blur ? kPoissonTaps : 0);
    const int w = gbuffer_.width;
    float* scale = radiusScale_.plane(0);
    parallelRows(gbuffer_.height, [&](int y) {
      for (int x0 = 0; x0 < w; x0 += 8) {  // eight pixels at a time
        const size_t i = size_t(y) * size_t(w) + size_t(x0);
        const LaneMask8 inRow = laneIndex(Lanes8{}) + x0 < w;
        // NRD: 1 / (1 + N_prev), the counter before this frame's increment; ours (radiusFalloff
        // =sqrt): sqrt(1 / (1 + N)) of the incremented counter.
        Lanes8 s = s_.radiusFalloff == RadiusFalloff::Nrd
                       ? 1.0f / (1.0f + loadLanes(previousFrames + i, inRow))
                       : sqrtLanes(1.0f / (1.0f + loadLanes(frames + i, inRow)));
        if (roughness_)
          s *= sqrtLanes(
              minFloat(maxFloat(loadLanes(roughness_ + i, inRow), Lanes8{}), Lanes8{} + 1.0f));
        storeLanes(scale + i, maxFloat(s, Lanes8{} + floor), inRow);
      }
    });
    if (s_.blur)
      poissonDiskBlur(fireflyFree_, guide, {maxRadius, s_.weights},
                      poissonRotation(2 * frameIndex + 1), &radiusScale_, blurred_);
    else
      blurred_ = fireflyFree_;
  }
  ScopedPass pass(this, "post-blur", s_.postBlur ? kPoissonTaps : 0);
  if (s_.postBlur)
    poissonDiskBlur(blurred_, guide, {2.0f * maxRadius, s_.weights},
                    poissonRotation(2 * frameIndex + 2), &radiusScale_, postBlurred_);
  else
    postBlurred_ = blurred_;
}

// ---- 5. Recurrence: the post-blurred result is next frame's history, so the spatial samples
// accumulate over time (GTC 2020; the talk p. "4.3.1": recur a *small* blur, shrink it with N).
// (After stabilisation, which reads this frame's post-blurred and fast images: they become the
// histories by a swap, no copy; every pass rewrites its whole image next frame.)
void Reblur::storeRecurrentHistory() {
  ScopedPass pass(this, "store history", 0);
  std::swap(slowHistory_,
            s_.recurrent ? postBlurred_ : temporal_);  // recurrent: the blurred result
  std::swap(fastHistory_, fast_);
}

// ---- 6. Temporal stabilisation with anti-lag (NRD TemporalStabilization): the stabilised
// history is clamped to mu +- sigmaScale sigma of the 3x3 neighbourhood of this frame's
// post-blurred result (NRD; `stabilizationBox=fast`: of the fast history, the first version); how far
// it moved, d = |L(h) - L(hc)| / max(L(h), L(hc)), shortens N: N' = N / (1 + d N / 3). The
// output blends with 1 / (1 + N'), and N' is what the next frame reprojects (anti-lag).
void Reblur::stabilize(Image& output) {
  ScopedPass pass(this, "stabilization", s_.stabilization ? 9 : 0);
  if (!s_.stabilization) {
    stabilized_ = postBlurred_;
    output = stabilized_;
    return;
  }
  const int w = gbuffer_.width, h = gbuffer_.height;
  const float k = s_.antilagSigmaScale;
  if (gpu::recording()) {  // the stabilised history, clamped to the fast history's 3x3
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    gpu::read({kRadiance, kRecord, kHistoryLength}, w, h);
    gpu::read({kFastRadiance, kMeshId}, w, h, 9);
    gpu::read(kStabilizerHistory, w, h, surface_.readTapsPerPixel());
    gpu::write({kRadiance, kHistoryLength}, w, h);
  }
  parallelRows(h, [&](int y) {
    for (int x0 = 0; x0 < w; x0 += 8) {
      // The box's mean and sigma over the 3x3 non-sky neighbourhood, eight pixels at a time
      // (taps in row-major order; a missing tap adds 0).
      const Neighbourhood3x3Lanes n(x0, y, w, h, gbuffer_.meshId);
      const Image& box = s_.stabilizationBox == StabilizationBox::Current ? postBlurred_ : fast_;
      Lanes8 count{}, mean[3], sigma[3];
      for (int j = 0; j < 9; ++j) count += selectFloat(n.present[j], Lanes8{} + 1.0f, Lanes8{});
      for (int c = 0; c < 3; ++c) {
        Lanes8 sum{}, sumSq{};
        for (int j = 0; j < 9; ++j) {
          const Lanes8 v = loadLanes(box.plane(c) + n.offset[j], n.present[j]);
          sum += v;
          sumSq += v * v;
        }
        mean[c] = sum / count;
        sigma[c] = sqrtLanes(maxFloat(Lanes8{}, sumSq / count - mean[c] * mean[c]));
      }
      // Clamp the history into mu +- k sigma, shorten N by how far it moved, blend.
      const HistoryBlock history = this->history(n.p, std::min(8, w - x0));
      const LaneMask8 stabilizeHere = n.present[4] & history.valid();  // a surface with history
      Lanes8 current[3], previous[3], clamped[3];
      for (int c = 0; c < 3; ++c) {
        current[c] = loadLanes(postBlurred_.plane(c) + n.p, n.inRow);
        previous[c] = history.apply(stabilizedHistory_.plane(c));
        const Lanes8 lo = mean[c] - k * sigma[c], hi = mean[c] + k * sigma[c];
        clamped[c] =
            selectFloat(previous[c] < lo, lo, selectFloat(hi < previous[c], hi, previous[c]));
      }
      float* accumulated = accumulatedFrames_.plane(0) + n.p;
      Lanes8 frames = loadLanes(accumulated, n.inRow);
      if (s_.antiLag) {
        const Lanes8 lh = luminance(previous[0], previous[1], previous[2]);
        const Lanes8 lc = luminance(clamped[0], clamped[1], clamped[2]);
        const Lanes8 d = absFloat(lh - lc) / maxFloat(maxFloat(lh, lc), Lanes8{} + 1e-6f);
        // NRD never lets anti-lag push a history below the history-fix threshold it had reached.
        const Lanes8 floorFrames = minFloat(frames, Lanes8{} + float(s_.historyFixFrames));
        frames = maxFloat(frames / (1.0f + d * frames / 3.0f), floorFrames);
        storeLanes(accumulated, frames, stabilizeHere);
      }
      const Lanes8 alpha = 1.0f / (1.0f + frames);
      for (int c = 0; c < 3; ++c) {
        const Lanes8 blended = alpha * current[c] + (1.0f - alpha) * clamped[c];
        const Lanes8 result = selectFloat(stabilizeHere, blended, current[c]);
        storeLanes(stabilized_.plane(c) + n.p, result, n.inRow);
        storeLanes(output.plane(c) + n.p, result, n.inRow);
      }
    }
  });
}

void Reblur::storeHistory() {
  ScopedPass pass(this, "store guides", 0);
  std::swap(stabilizedHistory_, stabilized_);
  std::swap(accumulatedFrames_, accumulatedFramesHistory_);
  previousGBuffer_.store(gbuffer_);
  hasHistory_ = true;
}

std::vector<std::pair<std::string, const Image*>> Reblur::passOutputs() const {
  // After a frame the post-blurred (or, non-recurrent, the temporal) image, the fast image and
  // the stabilised image live in their history buffers (swapped in, see storeRecurrentHistory).
  const Image* temporal = s_.recurrent ? &temporal_ : &slowHistory_;
  return {{"pre-blur", &preBlurred_},
          {"temporal", temporal},
          {"fast history", &fastHistory_},
          {"history fix", historyFixed_ == &temporal_ ? temporal : historyFixed_},
          {"anti-firefly", &fireflyFree_},
          {"blur", &blurred_},
          {"post-blur", s_.recurrent ? &slowHistory_ : &postBlurred_},
          {"history", &slowHistory_},
          {"stabilization", &stabilizedHistory_}};
}

const ParamTable<ReblurSettings>& reblurParams() {
  using S = ReblurSettings;
  static const ParamTable<S> table =
      ParamTable<S>()
          .boolean("preBlur", &S::preBlur, true, "pass 1: 8-tap Poisson pre-blur (NRD prepass)")
          .real("preBlurRadius", &S::preBlurRadius, 30, 0, 500,
                "diffuse pre-blur radius, px (NRD diffusePrepassBlurRadius 30)")
          .real("specularPreBlurRadius", &S::specularPreBlurRadius, 50, 0, 500,
                "specular pre-blur radius, px (NRD specularPrepassBlurRadius 50)")
          .integer("maxAccumulatedFrames", &S::maxAccumulatedFrames, 30, 1, 1000,
                   "cap of the accumulated-frame counter N (NRD maxAccumulatedFrameNum 30)")
          .integer("maxFastAccumulatedFrames", &S::maxFastAccumulatedFrames, 6, 1, 1000,
                   "cap of the fast history used for clamping (NRD maxFastAccumulatedFrameNum 6)")
          .boolean("hitPoint", &S::hitPoint, true,
                   "specular: blend hit-point (virtual) reprojection with surface motion by "
                   "roughness (NRD virtual motion; the talk)")
          .include(hitDistanceParams(), &S::hitDistanceChannel)
          .boolean("hitDistancePreBlur", &S::hitDistancePreBlur, true,
                   "specular: the pre-blur filters the hit distance too, and every later pass "
                   "reads the blurred one (NRD pre-pass)")
          .real("hitPointRoughness", &S::hitPointRoughness, 0.6, 0.0, 1.0,
                "specular: virtual-history weight 1 - smoothstep(0, this, roughness) (ours)")
          .choice("historyFix", &S::historyFix, "sparse",
                  {{"sparse", ReblurHistoryFix::Sparse},
                   {"mip", ReblurHistoryFix::Mip},
                   {"off", ReblurHistoryFix::Off}},
                  "pass 3 for N < historyFixFrames: 5x5 taps at stride 14 (NRD) or the mip chain "
                  "(ReBLUR 2020), or off")
          .integer("historyFixFrames", &S::historyFixFrames, 3, 0, 16,
                   "history fix while N < this (NRD 3)")
          .choice("historyFixShape", &S::historyFixShape, "nrd",
                  {{"nrd", HistoryFixShape::Nrd}, {"ours", HistoryFixShape::Ours}},
                  "history-fix grid: NRD v4's 20 taps (5x5 without corners) at stride "
                  "historyFixStride / (2 + N), or all 24 at historyFixStride (F - N) / F")
          .choice("radiusFalloff", &S::radiusFalloff, "nrd",
                  {{"nrd", RadiusFalloff::Nrd}, {"sqrt", RadiusFalloff::Sqrt}},
                  "blur radius scale: NRD's 1 / (1 + N_prev) or sqrt(1 / (1 + N)) of the "
                  "incremented counter (the first version here)")
          .real("historyFixStride", &S::historyFixStride, 14, 1, 100,
                "history-fix tap stride at N = 0, px (NRD historyFixStrideBetweenSamples 14)")
          .boolean("antiFirefly", &S::antiFirefly, true,
                   "clamp the luminance to its 3x3 neighbours' luminance range, colour rescaled "
                   "(NRD enableAntiFirefly; NRD's range is m1 +- sigma of a ring)")
          .boolean("fastHistoryClamp", &S::fastHistoryClamp, true,
                   "clamp the recurrent history's luminance to the fast history's 3x3 mu +- "
                   "antilagSigmaScale sigma (NRD HistoryFix)")
          .choice("fastHistoryBlend", &S::fastHistoryBlend, "nrd",
                  {{"nrd", FastHistoryBlend::Nrd}, {"ours", FastHistoryBlend::Ours}},
                  "fast-history clamp: the unclamped value blended back by 1/(1 + 2 N_prev) "
                  "(NRD) or 1/(1 + N_prev) (the first version)")
          .boolean("blur", &S::blur, true, "pass 4: Poisson blur")
          .boolean("postBlur", &S::postBlur, true, "pass 4: Poisson post-blur at twice the radius")
          .real("minBlurRadius", &S::minBlurRadius, 1, 0, 500,
                "blur radius floor, px (NRD minBlurRadius 1)")
          .real("maxBlurRadius", &S::maxBlurRadius, 30, 0, 500,
                "blur radius at N_prev = 0, px, shrinking per radiusFalloff (NRD maxBlurRadius "
                "30)")
          .boolean("recurrent", &S::recurrent, true,
                   "pass 5: the post-blurred result is the history (false: the temporal result)")
          .boolean("stabilization", &S::stabilization, true, "pass 6: temporal stabilisation")
          .boolean("antiLag", &S::antiLag, true,
                   "pass 6: shorten N by the clamp distance, N' = N / (1 + d N / 3)")
          .real("antilagSigmaScale", &S::antilagSigmaScale, 2, 0, 100,
                "stabilised history clamped to the box's mu +- this sigma (NRD 2)")
          .choice("stabilizationBox", &S::stabilizationBox, "current",
                  {{"current", StabilizationBox::Current}, {"fast", StabilizationBox::Fast}},
                  "stabiliser's clamp box: the 3x3 of this frame's post-blurred result (NRD "
                  "TemporalStabilization) or of the fast history (the first version)")
          .include(surfaceWeightParams(), &S::weights)
          .include(reprojectionParams(), &S::reprojection)
          .include(footprintParams(), &S::footprint);
  return table;
}

DenoiserInfo reblurInfo() {
  return {"reblur",
          "Recurrent blur: Poisson pre-blur, accumulation with a frame counter, history fix, "
          "shrinking blur + post-blur fed back as history, anti-lag stabilisation (Zhdan 2020; "
          "NRD REBLUR)",
          reblurParams().schema(), [](const ParamSet& params, SignalKind kind) {
            ReblurSettings s = reblurParams().settings(params, "reblur");
            // Specular weights add hit distance and roughness (NRD); diffuse uses geometry only.
            s.weights.hitDistance = s.weights.roughness = kind == SignalKind::Specular;
            return std::make_unique<Reblur>(s, kind);
          }};
}

}  // namespace arena
