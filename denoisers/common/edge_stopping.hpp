#pragma once
// Edge-stopping functions w(p, q) for joint-bilateral filters (each variant's terms and constants
// are in denoisers/FIDELITY.md):
// each term switchable and tunable, the weight their product, in [0, 1], 1 at the centre.
// EdgeStopping::weight is the per-tap reference form; the à-trous kernel (atrous_kernel.hpp)
// evaluates the same terms register-blocked, plus the specular-lobe similarity
// (specular_lobe.hpp).
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"

namespace arena {

enum class NormalWeightForm {
  CosinePower,       // SVGF eq. 4: max(0, n(p).n(q))^sigmaN
  GaussianDistance,  // Dammertz 2010: exp(-|n(p) - n(q)|^2 / sigmaN)
};

// The terms' switches and sigmas are parameters: their defaults, ranges and meanings are declared
// once, in the table of the variant that exposes them (svgfParams(): SVGF eq. 3-5 and Dammertz's
// position term; eawParams(): Dammertz 2010's terms). A filter that builds the settings itself
// (hybrid's and reengine's à-trous) sets every term it uses. A bare EdgeStoppingSettings{} has
// every term off and every sigma 0; the eps guards and the normal form below are constants.
struct EdgeStoppingSettings {
  // Depth, SVGF eq. 3: exp(-|z(p) - z(q)| / (sigmaZ |grad z(p) . (p - q)| + eps)).
  bool depth{};
  float sigmaZ{};
  // eps of eq. 3, relative to z(p) (ours: keeps a camera-facing plane, grad z = 0, from rejecting
  // depth rounding while a depth step of 0.1 % of the distance still stops the filter).
  float depthEpsilon = 1e-3f;
  // Normal: SVGF's cosine power or Dammertz's Gaussian of the normal distance (set by the variant).
  bool normal{};
  NormalWeightForm normalForm = NormalWeightForm::CosinePower;
  float sigmaN{};
  // Luminance, SVGF eq. 5: exp(-|l(p) - l(q)| / (sigmaL sqrt(g3x3(Var(l(p)))) + eps)).
  bool luminance{};
  float sigmaL{};
  float luminanceEpsilon = 1e-6f;  // eq. 5's eps, luminance units
  // World position, Dammertz 2010: exp(-|x(p) - x(q)|^2 / sigmaX), sigmaX in world units squared.
  bool position{};
  float sigmaX{};
  // Colour, Dammertz 2010: exp(-|c(p) - c(q)|^2 / sigmaRt); the caller halves sigmaRt per
  // iteration.
  bool color{};
  float sigmaColor{};
  // Mesh id (the talk: separates a poster from the wall it lies on): 0 across meshes.
  bool id{};
};

// The terms one by one, for filters that combine them differently and for tests.
inline float depthWeight(float zp, float zq, float dzdx, float dzdy, float offsetX, float offsetY,
                         float sigmaZ, float epsilon) {
  const float expected = sigmaZ * std::abs(dzdx * offsetX + dzdy * offsetY);
  // 1e-30 guards 0/0 where the depth and epsilon are both zero.
  return std::exp(-std::abs(zp - zq) / (expected + epsilon * std::abs(zp) + 1e-30f));
}
inline float cosinePowerWeight(float normalDot, float sigmaN) {
  return std::pow(std::clamp(normalDot, 0.0f, 1.0f), sigmaN);
}
inline float gaussianWeight(float distanceSquared, float sigma) {
  return std::exp(-distanceSquared / std::max(sigma, 1e-30f));
}
inline float luminanceWeight(float lp, float lq, float luminanceDenominator) {
  return std::exp(-std::abs(lp - lq) / std::max(luminanceDenominator, 1e-30f));
}

// w(p, q) over one frame's guides. `color` is the image being filtered (the colour and luminance
// terms compare its values); `luminanceVariance` the (pre-filtered) variance the luminance term
// scales by; `colorSigma` the colour term's sigma for this iteration. The images are referenced,
// not copied: they must outlive the EdgeStopping.
class EdgeStopping {
 public:
  EdgeStopping(const EdgeStoppingSettings& settings, const GBufferView& gbuffer,
               const Image* derivatives, const Image& color, const Image* luminanceVariance,
               float colorSigma)
      : s_(settings),
        g_(gbuffer),
        derivatives_(derivatives),
        color_(color),
        variance_(luminanceVariance),
        inverseColorSigma_(1.0f / std::max(colorSigma, 1e-30f)),
        inverseSigmaX_(1.0f / std::max(settings.sigmaX, 1e-30f)),
        inverseSigmaN_(1.0f / std::max(settings.sigmaN, 1e-30f)) {
    auto need = [](bool ok, const char* what) {
      if (!ok) throw Error(std::string("edge-stopping: the ") + what);
    };
    need(!s_.depth || (g_.depth && derivatives_), "depth term needs depth and its derivatives");
    need(!s_.normal || g_.normal[0], "normal term needs the normal layer");
    need(!s_.luminance || variance_, "luminance term needs a variance image");
    need(!s_.position || g_.position[0], "position term needs the position layer");
    need(!s_.id || g_.meshId, "id term needs the meshId layer");
    need(color_.channels() >= 3, "filtered image must have 3 channels");
  }

  // What the weight compares against, gathered once per filtered pixel.
  struct Centre {
    size_t index = 0;
    float z = 0, dzdx = 0, dzdy = 0, depthEpsilon = 0;
    float luminance = 0, inverseLuminanceDenominator = 0;
    float id = 0;
  };
  Centre centre(size_t p) const {
    Centre c;
    c.index = p;
    if (s_.depth) {
      c.z = g_.depth[p];
      c.dzdx = derivatives_->plane(kDepthDx)[p];
      c.dzdy = derivatives_->plane(kDepthDy)[p];
      c.depthEpsilon = s_.depthEpsilon * std::abs(c.z) + 1e-30f;  // 1e-30 guards 0/0
    }
    if (s_.luminance) {
      c.luminance = luminanceAt(p);
      c.inverseLuminanceDenominator =
          1.0f / (s_.sigmaL * std::sqrt(std::max(0.0f, variance_->plane(0)[p])) +
                  s_.luminanceEpsilon + 1e-30f);
    }
    if (s_.id) c.id = g_.meshId[p];
    return c;
  }

  // Product of the enabled terms for neighbour q at pixel offset (offsetX, offsetY) from p.
  // The exponential terms are summed in one exponent and the cosine power enters as
  // sigmaN log(n.n'), so a tap costs one exp (and one log) however many terms are on; both are
  // the polynomial versions of core/fast_math.hpp. Equal to the product of the functions above to
  // about 1e-6 relative.
  float weight(const Centre& p, size_t q, int offsetX, int offsetY) const {
    if (q == p.index) return 1.0f;
    if (s_.id && g_.meshId[q] != p.id) return 0.0f;
    float exponent = 0.0f;
    if (s_.depth) {
      const float expected =
          s_.sigmaZ * std::abs(p.dzdx * float(offsetX) + p.dzdy * float(offsetY));
      exponent += std::abs(p.z - g_.depth[q]) / (expected + p.depthEpsilon);
    }
    if (s_.luminance)
      exponent += std::abs(p.luminance - luminanceAt(q)) * p.inverseLuminanceDenominator;
    if (s_.position) exponent += distanceSquared(g_.position, p.index, q) * inverseSigmaX_;
    if (s_.color) {
      float d2 = 0;
      for (int c = 0; c < 3; ++c) {
        float d = color_.plane(c)[p.index] - color_.plane(c)[q];
        d2 += d * d;
      }
      exponent += d2 * inverseColorSigma_;
    }
    if (s_.normal) {
      if (s_.normalForm == NormalWeightForm::CosinePower) {
        const float cosine = std::min(g_.normalDot(p.index, q), 1.0f);
        if (cosine < 1e-30f) return s_.sigmaN == 0.0f ? expNonPositive(-exponent) : 0.0f;
        exponent -= s_.sigmaN * logPositive(cosine);
      } else {
        exponent += distanceSquared(g_.normal, p.index, q) * inverseSigmaN_;
      }
    }
    return expNonPositive(-exponent);
  }

 private:
  float luminanceAt(size_t i) const {
    return arena::luminance(color_.plane(0)[i], color_.plane(1)[i], color_.plane(2)[i]);
  }
  static float distanceSquared(const std::array<const float*, 3>& planes, size_t p, size_t q) {
    float d2 = 0;
    for (size_t c = 0; c < 3; ++c) {
      float d = planes[c][p] - planes[c][q];
      d2 += d * d;
    }
    return d2;
  }

  EdgeStoppingSettings s_;
  GBufferView g_;
  const Image* derivatives_;
  const Image& color_;
  const Image* variance_;
  float inverseColorSigma_, inverseSigmaX_, inverseSigmaN_;
};

}  // namespace arena
