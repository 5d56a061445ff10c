#include "metrics/stability.hpp"

#include <tbb/parallel_for.h>

#include <cmath>
#include <cstdint>
#include <limits>

#include "core/error.hpp"
#include "metrics/metric_registry.hpp"

namespace arena {

namespace {

// The per-channel term D of docs/metrics.md: the squared change over the squared normaliser.
inline double stabilityTerm(double now, double before, const Image* normaliser, double reference) {
  const double diff = now - before;
  const double scale = normaliser ? reference : 0.5 * (now + before);
  return diff * diff / (scale * scale + kStabilityEps);
}

double rootOfMean(const TileSums& tiles) {
  const double n = tiles.totalCount();
  return n > 0 ? std::sqrt(tiles.totalSum() / n) : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

StabilityPaths traceStabilityPaths(const std::vector<const LayerSet*>& guides,
                                   const ConsistencyThresholds& thresholds) {
  if (guides.size() < 2)
    throw Error("temporal stability: the paths need the guide layers of at least two frames");
  for (const LayerSet* g : guides)
    if (!g) throw Error("temporal stability: a guide layer set is missing");
  const Image& meshNow = guides[0]->get("meshId", "temporal stability");
  const int w = meshNow.width(), h = meshNow.height();
  const size_t n = size_t(w) * size_t(h), lags = guides.size() - 1;
  StabilityPaths paths;
  paths.width = w, paths.height = h;
  // Each pixel's path back through the motion layers: its position in the frame reached so far,
  // the nearest pixel there (whose motion and surface the next step reads), and whether every
  // step so far was consistent.
  std::vector<float> posX(n), posY(n);
  std::vector<int> nearX(n), nearY(n);
  std::vector<uint8_t> valid(n);
  for (int y = 0; y < h; ++y)
    for (int px = 0; px < w; ++px) {
      const size_t i = size_t(y) * size_t(w) + size_t(px);
      posX[i] = float(px), posY[i] = float(y), nearX[i] = px, nearY[i] = y;
      valid[i] = meshNow.at(px, y) >= 0;  // the sky has no surface to follow
    }
  for (size_t k = 1; k <= lags; ++k) {
    const LayerSet &a = *guides[k - 1], &b = *guides[k];
    const Image& motion = a.get("motion", "temporal stability");
    const Image &depthA = a.get("depth", "temporal stability"), &normalA = a.get("normal", "temporal stability"),
                &meshA = a.get("meshId", "temporal stability");
    const Image &depthB = b.get("depth", "temporal stability"), &normalB = b.get("normal", "temporal stability"),
                &meshB = b.get("meshId", "temporal stability");
    for (const Image* layer : {&motion, &depthA, &normalA, &meshA, &depthB, &normalB, &meshB})
      if (layer->width() != w || layer->height() != h)
        throw Error("temporal stability: the guide layers differ in size from the frame");
    tbb::parallel_for(0, h, [&](int y) {
      for (int px = 0; px < w; ++px) {
        const size_t i = size_t(y) * size_t(w) + size_t(px);
        if (!valid[i]) continue;
        const int ax = nearX[i], ay = nearY[i];
        const float qx = posX[i] + motion.at(ax, ay, 0), qy = posY[i] + motion.at(ax, ay, 1);
        const int x0 = int(std::floor(qx)), y0 = int(std::floor(qy));
        bool ok = x0 >= 0 && y0 >= 0 && x0 + 1 < w && y0 + 1 < h;
        if (ok) {
          const SurfaceSample surface = surfaceAt(depthA, normalA, meshA, ax, ay);
          const SurfaceDerivatives derivatives = surfaceDerivatives(depthA, normalA, meshA, ax, ay);
          for (int tap = 0; tap < 4 && ok; ++tap)
            ok = consistent(surface, derivatives, surfaceAt(depthB, normalB, meshB, x0 + (tap & 1), y0 + (tap >> 1)),
                            thresholds);
        }
        if (!ok) {
          valid[i] = 0;
          continue;
        }
        posX[i] = qx, posY[i] = qy;
        nearX[i] = int(std::floor(qx + 0.5f)), nearY[i] = int(std::floor(qy + 0.5f));
      }
    });
    paths.lags.push_back({posX, posY, valid});
  }
  return paths;
}

double StabilityPaths::validFraction() const {
  if (lags.empty() || lags[0].valid.empty()) return 0;
  size_t kept = 0;
  for (uint8_t v : lags[0].valid) kept += v;
  return double(kept) / double(lags[0].valid.size());
}

int followableLags(const FrameView& v) {
  int lags = 0;
  while (lags < kMaxMetricHistory && v.previous(lags + 1) && !v.cutWithin(lags + 1)) ++lags;
  return lags;
}

std::shared_ptr<const StabilityPaths> motionPaths(const FrameView& v, int lags) {
  std::vector<const LayerSet*> guides = {v.guides};
  for (int lag = 1; lag <= lags; ++lag) {
    const FrameView* p = v.previous(lag);
    if (!p)
      throw Error("motion paths: frame " + std::to_string(v.frame) + " has no frame " + std::to_string(lag) +
                  " before it");
    guides.push_back(p->guides);
  }
  const auto trace = [&] { return traceStabilityPaths(guides); };
  if (!v.frameMemo) return std::make_shared<const StabilityPaths>(trace());
  return v.frameMemo->get<StabilityPaths>("motion paths over " + std::to_string(lags) + " lags", trace);
}

std::vector<StabilityResult> temporalStability(const std::vector<StabilityInput>& signals,
                                               const std::vector<const LayerSet*>& guides,
                                               const ConsistencyThresholds& thresholds) {
  if (signals.empty()) return {};
  const size_t lags = signals.front().previous.size();
  if (guides.size() != lags + 1)
    throw Error("temporal stability: " + std::to_string(lags) + " previous frames need " +
                std::to_string(lags + 1) + " guide layer sets, got " +
                std::to_string(guides.size()));
  return temporalStability(signals, traceStabilityPaths(guides, thresholds));
}

std::vector<StabilityResult> temporalStability(const std::vector<StabilityInput>& signals,
                                               const StabilityPaths& paths) {
  if (signals.empty()) return {};
  for (const StabilityInput& in : signals)
    if (!in.current || in.current->empty()) throw Error("temporal stability: no current frame");
  const Image& first = *signals.front().current;
  const size_t lags = signals.front().previous.size();
  if (paths.lags.size() != lags)
    throw Error("temporal stability: " + std::to_string(lags) +
                " previous frames need paths over as many lags, got " +
                std::to_string(paths.lags.size()));
  if (paths.width != first.width() || paths.height != first.height())
    throw Error("temporal stability: the guide layers differ in size from the frame");
  for (const StabilityInput& in : signals) {
    if (!in.current->sameShape(first) || in.previous.size() != lags)
      throw Error(
          "temporal stability: the signals differ in size or in their number of previous frames");
    for (const Image* p : in.previous)
      if (!p || !p->sameShape(first))
        throw Error("temporal stability: a previous frame differs in size or is missing");
    if (in.normaliser && !in.normaliser->sameShape(first))
      throw Error("temporal stability: the normaliser differs in size from the frame");
  }
  const int w = first.width(), h = first.height(), c = first.channels();
  const size_t n = size_t(w) * size_t(h), count = signals.size();
  std::vector<std::vector<float>> warped(count, std::vector<float>(n * size_t(c)));
  std::vector<TileAccumulator> fine(count, TileAccumulator(w, h)),
      coarse(count, TileAccumulator(w, h));
  std::vector<StabilityResult> out(count);
  const double validFraction = paths.validFraction();
  for (StabilityResult& r : out) r.validFraction = validFraction;
  for (size_t k = 1; k <= lags; ++k) {
    const StabilityPaths::Lag& lag = paths.lags[k - 1];
    const std::vector<uint8_t>& valid = lag.valid;
    tbb::parallel_for(0, h, [&](int y) {
      for (int px = 0; px < w; ++px) {
        const size_t i = size_t(y) * size_t(w) + size_t(px);
        if (!valid[i]) continue;
        const float qx = lag.x[i], qy = lag.y[i];
        const int x0 = int(std::floor(qx)), y0 = int(std::floor(qy));
        // One bilinear resampling of frame t - k at the end of the path, so longer lags are not
        // blurred more than the first.
        const float fx = qx - float(x0), fy = qy - float(y0);
        for (size_t s = 0; s < count; ++s) {
          const StabilityInput& in = signals[s];
          const Image &x = *in.current, &before = *in.previous[k - 1];
          double sum = 0;
          for (int ch = 0; ch < c; ++ch) {
            const double value = (1 - fx) * (1 - fy) * before.at(x0, y0, ch) + fx * (1 - fy) * before.at(x0 + 1, y0, ch) +
                                 (1 - fx) * fy * before.at(x0, y0 + 1, ch) + fx * fy * before.at(x0 + 1, y0 + 1, ch);
            warped[s][size_t(ch) * n + i] = float(value);
            sum += stabilityTerm(x.at(px, y, ch), value, in.normaliser,
                                 in.normaliser ? in.normaliser->at(px, y, ch) : 0.0);
          }
          fine[s].add(px, y, sum, c);
        }
      }
    });
    // The coarse scale: 4x4 block means of the frame and of its warped predecessor, over blocks
    // whose every pixel is valid for this lag; a block's entry goes to its top-left pixel's tile.
    const int blocksX = w / kStabilityBlock, blocksY = h / kStabilityBlock;
    constexpr double area = kStabilityBlock * kStabilityBlock;
    tbb::parallel_for(0, blocksY, [&](int by) {
      for (int bx = 0; bx < blocksX; ++bx) {
        const int x0 = bx * kStabilityBlock, y0 = by * kStabilityBlock;
        bool all = true;
        for (int dy = 0; dy < kStabilityBlock && all; ++dy)
          for (int dx = 0; dx < kStabilityBlock && all; ++dx)
            all = valid[size_t(y0 + dy) * size_t(w) + size_t(x0 + dx)];
        if (!all) continue;
        for (size_t s = 0; s < count; ++s) {
          const StabilityInput& in = signals[s];
          double sum = 0;
          for (int ch = 0; ch < c; ++ch) {
            double now = 0, then = 0, reference = 0;
            for (int dy = 0; dy < kStabilityBlock; ++dy)
              for (int dx = 0; dx < kStabilityBlock; ++dx) {
                const size_t i = size_t(y0 + dy) * size_t(w) + size_t(x0 + dx);
                now += in.current->at(x0 + dx, y0 + dy, ch);
                then += warped[s][size_t(ch) * n + i];
                if (in.normaliser) reference += in.normaliser->at(x0 + dx, y0 + dy, ch);
              }
            sum += stabilityTerm(now / area, then / area, in.normaliser, reference / area);
          }
          coarse[s].add(x0, y0, sum, c);
        }
      }
    });
  }
  for (size_t s = 0; s < count; ++s) {
    out[s].fineTiles = fine[s].finish();
    out[s].coarseTiles = coarse[s].finish();
    out[s].fine = rootOfMean(out[s].fineTiles);
    out[s].coarse = rootOfMean(out[s].coarseTiles);
  }
  return out;
}

StabilityResult temporalStability(const StabilityInput& in, const ConsistencyThresholds& thresholds) {
  return temporalStability(std::vector<StabilityInput>{in}, in.guides, thresholds).front();
}

// Registered in metric_registry.cpp. Without a reference only the output's own stability is
// measured (a capture that has none is still scored on it).
MetricFamily multiScaleStabilityFamily() {
  MetricFamily f;
  f.metrics = {
      {.name = "stabilityFine", .needsReference = false, .transform = FrameTransform::Sqrt,
       .chart = ReportChart::Temporal, .title = "stability, fine (flicker)",
       .description = "motion-compensated relative change of the output vs lags 1-3, full resolution (flicker)"},
      {.name = "stabilityCoarse", .needsReference = false, .transform = FrameTransform::Sqrt,
       .chart = ReportChart::Temporal, .title = "stability, coarse (boiling)",
       .description = "the same on 4x4 block means (boiling: low-frequency change)"},
      {.name = "errorStabilityFine", .transform = FrameTransform::Sqrt,
       .description = "stabilityFine of the error d - r, relative to r (reference twin)"},
      {.name = "errorStabilityCoarse", .transform = FrameTransform::Sqrt,
       .description = "stabilityCoarse of the error d - r, relative to r (reference twin)"},
  };
  f.measure = [](const FrameView& v, const MetricOptions&, FrameRecorder& out) {
    // Across a camera cut there is nothing to follow; frame 0 or right after a cut: undefined.
    const int lags = followableLags(v);
    if (lags == 0) return;
    StabilityInput output{v.output, {}, {}, nullptr};
    StabilityInput error{v.error, {}, {}, v.reference};
    for (int lag = 1; lag <= lags; ++lag) {
      output.previous.push_back(v.previous(lag)->output);
      error.previous.push_back(v.previous(lag)->error);
    }
    auto put = [&](const char* name, double value, TileSums tiles) {
      if (tiles.totalCount() > 0) out.put(name, value, std::move(tiles));  // else nothing was valid: undefined
    };
    // The output and its error follow the same paths, traced once for every output of the scene
    // where the evaluation keeps them (the frame's memo).
    std::vector<StabilityInput> signals = {output};
    if (v.error) signals.push_back(error);
    std::vector<StabilityResult> r = temporalStability(signals, *motionPaths(v, lags));
    put("stabilityFine", r[0].fine, std::move(r[0].fineTiles));
    put("stabilityCoarse", r[0].coarse, std::move(r[0].coarseTiles));
    if (r.size() < 2) return;
    put("errorStabilityFine", r[1].fine, std::move(r[1].fineTiles));
    put("errorStabilityCoarse", r[1].coarse, std::move(r[1].coarseTiles));
  };
  return f;
}

}  // namespace arena
