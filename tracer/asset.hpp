#pragma once
// Asset files -- OBJ with MTL, glTF 2.0 (.gltf/.glb) -- imported through assimp into one scene
// object: triangles with per-face materials, texture coordinates and shading normals, the node
// hierarchy, and node TRS animations. The mapping of each format's materials onto the tracer's
// (Lambert + GGX, metallic workflow) is documented in README.md ("Asset objects") and below.
#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <string>
#include <vector>

#include "tracer/scene.hpp"
#include "tracer/scene_state.hpp"

namespace arena {

// One node of the asset's hierarchy, parents before children. A node whose TRS the animation
// drives has keys; missing key lists hold the node's own (decomposed) value.
struct AssetNode {
  std::string name;
  int parent = -1;
  glm::mat4 local{1.0f};
  bool animated = false;
  std::vector<std::pair<float, glm::vec3>> translation, scale;  // (seconds, value)
  std::vector<std::pair<float, glm::quat>> rotation;
};

// Counts of what the loader dropped or ignored (each also a line of `warnings`).
struct AssetStats {
  size_t triangles = 0;               // loaded
  size_t degenerateTriangles = 0;     // zero area or repeated vertices: dropped
  size_t pointAndLinePrimitives = 0;  // dropped
  size_t missingTextures = 0;         // fell back to the material's factor
};

struct AssetData {
  std::string file;
  // Asset space (what the file's nodes produce) -> object space: the up-axis rotation and the
  // unit scale (AssetRef), applied above the root.
  glm::mat4 assetToObject{1.0f};
  std::vector<AssetNode> nodes;
  // Unindexed triangles (3 corners each) in their node's space: positions, normals, texcoords,
  // vertexNodes per corner; triangleMaterials indexes `materials`.
  MeshData mesh;
  std::vector<Material> materials;
  AssetStats stats;
  std::vector<std::string> warnings;  // "<what>: <count> (<fallback>)", one per kind
  std::string contentHash;  // the asset file, every file the importer opened, every texture

  // Node -> object-space matrices at the asset's time `seconds` (glTF: keys clamp at both ends).
  std::vector<glm::mat4> nodeMatrices(float seconds) const;
  // The time span of the animation (0 when static).
  float durationSeconds() const;
};

// Mesh and asset vertex coordinates (object space): beyond this a triangle's edge cross product
// (its normal and area, ~|v|^2) overflows float and the triangle would vanish from the render.
constexpr double kMaxMeshCoordinate = 1e18;
// Emitted radiance (the scene file's materials, lights and sky, and assets' emission) above this
// overflows float accumulators once multiplied by sample counts and squared for the references'
// variances.
constexpr float kMaxRadiance = 1e9f;

// Largest asset, side file (MTL, .bin) or texture file read; checked before reading.
constexpr uintmax_t kMaxAssetBytes = uintmax_t(256) << 20;

// Imports `path` (resolved) as AssetRef describes. Throws an Error naming the file and what is
// wrong: unreadable or oversized file, unsupported format or feature (skinning, morph targets),
// non-finite vertices, no triangles. Missing textures, degenerate triangles and ignored features
// are documented fallbacks, counted in stats and warnings.
AssetData loadAsset(const std::string& path, const AssetRef& ref);

}  // namespace arena
