#include "tracer/scene_state.hpp"

#include <tiny_obj_loader.h>

#include <cmath>
#include <cstring>

#include "core/error.hpp"
#include "core/hash.hpp"
#include "tracer/asset.hpp"

namespace arena {

namespace {

void addQuad(MeshData& m, glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d, glm::vec3 n) {
  // a,b,c,d counter-clockwise seen from the side n points to.
  unsigned base = unsigned(m.positions.size());
  for (glm::vec3 p : {a, b, c, d}) {
    m.positions.push_back(p);
    m.normals.push_back(n);
  }
  m.triangles.push_back({base, base + 1, base + 2});
  m.triangles.push_back({base, base + 2, base + 3});
}

}  // namespace

MeshData parseObjMesh(const std::string& text, const std::string& file) {
  tinyobj::ObjReader reader;
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  // Geometry only: a mesh object takes the scene's material, so no .mtl is read.
  if (!reader.ParseFromString(text, "", config))
    throw Error(file + ": cannot read OBJ: " + reader.Error());
  const auto& attrib = reader.GetAttrib();
  MeshData m;
  for (const auto& shape : reader.GetShapes()) {
    const auto& idx = shape.mesh.indices;
    for (size_t f = 0; f + 2 < idx.size(); f += 3) {
      glm::vec3 p[3];
      for (int k = 0; k < 3; ++k) {
        // Indices as size_t: 3 * index in int overflows for an index near INT_MAX (a malformed
        // "f 2147483647 ..."; UBSan found it through the asset fuzz test).
        const int vi = idx[f + k].vertex_index;
        if (vi < 0 || 3 * size_t(vi) + 2 >= attrib.vertices.size())
          throw Error(file + ": face " + std::to_string(f / 3) + " references a missing vertex");
        const size_t v = 3 * size_t(vi);
        p[k] = {attrib.vertices[v], attrib.vertices[v + 1], attrib.vertices[v + 2]};
      }
      const glm::vec3 fn = directionOr(glm::cross(p[1] - p[0], p[2] - p[0]), glm::vec3(0, 1, 0));
      unsigned base = unsigned(m.positions.size());
      for (int k = 0; k < 3; ++k) {
        const int ni = idx[f + k].normal_index;
        glm::vec3 n = fn;
        // A zero or non-finite normal ("vn 0 0 0", "vn 1e39 0 0") has no direction: the face's
        // normal is used, as for a corner without one.
        if (ni >= 0 && 3 * size_t(ni) + 2 < attrib.normals.size()) {
          const size_t i = 3 * size_t(ni);
          n = directionOr({attrib.normals[i], attrib.normals[i + 1], attrib.normals[i + 2]}, fn);
        }
        m.positions.push_back(p[k]);
        m.normals.push_back(n);
      }
      m.triangles.push_back({base, base + 1, base + 2});
    }
  }
  if (m.triangles.empty()) throw Error(file + ": OBJ file has no triangles");
  return m;
}

MeshData makeMesh(Shape shape) {
  MeshData m;
  const float h = 0.5f;
  switch (shape) {
    case Shape::Quad:
      addQuad(m, {-h, 0, -h}, {-h, 0, h}, {h, 0, h}, {h, 0, -h}, {0, 1, 0});
      break;
    case Shape::Box:
      addQuad(m, {-h, h, -h}, {-h, h, h}, {h, h, h}, {h, h, -h}, {0, 1, 0});      // +Y
      addQuad(m, {-h, -h, -h}, {h, -h, -h}, {h, -h, h}, {-h, -h, h}, {0, -1, 0});  // -Y
      addQuad(m, {h, -h, -h}, {h, h, -h}, {h, h, h}, {h, -h, h}, {1, 0, 0});       // +X
      addQuad(m, {-h, -h, -h}, {-h, -h, h}, {-h, h, h}, {-h, h, -h}, {-1, 0, 0});  // -X
      addQuad(m, {-h, -h, h}, {h, -h, h}, {h, h, h}, {-h, h, h}, {0, 0, 1});       // +Z
      addQuad(m, {-h, -h, -h}, {-h, h, -h}, {h, h, -h}, {h, -h, -h}, {0, 0, -1});  // -Z
      break;
    case Shape::Sphere: {
      const int rings = 24, segments = 48;
      for (int i = 0; i <= rings; ++i) {
        float theta = float(M_PI) * float(i) / rings;
        for (int j = 0; j <= segments; ++j) {
          float phi = 2.0f * float(M_PI) * float(j) / segments;
          glm::vec3 p(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
          m.positions.push_back(p);
          m.normals.push_back(p);
        }
      }
      for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
          unsigned a = unsigned(i * (segments + 1) + j), b = a + segments + 1;
          if (i != 0) m.triangles.push_back({a, a + 1, b});
          if (i != rings - 1) m.triangles.push_back({a + 1, b + 1, b});
        }
      break;
    }
    case Shape::Mesh:
    case Shape::Asset:
      throw Error("makeMesh: an OBJ or asset mesh comes from its object (makeMesh(const Object&))");
  }
  return m;
}

MeshData makeMesh(const Object& object) {
  if (object.shape == Shape::Mesh) {
    if (!object.mesh)
      throw Error("makeMesh: mesh object '" + object.name +
                  "' holds no mesh (loadScene parses it)");
    return *object.mesh;
  }
  if (object.shape != Shape::Asset) return makeMesh(object.shape);
  MeshData m = object.asset->mesh;
  if (object.material >= 0)
    m.triangleMaterials.clear();  // the override: the object's material everywhere
  else
    for (int& id : m.triangleMaterials) id += object.assetMaterialBase;
  return m;
}

uint64_t SceneState::hash() const {
  Hasher h;
  auto addBytes = [&](const void* p, size_t n) { h.add(std::string_view(static_cast<const char*>(p), n)); };
  addBytes(&camera.eye, sizeof(glm::vec3));
  addBytes(&camera.forward, sizeof(glm::vec3));
  addBytes(&camera.up, sizeof(glm::vec3));
  addBytes(&camera.tanHalfFovY, sizeof(float));
  for (const glm::mat4& m : toWorld) addBytes(&m, sizeof m);
  for (const LightValue& l : lights) {
    glm::vec3 radiance = l.color * l.intensity;
    addBytes(&radiance, sizeof radiance);
  }
  for (const auto& nodes : nodeMatrices)  // nothing for scenes without assets: hashes unchanged
    for (const glm::mat4& m : nodes) addBytes(&m, sizeof m);
  return h.value();
}

SceneState evaluateState(const Scene& scene, int frame, int width, int height) {
  SceneState s;
  CameraKey c = scene.camera.at(float(frame));
  s.camera = CameraState::lookAt(c.eye, c.target, c.up, c.fovYDegrees, width, height);
  for (const Object& o : scene.objects) {
    s.toWorld.push_back(o.transform.at(float(frame)).matrix());
    if (o.asset) {
      s.nodeMatrices.resize(s.toWorld.size());
      s.nodeMatrices.back() = o.asset->nodeMatrices(float(frame) / o.assetRef.fps);
    }
  }
  for (const Light& l : scene.lights) {
    s.toWorld.push_back(l.transform.at(float(frame)).matrix());
    s.lights.push_back(l.emission.at(float(frame)));
  }
  return s;
}

}  // namespace arena
