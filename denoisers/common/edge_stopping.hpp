#pragma once
// Edge-stopping functions w(p, q) for joint-bilateral filters (the table in docs/algorithms.md):
// each term switchable and tunable, the weight their product, in [0, 1], 1 at the centre.
// Room left for the terms other variants will add here, next to these: the specular-lobe
// similarity (Tokuyoshi 2016; the talk), and, as separate footprints over the same weights,
// a Poisson-disk gather (ReBLUR), a 3x3 median (firefly pass) and mip-level bilateral upsampling.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/error.hpp"
#include "core/image.hpp"
#include "denoisers/common/fast_math.hpp"
#include "denoisers/common/gbuffer.hpp"

namespace arena {

enum class NormalWeightForm {
  CosinePower,       // SVGF eq. 4: max(0, n(p).n(q))^sigmaN
  GaussianDistance,  // Dammertz 2010: exp(-|n(p) - n(q)|^2 / sigmaN)
};

struct EdgeStoppingSettings {
  // Depth, SVGF eq. 3: exp(-|z(p) - z(q)| / (sigmaZ |grad z(p) . (p - q)| + eps)).
  bool depth = true;
  float sigmaZ = 1.0f;  // [0; inf) SVGF paper 1
  // eps of eq. 3, relative to z(p) (ours: keeps a camera-facing plane, grad z = 0, from rejecting
  // depth rounding while a depth step of 0.1 % of the distance still stops the filter).
  float depthEpsilon = 1e-3f;
  // Normal.
  bool normal = true;
  NormalWeightForm normalForm = NormalWeightForm::CosinePower;
  float sigmaN = 128.0f;  // [0; inf) SVGF paper and Falcor 128 (cosine power)
  // Luminance, SVGF eq. 5: exp(-|l(p) - l(q)| / (sigmaL sqrt(g3x3(Var(l(p)))) + eps)).
  bool luminance = true;
  float sigmaL = 4.0f;             // [0; inf) SVGF paper 4 (Falcor phiColor 10)
  float luminanceEpsilon = 1e-6f;  // eq. 5's eps, luminance units
  // World position, Dammertz 2010: exp(-|x(p) - x(q)|^2 / sigmaX).
  bool position = false;
  float sigmaX = 0.05f;  // (0; inf) world units squared (ours)
  // Colour, Dammertz 2010: exp(-|c(p) - c(q)|^2 / sigmaRt); the caller halves sigmaRt per
  // iteration.
  bool color = false;
  float sigmaColor = 2.0f;  // (0; inf) (ours, for demodulated radiance)
  // Mesh id (the talk: separates a poster from the wall it lies on): 0 across meshes.
  bool id = false;
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
  // the polynomial versions of fast_math.hpp. Equal to the product of the functions above to
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

  // Row form of weight(), for filters that sweep one tap offset across a row at a time, so the
  // loops vectorise across x: for p = (x, y), x in [xBegin, xEnd), and q = p + (offsetX,
  // offsetY), all q inside the image, writes w(p, q) to weights[x]. `centreLuminance` and
  // `centreInverseDenominator` (indexed by x) come from prepareRow(y, ...). Sky neighbours are
  // not excluded here (the caller does it).
  void prepareRow(int y, float* centreLuminance, float* centreInverseDenominator) const {
    if (!s_.luminance) return;
    const size_t row = size_t(y) * size_t(g_.width);
    for (int x = 0; x < g_.width; ++x) {
      const Centre c = centre(row + size_t(x));
      centreLuminance[x] = c.luminance;
      centreInverseDenominator[x] = c.inverseLuminanceDenominator;
    }
  }
  void rowWeights(int y, int xBegin, int xEnd, int offsetX, int offsetY,
                  const float* centreLuminance, const float* centreInverseDenominator,
                  float* weights) const {
    if (offsetX == 0 && offsetY == 0) {
      std::fill(weights + xBegin, weights + xEnd, 1.0f);
      return;
    }
    const size_t row = size_t(y) * size_t(g_.width);
    const std::ptrdiff_t shift = std::ptrdiff_t(offsetY) * g_.width + offsetX;
    float* e = weights;  // the exponent first, in place
    std::fill(e + xBegin, e + xEnd, 0.0f);
    if (s_.depth) {
      const float* z = g_.depth + row;
      const float* zq = z + shift;
      const float* dx = derivatives_->plane(kDepthDx) + row;
      const float* dy = derivatives_->plane(kDepthDy) + row;
      const float ox = s_.sigmaZ * float(offsetX), oy = s_.sigmaZ * float(offsetY);
      for (int x = xBegin; x < xEnd; ++x)
        e[x] += std::abs(z[x] - zq[x]) /
                (std::abs(dx[x] * ox + dy[x] * oy) + s_.depthEpsilon * std::abs(z[x]) + 1e-30f);
    }
    if (s_.luminance) {
      const float* r = color_.plane(0) + row + shift;
      const float* gr = color_.plane(1) + row + shift;
      const float* b = color_.plane(2) + row + shift;
      for (int x = xBegin; x < xEnd; ++x)
        e[x] += std::abs(centreLuminance[x] - arena::luminance(r[x], gr[x], b[x])) *
                centreInverseDenominator[x];
    }
    auto addDistance = [&](const std::array<const float*, 3>& planes, float inverseSigma) {
      for (size_t c = 0; c < 3; ++c) {
        const float* a = planes[c] + row;
        const float* aq = a + shift;
        for (int x = xBegin; x < xEnd; ++x) e[x] += (a[x] - aq[x]) * (a[x] - aq[x]) * inverseSigma;
      }
    };
    if (s_.position) addDistance(g_.position, inverseSigmaX_);
    if (s_.color) {
      addDistance({color_.plane(0), color_.plane(1), color_.plane(2)}, inverseColorSigma_);
    }
    if (s_.normal && s_.normalForm == NormalWeightForm::GaussianDistance)
      addDistance(g_.normal, inverseSigmaN_);
    if (s_.normal && s_.normalForm == NormalWeightForm::CosinePower && s_.sigmaN != 0.0f) {
      const float *nx = g_.normal[0] + row, *ny = g_.normal[1] + row, *nz = g_.normal[2] + row;
      const float sigmaN = s_.sigmaN;
      constexpr int32_t kTiny = 0x0DA24260, kOne = 0x3F800000;  // bits of 1e-30f and 1.0f
      for (int x = xBegin; x < xEnd; ++x) {
        const float dot = nx[x] * nx[x + shift] + ny[x] * ny[x + shift] + nz[x] * nz[x + shift];
        // min(n.n', 1) clamped below at 1e-30 on the bit pattern (see fast_math.hpp on why
        // not in floats); n.n' <= 1e-30 gives weight 0 via an exponent past the cut-off.
        const int32_t bits = std::bit_cast<int32_t>(dot);
        const float cosine = std::bit_cast<float>(std::min(std::max(bits, kTiny), kOne));
        e[x] += selectFloat(bits < kTiny, 1e30f, 0.0f) - sigmaN * logPositive(cosine);
      }
    }
    for (int x = xBegin; x < xEnd; ++x) weights[x] = expNonPositive(-e[x]);
    if (s_.id) {
      const float* id = g_.meshId + row;
      for (int x = xBegin; x < xEnd; ++x) weights[x] = id[x] == id[x + shift] ? weights[x] : 0.0f;
    }
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
