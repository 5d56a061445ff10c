#pragma once
// The scene description: a small JSON format that models no more than the failure-provoking scenes
// need (see scenes/*.json). Parsing is strict: unknown fields, wrong types, dangling material
// names and keyframes beyond the sequence are errors naming the file and JSON path.
#include <cstdint>
#include <glm/glm.hpp>
#include <memory>
#include <string>
#include <vector>

#include "core/sequence.hpp"
#include "tracer/texture.hpp"

namespace arena {

// A keyframed value. Keys are strictly increasing in frame; values interpolate linearly, and a key
// with "step": true switches instantly at its frame (holding the previous value until then).
template <class T>
struct Track {
  struct Key {
    int frame = 0;
    bool step = false;
    T value{};
  };
  std::vector<Key> keys;

  T at(float frame) const {
    if (keys.empty()) return T{};
    if (frame <= float(keys.front().frame)) return keys.front().value;
    for (size_t i = 0; i + 1 < keys.size(); ++i) {
      const Key& a = keys[i];
      const Key& b = keys[i + 1];
      if (frame < float(b.frame)) {
        if (b.step) return a.value;
        float s = (frame - float(a.frame)) / float(b.frame - a.frame);
        return lerp(a.value, b.value, s);
      }
    }
    return keys.back().value;
  }

  // Whether the value jumps at `frame`: a key there with "step": true after an earlier key (the
  // first key's step has nothing to switch from; `at` holds its value before it).
  bool stepsAt(int frame) const {
    for (size_t i = 1; i < keys.size(); ++i)
      if (keys[i].frame == frame) return keys[i].step;
    return false;
  }
};

struct Transform {
  glm::vec3 translate{0.0f};
  glm::vec3 rotateDegrees{0.0f};  // applied X, then Y, then Z
  glm::vec3 scale{1.0f};
  glm::mat4 matrix() const;
};
Transform lerp(const Transform& a, const Transform& b, float s);

struct CameraKey {
  glm::vec3 eye{0, 0, 5}, target{0}, up{0, 1, 0};
  float fovYDegrees = 45.0f;
};
CameraKey lerp(const CameraKey& a, const CameraKey& b, float s);

struct LightValue {
  float intensity = 1.0f;
  glm::vec3 color{1.0f};
};
LightValue lerp(const LightValue& a, const LightValue& b, float s);

struct Material {
  std::string name;
  glm::vec3 albedo{0.8f};
  bool checker = false;  // procedural checker in object space: albedo / checkerAlbedo
  glm::vec3 checkerAlbedo{0.2f};
  float checkerScale = 4.0f;  // cells per object-space unit
  float roughness = 1.0f;     // perceptual; GGX alpha = roughness^2
  float metallic = 0.0f;
  float specular = 0.04f;    // dielectric F0 (0 gives a pure Lambert surface)
  glm::vec3 emission{0.0f};  // emitted radiance
  // Asset materials only (tracer/asset.hpp): the textures multiply the factors above. Base colour
  // and emission are sRGB-decoded; metallicRoughness is linear (glTF: G = roughness, B = metallic).
  TextureRef baseColorTexture, metallicRoughnessTexture, emissionTexture;
  bool textured() const {
    return bool(baseColorTexture) || bool(metallicRoughnessTexture) || bool(emissionTexture);
  }
};

enum class Shape { Quad, Box, Sphere, Mesh, Asset };

// An asset file placed as an object ("asset": {...} in the scene file; README "Asset objects").
struct AssetRef {
  std::string file;         // resolved path ("assets:x" -> $ARENA_ASSET_DIR/x)
  float unitMeters = 1.0f;  // metres per asset unit; scene units are metres
  char upAxis = 'y';        // the asset's up axis, 'y' or 'z'; the scene's is +Y
  float fps = 30.0f;        // asset time t seconds plays at scene frame t * fps
};
struct AssetData;
struct MeshData;

struct Object {
  std::string name;
  Shape shape = Shape::Quad;
  std::string meshFile;  // Shape::Mesh: absolute path of an OBJ file
  // Shape::Mesh: that file as loadScene read it, the bytes the scene's hash covers; the renderer
  // never reads the file again (an edit during a study would render under the old hash).
  std::shared_ptr<const MeshData> mesh;
  // The material; for an asset, the override of all its materials, or -1 to use the asset's own,
  // which are scene.materials[assetMaterialBase ..] in the asset's order.
  int material = 0;
  AssetRef assetRef;                       // Shape::Asset
  std::shared_ptr<const AssetData> asset;  // Shape::Asset: the imported file
  int assetMaterialBase = 0;
  Track<Transform> transform;
};

// Where a model came from ("credits" in the scene file), carried into the run's results.
struct Credit {
  std::string asset, author, license, source;
};

// Area lights are one-sided quads (emitting along their +Y axis) or spheres; their radiance is
// colour * intensity and they are sampled by next-event estimation.
struct Light {
  std::string name;
  Shape shape = Shape::Quad;
  Track<Transform> transform;
  Track<LightValue> emission;
};

struct SceneEvent {
  int frame = 0;
  EventKind kind = EventKind::LightOff;
  std::string what;  // name of the light/object concerned
};

enum class ReferenceEstimator { Path, Bidirectional };
// A bidirectional reference keeps both paths' vertices on the stack: max_bounces at most this.
constexpr int kMaxBidirectionalBounces = 16;

struct Scene {
  std::string name;     // file stem
  std::string file;     // path it was loaded from
  std::string purpose;  // one sentence: the failure this scene provokes
  int width = 320, height = 180, frames = 32;
  uint32_t seed = 1;
  int maxBounces = 4;
  // How the references estimate each pixel (the 1-spp frames are always path traced):
  // "path" (unidirectional, next-event estimation) or "bidirectional" (docs/references.md).
  ReferenceEstimator referenceEstimator = ReferenceEstimator::Path;
  glm::vec3 skyTop{0.0f}, skyBottom{0.0f};
  Track<CameraKey> camera;
  std::vector<Material> materials;
  std::vector<Object> objects;
  std::vector<Light> lights;
  std::vector<SceneEvent> events;
  std::vector<Credit> credits;
  // Documented fallbacks taken while loading assets, counted ("<file>: <what>: <count> ..."):
  // missing textures, dropped degenerate triangles, ignored features. Recorded in the results.
  std::vector<std::string> warnings;
  std::string contentHash;  // scene file bytes + referenced mesh and asset files and textures

  // The meshId layer's value for the object or light named `what` (objects first, then lights, in
  // file order, as the tracer numbers them); -1 when nothing has that name.
  int meshIdOf(const std::string& what) const {
    for (size_t i = 0; i < objects.size(); ++i)
      if (objects[i].name == what) return int(i);
    for (size_t i = 0; i < lights.size(); ++i)
      if (lights[i].name == what) return int(objects.size() + i);
    return -1;
  }
};

// Limits of the format (scene files naming more are errors): per-axis resolution, frame count
// and the size of a referenced mesh file.
constexpr int kMaxSceneResolution = 16384;
constexpr int kMaxSceneFrames = 100000;
constexpr uintmax_t kMaxMeshBytes = uintmax_t(256) << 20;

Scene loadScene(const std::string& path);
// The same from the file's text; `path` names the file in errors and anchors relative mesh paths.
Scene parseScene(const std::string& text, const std::string& path);
// Scenes shipped in scenes/ (sorted by name).
std::vector<std::string> listSceneFiles(const std::string& scenesDir);
std::string defaultScenesDir();
// Where "assets:" paths point: $ARENA_ASSET_DIR, else <repo>/cache/assets (filled by
// scripts/setup.sh, never committed).
std::string assetCacheDir();

}  // namespace arena
