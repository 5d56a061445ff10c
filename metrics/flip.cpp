// FLIP, written from the definitions in the two papers cited in flip.hpp:
//   [1] HPG 2020 (LDR-FLIP): colour pipeline, feature pipeline, final combination.
//   [2] EG 2021 short paper (HDR-FLIP): exposure range and tone mapping.
// Citations below name the part of the paper ("[1] colour pipeline") rather than numbers.
//
// Layout of the computation (per image pair, two full-image passes per image):
//   pass 1 (per row):  display RGB -> linear RGB -> XYZ -> YCxCz and normalised luminance, then
//                      every horizontal 1D convolution of the separable filters (CSF and the
//                      edge/point detectors) into seven planes;
//   pass 2 (per row):  the matching vertical convolutions, then per pixel the rest of the
//                      colour pipeline (gamut clamp, L*a*b*, Hunt) and the feature magnitudes.
//                      For the reference the results are stored; for the test image they are
//                      combined with the stored reference values into the FLIP map directly.
// All 2D kernels are sums of separable products, so separable filtering is exact (not an
// approximation). Rows are distributed with oneTBB; per-chunk row buffers are the only
// allocations inside the parallel loops.
#include "metrics/flip.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "metrics/metric_registry.hpp"

namespace arena {
namespace {

// ---- Constants ([1] colour and feature pipelines) ---------------------------------------------------------------

constexpr double kQc = 0.7;    // colour-error exponent
constexpr double kPc = 0.4;    // knee of the colour-error compression, as a fraction of cmax
constexpr double kPt = 0.95;   // value the knee maps to
constexpr double kGw = 0.082;  // peak-to-trough width of the feature detectors, in degrees
// qf = 0.5 (feature-error exponent) is applied as a square root in combinePixel.

constexpr double kPi = std::numbers::pi;

// ---- Colour spaces ---------------------------------------------------------------------------

// Linear sRGB (Rec.709 primaries, D65) -> CIE XYZ, IEC 61966-2-1.
constexpr std::array<std::array<double, 3>, 3> kRgbToXyzD = {{{0.4124564, 0.3575761, 0.1804375},
                                                              {0.2126729, 0.7151522, 0.0721750},
                                                              {0.0193339, 0.1191920, 0.9503041}}};

constexpr std::array<std::array<double, 3>, 3> inverse3(const std::array<std::array<double, 3>, 3>& a) {
  const double c00 = a[1][1] * a[2][2] - a[1][2] * a[2][1];
  const double c01 = a[1][2] * a[2][0] - a[1][0] * a[2][2];
  const double c02 = a[1][0] * a[2][1] - a[1][1] * a[2][0];
  const double det = a[0][0] * c00 + a[0][1] * c01 + a[0][2] * c02;
  return {{{c00 / det, (a[0][2] * a[2][1] - a[0][1] * a[2][2]) / det,
            (a[0][1] * a[1][2] - a[0][2] * a[1][1]) / det},
           {c01 / det, (a[0][0] * a[2][2] - a[0][2] * a[2][0]) / det,
            (a[0][2] * a[1][0] - a[0][0] * a[1][2]) / det},
           {c02 / det, (a[0][1] * a[2][0] - a[0][0] * a[2][1]) / det,
            (a[0][0] * a[1][1] - a[0][1] * a[1][0]) / det}}};
}
// Exact inverse of the forward matrix, so that the YCxCz -> RGB -> L*a*b* round trip of the
// colour pipeline is consistent with the forward transform.
constexpr auto kXyzToRgbD = inverse3(kRgbToXyzD);

// Reference white: XYZ of linear RGB (1,1,1), i.e. D65 scaled to Y = 1. YCxCz and L*a*b* are
// both taken relative to it ([1] colour pipeline).
constexpr std::array<double, 3> kWhiteD = {kRgbToXyzD[0][0] + kRgbToXyzD[0][1] + kRgbToXyzD[0][2],
                                           kRgbToXyzD[1][0] + kRgbToXyzD[1][1] + kRgbToXyzD[1][2],
                                           kRgbToXyzD[2][0] + kRgbToXyzD[2][1] + kRgbToXyzD[2][2]};

// Float copies for the per-pixel loops.
struct ColourMatrices {
  float toXyz[3][3], toRgb[3][3], white[3], invWhite[3];
};
constexpr ColourMatrices makeColourMatrices() {
  ColourMatrices m{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      m.toXyz[i][j] = float(kRgbToXyzD[i][j]);
      m.toRgb[i][j] = float(kXyzToRgbD[i][j]);
    }
    m.white[i] = float(kWhiteD[i]);
    m.invWhite[i] = float(1.0 / kWhiteD[i]);
  }
  return m;
}
constexpr ColourMatrices kM = makeColourMatrices();


// Branch-free select. GCC (with the default -ftrapping-math) turns `c ? a : b` over computed
// floats into a branch, which stops the per-pixel loops from vectorising; a bit blend cannot.
inline float select(bool c, float a, float b) {
  const std::uint32_t m = 0u - std::uint32_t(c);
  return std::bit_cast<float>((std::bit_cast<std::uint32_t>(a) & m) | (std::bit_cast<std::uint32_t>(b) & ~m));
}
inline double select(bool c, double a, double b) { return c ? a : b; }
inline float minF(float a, float b) { return select(b < a, b, a); }
inline float maxF(float a, float b) { return select(a < b, b, a); }
// Clamp to [0,1]; NaN maps to 0 (the comparisons are false for NaN).
inline float clamp01(float v) { return select(v > 0.0f, select(v < 1.0f, v, 1.0f), 0.0f); }

// x^y for the per-pixel loops, as exp2(y log2 x) with short series instead of a libm call (which
// blocks vectorisation and dominated the profile). log2: x = 2^e m with m in [sqrt(1/2),
// sqrt(2)), ln m = 2 atanh(s), s = (m-1)/(m+1), |s| < 0.172, series to s^9 (error < 3e-9).
// exp2: v = n + f with |f| <= 1/2, e^(f ln 2) by Taylor to degree 7 (error < 6e-9). Overall
// error is float rounding (~1e-6 relative here). x <= 0 (and denormals) follow std::pow's
// limits for y >= 0: 0^y = 0 for y > 0 and 0^0 = 1, so identical images still give exactly 0.
inline float log2Fast(float x) {
  const std::uint32_t bits = std::bit_cast<std::uint32_t>(x);
  float e = float(int(bits >> 23) - 127);
  float m = std::bit_cast<float>((bits & 0x007fffffu) | 0x3f800000u);
  const bool high = m > 1.41421356f;
  m *= select(high, 0.5f, 1.0f);
  e += select(high, 1.0f, 0.0f);
  const float s = (m - 1.0f) / (m + 1.0f), s2 = s * s;
  const float ln =
      2.0f * s * (1.0f + s2 * (1.0f / 3.0f + s2 * (1.0f / 5.0f + s2 * (1.0f / 7.0f + s2 * (1.0f / 9.0f)))));
  return e + ln * 1.44269504088896341f;
}
inline float exp2Fast(float v) {
  v = select(v > 126.0f, 126.0f, select(v < -126.0f, -126.0f, v));
  // Round to nearest by truncating a positive number (v + 126.5 >= 0.5): vectorises, unlike floor.
  const int n = int(v + 126.5f) - 126;
  const float t = (v - float(n)) * 0.693147180559945309f;
  const float p =
      1.0f + t * (1.0f + t * (1.0f / 2.0f + t * (1.0f / 6.0f + t * (1.0f / 24.0f + t * (1.0f / 120.0f +
                                                                                   t * (1.0f / 720.0f + t * (1.0f / 5040.0f)))))));
  return p * std::bit_cast<float>(std::uint32_t(n + 127) << 23);
}
inline float powFast(float x, float y) {  // y >= 0
  const float r = exp2Fast(y * log2Fast(x));
  return select(x >= 1.17549435e-38f, r, select(y == 0.0f, 1.0f, 0.0f));
}
// sqrt for x >= 0 in vectorised loops (std::sqrt keeps a branch for errno on negative input).
inline float sqrtFast(float x) { return powFast(x, 0.5f); }
inline double sqrtFast(double x) { return std::sqrt(x); }

inline float srgbToLinear(float v) {
  const float curve = powFast((v + 0.055f) * (1.0f / 1.055f), 2.4f);
  return select(v <= 0.04045f, v * (1.0f / 12.92f), curve);
}

// Cube root for t >= 0 without a libm call, so the per-pixel loops can vectorise: an
// exponent-thirding bit trick (a few percent off) refined by two Halley steps (cubic
// convergence: ~1e-4, then below float precision).
inline float cbrtFast(float t) {
  float y = std::bit_cast<float>(std::bit_cast<std::uint32_t>(t) / 3u + 709921077u);
  for (int i = 0; i < 2; ++i) {
    const float y3 = y * y * y;
    y = y * (y3 + 2.0f * t) / (2.0f * y3 + t);
  }
  return y;
}
inline double cbrtFast(double t) { return std::cbrt(t); }  // constants only: exact libm

// The CIE L*a*b* companding function.
template <class T>
inline T labF(T t) {
  constexpr T d = T(6) / T(29);
  const T cube = cbrtFast(t), lin = t / (T(3) * d * d) + T(4) / T(29);
  return select(t > d * d * d, cube, lin);
}

// L*, a*, b* of XYZ relative to the reference white, with the Hunt adjustment of [1] (colour pipeline)
// (chroma scaled by 0.01 L*: colours lose saturation as they get darker).
template <class T>
inline void xyzToHuntLab(T x, T y, T z, const T invWhite[3], T& l, T& a, T& b) {
  const T fx = labF(x * invWhite[0]);
  const T fy = labF(y * invWhite[1]);
  const T fz = labF(z * invWhite[2]);
  l = T(116) * fy - T(16);
  a = T(500) * (fx - fy) * (T(0.01) * l);
  b = T(200) * (fy - fz) * (T(0.01) * l);
}

// HyAB distance of two Hunt-adjusted colours (city-block in L*, Euclidean in a*b*), [1] colour pipeline.
template <class T>
inline T hyab(T l1, T a1, T b1, T l2, T a2, T b2) {
  return std::abs(l1 - l2) + sqrtFast((a1 - a2) * (a1 - a2) + (b1 - b2) * (b1 - b2));
}

// cmax = HyAB(green, blue)^qc: [1] takes the HyAB distance between the Hunt-adjusted
// primaries green and blue as the largest colour difference within the sRGB gamut.
double maxColourDistance() {
  const double invWhite[3] = {1.0 / kWhiteD[0], 1.0 / kWhiteD[1], 1.0 / kWhiteD[2]};
  double lg, ag, bg, lb, ab, bb;
  // Column 1 of the RGB->XYZ matrix is XYZ of green (0,1,0), column 2 that of blue (0,0,1).
  xyzToHuntLab(kRgbToXyzD[0][1], kRgbToXyzD[1][1], kRgbToXyzD[2][1], invWhite, lg, ag, bg);
  xyzToHuntLab(kRgbToXyzD[0][2], kRgbToXyzD[1][2], kRgbToXyzD[2][2], invWhite, lb, ab, bb);
  return std::pow(hyab(lg, ag, bg, lb, ab, bb), kQc);
}

// ---- Filters ---------------------------------------------------------------------------------

// Every FLIP kernel is even (Gaussians, second derivative) or odd (first derivative), so only
// the taps at offsets 0..radius are kept and mirrored pairs are added (or subtracted) before
// multiplying: half the multiplies. Named (not file-local) types: a FlipReference keeps them.
}  // namespace

namespace flip_detail {

struct Kernel {
  int radius = 0;
  bool odd = false;         // taps(-j) = -taps(j) (then taps(0) = 0); otherwise taps(-j) = taps(j)
  std::vector<float> half;  // radius + 1 taps: half[j] is the weight at offset +j
};

// Kernel from 2r+1 taps centred on index r; the mirrored half is implied by `odd`.
Kernel makeKernel(const std::vector<double>& taps, double scale, bool odd) {
  Kernel k;
  k.radius = int(taps.size() / 2);
  k.odd = odd;
  for (int j = 0; j <= k.radius; ++j) k.half.push_back(odd && j == 0 ? 0.0f : float(taps[size_t(k.radius + j)] * scale));
  return k;
}

struct Kernels {
  // Contrast sensitivity functions of [1] (colour pipeline, spatial filtering): each channel's spatial filter is
  // s(x) = a1 sqrt(pi/b1) exp(-pi^2 x^2 / b1) + a2 sqrt(pi/b2) exp(-pi^2 x^2 / b2), x in degrees,
  // with (a1, b1, a2, b2) = A (1, 0.0047, 0, -), RG (1, 0.0053, 0, -), BY (34.1, 0.04, 13.5,
  // 0.025). A and RG are single Gaussians; BY is the sum of two, kept as two separable parts.
  Kernel csfA, csfRG, csfBY1, csfBY2;
  // Feature detectors of [1] (feature pipeline): Gaussian (sigma = 0.5 gw ppd), its first and second
  // derivative, each 2D detector being a derivative along one axis times the Gaussian along
  // the other.
  Kernel blur, d1, d2;
  int maxRadius = 0;
};

}  // namespace flip_detail

namespace {

using flip_detail::Kernel;
using flip_detail::Kernels;
using flip_detail::makeKernel;

Kernels makeKernels(double ppd) {
  Kernels k;
  // CSF support: three standard deviations of the widest Gaussian (b = 0.04; a Gaussian
  // exp(-pi^2 x^2 / b) has sigma = sqrt(b / (2 pi^2)) degrees), shared by all three channels.
  const double bMax = 0.04;
  const int rc = int(std::ceil(3.0 * std::sqrt(bMax / (2.0 * kPi * kPi)) * ppd));
  const double dx = 1.0 / ppd;  // degrees per pixel
  auto gaussian = [&](double b) {
    std::vector<double> g(size_t(2 * rc + 1));
    for (int i = -rc; i <= rc; ++i) g[size_t(i + rc)] = std::exp(-kPi * kPi * (i * dx) * (i * dx) / b);
    return g;
  };
  auto sum = [](const std::vector<double>& g) {
    double s = 0;
    for (double v : g) s += v;
    return s;
  };
  // Single-Gaussian channels: the 2D kernel is g(x) g(y) normalised to unit sum, i.e. the 1D
  // kernel normalised to unit sum (the amplitude a1 sqrt(pi/b1) cancels).
  const auto gA = gaussian(0.0047), gRG = gaussian(0.0053);
  k.csfA = makeKernel(gA, 1.0 / sum(gA), false);
  k.csfRG = makeKernel(gRG, 1.0 / sum(gRG), false);
  // BY: K(x,y) = (w1 G1(x)G1(y) + w2 G2(x)G2(y)) / Z with w_i = a_i sqrt(pi/b_i) and Z the 2D
  // sum w1 S1^2 + w2 S2^2; each part is the outer product of G_i sqrt(w_i / Z) with itself.
  const auto g1 = gaussian(0.04), g2 = gaussian(0.025);
  const double w1 = 34.1 * std::sqrt(kPi / 0.04), w2 = 13.5 * std::sqrt(kPi / 0.025);
  const double z = w1 * sum(g1) * sum(g1) + w2 * sum(g2) * sum(g2);
  k.csfBY1 = makeKernel(g1, std::sqrt(w1 / z), false);
  k.csfBY2 = makeKernel(g2, std::sqrt(w2 / z), false);

  // Feature detectors: sigma = 0.5 gw ppd pixels (gw is the peak-to-trough distance, i.e. two
  // standard deviations, of the edge detector), radius ceil(3 sigma).
  const double sigma = 0.5 * kGw * ppd;
  const int rf = std::max(1, int(std::ceil(3.0 * sigma)));
  std::vector<double> g(size_t(2 * rf + 1)), e(g.size()), p(g.size());
  for (int i = -rf; i <= rf; ++i) {
    const double gi = std::exp(-double(i) * i / (2.0 * sigma * sigma));
    g[size_t(i + rf)] = gi;
    e[size_t(i + rf)] = -i * gi;                                    // first derivative (up to scale)
    p[size_t(i + rf)] = (double(i) * i / (sigma * sigma) - 1.0) * gi;  // second derivative
  }
  // [1] normalises each detector so that its positive weights sum to 1 and its negative
  // weights to -1 (a unit step / unit impulse gives a response of at most 1). For the 2D
  // detector D(x) G(y) the positive sum is (positive sum of D) * (sum of G), so normalising the
  // two 1D factors separately is exactly the 2D normalisation.
  auto normaliseSigned = [](std::vector<double>& v) {
    double pos = 0, neg = 0;
    for (double x : v) (x > 0 ? pos : neg) += x;
    for (double& x : v) {
      if (x > 0 && pos > 0) x /= pos;
      if (x < 0 && neg < 0) x /= -neg;
    }
  };
  normaliseSigned(e);
  normaliseSigned(p);
  const double gs = sum(g);
  for (double& x : g) x /= gs;
  k.blur = makeKernel(g, 1.0, false);
  k.d1 = makeKernel(e, 1.0, true);
  k.d2 = makeKernel(p, 1.0, false);
  k.maxRadius = std::max(rc, rf);
  return k;
}

// Convolutions work on blocks of kBlock pixels whose accumulators stay in vector registers
// across all taps. Rows are read up to the next multiple of kBlock; the buffers carry that much
// slack (the extra outputs are computed and dropped).
constexpr int kBlock = 32;
inline int roundUpToBlock(int n) { return (n + kBlock - 1) / kBlock * kBlock; }

// out[i] = sum over offsets j in [-r, r] of weight(j) * at(j)[i]: computed for i < kBlock,
// stored for i < n (so neighbouring rows, written by other threads, are never touched).
template <class At>
inline void convolveBlock(const Kernel& k, const At& at, int n, float* __restrict out) {
  const float* h = k.half.data();
  float a[kBlock];
  const float* c = at(0);
  for (int i = 0; i < kBlock; ++i) a[i] = h[0] * c[i];
  if (k.odd) {
    for (int j = 1; j <= k.radius; ++j) {
      const float* p = at(j);
      const float* m = at(-j);
      const float hj = h[j];
      for (int i = 0; i < kBlock; ++i) a[i] += hj * (p[i] - m[i]);
    }
  } else {
    for (int j = 1; j <= k.radius; ++j) {
      const float* p = at(j);
      const float* m = at(-j);
      const float hj = h[j];
      for (int i = 0; i < kBlock; ++i) a[i] += hj * (p[i] + m[i]);
    }
  }
  for (int i = 0; i < n; ++i) out[i] = a[i];
}

// out[x] = sum_j weight(j) * in[x + j]: `in` points at pixel 0 of a row that is padded (clamp to
// edge) by at least r before pixel 0 and after pixel roundUpToBlock(w) - 1.
inline void convolveRow(const float* in, int w, const Kernel& k, float* out) {
  for (int x0 = 0; x0 < w; x0 += kBlock)
    convolveBlock(k, [&](int j) { return in + x0 + j; }, std::min(kBlock, w - x0), out + x0);
}

// out[x] = sum_j weight(j) * plane[clamp(y + j)][x] (clamp-to-edge borders). Rows of `plane`
// are w apart and the plane has kBlock floats of slack after its last row.
inline void convolveColumn(const float* plane, int w, int h, int y, const Kernel& k, float* out) {
  for (int x0 = 0; x0 < w; x0 += kBlock)
    convolveBlock(k, [&](int j) { return plane + size_t(std::clamp(y + j, 0, h - 1)) * size_t(w) + size_t(x0); },
                  std::min(kBlock, w - x0), out + x0);
}

// ---- Per image pair --------------------------------------------------------------------------

// Planes of the horizontal pass, then of the stored reference.
enum HPlane { kHA, kHRG, kHBY1, kHBY2, kHBlur, kHD1, kHD2, kHCount };
enum RefPlane { kRL, kRA, kRB, kREdge, kRPoint, kRCount };

// The horizontal pass's planes: scratch for one image at a time.
struct Workspace {
  int w = 0, h = 0;
  std::array<std::vector<float>, kHCount> hp;

  Workspace(int width, int height) : w(width), h(height) {
    for (auto& p : hp) p.resize(size_t(w) * size_t(h) + kBlock);  // slack for block reads
  }
};

constexpr int kRowGrain = 8;

// Per-pixel loops live in functions with __restrict pointers: with many arrays in one loop,
// GCC otherwise needs more runtime alias checks than it allows and leaves the loop scalar.

// Display RGB -> linear RGB -> YCxCz plus normalised luminance, for one row.
template <class ToLinear>
void toOpponentRow(const float* __restrict pr, const float* __restrict pg, const float* __restrict pb,
                   const ToLinear& toLinear, int w, float* __restrict yy, float* __restrict cx,
                   float* __restrict cz, float* __restrict gray) {
  for (int x = 0; x < w; ++x) {
    const float r = toLinear(pr[x]), g = toLinear(pg[x]), b = toLinear(pb[x]);
    const float xr = (kM.toXyz[0][0] * r + kM.toXyz[0][1] * g + kM.toXyz[0][2] * b) * kM.invWhite[0];
    const float yr = (kM.toXyz[1][0] * r + kM.toXyz[1][1] * g + kM.toXyz[1][2] * b) * kM.invWhite[1];
    const float zr = (kM.toXyz[2][0] * r + kM.toXyz[2][1] * g + kM.toXyz[2][2] * b) * kM.invWhite[2];
    // YCxCz ([1] colour pipeline): the linear analogue of L*a*b*, in which filtering is meaningful.
    yy[x] = 116.0f * yr - 16.0f;
    cx[x] = 500.0f * (xr - yr);
    cz[x] = 200.0f * (yr - zr);
    // [1] feature pipeline: the detectors run on the achromatic channel normalised to [0,1],
    // (Y_ycxcz + 16) / 116, which is the relative luminance Y / Y_white.
    gray[x] = yr;
  }
}

// Pass 1. `toLinear` maps an input channel value to linear RGB in [0,1] (sRGB decoding for
// LDR-FLIP, exposure + tone mapping for HDR-FLIP).
template <class ToLinear>
void horizontalPass(const Image& img, const ToLinear& toLinear, const Kernels& k, Workspace& ws) {
  const int w = ws.w, pad = k.maxRadius, padded = roundUpToBlock(w), stride = padded + 2 * pad;
  tbb::parallel_for(tbb::blocked_range<int>(0, ws.h, kRowGrain), [&](const tbb::blocked_range<int>& rows) {
    std::vector<float> buf(size_t(4) * size_t(stride));
    float* yy = buf.data() + pad;  // YCxCz achromatic channel
    float* cx = yy + stride;
    float* cz = cx + stride;
    float* gray = cz + stride;  // luminance normalised to [0,1], input of the feature detectors
    for (int y = rows.begin(); y != rows.end(); ++y) {
      const size_t o = size_t(y) * size_t(w);
      const float* pr = img.plane(0) + o;
      const float* pg = img.plane(1) + o;
      const float* pb = img.plane(2) + o;
      toOpponentRow(pr, pg, pb, toLinear, w, yy, cx, cz, gray);
      for (float* row : {yy, cx, cz, gray}) {
        std::fill(row - pad, row, row[0]);
        std::fill(row + w, row + padded + pad, row[w - 1]);
      }
      convolveRow(yy, w, k.csfA, ws.hp[kHA].data() + o);
      convolveRow(cx, w, k.csfRG, ws.hp[kHRG].data() + o);
      convolveRow(cz, w, k.csfBY1, ws.hp[kHBY1].data() + o);
      convolveRow(cz, w, k.csfBY2, ws.hp[kHBY2].data() + o);
      convolveRow(gray, w, k.blur, ws.hp[kHBlur].data() + o);
      convolveRow(gray, w, k.d1, ws.hp[kHD1].data() + o);
      convolveRow(gray, w, k.d2, ws.hp[kHD2].data() + o);
    }
  });
}

// Filtered YCxCz and detector responses of one row -> Hunt-adjusted L*a*b* and feature magnitudes.
void toHuntLabRow(const float* __restrict c0, const float* __restrict c1, const float* __restrict c2,
                  const float* __restrict c3, const float* __restrict ex, const float* __restrict ey,
                  const float* __restrict px, const float* __restrict py, int w, float* __restrict outL,
                  float* __restrict outA, float* __restrict outB, float* __restrict outE,
                  float* __restrict outP) {
  for (int x = 0; x < w; ++x) {
    // Filtered YCxCz -> XYZ -> linear RGB, clamped into the sRGB gamut ([1] colour pipeline: the
    // filtered colours may leave the gamut; L*a*b* is only meaningful inside it).
    const float yr = (c0[x] + 16.0f) * (1.0f / 116.0f);
    const float xX = (yr + c1[x] * (1.0f / 500.0f)) * kM.white[0];
    const float yY = yr * kM.white[1];
    const float zZ = (yr - (c2[x] + c3[x]) * (1.0f / 200.0f)) * kM.white[2];
    const float r = clamp01(kM.toRgb[0][0] * xX + kM.toRgb[0][1] * yY + kM.toRgb[0][2] * zZ);
    const float g = clamp01(kM.toRgb[1][0] * xX + kM.toRgb[1][1] * yY + kM.toRgb[1][2] * zZ);
    const float b = clamp01(kM.toRgb[2][0] * xX + kM.toRgb[2][1] * yY + kM.toRgb[2][2] * zZ);
    xyzToHuntLab(kM.toXyz[0][0] * r + kM.toXyz[0][1] * g + kM.toXyz[0][2] * b,
                 kM.toXyz[1][0] * r + kM.toXyz[1][1] * g + kM.toXyz[1][2] * b,
                 kM.toXyz[2][0] * r + kM.toXyz[2][1] * g + kM.toXyz[2][2] * b, kM.invWhite,
                 outL[x], outA[x], outB[x]);
    outE[x] = sqrtFast(ex[x] * ex[x] + ey[x] * ey[x]);
    outP[x] = sqrtFast(px[x] * px[x] + py[x] * py[x]);
  }
}

// Pass 2: vertical convolutions and the per-pixel colour/feature values of one row, handed to
// `sink(y, L, a, b, edge, point)`.
template <class Sink>
void verticalPass(const Kernels& k, const Workspace& ws, const Sink& sink) {
  const int w = ws.w, h = ws.h;
  tbb::parallel_for(tbb::blocked_range<int>(0, h, kRowGrain), [&](const tbb::blocked_range<int>& rows) {
    std::vector<float> buf(size_t(13) * size_t(w));
    float* c0 = buf.data();
    float* c1 = c0 + w;
    float* c2 = c1 + w;
    float* c3 = c2 + w;
    float* ex = c3 + w;
    float* ey = ex + w;
    float* px = ey + w;
    float* py = px + w;
    float* outL = py + w;
    float* outA = outL + w;
    float* outB = outA + w;
    float* outE = outB + w;
    float* outP = outE + w;
    for (int y = rows.begin(); y != rows.end(); ++y) {
      convolveColumn(ws.hp[kHA].data(), w, h, y, k.csfA, c0);
      convolveColumn(ws.hp[kHRG].data(), w, h, y, k.csfRG, c1);
      convolveColumn(ws.hp[kHBY1].data(), w, h, y, k.csfBY1, c2);
      convolveColumn(ws.hp[kHBY2].data(), w, h, y, k.csfBY2, c3);
      // Edge detector: derivative along x times Gaussian along y, and the transpose; likewise
      // for the point (second derivative) detector.
      convolveColumn(ws.hp[kHD1].data(), w, h, y, k.blur, ex);
      convolveColumn(ws.hp[kHBlur].data(), w, h, y, k.d1, ey);
      convolveColumn(ws.hp[kHD2].data(), w, h, y, k.blur, px);
      convolveColumn(ws.hp[kHBlur].data(), w, h, y, k.d2, py);
      toHuntLabRow(c0, c1, c2, c3, ex, ey, px, py, w, outL, outA, outB, outE, outP);
      sink(y, outL, outA, outB, outE, outP);
    }
  });
}

// Final per-pixel FLIP value from the reference's and the test's colour/feature values.
inline float combinePixel(float cmax, float pcCmax, float lr, float ar, float br, float er, float pr,
                          float lt, float at, float bt, float et, float pt) {
  // Colour error ([1] colour pipeline): HyAB^qc, compressed piecewise linearly so that the lower pc * cmax
  // of the range (where most perceptible differences lie) gets pt of the output range.
  const float dist = powFast(hyab(lr, ar, br, lt, at, bt), float(kQc));
  const float colour = select(dist < pcCmax, dist * (float(kPt) / pcCmax),
                              float(kPt) + (dist - pcCmax) * (float(1.0 - kPt) / (cmax - pcCmax)));
  // cmax is the largest in-gamut distance per [1]; the clamp only guards float round-off.
  const float ec = minF(colour, 1.0f);
  // Feature error ([1] feature pipeline): largest of the edge and point magnitude differences, scaled by
  // 1/sqrt(2) (the largest possible magnitude difference) and raised to qf = 0.5.
  const float df = maxF(std::abs(er - et), std::abs(pr - pt)) * float(1.0 / std::numbers::sqrt2);
  const float ef = minF(sqrtFast(df), 1.0f);
  // [1] final error: features amplify the colour error, dE = dEc^(1 - dEf).
  return minF(powFast(ec, 1.0f - ef), 1.0f);
}

// FLIP values of one row into `out` (or their maximum with its contents, for HDR-FLIP).
void combineRow(float cmax, float pcCmax, const float* __restrict rl, const float* __restrict ra,
                const float* __restrict rb, const float* __restrict re, const float* __restrict rp,
                const float* __restrict l, const float* __restrict a, const float* __restrict b,
                const float* __restrict e, const float* __restrict p, int w, bool takeMax,
                float* __restrict out) {
  for (int x = 0; x < w; ++x) {
    const float v = combinePixel(cmax, pcCmax, rl[x], ra[x], rb[x], re[x], rp[x], l[x], a[x], b[x], e[x], p[x]);
    out[x] = select(takeMax, maxF(out[x], v), v);
  }
}

// The reference's side of one LDR-FLIP: its filtered Hunt L*a*b* and feature magnitudes.
using ReferencePlanes = std::array<std::vector<float>, kRCount>;

template <class ToLinear>
ReferencePlanes filterReference(const Image& reference, const ToLinear& toLinear, const Kernels& k,
                                Workspace& ws) {
  const size_t w = size_t(ws.w);
  ReferencePlanes ref;
  for (auto& plane : ref) plane.resize(w * size_t(ws.h));
  horizontalPass(reference, toLinear, k, ws);
  verticalPass(k, ws, [&](int y, const float* l, const float* a, const float* b, const float* e,
                          const float* p) {
    const size_t o = size_t(y) * w;
    std::copy(l, l + w, ref[kRL].data() + o);
    std::copy(a, a + w, ref[kRA].data() + o);
    std::copy(b, b + w, ref[kRB].data() + o);
    std::copy(e, e + w, ref[kREdge].data() + o);
    std::copy(p, p + w, ref[kRPoint].data() + o);
  });
  return ref;
}

// LDR-FLIP of `test` against a filtered reference into `map`; with takeMax the map keeps the
// per-pixel maximum of its previous contents and this comparison's values (HDR-FLIP).
template <class ToLinear>
void compareWithReference(const ReferencePlanes& ref, const Image& test, const ToLinear& toLinear,
                          const Kernels& k, Workspace& ws, float* map, bool takeMax) {
  const size_t w = size_t(ws.w);
  static const double c = maxColourDistance();
  const float cmax = float(c), pcCmax = float(kPc * c);
  horizontalPass(test, toLinear, k, ws);
  verticalPass(k, ws, [&](int y, const float* l, const float* a, const float* b, const float* e,
                          const float* p) {
    const size_t o = size_t(y) * w;
    combineRow(cmax, pcCmax, ref[kRL].data() + o, ref[kRA].data() + o, ref[kRB].data() + o,
               ref[kREdge].data() + o, ref[kRPoint].data() + o, l, a, b, e, p, int(w), takeMax,
               map + o);
  });
}

double meanOf(const Image& map) {
  // Per-row partial sums in double, added in row order: deterministic whatever the threading.
  const int w = map.width(), h = map.height();
  std::vector<double> rowSums(size_t(h), 0.0);
  tbb::parallel_for(tbb::blocked_range<int>(0, h, kRowGrain), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y != rows.end(); ++y) {
      const float* row = map.plane(0) + size_t(y) * size_t(w);
      double s = 0;
      for (int x = 0; x < w; ++x) s += row[x];
      rowSums[size_t(y)] = s;
    }
  });
  double total = 0;
  for (double s : rowSums) total += s;
  return total / double(map.pixelCount());
}

void validate(const std::string& name, const FlipImageShape& reference, const Image& test,
              double ppd) {
  if (reference.empty() || test.empty())
    throw Error(name + ": empty image (reference " + std::to_string(reference.width) + "x" +
                std::to_string(reference.height) + ", test " + std::to_string(test.width()) + "x" +
                std::to_string(test.height()) + ")");
  if (reference.width != test.width() || reference.height != test.height())
    throw Error(name + ": image sizes differ (reference " + std::to_string(reference.width) + "x" +
                std::to_string(reference.height) + ", test " + std::to_string(test.width()) + "x" +
                std::to_string(test.height()) + ")");
  if (reference.channels != 3 || test.channels() != 3)
    throw Error(name + ": expected 3-channel RGB images, got " +
                std::to_string(reference.channels) + " (reference) and " +
                std::to_string(test.channels()) + " (test) channels");
  if (!(std::isfinite(ppd) && ppd > 0))
    throw Error(name + ": pixels per degree must be a positive finite number, got " + std::to_string(ppd));
}

void validate(const std::string& name, const Image& reference, const Image& test, double ppd) {
  validate(name, FlipImageShape::of(reference), test, ppd);
}

// ---- HDR-FLIP ([2]) --------------------------------------------------------------------------

// ACES filmic curve as fitted by Narkowicz (2016), x (a x + b) / (x (c x + d) + e) with
// a = 2.51, b = 0.03, c = 2.43, d = 0.59, e = 0.14, applied to 0.6 x: the 0.6 pre-exposure of
// Narkowicz's fit is folded into the coefficients, which is the ACES curve used by HDR-FLIP's
// open implementation. Written as (k0 x^2 + k1 x) / (k3 x^2 + k4 x + k5).
constexpr double kAcesK0 = 0.6 * 0.6 * 2.51, kAcesK1 = 0.6 * 0.03;
constexpr double kAcesK3 = 0.6 * 0.6 * 2.43, kAcesK4 = 0.6 * 0.59, kAcesK5 = 0.14;

struct ExposureRange {
  double start = 0, stop = 0;
  int count = 1;
};

ExposureRange exposureRange(const Image& reference) {
  // [2]: x_max is the tone mapper input that maps to 0.85; solve
  // (k0 - 0.85 k3) x^2 + (k1 - 0.85 k4) x - 0.85 k5 = 0 for its positive root.
  const double t = 0.85;
  const double qa = kAcesK0 - t * kAcesK3, qb = kAcesK1 - t * kAcesK4, qc = -t * kAcesK5;
  const double xMax = (-qb + std::sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa);

  // Luminance of the reference; non-finite pixels are ignored so one NaN cannot void the range.
  std::vector<float> lum;
  lum.reserve(reference.pixelCount());
  const float* r = reference.plane(0);
  const float* g = reference.plane(1);
  const float* b = reference.plane(2);
  float yMax = 0;
  for (size_t i = 0; i < reference.pixelCount(); ++i) {
    const float y = kM.toXyz[1][0] * r[i] + kM.toXyz[1][1] * g[i] + kM.toXyz[1][2] * b[i];
    if (!std::isfinite(y)) continue;
    lum.push_back(y);
    yMax = std::max(yMax, y);
  }
  ExposureRange range;
  if (!(yMax > 0)) return range;  // black reference: a single exposure 0 (start = stop)
  // Median (mean of the two middle values for an even count, like a 50th percentile).
  const size_t n = lum.size(), mid = n / 2;
  std::nth_element(lum.begin(), lum.begin() + ptrdiff_t(mid), lum.end());
  double yMedian = lum[mid];
  if (n % 2 == 0) yMedian = 0.5 * (yMedian + *std::max_element(lum.begin(), lum.begin() + ptrdiff_t(mid)));
  if (!(yMedian > 0)) {
    // log2 of 0 is undefined: fall back to the smallest positive luminance.
    float smallest = yMax;
    for (float y : lum)
      if (y > 0) smallest = std::min(smallest, y);
    yMedian = smallest;
  }
  // [2]: start exposure makes the brightest pixel map to x_max, stop exposure the median one;
  // N = max(2, ceil(stop - start)) exposures evenly spaced in [start, stop] (about one per stop).
  range.start = std::log2(xMax / yMax);
  range.stop = std::log2(xMax / yMedian);
  range.count = std::max(2, int(std::ceil(range.stop - range.start)));
  // Evenly spaced exposures over an empty interval are all the same exposure: evaluate it once
  // (the per-pixel maximum of identical maps is that map).
  if (range.stop <= range.start) range.count = 1;
  return range;
}

// Display-referred input: clamp to the displayable range, then decode the sRGB transfer.
struct SrgbDisplay {
  float operator()(float v) const { return srgbToLinear(clamp01(v)); }
};

// Exposure, then the ACES curve, clamped to [0,1]. [2] then sRGB-encodes the tone-mapped image and
// hands it to LDR-FLIP, which decodes it again; that round trip is the identity, so the tone-mapped
// linear values go straight into the pipeline. Negative and NaN inputs become 0; the input is
// capped where the curve has long saturated (it tends to k0/k3 > 1) so that +inf maps to white
// instead of inf/inf.
struct AcesExposure {
  float scale = 1;
  float operator()(float v) const {
    float x = v * scale;
    x = select(x > 0.0f, minF(x, 1.0e6f), 0.0f);
    const float num = (float(kAcesK0) * x + float(kAcesK1)) * x;
    const float den = (float(kAcesK3) * x + float(kAcesK4)) * x + float(kAcesK5);
    return clamp01(num / den);
  }
};

}  // namespace

FlipImageShape FlipImageShape::of(const Image& image) {
  return {image.width(), image.height(), image.channels()};
}

struct FlipReference::Filtered {
  struct Exposure {
    float scale = 1;  // 2^exposure
    ReferencePlanes planes;
  };
  Kernels kernels;
  ReferencePlanes ldr;        // of the display image (empty without one)
  std::vector<Exposure> hdr;  // of the linear image, per exposure (empty without one)
};

namespace {

// A FLIP map of `test`'s size filled by compareInto(workspace, map), and its mean.
template <class CompareInto>
FlipResult flipMap(const Image& test, const CompareInto& compareInto) {
  Workspace ws(test.width(), test.height());
  FlipResult result;
  result.map = Image(test.width(), test.height(), 1);
  compareInto(ws, result.map.plane(0));
  result.mean = meanOf(result.map);
  return result;
}

}  // namespace

FlipReference::FlipReference(const Image* display, const Image* linear, double pixelsPerDegree)
    : pixelsPerDegree_(pixelsPerDegree) {
  if (display) display_ = FlipImageShape::of(*display);
  if (linear) linear_ = FlipImageShape::of(*linear);
  // Each image is checked against itself here (empty, channels, ppd); a test against it when
  // compared.
  if (display) validate("ldrFlip", *display, *display, pixelsPerDegree);
  if (linear) validate("hdrFlip", *linear, *linear, pixelsPerDegree);
  auto filtered = std::make_shared<Filtered>();
  Filtered& f = *filtered;
  f.kernels = makeKernels(pixelsPerDegree);
  if (display) {
    Workspace ws(display->width(), display->height());
    f.ldr = filterReference(*display, SrgbDisplay{}, f.kernels, ws);
  }
  if (linear) {
    Workspace ws(linear->width(), linear->height());
    const ExposureRange range = exposureRange(*linear);
    for (int i = 0; i < range.count; ++i) {
      const double exposure =
          range.count == 1
              ? range.start
              : range.start + (range.stop - range.start) * double(i) / double(range.count - 1);
      const float scale = float(std::exp2(exposure));
      f.hdr.push_back({scale, filterReference(*linear, AcesExposure{scale}, f.kernels, ws)});
    }
  }
  filtered_ = std::move(filtered);
}

size_t FlipReference::bytes() const {
  size_t floats = 0;
  for (const auto& plane : filtered_->ldr) floats += plane.size();
  for (const Filtered::Exposure& exposure : filtered_->hdr)
    for (const auto& plane : exposure.planes) floats += plane.size();
  return floats * sizeof(float);
}

FlipResult FlipReference::ldr(const Image& test) const {
  if (!display_) throw Error("ldrFlip: this FLIP reference was prepared without a display image");
  validate("ldrFlip", *display_, test, pixelsPerDegree_);
  const Filtered& f = *filtered_;
  return flipMap(test, [&](Workspace& ws, float* map) {
    compareWithReference(f.ldr, test, SrgbDisplay{}, f.kernels, ws, map, false);
  });
}

FlipResult FlipReference::hdr(const Image& test) const {
  if (!linear_) throw Error("hdrFlip: this FLIP reference was prepared without a linear image");
  validate("hdrFlip", *linear_, test, pixelsPerDegree_);
  const Filtered& f = *filtered_;
  return flipMap(test, [&](Workspace& ws, float* map) {
    for (size_t i = 0; i < f.hdr.size(); ++i)  // the per-pixel maximum over the exposures
      compareWithReference(f.hdr[i].planes, test, AcesExposure{f.hdr[i].scale}, f.kernels, ws, map,
                           i > 0);
  });
}

// Both images checked first: a mismatched test is refused before the reference is filtered.
FlipResult ldrFlip(const Image& reference, const Image& test, double pixelsPerDegree) {
  validate("ldrFlip", reference, test, pixelsPerDegree);
  return FlipReference(&reference, nullptr, pixelsPerDegree).ldr(test);
}

FlipResult hdrFlip(const Image& reference, const Image& test, double pixelsPerDegree) {
  validate("hdrFlip", reference, test, pixelsPerDegree);
  return FlipReference(nullptr, &reference, pixelsPerDegree).hdr(test);
}

}  // namespace arena

namespace arena {

// Registered in metric_registry.cpp: LDR-FLIP of the display image and HDR-FLIP of the linear one,
// as --flip asks (ldr: LDR only; all: both; none: neither). The LDR map is kept for the report.
MetricFamily flipFamily() {
  MetricFamily f;
  f.metrics = {
      {.name = "ldrFlip",
       .reads = MetricInput::Display,
       .floor = FloorRule::ReferenceNoise,
       .floorWarningFactor = 2,
       .ranked = true,
       .gatedByDefault = true,
       .overall = true,
       .reportColumn = true,
       .chart = ReportChart::Error,
       .title = "LDR-FLIP",
       .description = "mean LDR-FLIP of the display image, 67 ppd"},
      {.name = "hdrFlip",
       .computedUnder = [](const MetricOptions& o) { return o.flip == "all"; },
       .floor = FloorRule::ReferenceNoise,
       .floorWarningFactor = 2,
       .ranked = true,
       .gatedByDefault = true,
       .overall = true,
       .reportColumn = true,
       .chart = ReportChart::Error,
       .title = "HDR-FLIP",
       .description = "mean HDR-FLIP of the linear image, 67 ppd"},
  };
  f.enabled = [](const MetricOptions& o) { return o.flip != "none"; };
  f.measure = [](const FrameView& v, const MetricOptions& o, FrameRecorder& out) {
    const int w = v.output->width(), h = v.output->height();
    const bool hdr = o.flip == "all";
    // The reference's side, filtered once per reference for every output compared with it.
    auto prepare = [&] { return FlipReference(v.referenceDisplay, hdr ? v.reference : nullptr); };
    const std::shared_ptr<const FlipReference> prepared =
        v.referenceMemo ? v.referenceMemo->get<FlipReference>("flip:" + o.flip, prepare)
                        : std::make_shared<const FlipReference>(prepare());
    const FlipReference& reference = *prepared;
    FlipResult ldrResult = reference.ldr(*v.outputDisplay);
    out.put("ldrFlip", ldrResult.mean, tileSumsOfMap(ldrResult.map.raw(), w, h));
    out.keepMap("ldrFlip", std::move(ldrResult.map));
    if (hdr) {
      const FlipResult hdrResult = reference.hdr(*v.output);
      out.put("hdrFlip", hdrResult.mean, tileSumsOfMap(hdrResult.map.raw(), w, h));
    }
  };
  return f;
}

}  // namespace arena
