#include "denoisers/common/reprojection.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>

#include "core/consistency.hpp"
#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "denoisers/common/gpu_traffic.hpp"

namespace arena {

const ParamTable<ReprojectionSettings>& reprojectionParams() {
  using S = ReprojectionSettings;
  static const ParamTable<S> table =
      ParamTable<S>()
          .real("depthThreshold", &S::depthThreshold, 10, 0, 1e6,
                "reprojection rejects a tap when |z_prev - z| / (fwidth(z) + 0.01) exceeds "
                "this (Falcor 10)")
          .real("normalThreshold", &S::normalThreshold, 16, 0, 1e6,
                "reprojection rejects a tap when |n - n_prev| / (fwidth(n) + 0.01) exceeds "
                "this (Falcor 16)");
  return table;
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

  // The 2x2 test runs eight pixels at a time (gathered previous-frame taps); the per-pixel records
  // and the rare 3x3 fallback are then written lane by lane.
  parallelRows(h, [&](int y) {
    int64_t tested = 0, read = 0;
    for (int xBlock = 0; xBlock < w; xBlock += 8) {
      const size_t p = size_t(y) * size_t(w) + size_t(xBlock);
      const LaneMask8 x = laneIndex(Lanes8{}) + xBlock;
      const LaneMask8 inRow = x < w;
      const Lanes8 id = loadLanes(current.meshId + p, inRow);
      // Continuous previous-frame position; its bilinear taps surround (px - 0.5, py - 0.5).
      const Lanes8 px = (toFloat(x) + 0.5f) + loadLanes(current.motion[0] + p, inRow);
      const Lanes8 py = (float(y) + 0.5f) + loadLanes(current.motion[1] + p, inRow);
      // Not the sky, and a finite position on the way (NaN compares false).
      const LaneMask8 surface = inRow & (id >= 0.0f);
      const LaneMask8 ok = surface & (absFloat(px) <= 1e7f) & (absFloat(py) <= 1e7f);

      // This pixel's surface as the previous frame should show it (the depth camera-corrected).
      Lanes8 depth = loadLanes(current.depth + p, inRow);
      Lanes8 normal[3];
      for (size_t c = 0; c < 3; ++c) normal[c] = loadLanes(current.normal[c] + p, inRow);
      if (correctDepth) {
        Lanes8 world[3];
        for (size_t c = 0; c < 3; ++c) world[c] = loadLanes(current.position[c] + p, inRow);
        depth = previousViewDepth(depth, world, *camera, *previousCamera);
      }
      // Falcor's depth derivative: max(|dz/dx|, |dz/dy|) (SVGFPackLinearZAndNormal), not HLSL's
      // fwidth sum (issue 15, item 12).
      const Lanes8 fwidthDepth =
          maxFloat(absFloat(loadLanes(derivatives.plane(kDepthDx) + p, inRow)),
                   absFloat(loadLanes(derivatives.plane(kDepthDy) + p, inRow)));
      const Lanes8 fwidthNormal = loadLanes(derivatives.plane(kNormalFwidth) + p, inRow);

      // SVGF §4.1: each tap is tested separately for depth, normal and mesh id, by the one
      // definition the metrics use too (core/consistency.hpp). A zero-weight tap is never read,
      // so an exact integer shift reads exactly one pixel.
      const Lanes8 fx = px - 0.5f, fy = py - 0.5f;
      const Lanes8 floorX = floorLanes(fx), floorY = floorLanes(fy);
      const LaneMask8 x0 = truncateToInt(selectFloat(ok, floorX, Lanes8{}));
      const LaneMask8 y0 = truncateToInt(selectFloat(ok, floorY, Lanes8{}));
      const Lanes8 tx = fx - floorX, ty = fy - floorY;
      const Lanes8 bilinear[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
      Lanes8 weightSum{};
      LaneMask8 passed[4];
      for (int k = 0; k < 4; ++k) {
        const LaneMask8 qx = x0 + k % 2, qy = y0 + k / 2;
        const LaneMask8 inside =
            ok & (bilinear[k] > 0.0f) & (qx >= 0) & (qy >= 0) & (qx < w) & (qy < h);
        const LaneMask8 q = qy * w + qx;
        Lanes8 previousNormal[3];
        for (size_t c = 0; c < 3; ++c)
          previousNormal[c] = gatherLanes(previous.normal[c], q, inside);
        passed[k] = inside & consistent(depth, normal, id, fwidthDepth, fwidthNormal,
                                        gatherLanes(previous.depth, q, inside), previousNormal,
                                        gatherLanes(previous.meshId, q, inside), thresholds);
        weightSum += selectFloat(passed[k], bilinear[k], Lanes8{});
      }

      for (int lane = 0; lane < 8 && xBlock + lane < w; ++lane) {
        ReprojectionRecord& rec = records_[p + size_t(lane)];
        rec = ReprojectionRecord{};
        if (!ok[lane]) continue;
        tested += 4;
        if (weightSum[lane] >= settings.minWeightSum) {
          rec.footprint = ReprojectionFootprint::Bilinear2x2;
          rec.x0 = x0[lane];
          rec.y0 = y0[lane];
          for (int k = 0; k < 4; ++k)
            if (passed[k][lane]) {
              rec.mask |= uint16_t(1u << k);
              rec.weights[k] = bilinear[k][lane] / weightSum[lane];
            }
          read += std::popcount(rec.mask);
          continue;
        }
        if (!settings.fallback3x3) continue;

        // 3x3 around the pixel that contains the reprojected position; consistent taps averaged.
        const SurfaceSample surfaceSample{
            depth[lane], {normal[0][lane], normal[1][lane], normal[2][lane]}, int(id[lane])};
        const SurfaceDerivatives fwidth{fwidthDepth[lane], fwidthNormal[lane]};
        const int cx = int(std::floor(px[lane])), cy = int(std::floor(py[lane]));
        tested += 9;
        for (int k = 0; k < 9; ++k) {
          const int qx = cx - 1 + k % 3, qy = cy - 1 + k / 3;
          if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;  // off-screen
          const size_t q = size_t(qy) * size_t(w) + size_t(qx);
          const SurfaceSample tap{
              previous.depth[q],
              {previous.normal[0][q], previous.normal[1][q], previous.normal[2][q]},
              int(previous.meshId[q])};
          if (consistent(surfaceSample, fwidth, tap, thresholds)) rec.mask |= uint16_t(1u << k);
        }
        const int count = std::popcount(rec.mask);
        if (count == 0) continue;  // disocclusion
        rec.footprint = ReprojectionFootprint::Box3x3;
        rec.x0 = cx - 1;
        rec.y0 = cy - 1;
        rec.weights[0] = 1.0f / float(count);
        read += count;
      }
    }
    testedTaps_.set(y, tested);
    readTaps_.set(y, read);
  });
  if (gpu::recording()) {  // the tests of the taps actually tested, one record written per pixel
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    for (const GpuBuffer& b : {kDepth, kNormal, kMeshId, kMotion, kDerivatives})
      gpu::read(b, w, h, 1);
    if (correctDepth) gpu::read(kPosition, w, h, 1);
    const double taps = testedTapsPerPixel();
    for (const GpuBuffer& b : {kPreviousDepth, kPreviousNormal, kPreviousMeshId})
      gpu::read(b, w, h, taps);
    gpu::write(kRecord, w, h);
  }
}

HistoryLanes Reprojection::lanes(size_t i, int count) const {
  static_assert(sizeof(ReprojectionRecord) == 7 * sizeof(int32_t) &&
                    offsetof(ReprojectionRecord, mask) == 8 &&
                    offsetof(ReprojectionRecord, footprint) == 10 &&
                    offsetof(ReprojectionRecord, weights) == 12,
                "HistoryLanes gathers the record's fields as int32 words");
  HistoryLanes lanes;
  lanes.width = width_;
  const LaneMask8 inRow = laneIndex(Lanes8{}) < count;
  // The footprint is the third byte of word 2 (mask in the low 16 bits).
  const LaneMask8 footprint = (gatherIntLanes(reinterpret_cast<const int32_t*>(&records_[i]),
                                              laneIndex(Lanes8{}) * 7 + 2, inRow) >>
                               16) &
                              0xFF;
  lanes.gatherBilinear(&records_[i], 7, 16, 3,
                       inRow & (footprint == int(ReprojectionFootprint::Bilinear2x2)));
  lanes.box = inRow & (footprint == int(ReprojectionFootprint::Box3x3));
  if (anyLane(lanes.box)) {
    lanes.valid |= lanes.box;
    lanes.boxRecords = &records_[i];
  }
  return lanes;
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
