// FLIP (metrics/flip.hpp): zero for identical images, bounded output, monotone in noise, edges
// weighted above flat regions, HDR exposure handling, input validation.
#include "metrics/flip.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "core/error.hpp"

namespace arena {
namespace {

constexpr int kSize = 64;

// Smooth colourful LDR image in [0.15, 0.85]: no clamping when small changes are added.
Image smoothLdr(int w = kSize, int h = kSize) {
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      img.at(x, y, 0) = 0.15f + 0.7f * float(x) / float(w - 1);
      img.at(x, y, 1) = 0.15f + 0.7f * float(y) / float(h - 1);
      img.at(x, y, 2) = 0.5f + 0.35f * std::sin(0.2f * float(x + y));
    }
  return img;
}

Image randomImage(unsigned seed, float lo, float hi, int w = kSize, int h = kSize) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  Image img(w, h, 3);
  for (float& v : img.raw()) v = u(rng);
  return img;
}

// Linear HDR radiance spanning several stops: a smooth ramp times a bright spot.
Image smoothHdr(int w = kSize, int h = kSize) {
  Image img(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float base = 0.05f * std::exp2(6.0f * float(x) / float(w - 1));  // 0.05 .. 3.2
      const float dx = float(x - w / 2), dy = float(y - h / 2);
      const float spot = 20.0f * std::exp(-(dx * dx + dy * dy) / 18.0f);
      img.at(x, y, 0) = base + spot;
      img.at(x, y, 1) = 0.7f * base + spot;
      img.at(x, y, 2) = 0.4f * base + 0.5f * spot;
    }
  return img;
}

void expectAllInUnitRange(const FlipResult& r) {
  EXPECT_GE(r.mean, 0.0);
  EXPECT_LE(r.mean, 1.0);
  ASSERT_EQ(r.map.channels(), 1);
  for (float v : r.map.raw()) {
    ASSERT_TRUE(v >= 0.0f && v <= 1.0f) << v;
  }
}

void expectAllZero(const FlipResult& r) {
  EXPECT_EQ(r.mean, 0.0);
  for (float v : r.map.raw()) ASSERT_EQ(v, 0.0f);
}

// A direct, slow evaluation of the LDR-FLIP definition for cross-checking the fast one: full
// (non-separable) 2D kernels built from the papers' formulas, double precision, one stage at a
// time, clamp-to-edge borders.
std::vector<double> directLdrFlip(const Image& ref, const Image& test, double ppd) {
  const int w = ref.width(), h = ref.height();
  const double pi = 3.14159265358979323846;
  const double m[3][3] = {{0.4124564, 0.3575761, 0.1804375},
                          {0.2126729, 0.7151522, 0.0721750},
                          {0.0193339, 0.1191920, 0.9503041}};
  double inv[3][3];
  {
    const double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                       m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                       m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
        inv[i][j] = (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) / det;
      }
  }
  const double white[3] = {m[0][0] + m[0][1] + m[0][2], m[1][0] + m[1][1] + m[1][2], m[2][0] + m[2][1] + m[2][2]};
  auto idx = [&](int x, int y) { return size_t(std::clamp(y, 0, h - 1)) * size_t(w) + size_t(std::clamp(x, 0, w - 1)); };
  auto conv = [&](const std::vector<double>& img, const std::vector<double>& k, int r) {
    std::vector<double> out(img.size(), 0.0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        double s = 0;
        for (int j = -r; j <= r; ++j)
          for (int i = -r; i <= r; ++i) s += k[size_t((j + r) * (2 * r + 1) + (i + r))] * img[idx(x + i, y + j)];
        out[size_t(y) * size_t(w) + size_t(x)] = s;
      }
    return out;
  };
  // Contrast sensitivity kernels (A, RG, BY).
  const double csf[3][4] = {{1, 0.0047, 0, 1e-5}, {1, 0.0053, 0, 1e-5}, {34.1, 0.04, 13.5, 0.025}};
  const int rc = int(std::ceil(3 * std::sqrt(0.04 / (2 * pi * pi)) * ppd));
  std::vector<double> csfK[3];
  for (int c = 0; c < 3; ++c) {
    double sum = 0;
    for (int j = -rc; j <= rc; ++j)
      for (int i = -rc; i <= rc; ++i) {
        const double d2 = (i * i + j * j) / (ppd * ppd);
        const double v = csf[c][0] * std::sqrt(pi / csf[c][1]) * std::exp(-pi * pi * d2 / csf[c][1]) +
                         csf[c][2] * std::sqrt(pi / csf[c][3]) * std::exp(-pi * pi * d2 / csf[c][3]);
        csfK[c].push_back(v);
        sum += v;
      }
    for (double& v : csfK[c]) v /= sum;
  }
  // Feature kernels: d/dx and d2/dx2 of a Gaussian, positive and negative weights each
  // normalised to +-1, and their transposes.
  const double sigma = 0.5 * 0.082 * ppd;
  const int rf = int(std::ceil(3 * sigma));
  std::vector<double> ex, ey, px, py;
  for (int j = -rf; j <= rf; ++j)
    for (int i = -rf; i <= rf; ++i) {
      const double g = std::exp(-(i * i + j * j) / (2 * sigma * sigma));
      ex.push_back(-i * g);
      ey.push_back(-j * g);
      px.push_back((i * i / (sigma * sigma) - 1) * g);
      py.push_back((j * j / (sigma * sigma) - 1) * g);
    }
  for (auto* k : {&ex, &ey, &px, &py}) {
    double pos = 0, neg = 0;
    for (double v : *k) (v > 0 ? pos : neg) += v;
    for (double& v : *k) v = v > 0 ? v / pos : v / -neg;
  }
  auto labF = [](double t) {
    const double d = 6.0 / 29.0;
    return t > d * d * d ? std::cbrt(t) : t / (3 * d * d) + 4.0 / 29.0;
  };
  struct Out {
    std::vector<double> l, a, b, edge, point;
  };
  auto process = [&](const Image& img) {
    std::vector<double> ycc[3], gray(img.pixelCount());
    for (auto& p : ycc) p.resize(img.pixelCount());
    for (size_t i = 0; i < img.pixelCount(); ++i) {
      double rgb[3];
      for (int c = 0; c < 3; ++c) {
        const double v = std::clamp(double(img.plane(c)[i]), 0.0, 1.0);
        rgb[c] = v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
      }
      double xyz[3];
      for (int r = 0; r < 3; ++r) xyz[r] = (m[r][0] * rgb[0] + m[r][1] * rgb[1] + m[r][2] * rgb[2]) / white[r];
      ycc[0][i] = 116 * xyz[1] - 16;
      ycc[1][i] = 500 * (xyz[0] - xyz[1]);
      ycc[2][i] = 200 * (xyz[1] - xyz[2]);
      gray[i] = (ycc[0][i] + 16) / 116;
    }
    Out o;
    std::vector<double> f[3];
    for (int c = 0; c < 3; ++c) f[c] = conv(ycc[c], csfK[c], rc);
    for (size_t i = 0; i < img.pixelCount(); ++i) {
      const double yr = (f[0][i] + 16) / 116;
      const double xyz[3] = {(yr + f[1][i] / 500) * white[0], yr * white[1], (yr - f[2][i] / 200) * white[2]};
      double rgb[3];
      for (int r = 0; r < 3; ++r)
        rgb[r] = std::clamp(inv[r][0] * xyz[0] + inv[r][1] * xyz[1] + inv[r][2] * xyz[2], 0.0, 1.0);
      double fx[3];
      for (int r = 0; r < 3; ++r) fx[r] = labF((m[r][0] * rgb[0] + m[r][1] * rgb[1] + m[r][2] * rgb[2]) / white[r]);
      const double l = 116 * fx[1] - 16;
      o.l.push_back(l);
      o.a.push_back(500 * (fx[0] - fx[1]) * 0.01 * l);
      o.b.push_back(200 * (fx[1] - fx[2]) * 0.01 * l);
    }
    const auto gx = conv(gray, ex, rf), gy = conv(gray, ey, rf), gxx = conv(gray, px, rf), gyy = conv(gray, py, rf);
    for (size_t i = 0; i < img.pixelCount(); ++i) {
      o.edge.push_back(std::hypot(gx[i], gy[i]));
      o.point.push_back(std::hypot(gxx[i], gyy[i]));
    }
    return o;
  };
  const Out r = process(ref), t = process(test);
  // cmax from Hunt-adjusted green and blue.
  auto huntLab = [&](int primary, double& l, double& a, double& b) {
    double fx[3];
    for (int r2 = 0; r2 < 3; ++r2) fx[r2] = labF(m[r2][primary] / white[r2]);
    l = 116 * fx[1] - 16;
    a = 500 * (fx[0] - fx[1]) * 0.01 * l;
    b = 200 * (fx[1] - fx[2]) * 0.01 * l;
  };
  double lg, ag, bg, lb, ab, bb;
  huntLab(1, lg, ag, bg);
  huntLab(2, lb, ab, bb);
  const double cmax = std::pow(std::abs(lg - lb) + std::hypot(ag - ab, bg - bb), 0.7);
  std::vector<double> out;
  for (size_t i = 0; i < ref.pixelCount(); ++i) {
    const double e = std::pow(std::abs(r.l[i] - t.l[i]) + std::hypot(r.a[i] - t.a[i], r.b[i] - t.b[i]), 0.7);
    const double ec = e < 0.4 * cmax ? 0.95 / (0.4 * cmax) * e : 0.95 + (e - 0.4 * cmax) / (cmax - 0.4 * cmax) * 0.05;
    const double ef = std::pow(std::max(std::abs(r.edge[i] - t.edge[i]), std::abs(r.point[i] - t.point[i])) / std::sqrt(2.0), 0.5);
    out.push_back(std::pow(ec, 1 - ef));
  }
  return out;
}

TEST(Flip, IdenticalLdrImagesScoreExactlyZero) {
  const Image a = randomImage(1, 0.0f, 1.0f);
  const FlipResult r = ldrFlip(a, a);
  EXPECT_EQ(r.map.width(), kSize);
  EXPECT_EQ(r.map.height(), kSize);
  expectAllZero(r);
  expectAllZero(ldrFlip(smoothLdr(), smoothLdr()));
}

TEST(Flip, IdenticalHdrImagesScoreExactlyZero) {
  expectAllZero(hdrFlip(smoothHdr(), smoothHdr()));
  const Image a = randomImage(2, 0.0f, 50.0f);
  expectAllZero(hdrFlip(a, a));
}

TEST(Flip, MatchesDirectEvaluationOfTheDefinition) {
  // Small image and a low pixels-per-degree so the 2D reference stays fast; both kernel radii
  // still exceed the image border, which exercises clamp-to-edge handling.
  const Image ref = smoothLdr(23, 17);
  Image test = ref;
  std::mt19937 rng(99);
  std::uniform_real_distribution<float> u(-0.15f, 0.15f);
  for (float& v : test.raw()) v += u(rng);
  for (int y = 0; y < 17; ++y) test.at(11, y, 1) = 1.0f;  // a saturated line: out-of-gamut filtering
  for (double ppd : {20.0, 45.0}) {
    const FlipResult fast = ldrFlip(ref, test, ppd);
    const std::vector<double> direct = directLdrFlip(ref, test, ppd);
    double mean = 0;
    for (size_t i = 0; i < direct.size(); ++i) {
      ASSERT_NEAR(fast.map.raw()[i], direct[i], 2e-4) << "pixel " << i << " ppd " << ppd;
      mean += direct[i];
    }
    EXPECT_NEAR(fast.mean, mean / double(direct.size()), 1e-5);
    EXPECT_GT(fast.mean, 0.05);  // a real difference, not two all-zero maps
  }
}

TEST(Flip, ValuesStayInUnitRange) {
  expectAllInUnitRange(ldrFlip(randomImage(3, 0.0f, 1.0f), randomImage(4, 0.0f, 1.0f)));
  // The largest colour difference of the definition (green vs blue) and black vs white.
  Image green(kSize, kSize, 3), blue(kSize, kSize, 3), black(kSize, kSize, 3), white(kSize, kSize, 3, 1.0f);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      green.at(x, y, 1) = 1.0f;
      blue.at(x, y, 2) = 1.0f;
    }
  const FlipResult gb = ldrFlip(green, blue);
  expectAllInUnitRange(gb);
  EXPECT_GT(gb.mean, 0.99);  // the normalisation maps green vs blue to (about) 1
  const FlipResult bw = ldrFlip(black, white);
  expectAllInUnitRange(bw);
  EXPECT_GT(bw.mean, 0.9);
  // Out-of-range and non-finite inputs are clamped rather than propagated.
  Image wild = randomImage(5, -2.0f, 3.0f);
  wild.at(3, 3, 0) = std::numeric_limits<float>::quiet_NaN();
  wild.at(4, 4, 1) = std::numeric_limits<float>::infinity();
  expectAllInUnitRange(ldrFlip(randomImage(6, 0.0f, 1.0f), wild));
  expectAllInUnitRange(hdrFlip(smoothHdr(), wild));
  expectAllInUnitRange(hdrFlip(randomImage(7, 0.0f, 100.0f), randomImage(8, 0.0f, 100.0f)));
}

TEST(Flip, MeanIncreasesWithNoise) {
  const Image ref = smoothLdr();
  std::mt19937 rng(1234);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<float> noise(ref.raw().size());
  for (float& n : noise) n = u(rng);
  double previous = 0.0;
  for (float amplitude : {0.02f, 0.05f, 0.1f}) {
    Image test = ref;
    for (size_t i = 0; i < noise.size(); ++i) test.raw()[i] += amplitude * noise[i];
    const double m = ldrFlip(ref, test).mean;
    EXPECT_GT(m, previous) << "amplitude " << amplitude;
    previous = m;
  }
}

TEST(Flip, ShiftedEdgeScoresAboveFlatChangeOfEqualMse) {
  // Reference: a grey vertical step edge (dark left, bright right). Test A moves the edge one
  // pixel to the right (one 64-pixel column goes bright -> dark). Test B changes 64 pixels of the
  // dark flat region by the same amount (an 8x8 block goes dark -> bright), far from the edge:
  // same pixel count, same amplitude, hence the same MSE. FLIP rates the displaced edge higher.
  // (Spreading the same squared error thinner over more flat pixels scores higher instead: like
  // any concave error measure, FLIP's error^0.7 favours many small errors over few large ones.)
  const int edge = kSize / 2;
  const float dark = 0.2f, bright = 0.8f;
  Image ref(kSize, kSize, 3);
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x) ref.at(x, y, c) = x < edge ? dark : bright;
  Image shifted = ref;
  for (int c = 0; c < 3; ++c)
    for (int y = 0; y < kSize; ++y) shifted.at(edge, y, c) = dark;
  Image block = ref;
  for (int c = 0; c < 3; ++c)
    for (int y = 28; y < 36; ++y)
      for (int x = 8; x < 16; ++x) block.at(x, y, c) = bright;
  auto mse = [&](const Image& t) {
    double s = 0;
    for (size_t i = 0; i < ref.raw().size(); ++i) {
      const double d = double(t.raw()[i]) - double(ref.raw()[i]);
      s += d * d;
    }
    return s / double(ref.raw().size());
  };
  ASSERT_DOUBLE_EQ(mse(shifted), mse(block));
  const double edgeScore = ldrFlip(ref, shifted).mean;
  const double flatScore = ldrFlip(ref, block).mean;
  EXPECT_GT(edgeScore, 1.1 * flatScore);
}

TEST(Flip, HdrFlipSeesBrighterCopy) {
  const Image ref = smoothHdr();
  Image brighter = ref;
  for (float& v : brighter.raw()) v *= 2.0f;
  const FlipResult r = hdrFlip(ref, brighter);
  expectAllInUnitRange(r);
  EXPECT_GT(r.mean, 0.0);
  // A larger exposure error scores higher than a barely visible one.
  Image slightly = ref;
  for (float& v : slightly.raw()) v *= 1.05f;
  EXPECT_GT(r.mean, hdrFlip(ref, slightly).mean);
}

void expectSameMap(const FlipResult& a, const FlipResult& b) {
  ASSERT_EQ(a.map.raw().size(), b.map.raw().size());
  EXPECT_EQ(std::memcmp(a.map.raw().data(), b.map.raw().data(), a.map.raw().size() * sizeof(float)),
            0);
  EXPECT_EQ(a.mean, b.mean);
}

TEST(Flip, APreparedReferenceGivesEachComparisonsOwnValues) {
  // The evaluation filters a reference once for every method compared with it: each comparison
  // must be the bits of ldrFlip / hdrFlip alone, in any order, whatever was compared before.
  const Image ldrRef = randomImage(11, 0.0f, 1.0f), hdrRef = randomImage(12, 0.0f, 200.0f);
  const FlipReference prepared(&ldrRef, &hdrRef);
  for (uint32_t seed : {13u, 14u, 13u}) {
    const Image ldrTest = randomImage(seed, 0.0f, 1.0f),
                hdrTest = randomImage(seed + 10, 0.0f, 200.0f);
    const FlipResult hdr = prepared.hdr(hdrTest);
    EXPECT_GT(hdr.mean, 0.05);  // a real difference, over several exposures
    expectSameMap(hdr, hdrFlip(hdrRef, hdrTest));
    expectSameMap(prepared.ldr(ldrTest), ldrFlip(ldrRef, ldrTest));
  }
}

// [2]'s definition, written out independently: HDR-FLIP is the per-pixel maximum of LDR-FLIP
// over the exposures, each pair tone-mapped (exposure, the ACES fit on 0.6x, clamp) and
// sRGB-encoded for LDR-FLIP. Exposures run evenly from start = log2(x_max / Y_max) to stop =
// log2(x_max / Y_median), max(2, ceil(stop - start)) of them, where the tone mapper maps x_max
// to 0.85.
std::vector<float> hdrFlipByItsExposures(const Image& ref, const Image& test) {
  auto aces = [](double x) {
    x *= 0.6;
    return std::clamp(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
  };
  double lo = 0, hi = 100;  // x_max by bisection
  for (int i = 0; i < 200; ++i) (aces((lo + hi) / 2) < 0.85 ? lo : hi) = (lo + hi) / 2;
  const double xMax = (lo + hi) / 2;
  std::vector<double> y;
  for (size_t i = 0; i < ref.pixelCount(); ++i)
    y.push_back(0.2126729 * ref.raw()[i] + 0.7151522 * ref.raw()[ref.pixelCount() + i] +
                0.0721750 * ref.raw()[2 * ref.pixelCount() + i]);
  std::sort(y.begin(), y.end());
  const double median =
      y.size() % 2 ? y[y.size() / 2] : 0.5 * (y[y.size() / 2 - 1] + y[y.size() / 2]);
  const double start = std::log2(xMax / y.back()), stop = std::log2(xMax / median);
  const int count = std::max(2, int(std::ceil(stop - start)));
  auto toneMapped = [&](const Image& img, double exposure) {
    Image out = img;
    for (float& v : out.raw()) {
      const double t = aces(std::max(0.0, double(v)) * std::exp2(exposure));
      v = float(t <= 0.0031308 ? 12.92 * t
                               : 1.055 * std::pow(t, 1 / 2.4) - 0.055);  // sRGB encoding
    }
    return out;
  };
  std::vector<float> map(ref.pixelCount(), 0.0f);
  for (int i = 0; i < count; ++i) {
    const double exposure = start + (stop - start) * i / (count - 1);
    const FlipResult ldr = ldrFlip(toneMapped(ref, exposure), toneMapped(test, exposure));
    for (size_t p = 0; p < map.size(); ++p) map[p] = std::max(map[p], ldr.map.raw()[p]);
  }
  EXPECT_GE(count, 4);  // the images span several stops
  return map;
}

TEST(Flip, HdrIsTheMaximumOverItsExposuresOfLdrFlip) {
  Image ref = smoothHdr(), test = ref;
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(0.7f, 1.4f);
  for (float& v : test.raw()) v *= u(rng);
  const std::vector<float> expected = hdrFlipByItsExposures(ref, test);
  const FlipResult alone = hdrFlip(ref, test);
  const FlipReference prepared(nullptr, &ref);
  const FlipResult shared = prepared.hdr(test);
  for (size_t p = 0; p < expected.size(); ++p) {
    ASSERT_NEAR(alone.map.raw()[p], expected[p], 1e-4) << "pixel " << p;
    ASSERT_NEAR(shared.map.raw()[p], expected[p], 1e-4) << "pixel " << p;
  }
  EXPECT_GT(alone.mean, 0.05);
}

TEST(Flip, APreparedReferenceRefusesWhatItWasNotPreparedFor) {
  const Image a = randomImage(15, 0.0f, 1.0f), b(kSize + 1, kSize, 3);
  const FlipReference linearOnly(nullptr, &a);
  try {
    linearOnly.ldr(a);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("without a display image"), std::string::npos) << e.what();
  }
  EXPECT_THROW(FlipReference(&a, nullptr).hdr(a), Error);
  try {
    linearOnly.hdr(b);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sizes differ"), std::string::npos) << e.what();
  }
  const Image empty;
  EXPECT_THROW(FlipReference(&empty, nullptr), Error);
  EXPECT_THROW(FlipReference(&a, nullptr, 0.0), Error);
}

TEST(Flip, RejectsMismatchedOrEmptyImages) {
  const Image a(kSize, kSize, 3), b(kSize + 1, kSize, 3), c(kSize, kSize, 1), empty;
  EXPECT_THROW(ldrFlip(a, b), Error);
  EXPECT_THROW(hdrFlip(a, b), Error);
  EXPECT_THROW(ldrFlip(a, c), Error);
  EXPECT_THROW(hdrFlip(c, c), Error);
  EXPECT_THROW(ldrFlip(empty, empty), Error);
  EXPECT_THROW(hdrFlip(empty, a), Error);
  EXPECT_THROW(ldrFlip(a, a, 0.0), Error);
  try {
    ldrFlip(a, b);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sizes differ"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace arena
