#include "denoisers/common/poisson_blur.hpp"

#include <algorithm>
#include <numbers>

#include "core/error.hpp"
#include "core/fast_math.hpp"
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
  return surfaceWeight(s_, point(p), point(q));
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

namespace {

// The guides of eight pixels that surfaceWeight() reads for the enabled terms (the neighbour's
// normal only for the normal term, its depth never): at consecutive indices from i (mask: the
// lanes to read), or gathered at per-lane indices.
struct SurfaceLanes {
  const SurfaceGuide& guide;
  const SurfaceWeightSettings& s;
  SurfacePoint<Lanes8> load(size_t i, LaneMask8 mask, bool centre) const {
    return read(centre, [&](const float* plane) { return loadLanes(plane + i, mask); });
  }
  SurfacePoint<Lanes8> gather(LaneMask8 index, LaneMask8 mask) const {
    return read(false, [&](const float* plane) { return gatherLanes(plane, index, mask); });
  }
  template <class Read>
  SurfacePoint<Lanes8> read(bool centre, Read&& planeLanes) const {
    const GBufferView& g = guide.gbuffer;
    SurfacePoint<Lanes8> point{};
    const bool normal = s.normal && s.normalPower != 0.0f;
    for (size_t c = 0; c < 3; ++c) {
      if (s.planeDistance) point.position[c] = planeLanes(g.position[c]);
      if (normal || (centre && s.planeDistance)) point.normal[c] = planeLanes(g.normal[c]);
    }
    if (centre && (s.planeDistance || s.hitDistance)) point.depth = planeLanes(g.depth);
    if (s.hitDistance) point.hitDistance = planeLanes(guide.hitDistance);
    if (s.roughness) point.roughness = planeLanes(guide.roughness);
    return point;
  }
};

// std::lround per lane (half away from zero), exactly: the fraction after truncation is exact.
inline LaneMask8 roundToNearestInt(Lanes8 v) {
  const LaneMask8 whole = truncateToInt(v);
  const Lanes8 fraction = v - toFloat(whole);
  return whole + ((fraction >= 0.5f) & 1) - ((fraction <= -0.5f) & 1);
}

}  // namespace

void poissonDiskBlur(const Image& in, const SurfaceGuide& guide,
                     const PoissonBlurSettings& settings, float rotation, const Image* radiusScale,
                     Image& out) {
  const GBufferView& g = guide.gbuffer;
  const int w = in.width(), h = in.height(), channels = in.channels();
  if (!out.sameShape(in) || g.width != w || g.height != h || channels > 8 || &in == &out)
    throw Error("Poisson blur: in/out must be distinct images of the G-buffer's size");
  const SurfaceWeights checked(settings.weights, guide);  // throws where a guide is missing
  const auto disk = poissonDisk(rotation);
  const float* scale = radiusScale ? radiusScale->plane(0) : nullptr;
  const SurfaceLanes surface{guide, settings.weights};
  // Eight pixels at a time; a tap's neighbours are gathered (the disk's offsets scale with each
  // pixel's radius). Dropped taps -- off the image, onto p itself, into the sky -- weigh 0.
  parallelRows(h, [&](int y) {
    for (int x0 = 0; x0 < w; x0 += 8) {
      const size_t p = size_t(y) * size_t(w) + size_t(x0);
      const LaneMask8 x = laneIndex(Lanes8{}) + x0;
      const LaneMask8 inRow = x < w;
      const LaneMask8 sky =
          g.meshId ? inRow & (loadLanes(g.meshId + p, inRow) < 0.0f) : LaneMask8{};
      const LaneMask8 surfacePixel = inRow & ~sky;
      Lanes8 sum[8];
      for (int c = 0; c < channels; ++c) sum[c] = loadLanes(in.plane(c) + p, inRow);
      Lanes8 weightSum = Lanes8{} + 1.0f;  // the centre
      const Lanes8 radius = settings.radius * (scale ? loadLanes(scale + p, inRow) : Lanes8{} + 1.0f);
      const SurfacePoint<Lanes8> centre = surface.load(p, inRow, true);
      for (const auto& tap : disk) {
        const LaneMask8 dx = roundToNearestInt(tap[0] * radius);
        const LaneMask8 dy = roundToNearestInt(tap[1] * radius);
        const LaneMask8 qx = x + dx, qy = y + dy;
        LaneMask8 use = surfacePixel & (qx >= 0) & (qx < w) & (qy >= 0) & (qy < h) &
                        ((dx != 0) | (dy != 0));
        const LaneMask8 q = qy * w + qx;
        // Where every lane has the same offset (a uniform radius: a converged history, one
        // roughness), the neighbours are consecutive and load without a gather; same values.
        const bool uniform = allLanes((dx == dx[0]) & (dy == dy[0]));
        const size_t q0 = p + size_t(std::ptrdiff_t(dy[0]) * w + dx[0]);
        auto neighbour = [&](const float* plane) {
          return uniform ? loadLanes(plane + q0, use) : gatherLanes(plane, q, use);
        };
        if (g.meshId) use &= neighbour(g.meshId) >= 0.0f;
        const SurfacePoint<Lanes8> other =
            uniform ? surface.load(q0, use, false) : surface.gather(q, use);
        const Lanes8 weight = selectFloat(use, surfaceWeight(settings.weights, centre, other), Lanes8{});
        for (int c = 0; c < channels; ++c) sum[c] += weight * neighbour(in.plane(c));
        weightSum += weight;
      }
      const Lanes8 inverse = 1.0f / weightSum;
      for (int c = 0; c < channels; ++c) {
        const Lanes8 result = selectFloat(sky, loadLanes(in.plane(c) + p, inRow), sum[c] * inverse);
        storeLanes(out.plane(c) + p, result, inRow);
      }
    }
  });
}

}  // namespace arena
