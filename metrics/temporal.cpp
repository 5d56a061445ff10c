#include "metrics/temporal.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "core/error.hpp"
#include "metrics/error.hpp"
#include "metrics/metric_registry.hpp"

namespace arena {

namespace {
void requireShapes(std::initializer_list<const Image*> images, const char* what) {
  const Image* first = *images.begin();
  for (const Image* i : images)
    if (!i->sameShape(*first) || i->empty()) throw Error(std::string(what) + ": images differ in size or are empty");
}
}  // namespace

double temporalRelativeMae(const Image& d, const Image& dPrev, const Image& r, const Image& rPrev, double eps,
                           TileSums* tiles) {
  requireShapes({&d, &dPrev, &r, &rPrev}, "tRMAE");
  const int w = d.width(), c = d.channels();
  std::vector<double> rows(size_t(d.height()));
  std::optional<TileAccumulator> acc;
  if (tiles) acc.emplace(w, d.height());
  tbb::parallel_for(0, d.height(), [&](int y) {
    double s = 0;
    for (int x = 0; x < w; ++x) {
      double p = 0;
      for (int ch = 0; ch < c; ++ch) {
        double dd = double(d.at(x, y, ch)) - dPrev.at(x, y, ch);
        double dr = double(r.at(x, y, ch)) - rPrev.at(x, y, ch);
        p += std::abs(dd - dr) / (std::abs(dr) + eps);
      }
      s += p;
      if (acc) acc->add(x, y, p, c);
    }
    rows[size_t(y)] = s;
  });
  if (tiles) *tiles = acc->finish();
  double total = 0;
  for (double v : rows) total += v;
  return total / double(d.pixelCount() * size_t(c));
}

double temporalPsnr(const Image& d, const Image& dPrev, const Image& r, const Image& rPrev, TileSums* tiles) {
  requireShapes({&d, &dPrev, &r, &rPrev}, "tPSNR");
  Image dd(d.width(), d.height(), d.channels()), dr(d.width(), d.height(), d.channels());
  for (size_t i = 0; i < d.raw().size(); ++i) {
    dd.raw()[i] = d.raw()[i] - dPrev.raw()[i];
    dr.raw()[i] = r.raw()[i] - rPrev.raw()[i];
  }
  return psnrFromMse(meanSquaredError(dd, dr, tiles));
}

WarpedFlicker warpedFlicker(const Image& e, const Image& ePrev, const LayerSet& g, const LayerSet& gPrev,
                            const ConsistencyThresholds& thresholds, TileSums* tiles) {
  return warpedFlicker(e, ePrev, traceStabilityPaths({&g, &gPrev}, thresholds), tiles);
}

WarpedFlicker warpedFlicker(const Image& e, const Image& ePrev, const StabilityPaths& paths, TileSums* tiles) {
  requireShapes({&e, &ePrev}, "warped flicker");
  const int w = e.width(), h = e.height(), c = e.channels();
  if (paths.lags.empty() || paths.width != w || paths.height != h)
    throw Error("warped flicker: the motion paths have no lag or differ in size from the frame");
  const StabilityPaths::Lag& lag = paths.lags[0];
  std::vector<double> rowSum(static_cast<size_t>(h)), rowCount(static_cast<size_t>(h));
  std::optional<TileAccumulator> acc;
  if (tiles) acc.emplace(w, h);
  tbb::parallel_for(0, h, [&](int y) {
    double s = 0, n = 0;
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * size_t(w) + size_t(x);
      if (!lag.valid[i]) continue;
      // Previous-frame continuous position, relative to pixel centres.
      const float px = lag.x[i], py = lag.y[i];
      const int x0 = int(std::floor(px)), y0 = int(std::floor(py));
      const float fx = px - float(x0), fy = py - float(y0);
      n += 1;
      double p = 0;
      for (int ch = 0; ch < c; ++ch) {
        double warped = (1 - fx) * (1 - fy) * ePrev.at(x0, y0, ch) + fx * (1 - fy) * ePrev.at(x0 + 1, y0, ch) +
                        (1 - fx) * fy * ePrev.at(x0, y0 + 1, ch) + fx * fy * ePrev.at(x0 + 1, y0 + 1, ch);
        double diff = double(e.at(x, y, ch)) - warped;
        p += diff * diff / c;
      }
      s += p;
      if (acc) acc->add(x, y, p, 1);
    }
    rowSum[size_t(y)] = s;
    rowCount[size_t(y)] = n;
  });
  double s = 0, n = 0;
  for (int y = 0; y < h; ++y) {
    s += rowSum[size_t(y)];
    n += rowCount[size_t(y)];
  }
  if (tiles) *tiles = acc->finish();
  WarpedFlicker out;
  out.validFraction = n / double(size_t(w) * size_t(h));
  out.value = n > 0 ? std::sqrt(s / n) : std::numeric_limits<double>::quiet_NaN();  // no valid pixel: undefined
  return out;
}

}  // namespace arena

namespace arena {

// Registered in metric_registry.cpp: frame-to-frame flicker against the reference's own change.
MetricFamily temporalFlickerFamily() {
  MetricFamily f;
  f.metrics = {
      {.name = "tRmae",
       .ranked = true,
       .gatedByDefault = true,
       .overall = true,
       .reportColumn = true,
       .chart = ReportChart::Temporal,
       .title = "tRMAE",
       .description = "temporal relative MAE vs the reference's frame difference (no /3)"},
      {.name = "tPsnr",
       .unit = "dB",
       .better = Better::Higher,
       .reads = MetricInput::Display,
       .transform = FrameTransform::Psnr,
       .chart = ReportChart::Temporal,
       .title = "tPSNR (dB)",
       .description = "temporal PSNR of display frame differences, dB"},
      {.name = "warpedFlicker",
       .transform = FrameTransform::Sqrt,
       .ranked = true,
       .reportColumn = true,
       .chart = ReportChart::Temporal,
       .title = "warped flicker",
       .description = "motion-compensated flicker of the error e = d - r"},
  };
  f.measure = [](const FrameView& v, const MetricOptions&, FrameRecorder& out) {
    const FrameView* p = v.previous(1);
    // Frame 0, or a camera cut: the frame before shows another view, and its difference (or
    // reprojection: walls keep their mesh ids across a cut, and a few pixels pass by chance)
    // measures the cut, not flicker.
    if (!p || v.cutWithin(1)) return;
    TileSums tiles;
    const double trmae = temporalRelativeMae(*v.output, *p->output, *v.reference, *p->reference, 0.01, &tiles);
    out.put("tRmae", trmae, std::move(tiles));
    const double tpsnr = temporalPsnr(*v.outputDisplay, *p->outputDisplay, *v.referenceDisplay,
                                      *p->referenceDisplay, &tiles);
    out.put("tPsnr", tpsnr, std::move(tiles));
    // Lag 1 of the paths the stability metric follows (at least one here: no cut), kept once per
    // frame.
    const WarpedFlicker wf =
        warpedFlicker(*v.error, *p->error, *motionPaths(v, followableLags(v)), &tiles);
    // No consistent pixel (a full disocclusion): warped flicker is undefined there.
    if (wf.validFraction > 0) out.put("warpedFlicker", wf.value, std::move(tiles));
    out.note("warpedValid", wf.validFraction);
  };
  return f;
}

}  // namespace arena
