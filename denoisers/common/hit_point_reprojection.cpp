#include "denoisers/common/hit_point_reprojection.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "core/error.hpp"
#include "denoisers/common/gpu_traffic.hpp"

namespace arena {

const ParamTable<std::string>& hitDistanceParams() {
  static const ParamTable<std::string> table = ParamTable<std::string>().choice(
      "hitDistance", [](std::string& channel) -> std::string& { return channel; }, "sampled",
      {{"sampled", "specHitDist"}, {"mirror", "specHitDistMirror"}},
      "specular hit distance: the 1-spp sample's own ray length (what a real tracer has; the "
      "talk, NRD) or the noise-free mirror ray (an oracle)");
  return table;
}

glm::vec3 virtualHitPoint(const CameraState& camera, glm::vec3 surface, float hitDist) {
  const glm::vec3 toSurface = surface - camera.eye;
  const float viewDistance = glm::length(toSurface);
  if (viewDistance <= 0.0f) return surface;
  // The talk: "ray_length = primary_ray_length + reflected_ray_length; vPos *= ray_length".
  return camera.eye + toSurface * ((viewDistance + std::max(hitDist, 0.0f)) / viewDistance);
}

void HitPointReprojection::setup(int width, int height) {
  width_ = width;
  height_ = height;
  records_.assign(size_t(width) * size_t(height), Record{});
}

void HitPointReprojection::invalidateAll() {
  std::fill(records_.begin(), records_.end(), Record{});
}

void HitPointReprojection::compute(const GBufferView& current, const float* hitDistance,
                                   const CameraState& camera, const CameraState& previousCamera,
                                   const GBufferView& previous,
                                   const HitPointReprojectionSettings& settings) {
  if (current.width != width_ || current.height != height_ || previous.width != width_ ||
      previous.height != height_)
    throw Error("hit-point reprojection: frame size differs from the size given to setup()");
  if (!current.depth || !current.normal[0] || !current.meshId || !current.position[0] ||
      !hitDistance || !previous.depth || !previous.normal[0] || !previous.meshId)
    throw Error("hit-point reprojection: needs depth, normal, meshId, position and specHitDist");
  const int w = width_, h = height_;
  if (gpu::recording()) {  // the virtual point, then its 2x2 footprint tested in the previous frame
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    for (const GpuBuffer& b : {kDepth, kNormal, kMeshId, kPosition, kHitDistance})
      gpu::read(b, w, h, 1);
    for (const GpuBuffer& b : {kPreviousDepth, kPreviousNormal, kPreviousMeshId})
      gpu::read(b, w, h, 4);
    gpu::write(kVirtualRecord, w, h);
  }
  parallelRows(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      Record& rec = records_[p];
      rec = Record{};
      if (current.isSky(p)) continue;
      const glm::vec3 surface(current.position[0][p], current.position[1][p],
                              current.position[2][p]);
      const glm::vec3 n(current.normal[0][p], current.normal[1][p], current.normal[2][p]);
      glm::vec2 pixel;
      if (!previousCamera.project(virtualHitPoint(camera, surface, hitDistance[p]), pixel))
        continue;
      if (!std::isfinite(pixel.x) || !std::isfinite(pixel.y) || std::abs(pixel.x) > 1e7f ||
          std::abs(pixel.y) > 1e7f)
        continue;
      rec.px = pixel.x;
      rec.py = pixel.y;
      const float planeLimit = settings.planeThreshold * std::abs(current.depth[p]);
      auto consistent = [&](int qx, int qy) {
        if (qx < 0 || qy < 0 || qx >= w || qy >= h) return false;  // off-screen
        const size_t q = size_t(qy) * size_t(w) + size_t(qx);
        if (previous.meshId[q] != current.meshId[p] || previous.meshId[q] < 0.0f) return false;
        const glm::vec3 nq(previous.normal[0][q], previous.normal[1][q], previous.normal[2][q]);
        if (glm::dot(n, nq) < settings.normalThreshold) return false;
        // The previous surface point at q, from the previous camera and its linear view depth.
        const glm::vec3 xq =
            previousCamera.pointAtDepth(float(qx) + 0.5f, float(qy) + 0.5f, previous.depth[q]);
        return std::abs(glm::dot(n, xq - surface)) <= planeLimit;
      };
      const float fx = pixel.x - 0.5f, fy = pixel.y - 0.5f;
      const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
      const float tx = fx - float(x0), ty = fy - float(y0);
      const float bilinear[4] = {(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty, tx * ty};
      float weightSum = 0;
      uint8_t mask = 0;
      for (int k = 0; k < 4; ++k)
        if (bilinear[k] > 0.0f && consistent(x0 + k % 2, y0 + k / 2)) {
          mask |= uint8_t(1u << k);
          weightSum += bilinear[k];
        }
      if (weightSum < settings.minWeightSum) continue;
      rec.mask = mask;
      rec.x0 = x0;
      rec.y0 = y0;
      for (int k = 0; k < 4; ++k)
        rec.weights[k] = (mask >> k) & 1u ? bilinear[k] / weightSum : 0.0f;
    }
  });
}

float HitPointReprojection::sample(size_t i, const float* plane) const {
  return taps(i).apply(plane);
}

HistoryLanes HitPointReprojection::lanes(size_t i, int count) const {
  static_assert(sizeof(Record) == 9 * sizeof(int32_t) && offsetof(Record, mask) == 8 &&
                    offsetof(Record, weights) == 20,
                "HistoryLanes gathers the record's fields as int32 words");
  HistoryLanes lanes;
  lanes.width = width_;
  const LaneMask8 inRow = laneIndex(Lanes8{}) < count;
  const LaneMask8 mask = gatherIntLanes(reinterpret_cast<const int32_t*>(&records_[i]),
                                        laneIndex(Lanes8{}) * 9 + 2, inRow) &
                         0xFF;
  lanes.gatherBilinear(&records_[i], 9, 8, 5, inRow & (mask != 0));
  return lanes;
}

HistoryTaps HitPointReprojection::taps(size_t i) const {
  const Record& rec = records_[i];
  HistoryTaps taps;
  for (int k = 0; k < 4; ++k)
    if ((rec.mask >> k) & 1u) {
      taps.index[taps.count] = size_t(rec.y0 + k / 2) * size_t(width_) + size_t(rec.x0 + k % 2);
      taps.weight[taps.count++] = rec.weights[k];
    }
  return taps;
}

double HitPointReprojection::validFraction() const {
  if (records_.empty()) return 0.0;
  return double(std::count_if(records_.begin(), records_.end(),
                              [](const Record& r) { return r.mask != 0; })) /
         double(records_.size());
}

}  // namespace arena
