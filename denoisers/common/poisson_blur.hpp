#pragma once
// Poisson-disk blur (ReBLUR, Zhdan GTC 2020 / NRD; the CEDEC 2021 talk p. "4.1.2"): a fixed set
// of 8 taps inside a disk of a given radius, rotated by a per-frame angle so that temporal
// accumulation sees different taps every frame ("サンプル点に回転のようなランダマイズ処理を
// 適用することで有効なサンプル数を増やす"). The weights are NRD's kind -- geometry only, no
// luminance: plane distance, normal, and for the specular signal hit distance and roughness.
// The same weights drive any sparse gather (ReBLUR's stride-14 history fix), see sparseBlur.
#include <array>
#include <cmath>

#include "core/fast_math.hpp"
#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/param_table.hpp"

namespace arena {

// The guides the weights read; roughness and hitDistance only for the specular terms.
struct SurfaceGuide {
  const GBufferView& gbuffer;          // depth, normal, position, meshId
  const float* roughness = nullptr;    // perceptual roughness
  const float* hitDistance = nullptr;  // specHitDist (1e6 on miss)
};

struct SurfaceWeightSettings {
  // The sigmas are parameters ("planeSigma", ...; surfaceWeightParams() declares their defaults,
  // ranges and meanings once, for every variant that includes it). A bare SurfaceWeightSettings
  // has them 0: a caller outside a denoiser's table starts from surfaceWeightParams().defaults().
  // The switches are set by the variant (hit distance and roughness: the specular signal).
  // Plane distance (NRD's geometry weight): exp(-|n(p).(x(q) - x(p))| / (planeSigma z(p))), a
  // neighbour off the tangent plane of p by planeSigma of the view depth weighs 1/e.
  bool planeDistance = true;
  float planeSigma{};
  // Normal: max(0, n(p).n(q))^normalPower (NRD limits the lobe angle instead).
  bool normal = true;
  float normalPower{};
  // Specular: hit distance, max(exp(-|h(p) - h(q)| / (hitSigma (min(h(p), 1e4) + z(p)))),
  // minHitWeight). The floor is NRD's minHitDistanceWeight: without it the noise-free mirror
  // distance's cliff between a reflected miss (1e6) and a near hit split a glossy sphere into
  // regions that never exchanged samples -- the sharp-edged dark patch of issue 15, item 14.
  bool hitDistance = false;
  float hitSigma{};
  float minHitWeight{};
  float maxHitExponent() const { return minHitWeight > 0.0f ? -std::log(minHitWeight) : 1e30f; }
  // Specular: roughness, exp(-|r(p) - r(q)| / roughnessSigma).
  bool roughness = false;
  float roughnessSigma{};
};

// The guides of one pixel as the weights read them; F is float or a lane type of
// core/fast_math.hpp.
template <class F>
struct SurfacePoint {
  F position[3], normal[3];
  F depth, hitDistance, roughness;
};

// p's side of the weights, computed once per pixel: its guides and the terms' inverse scales.
template <class F>
struct SurfaceCentre {
  SurfacePoint<F> point;
  F inversePlaneScale{}, hitDistance{}, inverseHitScale{};
  float maxHitExponent = 1e30f;  // -log(minHitWeight)
};
template <class F>
inline SurfaceCentre<F> surfaceCentre(const SurfaceWeightSettings& s, const SurfacePoint<F>& p) {
  SurfaceCentre<F> c;
  c.point = p;
  if (s.planeDistance) c.inversePlaneScale = 1.0f / (s.planeSigma * absFloat(p.depth) + 1e-20f);
  if (s.hitDistance) {
    c.hitDistance = minFloat(p.hitDistance, F{} + 1e4f);
    c.inverseHitScale = 1.0f / (s.hitSigma * (c.hitDistance + absFloat(p.depth)) + 1e-20f);
    c.maxHitExponent = s.maxHitExponent();
  }
  return c;
}

// w(p, q) for a surface neighbour q of p (neither in the sky), written once for scalar and lane
// code: the exponential terms and the normal's cosine power summed into one exp.
template <class F>
inline F surfaceWeight(const SurfaceWeightSettings& s, const SurfaceCentre<F>& p,
                       const SurfacePoint<F>& q) {
  F exponent{};
  if (s.planeDistance) {
    F d{};
    for (int c = 0; c < 3; ++c) d += p.point.normal[c] * (q.position[c] - p.point.position[c]);
    exponent += absFloat(d) * p.inversePlaneScale;
  }
  if (s.hitDistance)  // exp(-min(x, -log(floor))) = max(exp(-x), floor): the floor costs no exp
    exponent +=
        minFloat(absFloat(p.hitDistance - minFloat(q.hitDistance, F{} + 1e4f)) * p.inverseHitScale,
                 F{} + p.maxHitExponent);
  if (s.roughness)
    exponent += absFloat(p.point.roughness - q.roughness) * (1.0f / s.roughnessSigma);
  if (!s.normal || s.normalPower == 0.0f) return expNonPositive(-exponent);
  // cosine^normalPower as exp(normalPower log(cosine)), inside the same exp; 0 facing away.
  const SurfacePoint<F>& c = p.point;
  F cosine = c.normal[0] * q.normal[0] + c.normal[1] * q.normal[1] + c.normal[2] * q.normal[2];
  cosine = minFloat(cosine, F{} + 1.0f);
  const auto facing = F{} + 1e-30f < cosine;
  exponent -= s.normalPower * logPositive(maxFloat(cosine, F{} + 1e-30f));
  return selectFloat(facing, expNonPositive(-exponent), F{});
}

// w(p, q) in [0, 1] for one pair of pixels, 0 for sky q: the per-pixel form of what sparseBlur
// evaluates in lanes (the reference the tests compare with); its constructor checks that the
// enabled terms have their guides. References the guide's planes.
class SurfaceWeights {
 public:
  SurfaceWeights(const SurfaceWeightSettings& settings, const SurfaceGuide& guide);
  float operator()(size_t p, size_t q) const;
  SurfacePoint<float> point(size_t i) const;

 private:
  SurfaceWeightSettings s_;
  GBufferView g_;
  const float* roughness_;
  const float* hitDistance_;
};

// The sigmas above as parameters, shared by the variants that gather with these weights (reblur,
// reengine; ParamTable::include at their SurfaceWeightSettings).
const ParamTable<SurfaceWeightSettings>& surfaceWeightParams();

struct PoissonBlurSettings {
  float radius = 30.0f;  // pixels (NRD blurRadius 30 at its defaults)
  SurfaceWeightSettings weights;
};

// The 8 unit-disk taps (a Vogel / golden-angle spiral: the talk notes any pattern with
// Poisson-like spacing serves, e.g. AMD's Halton points), rotated by poissonRotation(frame).
constexpr int kPoissonTaps = 8;
std::array<std::array<float, 2>, kPoissonTaps> poissonDisk(float rotation);
// Deterministic per-frame rotation: frame * golden angle, mod 2 pi.
float poissonRotation(int frameIndex);

// The sparse gather underneath: out(p) = sum_q w(p, q) in(q) / sum_q w(p, q) over p and its taps
// q = p + round(tap * radius * radiusScale(p)) (nearest pixel; radiusScale: optional 1-channel
// image). Taps off the image, onto p itself or in the sky are dropped, so a pixel whose scale is 0
// passes through unchanged; sky pixels pass through. Up to kMaxSparseTaps taps, at most 8
// channels; out must not alias in. `mostlyIdle`: most pixels have scale 0 (a pass over a few
// young histories); blocks with nothing to gather are then skipped -- the same result.
constexpr int kMaxSparseTaps = 24;
void sparseBlur(const Image& in, const SurfaceGuide& guide, const SurfaceWeightSettings& weights,
                const std::array<float, 2>* taps, int tapCount, float radius,
                const Image* radiusScale, Image& out, bool mostlyIdle);

// The Poisson-disk blur: sparseBlur over the 8 disk taps rotated by `rotation`, radius
// settings.radius.
void poissonDiskBlur(const Image& in, const SurfaceGuide& guide,
                     const PoissonBlurSettings& settings, float rotation, const Image* radiusScale,
                     Image& out);

}  // namespace arena
