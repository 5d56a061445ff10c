#include "metrics/error.hpp"

#include <tbb/parallel_for.h>

#include <cmath>
#include <optional>
#include <vector>

#include "core/error.hpp"
#include "metrics/metric_registry.hpp"

namespace arena {

namespace {

void requireSameShape(const Image& a, const Image& b, const char* what) {
  if (a.width() != b.width() || a.height() != b.height() || a.channels() != b.channels())
    throw Error(std::string(what) + ": images differ in size or channels (" + std::to_string(a.width()) + "x" +
                std::to_string(a.height()) + "x" + std::to_string(a.channels()) + " vs " + std::to_string(b.width()) +
                "x" + std::to_string(b.height()) + "x" + std::to_string(b.channels()) + ")");
  if (a.empty()) throw Error(std::string(what) + ": empty image");
}

// Sums a per-row quantity in a fixed order so results do not depend on thread scheduling.
template <class RowFn>
double deterministicSum(int height, const RowFn& row) {
  std::vector<double> rows(size_t(height), 0.0);
  tbb::parallel_for(0, height, [&](int y) { rows[size_t(y)] = row(y); });
  double s = 0;
  for (double r : rows) s += r;
  return s;
}

}  // namespace

Image luminanceOf(const Image& rgb) { return luminance(rgb); }

ErrorStats linearError(const Image& d, const Image& r, const Image* var, const Image* mask, double eps,
                       ErrorTiles* tiles) {
  requireSameShape(d, r, "relMSE");
  if (var) requireSameShape(*var, r, "relMSE reference variance");
  const int w = d.width(), c = d.channels();
  std::optional<TileAccumulator> tSq, tRel, tCorr;
  if (tiles) tSq.emplace(w, d.height()), tRel.emplace(w, d.height()), tCorr.emplace(w, d.height());
  std::vector<double> counts(size_t(d.height()), 0.0);
  double sq = 0, rel = 0, relCorr = 0;
  std::vector<double> rowSq(size_t(d.height())), rowRel(size_t(d.height())), rowCorr(size_t(d.height()));
  tbb::parallel_for(0, d.height(), [&](int y) {
    double s = 0, rl = 0, rc = 0, n = 0;
    for (int x = 0; x < w; ++x) {
      if (mask && mask->at(x, y) == 0) continue;
      n += c;
      double ps = 0, pl = 0, pc = 0;
      for (int ch = 0; ch < c; ++ch) {
        double diff = double(d.at(x, y, ch)) - double(r.at(x, y, ch));
        double rr = double(r.at(x, y, ch));
        double denom = rr * rr + eps;
        ps += diff * diff;
        pl += diff * diff / denom;
        pc += (diff * diff - (var ? double(var->at(x, y, ch)) : 0.0)) / denom;
      }
      s += ps, rl += pl, rc += pc;
      if (tiles) tSq->add(x, y, ps, c), tRel->add(x, y, pl, c), tCorr->add(x, y, pc, c);
    }
    rowSq[size_t(y)] = s;
    rowRel[size_t(y)] = rl;
    rowCorr[size_t(y)] = rc;
    counts[size_t(y)] = n;
  });
  double n = 0;
  for (int y = 0; y < d.height(); ++y) {
    sq += rowSq[size_t(y)];
    rel += rowRel[size_t(y)];
    relCorr += rowCorr[size_t(y)];
    n += counts[size_t(y)];
  }
  if (tiles) *tiles = {tRel->finish(), tCorr->finish(), tSq->finish()};
  ErrorStats out;
  if (n == 0) return out;
  out.mse = sq / n;
  out.rmse = std::sqrt(out.mse);
  out.relMse = rel / n;
  out.relMseCorrected = relCorr / n;
  return out;
}

BiasVariance biasVariance(const std::vector<const Image*>& outputs, const Image& r, const Image* var, double eps,
                          BiasVarianceTiles* tiles) {
  if (outputs.size() < 2) throw Error("bias/variance: needs the outputs of at least 2 input seeds");
  for (const Image* d : outputs) requireSameShape(*d, r, "bias/variance");
  if (var) requireSameShape(*var, r, "bias/variance reference variance");
  const int w = r.width(), h = r.height(), c = r.channels();
  const double k = double(outputs.size());
  const size_t rows = static_cast<size_t>(h);
  std::vector<double> rowBias(rows), rowCorr(rows), rowVar(rows);
  std::optional<TileAccumulator> tBias, tCorr, tVar;
  if (tiles) tBias.emplace(w, h), tCorr.emplace(w, h), tVar.emplace(w, h);
  tbb::parallel_for(0, h, [&](int y) {
    double b = 0, bc = 0, v = 0;
    for (int x = 0; x < w; ++x) {
      double pb = 0, pc = 0, pv = 0;
      for (int ch = 0; ch < c; ++ch) {
        double mean = 0;
        for (const Image* d : outputs) mean += d->at(x, y, ch);
        mean /= k;
        double spread = 0;
        for (const Image* d : outputs) spread += (d->at(x, y, ch) - mean) * (d->at(x, y, ch) - mean);
        // Unbiased: s^2 = spread / (K - 1); (dbar - r)^2 overestimates bias^2 by s^2 / K.
        const double rr = r.at(x, y, ch), denom = rr * rr + eps, diff = mean - rr, s2 = spread / (k - 1);
        pb += (diff * diff - s2 / k) / denom;
        pc += (diff * diff - s2 / k - (var ? double(var->at(x, y, ch)) : 0.0)) / denom;
        pv += s2 / denom;
      }
      b += pb, bc += pc, v += pv;
      if (tiles) tBias->add(x, y, pb, c), tCorr->add(x, y, pc, c), tVar->add(x, y, pv, c);
    }
    rowBias[size_t(y)] = b, rowCorr[size_t(y)] = bc, rowVar[size_t(y)] = v;
  });
  BiasVariance out;
  for (int y = 0; y < h; ++y) out.bias2 += rowBias[size_t(y)], out.bias2Corrected += rowCorr[size_t(y)], out.variance += rowVar[size_t(y)];
  const double n = double(r.pixelCount()) * c;
  out.bias2 /= n, out.bias2Corrected /= n, out.variance /= n;
  if (tiles) *tiles = {tBias->finish(), tCorr->finish(), tVar->finish()};
  return out;
}

double referenceRelMse(const Image& r, const Image& var, const Image* mask, double eps) {
  requireSameShape(r, var, "reference relMSE");
  const int w = r.width(), c = r.channels();
  std::vector<double> counts(size_t(r.height()), 0.0);
  double total = deterministicSum(r.height(), [&](int y) {
    double s = 0, n = 0;
    for (int x = 0; x < w; ++x) {
      if (mask && mask->at(x, y) == 0) continue;
      n += c;
      for (int ch = 0; ch < c; ++ch) {
        double rr = r.at(x, y, ch);
        s += double(var.at(x, y, ch)) / (rr * rr + eps);
      }
    }
    counts[size_t(y)] = n;
    return s;
  });
  double n = 0;
  for (double k : counts) n += k;
  return n > 0 ? total / n : 0.0;
}

double meanSquaredError(const Image& a, const Image& b, TileSums* tiles) {
  requireSameShape(a, b, "MSE");
  const int w = a.width(), c = a.channels();
  std::optional<TileAccumulator> acc;
  if (tiles) acc.emplace(w, a.height());
  double total = deterministicSum(a.height(), [&](int y) {
    double s = 0;
    for (int x = 0; x < w; ++x) {
      double p = 0;
      for (int ch = 0; ch < c; ++ch) {
        double diff = double(a.at(x, y, ch)) - double(b.at(x, y, ch));
        p += diff * diff;
      }
      s += p;
      if (acc) acc->add(x, y, p, c);
    }
    return s;
  });
  if (tiles) *tiles = acc->finish();
  return total / double(a.pixelCount() * size_t(c));
}

double psnrFromMse(double mse) {
  if (std::isnan(mse)) return mse;  // no data is no score, never the cap
  if (mse <= 0) return kPsnrCapDb;
  return std::min(kPsnrCapDb, 10.0 * std::log10(1.0 / mse));
}

double ssim(const Image& a, const Image& b, TileSums* tiles) {
  requireSameShape(a, b, "SSIM");
  const Image la = a.channels() >= 3 ? luminance(a) : a;
  const Image lb = b.channels() >= 3 ? luminance(b) : b;
  const int w = la.width(), h = la.height();
  constexpr int kRadius = 5;  // 11x11 window
  constexpr double kSigma = 1.5, C1 = 0.01 * 0.01, C2 = 0.03 * 0.03;
  double kernel[2 * kRadius + 1], ksum = 0;
  for (int i = -kRadius; i <= kRadius; ++i) ksum += kernel[i + kRadius] = std::exp(-i * i / (2 * kSigma * kSigma));
  for (double& k : kernel) k /= ksum;
  // Separable Gaussian of x, y, x^2, y^2, xy; horizontal pass then vertical, clamped borders.
  auto blur = [&](const std::vector<double>& src) {
    std::vector<double> tmp(src.size()), out(src.size());
    tbb::parallel_for(0, h, [&](int y) {
      for (int x = 0; x < w; ++x) {
        double s = 0;
        for (int i = -kRadius; i <= kRadius; ++i) s += kernel[i + kRadius] * src[size_t(y) * w + std::clamp(x + i, 0, w - 1)];
        tmp[size_t(y) * w + x] = s;
      }
    });
    tbb::parallel_for(0, h, [&](int y) {
      for (int x = 0; x < w; ++x) {
        double s = 0;
        for (int i = -kRadius; i <= kRadius; ++i) s += kernel[i + kRadius] * tmp[size_t(std::clamp(y + i, 0, h - 1)) * w + x];
        out[size_t(y) * w + x] = s;
      }
    });
    return out;
  };
  const size_t n = la.pixelCount();
  std::vector<double> x(n), y(n), xx(n), yy(n), xy(n);
  for (size_t i = 0; i < n; ++i) {
    x[i] = la.plane(0)[i];
    y[i] = lb.plane(0)[i];
    xx[i] = x[i] * x[i];
    yy[i] = y[i] * y[i];
    xy[i] = x[i] * y[i];
  }
  auto mx = blur(x), my = blur(y), sxx = blur(xx), syy = blur(yy), sxy = blur(xy);
  // Window centres whose 11x11 window lies inside the image (Wang's "valid" region); tiny images
  // fall back to every pixel.
  const bool valid = w > 2 * kRadius && h > 2 * kRadius;
  const int x0 = valid ? kRadius : 0, y0 = valid ? kRadius : 0, x1 = valid ? w - kRadius : w, y1 = valid ? h - kRadius : h;
  double total = 0;
  std::optional<TileAccumulator> acc;
  if (tiles) acc.emplace(w, h);
  for (int py = y0; py < y1; ++py)
    for (int px = x0; px < x1; ++px) {
      size_t i = size_t(py) * w + px;
      double vx = sxx[i] - mx[i] * mx[i], vy = syy[i] - my[i] * my[i], cxy = sxy[i] - mx[i] * my[i];
      const double v =
          ((2 * mx[i] * my[i] + C1) * (2 * cxy + C2)) / ((mx[i] * mx[i] + my[i] * my[i] + C1) * (vx + vy + C2));
      total += v;
      if (acc) acc->add(px, py, v, 1);
    }
  if (tiles) *tiles = acc->finish();
  return total / double((x1 - x0) * (y1 - y0));
}

}  // namespace arena

namespace arena {

// Registered in metric_registry.cpp: the error against the reference on linear values, the
// effective spp derived from it, and the reference's own error beside them (docs/metrics.md).
MetricFamily linearErrorFamily() {
  MetricFamily f;
  f.metrics = {
      {.name = "relMse",
       .floor = FloorRule::ReferenceNoise,
       .ranked = true,
       .gatedByDefault = true,
       .overall = true,
       .reportColumn = true,
       .chart = ReportChart::Error,
       .title = "relMSE",
       .description = "relative MSE vs the reference, eps 0.01 (raw)"},
      {.name = "relMseCorrected",
       .reportColumn = true,
       .chart = ReportChart::Error,
       .title = "relMSE (reference-corrected)",
       .description = "relMSE minus the reference's own noise term"},
      {.name = "mse", .description = "MSE, linear"},
      {.name = "rmse", .transform = FrameTransform::Sqrt, .description = "RMSE, linear"},
      {.name = "effectiveSpp",
       .unit = "spp",
       .better = Better::Higher,
       .frameScalar = true,
       .description = "samples plain accumulation would need for the same relMSE"},
      {.name = "referenceRelMse",
       .frameScalar = true,
       .description = "the reference's own estimated relMSE (the same for every method: context, "
                      "not a score)"},
  };
  f.measure = [](const FrameView& v, const MetricOptions&, FrameRecorder& out) {
    ErrorTiles et;
    const ErrorStats e = linearError(*v.output, *v.reference, v.referenceVariance, nullptr, kRelMseEpsilon, &et);
    out.put("relMse", e.relMse, std::move(et.relMse));
    out.put("relMseCorrected", e.relMseCorrected, std::move(et.relMseCorrected));
    out.put("mse", e.mse, et.mse);
    out.put("rmse", e.rmse, std::move(et.mse));
    // 1-spp relMSE falls as 1/spp, so spp_eff = relMSE(noisy) / relMSE(method); the
    // reference-corrected values when both are positive.
    const double noisyCorrected = v.noisyRelMse - v.referenceRelMse;
    const bool corrected = noisyCorrected > 0 && e.relMseCorrected > 0;
    out.put("effectiveSpp", corrected ? noisyCorrected / e.relMseCorrected : v.noisyRelMse / std::max(e.relMse, 1e-12));
    out.put("referenceRelMse", v.referenceRelMse);
  };
  return f;
}

// Registered in metric_registry.cpp: PSNR and SSIM of the display image.
MetricFamily displayErrorFamily() {
  MetricFamily f;
  f.metrics = {
      {.name = "psnr", .unit = "dB", .better = Better::Higher, .reads = MetricInput::Display,
       .transform = FrameTransform::Psnr, .floor = FloorRule::ReferenceNoise,
       .chart = ReportChart::Error, .title = "PSNR (dB)", .description = "PSNR of the display image, dB (capped at 100)"},
      {.name = "ssim", .better = Better::Higher, .reads = MetricInput::Display, .floor = FloorRule::ReferenceNoise,
       .floorWarningFactor = 2, .perfect = 1, .ranked = true, .gatedByDefault = true, .reportColumn = true,
       .description = "SSIM of display luminance (11x11 Gaussian, sigma 1.5)"},
      {.name = "dssim", .reads = MetricInput::Display, .overall = true, .chart = ReportChart::Error, .title = "1 − SSIM",
       .description = "1 - SSIM: SSIM as an error, lower is better (the speed chart's axis and its overall score)"},
  };
  f.measure = [](const FrameView& v, const MetricOptions&, FrameRecorder& out) {
    TileSums tiles;
    const double psnr = psnrFromMse(meanSquaredError(*v.outputDisplay, *v.referenceDisplay, &tiles));
    out.put("psnr", psnr, std::move(tiles));
    const double s = ssim(*v.outputDisplay, *v.referenceDisplay, &tiles);
    // 1 - SSIM per tile is (windows - SSIM sum) / windows: the same blocks, the complement's sums.
    TileSums complement = tiles;
    for (size_t i = 0; i < complement.sum.size(); ++i) complement.sum[i] = complement.count[i] - complement.sum[i];
    out.put("ssim", s, std::move(tiles));
    out.put("dssim", 1 - s, std::move(complement));
  };
  return f;
}

}  // namespace arena
