#pragma once
// Specular-lobe similarity (Tokuyoshi 2016, "Specular Lobe-Aware Filtering and Upsampling for
// Interactive Indirect Illumination"; the CEDEC 2021 talk's edge-stopping term, p. "4.1.4"):
// every pixel's reflection lobe is a spherical Gaussian G(v; xi, lambda) = exp(lambda (v.xi - 1))
// with axis xi = the reflection vector and sharpness lambda from the roughness. Two pixels may
// share samples in proportion to how much their lobes overlap: the normalised SG product integral
//   s = int G_p G_q / sqrt(int G_p^2 int G_q^2) = 2 sqrt(l_p l_q) / l_m * exp(l_m - l_p - l_q),
//   l_m = |l_p xi_p + l_q xi_q|,
// using int G(v; xi, l) dv ~ 2 pi / l (the e^(-2l) term dropped, as Tokuyoshi does). s = 1 for
// identical lobes, < 1 otherwise. The talk raises it to a power beta to sharpen it; for equal
// axes s reduces to the talk's 2 sqrt(l_i l_j) / (l_i + l_j).
#include <algorithm>
#include <cmath>

#include "core/camera.hpp"
#include "core/fast_math.hpp"
#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"

namespace arena {

// Channels of a lobe image (computeSpecularLobes).
enum SpecularLobeChannel : int {
  kLobeAxisX = 0,
  kLobeAxisY = 1,
  kLobeAxisZ = 2,
  kLobeSharpness = 3,
  kSpecularLobeChannels = 4,
};

struct SpecularLobeSettings {
  // Roughness is clamped below here before alpha = roughness^2, so a perfect mirror keeps a
  // finite lobe (ours; 0.05 gives lambda ~ 8e4 at normal incidence).
  float minRoughness = 0.05f;
  // Diffuse signal: the lobe is the cosine lobe about the normal. A fitted cosine SG has
  // lambda ~ 2.13, far too wide to stop anything, so the diffuse instance uses this sharpness
  // instead: the parameter "lobeDiffuseSharpness" (hybridParams(), its default and meaning).
  float diffuseSharpness{};
};

// The specular lobe of a GGX surface seen from `view` (unit, surface to eye) with normal n:
// axis = reflect(-view, n); sharpness of the NDF's SG fit 2 / alpha^2 (alpha = roughness^2),
// warped into reflected-direction space by 1 / (4 |n.v|) (Wang et al. 2009, used by Tokuyoshi).
inline float specularLobeSharpness(float roughness, float normalDotView, float minRoughness) {
  const float r = std::max(roughness, minRoughness);
  const float alpha = r * r;
  return 2.0f / (alpha * alpha) / (4.0f * std::max(std::abs(normalDotView), 0.05f));
}

// Lobe of every pixel: 4 planes (axis xyz, sharpness). specular = true: the GGX lobe above,
// from `roughness` (perceptual, one plane), world positions and the camera's eye; false: the
// normal with settings.diffuseSharpness. Sky pixels get a zero lobe (never compared: filters
// drop sky taps). Needs normal (and position for specular).
void computeSpecularLobes(const GBufferView& gbuffer, const float* roughness,
                          const CameraState& camera, bool specular,
                          const SpecularLobeSettings& settings, Image& lobes);

// log of the normalised SG product integral (<= 0), for lobes a and b; F is float or a lane type
// of core/fast_math.hpp. beta * this is the exponent of the talk's beta-sharpened weight.
template <class F>
inline F logLobeSimilarity(F ax, F ay, F az, F la, F bx, F by, F bz, F lb) {
  const F mx = la * ax + lb * bx, my = la * ay + lb * by, mz = la * az + lb * bz;
  const F lm = maxFloat(sqrtLanes(mx * mx + my * my + mz * mz), F{} + 1e-12f);
  const F ratio = 2.0f * sqrtLanes(la * lb) / lm;
  // log(ratio) + (lm - la - lb), clamped at 0 (s <= 1; the dropped e^(-2l) terms can push the
  // approximation a hair above 1 for very wide lobes).
  return minFloat(F{}, logPositive(maxFloat(ratio, F{} + 1e-30f)) + (lm - la - lb));
}

// s^beta for pixels p and q of a lobe image.
inline float lobeWeight(const Image& lobes, size_t p, size_t q, float beta) {
  const float e = logLobeSimilarity(lobes.plane(kLobeAxisX)[p], lobes.plane(kLobeAxisY)[p],
                                    lobes.plane(kLobeAxisZ)[p], lobes.plane(kLobeSharpness)[p],
                                    lobes.plane(kLobeAxisX)[q], lobes.plane(kLobeAxisY)[q],
                                    lobes.plane(kLobeAxisZ)[q], lobes.plane(kLobeSharpness)[q]);
  return expNonPositive(beta * e);
}

}  // namespace arena
