#include "denoisers/common/poisson_blur.hpp"

#include <algorithm>
#include <numbers>

#include "core/error.hpp"
#include "denoisers/common/fast_math.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

namespace {
constexpr float kGoldenAngle = 2.39996323f;  // pi (3 - sqrt 5)
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

float SurfaceWeights::operator()(size_t p, size_t q) const {
  if (g_.isSky(q)) return 0.0f;
  float exponent = 0.0f;
  if (s_.planeDistance) {
    float d = 0.0f;
    for (size_t c = 0; c < 3; ++c) d += g_.normal[c][p] * (g_.position[c][q] - g_.position[c][p]);
    exponent += std::abs(d) / (s_.planeSigma * std::abs(g_.depth[p]) + 1e-20f);
  }
  if (s_.hitDistance) {
    const float hp = std::min(hitDistance_[p], 1e4f), hq = std::min(hitDistance_[q], 1e4f);
    exponent += std::abs(hp - hq) / (s_.hitSigma * (hp + std::abs(g_.depth[p])) + 1e-20f);
  }
  if (s_.roughness) exponent += std::abs(roughness_[p] - roughness_[q]) / s_.roughnessSigma;
  float w = expNonPositive(-exponent);
  if (s_.normal && s_.normalPower != 0.0f) {
    const float cosine = std::min(g_.normalDot(p, q), 1.0f);
    w = cosine <= 1e-30f ? 0.0f : w * expNonPositive(s_.normalPower * logPositive(cosine));
  }
  return w;
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

void poissonDiskBlur(const Image& in, const SurfaceGuide& guide,
                     const PoissonBlurSettings& settings, float rotation, const Image* radiusScale,
                     Image& out) {
  const GBufferView& g = guide.gbuffer;
  const int w = in.width(), h = in.height(), channels = in.channels();
  if (!out.sameShape(in) || g.width != w || g.height != h || channels > 8 || &in == &out)
    throw Error("Poisson blur: in/out must be distinct images of the G-buffer's size");
  const SurfaceWeights weight(settings.weights, guide);
  const auto disk = poissonDisk(rotation);
  const float* scale = radiusScale ? radiusScale->plane(0) : nullptr;
  parallelRows(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      float sum[8];
      for (int c = 0; c < channels; ++c) sum[c] = in.plane(c)[p];
      if (g.isSky(p)) {
        for (int c = 0; c < channels; ++c) out.plane(c)[p] = sum[c];
        continue;
      }
      float weightSum = 1.0f;  // the centre
      const float radius = settings.radius * (scale ? scale[p] : 1.0f);
      for (const auto& tap : disk) {
        const int qx = x + int(std::lround(tap[0] * radius));
        const int qy = y + int(std::lround(tap[1] * radius));
        if (qx < 0 || qy < 0 || qx >= w || qy >= h || (qx == x && qy == y)) continue;
        const size_t q = size_t(qy) * size_t(w) + size_t(qx);
        const float wq = weight(p, q);
        if (wq <= 0.0f) continue;
        for (int c = 0; c < channels; ++c) sum[c] += wq * in.plane(c)[q];
        weightSum += wq;
      }
      const float inverse = 1.0f / weightSum;
      for (int c = 0; c < channels; ++c) out.plane(c)[p] = sum[c] * inverse;
    }
  });
}

}  // namespace arena
