#pragma once
// The reprojection consistency test, defined once for everyone who follows a surface from one
// frame to the previous: the denoisers' reprojection and the warped-flicker metric. A previous-frame
// tap is consistent with the current pixel when it shows the same mesh at a consistent depth and
// normal (SVGF sec. 4.1; Falcor's SVGF thresholds).
#include <glm/glm.hpp>

#include "core/camera.hpp"
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
SurfaceDerivatives surfaceDerivatives(const Image& depth, const Image& normal, const Image& meshId, int x, int y);

struct SurfaceSample {
  float depth;
  glm::vec3 normal;
  int meshId;
};
inline SurfaceSample surfaceAt(const Image& depth, const Image& normal, const Image& meshId, int x, int y) {
  return {depth.at(x, y), {normal.at(x, y, 0), normal.at(x, y, 1), normal.at(x, y, 2)}, int(meshId.at(x, y))};
}

// The view depth that the surface point at world position `world`, seen now at view depth `depth`,
// had from the previous camera: z + previousCamera.viewDepth(x) - camera.viewDepth(x). A camera
// moving along its axis changes every depth, so a previous-frame tap must be compared with this,
// not with the current depth (Falcor's G-buffer stores the previous clip-space depth for the same
// reason). Callers that know both cameras and the position pass it as `current.depth` below; the
// others (a still camera, or no position layer) pass the current depth.
inline float previousViewDepth(float depth, glm::vec3 world, const CameraState& camera,
                               const CameraState& previousCamera) {
  return depth + (previousCamera.viewDepth(world) - camera.viewDepth(world));
}

// `current.depth` is the depth the previous frame should show there (see previousViewDepth).
inline bool consistent(const SurfaceSample& current, const SurfaceDerivatives& d, const SurfaceSample& previous,
                       const ConsistencyThresholds& t = {}) {
  if (current.meshId < 0 || current.meshId != previous.meshId) return false;
  if (std::abs(previous.depth - current.depth) / (d.depth + 1e-2f) > t.depth) return false;
  if (glm::length(previous.normal - current.normal) / (d.normal + 1e-2f) > t.normal) return false;
  return true;
}

}  // namespace arena
