#pragma once
// A scene evaluated at one frame: camera, object-to-world matrices, light values. Two frames with
// equal state hashes render identical images, so they share one reference.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "core/camera.hpp"
#include "tracer/scene.hpp"

namespace arena {

// v / |v|, or `fallback` when v has no direction (zero or not finite). glm::normalize squares v:
// a file normal of 1e30 or the cross product of a triangle with corners near kMaxMeshCoordinate
// overflows and becomes 0 or NaN, so such a v is scaled by its largest component first (ordinary
// vectors take glm::normalize's bits unchanged).
inline glm::vec3 directionOr(glm::vec3 v, glm::vec3 fallback) {
  if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) return fallback;
  const float squared = glm::dot(v, v);
  if (std::isfinite(squared) && squared > 0.0f) return glm::normalize(v);
  const float largest = std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
  if (!(largest > 0.0f)) return fallback;
  return glm::normalize(v / largest);
}

// Local-space triangle mesh of a shape. Quads lie in the XZ plane ([-0.5, 0.5]^2, front +Y); boxes
// are the unit cube centred at 0; spheres have radius 1 (smooth shading normals).
struct MeshData {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;  // per vertex
  std::vector<glm::uvec3> triangles;
  // Assets only (empty otherwise): texture coordinates and asset node per vertex (its position is
  // in that node's space, SceneState::nodeMatrices), scene material per triangle.
  std::vector<glm::vec2> texcoords;
  std::vector<uint32_t> vertexNodes;
  std::vector<int> triangleMaterials;
};
// A built-in shape's unit mesh (Quad, Box, Sphere).
MeshData makeMesh(Shape shape);
// An OBJ file's triangles (`text`: its bytes; `file` names it in errors), normals per corner (the
// face's where the file gives none or an unusable one). Throws an Error naming the file.
MeshData parseObjMesh(const std::string& text, const std::string& file);
// The object's local mesh: its shape's, or its asset's with triangleMaterials mapped to the
// scene's materials (all the override when the object names one).
MeshData makeMesh(const Object& object);

struct SceneState {
  CameraState camera;
  std::vector<glm::mat4> toWorld;  // objects first, then lights (index = meshId)
  std::vector<LightValue> lights;
  // Per object (index = meshId): asset node -> object space matrices at this frame (the asset's
  // time frame / fps); empty for shapes.
  std::vector<std::vector<glm::mat4>> nodeMatrices;
  uint64_t hash() const;
};

SceneState evaluateState(const Scene& scene, int frame, int width, int height);

}  // namespace arena
