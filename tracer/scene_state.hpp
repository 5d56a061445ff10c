#pragma once
// A scene evaluated at one frame: camera, object-to-world matrices, light values. Two frames with
// equal state hashes render identical images, so they share one reference.
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "core/camera.hpp"
#include "tracer/scene.hpp"

namespace arena {

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
MeshData makeMesh(Shape shape, const std::string& objFile);
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
