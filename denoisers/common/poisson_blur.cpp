#include "denoisers/common/poisson_blur.hpp"

#include <algorithm>
#include <numbers>
#include <string>

#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/poisson_blur_kernel.hpp"
#include "denoisers/common/simd.hpp"

namespace arena {

namespace {
constexpr float kGoldenAngle = 2.39996323f;  // pi (3 - sqrt 5)
}

const ParamTable<SurfaceWeightSettings>& surfaceWeightParams() {
  using W = SurfaceWeightSettings;
  static const ParamTable<W> table =
      ParamTable<W>()
          .real("planeSigma", &W::planeSigma, 0.02, 1e-6, 10,
                "plane-distance weight scale, fraction of view depth (ours; NRD compares with a "
                "fraction of the frustum size)")
          .real("normalPower", &W::normalPower, 32, 0, 1e4,
                "normal weight max(0, n.n')^this (ours: 10 degrees weighs 0.61)")
          .real("hitSigma", &W::hitSigma, 0.3, 1e-6, 100,
                "specular hit-distance weight scale, fraction of (h + z) (ours)")
          .real("roughnessSigma", &W::roughnessSigma, 0.1, 1e-6, 10,
                "specular roughness weight scale (ours)")
          .real("minHitWeight", &W::minHitWeight, 0.1, 0, 1,
                "floor of the specular hit-distance weight (NRD minHitDistanceWeight 0.1; 0 = "
                "none, reblur's first version)");
  return table;
}

SurfaceWeights::SurfaceWeights(const SurfaceWeightSettings& settings, const SurfaceGuide& guide)
    : s_(settings),
      g_(guide.gbuffer),
      roughness_(guide.roughness),
      hitDistance_(guide.hitDistance) {
  if (s_.planeDistance && (!g_.position[0] || !g_.normal[0] || !g_.depth))
    throw Error("surface weights: the plane-distance term needs position, normal and depth");
  if (s_.normal && !g_.normal[0]) throw Error("surface weights: the normal term needs normals");
  if (s_.hitDistance && (!hitDistance_ || !g_.depth))
    throw Error("surface weights: the hit-distance term needs specHitDist and depth");
  if (s_.roughness && !roughness_)
    throw Error("surface weights: the roughness term needs roughness");
}

SurfacePoint<float> SurfaceWeights::point(size_t i) const {
  SurfacePoint<float> point{};
  for (size_t c = 0; c < 3; ++c) {
    point.position[c] = g_.position[0] ? g_.position[c][i] : 0.0f;
    point.normal[c] = g_.normal[0] ? g_.normal[c][i] : 0.0f;
  }
  point.depth = g_.depth ? g_.depth[i] : 0.0f;
  point.hitDistance = hitDistance_ ? hitDistance_[i] : 0.0f;
  point.roughness = roughness_ ? roughness_[i] : 0.0f;
  return point;
}

float SurfaceWeights::operator()(size_t p, size_t q) const {
  if (g_.isSky(q)) return 0.0f;
  return surfaceWeight(s_, surfaceCentre(s_, point(p)), point(q));
}

std::array<std::array<float, 2>, kPoissonTaps> poissonDisk(float rotation) {
  std::array<std::array<float, 2>, kPoissonTaps> taps{};
  for (int i = 0; i < kPoissonTaps; ++i) {
    // Equal-area radii sqrt((i + 0.5) / 8) and golden-angle steps: no two taps clump.
    const float r = std::sqrt((float(i) + 0.5f) / float(kPoissonTaps));
    const float a = rotation + float(i) * kGoldenAngle;
    taps[size_t(i)] = {r * std::cos(a), r * std::sin(a)};
  }
  return taps;
}

float poissonRotation(int frameIndex) {
  return std::fmod(float(frameIndex) * kGoldenAngle, 2.0f * std::numbers::pi_v<float>);
}

void sparseBlur(const Image& in, const SurfaceGuide& guide, const SurfaceWeightSettings& weights,
                const std::array<float, 2>* taps, int tapCount, float radius,
                const Image* radiusScale, Image& out, bool mostlyIdle) {
  const GBufferView& g = guide.gbuffer;
  const int w = in.width(), h = in.height(), channels = in.channels();
  if (!out.sameShape(in) || g.width != w || g.height != h ||
      channels > poisson_detail::kMaxChannels || &in == &out)
    throw Error(
        "sparse blur: in/out must be distinct images of the G-buffer's size, <= 8 channels");
  if (tapCount < 0 || tapCount > kMaxSparseTaps)
    throw Error("sparse blur: " + std::to_string(tapCount) + " taps, at most " +
                std::to_string(kMaxSparseTaps));
  if (radiusScale && (radiusScale->width() != w || radiusScale->height() != h))
    throw Error("sparse blur: the radius scale must have the image's size");
  const SurfaceWeights checked(weights, guide);  // throws where a guide is missing
  if (gpu::recording()) {  // the centre and every tap: the signal and the guides the weight uses
    using namespace gpu_buffers;
    // A pixel that does not gather (its radius scale not above 0, or a sky pixel) passes through:
    // a shader reads its scale, meshId and signal and exits, so the taps and the guides count for
    // the share of pixels that gather, as data-dependent taps are counted where they happen (a
    // history fix over a few young pixels). Without a scale every surface pixel gathers.
    double gathering = 1.0;
    if (radiusScale || g.meshId) {
      const size_t pixels = size_t(w) * size_t(h);
      const float* scale = radiusScale ? radiusScale->plane(0) : nullptr;
      size_t n = 0;
      for (size_t i = 0; i < pixels; ++i)
        n += (!scale || scale[i] > 0.0f) && (!g.meshId || g.meshId[i] >= 0.0f);
      gathering = double(n) / double(pixels);
    }
    const double fetches = 1.0 + tapCount * gathering, guides = gathering * (1.0 + tapCount);
    gpu::dispatch(w, h);
    gpu::read(kRadiance, w, h, fetches);
    if (channels > 4) gpu::read(kExtraChannels, w, h, fetches);
    if (g.meshId) gpu::read(kMeshId, w, h, fetches);
    gpu::read(kDepth, w, h, 1);
    if (weights.planeDistance) gpu::read(kPosition, w, h, guides);
    if (weights.normal) gpu::read(kNormal, w, h, guides);
    if (weights.hitDistance && guide.hitDistance) gpu::read(kHitDistance, w, h, guides);
    if (weights.roughness && guide.roughness) gpu::read(kRoughness, w, h, guides);
    if (radiusScale) gpu::read(kHistoryLength, w, h, 1);  // the radius follows the history
    gpu::write(kRadiance, w, h);
    if (channels > 4) gpu::write(kExtraChannels, w, h);
  }
  poisson_detail::Blur b{};
  b.width = w;
  b.height = h;
  b.channels = channels;
  for (int c = 0; c < channels; ++c) {
    b.in[c] = in.plane(c);
    b.out[c] = out.plane(c);
  }
  b.meshId = g.meshId;
  b.scale = radiusScale ? radiusScale->plane(0) : nullptr;
  b.radius = radius;
  b.tapCount = tapCount;
  for (int t = 0; t < tapCount; ++t)
    for (int k = 0; k < 2; ++k) b.taps[t][k] = taps[t][size_t(k)];
  b.weights = weights;
  for (size_t c = 0; c < 3; ++c) {
    b.position[c] = g.position[c];
    b.normal[c] = g.normal[c];
  }
  b.depth = g.depth;
  b.hitDistance = guide.hitDistance;
  b.roughness = guide.roughness;
  const poisson_detail::BlurRowFunction blurRow =
      simdUsesAvx512() ? poisson_detail::selectBlurRowAvx512(tapCount, mostlyIdle)
                       : poisson_detail::selectBlurRow<Lanes8>(tapCount, mostlyIdle);
  parallelRows(h, [&](int y) { blurRow(b, y); });
}

void poissonDiskBlur(const Image& in, const SurfaceGuide& guide,
                     const PoissonBlurSettings& settings, float rotation, const Image* radiusScale,
                     Image& out) {
  const auto disk = poissonDisk(rotation);
  sparseBlur(in, guide, settings.weights, disk.data(), kPoissonTaps, settings.radius, radiusScale,
             out, false);
}

}  // namespace arena
