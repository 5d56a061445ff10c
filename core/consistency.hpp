#pragma once
// The reprojection consistency test, defined once for everyone who follows a surface from one
// frame to the previous: the denoisers' reprojection and the warped-flicker metric. A
// previous-frame tap is consistent with the current pixel when it shows the same mesh at a
// consistent depth and normal (SVGF sec. 4.1; Falcor's SVGF thresholds).
#include <glm/glm.hpp>

#include "core/camera.hpp"
#include "core/fast_math.hpp"
#include "core/image.hpp"

namespace arena {

struct ConsistencyThresholds {
  // Falcor SVGFReproject: reject when |z_prev - z| / (fwidth(z) + 1e-2) > 10 ...
  float depth = 10.0f;
  // ... or when distance(n, n_prev) / (fwidth(n) + 1e-2) > 16.
  float normal = 16.0f;
};

// Screen-space derivative magnitudes at the current pixel: fwidth(z) = |dz/dx| + |dz/dy| (one-sided
// differences with neighbours of the same mesh), and the same for the normal's length of change.
struct SurfaceDerivatives {
  float depth = 0, normal = 0;
};
SurfaceDerivatives surfaceDerivatives(const Image& depth, const Image& normal, const Image& meshId,
                                      int x, int y);

struct SurfaceSample {
  float depth;
  glm::vec3 normal;
  int meshId;
};
inline SurfaceSample surfaceAt(const Image& depth, const Image& normal, const Image& meshId, int x,
                               int y) {
  return {depth.at(x, y),
          {normal.at(x, y, 0), normal.at(x, y, 1), normal.at(x, y, 2)},
          int(meshId.at(x, y))};
}

// The definitions, over a lane type F of core/fast_math.hpp (float for one pixel): the same
// operations in the same order either way, so every caller gets the same answer.

// camera.viewDepth(world): (world - eye) . forward.
template <class F>
inline F viewDepth(const F world[3], const CameraState& camera) {
  return (world[0] - camera.eye.x) * camera.forward.x +
         (world[1] - camera.eye.y) * camera.forward.y +
         (world[2] - camera.eye.z) * camera.forward.z;
}
template <class F>
inline F previousViewDepth(F depth, const F world[3], const CameraState& camera,
                           const CameraState& previousCamera) {
  return depth + (viewDepth(world, previousCamera) - viewDepth(world, camera));
}

// Consistent (true, or an all-ones lane) when the ids are equal and not the sky's (ids are
// integers stored as floats; truncated as an int conversion would), and neither the depth nor the
// normal moved past its threshold relative to fwidth + 1e-2.
template <class F>
inline auto consistent(F currentDepth, const F currentNormal[3], F currentId, F fwidthDepth,
                       F fwidthNormal, F previousDepth, const F previousNormal[3], F previousId,
                       const ConsistencyThresholds& t) {
  const auto id = truncateToInt(currentId), previousIdInt = truncateToInt(previousId);
  const F dx = previousNormal[0] - currentNormal[0], dy = previousNormal[1] - currentNormal[1],
          dz = previousNormal[2] - currentNormal[2];
  const F normalDistance = sqrtLanes(dx * dx + dy * dy + dz * dz);
  const auto depthFar = absFloat(previousDepth - currentDepth) / (fwidthDepth + 1e-2f) > t.depth;
  const auto normalFar = normalDistance / (fwidthNormal + 1e-2f) > t.normal;
  return (id >= 0) & (id == previousIdInt) & (depthFar == 0) & (normalFar == 0);
}

// The view depth that the surface point at world position `world`, seen now at view depth `depth`,
// had from the previous camera: z + previousCamera.viewDepth(x) - camera.viewDepth(x). A camera
// moving along its axis changes every depth, so a previous-frame tap must be compared with this,
// not with the current depth (Falcor's G-buffer stores the previous clip-space depth for the same
// reason). Callers that know both cameras and the position pass it as `current.depth` below; the
// others (a still camera, or no position layer) pass the current depth.
inline float previousViewDepth(float depth, glm::vec3 world, const CameraState& camera,
                               const CameraState& previousCamera) {
  const float position[3] = {world.x, world.y, world.z};
  return previousViewDepth(depth, position, camera, previousCamera);
}

// `current.depth` is the depth the previous frame should show there (see previousViewDepth).
inline bool consistent(const SurfaceSample& current, const SurfaceDerivatives& d,
                       const SurfaceSample& previous, const ConsistencyThresholds& t = {}) {
  const float currentNormal[3] = {current.normal.x, current.normal.y, current.normal.z};
  const float previousNormal[3] = {previous.normal.x, previous.normal.y, previous.normal.z};
  return consistent(current.depth, currentNormal, float(current.meshId), d.depth, d.normal,
                    previous.depth, previousNormal, float(previous.meshId), t);
}

}  // namespace arena
