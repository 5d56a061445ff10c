#include "denoisers/common/reprojection.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#include "core/consistency.hpp"
#include "core/error.hpp"

namespace arena {

std::vector<ParamSpec> reprojectionParamSpecs() {
  return {
      ParamSpec::real("depthThreshold", 10, 0, 1e6,
                      "reprojection rejects a tap when |z_prev - z| / (fwidth(z) + 0.01) exceeds "
                      "this (Falcor 10)"),
      ParamSpec::real("normalThreshold", 16, 0, 1e6,
                      "reprojection rejects a tap when |n - n_prev| / (fwidth(n) + 0.01) exceeds "
                      "this (Falcor 16)"),
  };
}

ReprojectionSettings reprojectionSettings(const ParamSet& params) {
  ReprojectionSettings s;
  s.depthThreshold = params.getFloat("depthThreshold");
  s.normalThreshold = params.getFloat("normalThreshold");
  return s;
}

void Reprojection::setup(int width, int height) {
  width_ = width;
  height_ = height;
  records_.assign(size_t(width) * size_t(height), ReprojectionRecord{});
  testedTaps_.setup(height);
  readTaps_.setup(height);
}

void Reprojection::invalidateAll() {
  std::fill(records_.begin(), records_.end(), ReprojectionRecord{});
  for (int y = 0; y < height_; ++y) {
    testedTaps_.set(y, 0);
    readTaps_.set(y, 0);
  }
}

void Reprojection::compute(const GBufferView& current, const Image& derivatives,
                           const GBufferView& previous, const ReprojectionSettings& settings,
                           const CameraState* camera, const CameraState* previousCamera) {
  if (current.width != width_ || current.height != height_ || previous.width != width_ ||
      previous.height != height_)
    throw Error("reprojection: frame size differs from the size given to setup()");
  if (!current.depth || !current.normal[0] || !current.meshId || !current.motion[0])
    throw Error("reprojection: needs the depth, normal, meshId and motion layers");
  const bool correctDepth = camera && previousCamera && current.position[0];
  const int w = width_, h = height_;
  // Falcor's +1e-2 keeps a flat, camera-facing surface (fwidth = 0) from rejecting rounding noise;
  // core/consistency.hpp adds it.
  const ConsistencyThresholds thresholds{settings.depthThreshold, settings.normalThreshold};

  parallelRows(h, [&](int y) {
    int64_t tested = 0, read = 0;
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      ReprojectionRecord& rec = records_[p];
      rec = ReprojectionRecord{};
      if (current.isSky(p)) continue;

      // Continuous previous-frame position; its bilinear taps surround (px - 0.5, py - 0.5).
      const float px = float(x) + 0.5f + current.motion[0][p];
      const float py = float(y) + 0.5f + current.motion[1][p];
      if (!std::isfinite(px) || !std::isfinite(py) || std::abs(px) > 1e7f || std::abs(py) > 1e7f)
        continue;

      // This pixel's surface as the previous frame should show it (the depth camera-corrected).
      SurfaceSample surface{current.depth[p],
                            {current.normal[0][p], current.normal[1][p], current.normal[2][p]},
                            int(current.meshId[p])};
      if (correctDepth) {
        const glm::vec3 world(current.position[0][p], current.position[1][p],
                              current.position[2][p]);
        surface.depth = previousViewDepth(surface.depth, world, *camera, *previousCamera);
      }
      const SurfaceDerivatives fwidth{depthFwidth(derivatives, p),
                                      derivatives.plane(kNormalFwidth)[p]};

      // SVGF §4.1: each tap is tested separately for depth, normal and mesh id, by the one
      // definition the metrics use too (core/consistency.hpp).
      auto consistentTap = [&](int qx, int qy) {
        if (qx < 0 || qy < 0 || qx >= w || qy >= h) return false;  // off-screen
        const size_t q = size_t(qy) * size_t(w) + size_t(qx);
        const SurfaceSample tap{
            previous.depth[q],
            {previous.normal[0][q], previous.normal[1][q], previous.normal[2][q]},
            int(previous.meshId[q])};
        return consistent(surface, fwidth, tap, thresholds);
      };

      const float fx = px - 0.5f, fy = py - 0.5f;
      const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
      const float tx = fx - float(x0), ty = fy - float(y0);
      const float bilinear[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
      float weightSum = 0;
      tested += 4;
      for (int k = 0; k < 4; ++k) {
        // A zero-weight tap is never read, so an exact integer shift reads exactly one pixel.
        if (bilinear[k] > 0.0f && consistentTap(x0 + k % 2, y0 + k / 2)) {
          rec.mask |= uint16_t(1u << k);
          weightSum += bilinear[k];
        }
      }
      if (weightSum >= settings.minWeightSum) {
        rec.footprint = ReprojectionFootprint::Bilinear2x2;
        rec.x0 = x0;
        rec.y0 = y0;
        for (int k = 0; k < 4; ++k)
          rec.weights[k] = (rec.mask >> k) & 1u ? bilinear[k] / weightSum : 0.0f;
        read += std::popcount(rec.mask);
        continue;
      }
      rec.mask = 0;
      if (!settings.fallback3x3) continue;

      // 3x3 around the pixel that contains the reprojected position; consistent taps averaged.
      const int cx = int(std::floor(px)), cy = int(std::floor(py));
      tested += 9;
      for (int k = 0; k < 9; ++k)
        if (consistentTap(cx - 1 + k % 3, cy - 1 + k / 3)) rec.mask |= uint16_t(1u << k);
      const int count = std::popcount(rec.mask);
      if (count == 0) continue;  // disocclusion
      rec.footprint = ReprojectionFootprint::Box3x3;
      rec.x0 = cx - 1;
      rec.y0 = cy - 1;
      rec.weights[0] = 1.0f / float(count);
      read += count;
    }
    testedTaps_.set(y, tested);
    readTaps_.set(y, read);
  });
}

float Reprojection::sample(size_t i, const float* plane) const {
  return HistoryTaps(records_[i], width_).apply(plane);
}

void Reprojection::resample(const Image& history, Image& out, float fillDisoccluded) const {
  if (history.width() != width_ || history.height() != height_ || !out.sameShape(history))
    throw Error("reprojection: resample() images must match the reprojection size and each other");
  parallelRows(height_, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      const size_t i = size_t(y) * size_t(width_) + size_t(x);
      if (!valid(i)) {
        for (int c = 0; c < history.channels(); ++c) out.plane(c)[i] = fillDisoccluded;
        continue;
      }
      const HistoryTaps taps(records_[i], width_);
      for (int c = 0; c < history.channels(); ++c) out.plane(c)[i] = taps.apply(history.plane(c));
    }
  });
}

double Reprojection::validFraction() const {
  if (records_.empty()) return 0.0;
  size_t n = size_t(std::count_if(records_.begin(), records_.end(), [](const auto& r) {
    return r.footprint != ReprojectionFootprint::Disoccluded;
  }));
  return double(n) / double(records_.size());
}

}  // namespace arena
