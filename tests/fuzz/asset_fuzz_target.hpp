#pragma once
// The asset importers' fuzz contract, shared by the libFuzzer target (asset_fuzzer.cpp, clang only)
// and the deterministic mutation test that always runs (tests/asset_fuzz_test.cpp): any bytes, as an
// asset object's OBJ + MTL or glTF (+ .bin) or .glb (tracer/asset.cpp, assimp) or as a mesh
// object's OBJ (tracer/scene_state.cpp, tinyobjloader), either load into geometry the tracer can
// use or are rejected with an arena::Error naming the file. Any other exception, a crash, a hang
// or a sanitizer report is a bug. The files go through the scene parser, as a scene places them.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.hpp"
#include "tracer/asset.hpp"
#include "tracer/scene.hpp"
#include "tracer/scene_state.hpp"
#include "tests/fuzz/work_dir.hpp"

namespace arena::fuzz {

// Which importer an input goes to (libFuzzer: its first byte, modulo 4).
enum class AssetInput { ObjWithMtl, Gltf, Glb, MeshObj };

// Splits a libFuzzer input into the main file and the side file (the MTL or the .bin buffer).
inline constexpr std::string_view kSideFileSeparator = "\n#side-file\n";

// The main file's name in `dir` for `kind`; the side file is the same stem with .mtl or .bin.
inline std::filesystem::path mainFileOf(AssetInput kind, const std::filesystem::path& dir) {
  switch (kind) {
    case AssetInput::ObjWithMtl:
      return dir / "a.obj";
    case AssetInput::Gltf:
      return dir / "a.gltf";
    case AssetInput::Glb:
      return dir / "a.glb";
    case AssetInput::MeshObj:
      break;
  }
  return dir / "m.obj";
}

// The scene that places the file: an asset object, or a mesh object.
inline std::string sceneFor(AssetInput kind, const std::filesystem::path& file) {
  const std::string object =
      kind == AssetInput::MeshObj
          ? R"({"name": "m", "shape": "mesh", "file": ")" + file.filename().string() +
                R"(", "material": "white", "keys": [{"frame": 0}]})"
          : R"({"name": "m", "asset": {"file": ")" + file.filename().string() +
                R"(", "unitMeters": 1, "upAxis": "y"}, "keys": [{"frame": 0}]})";
  return R"({"purpose": "fuzz", "resolution": [4, 4], "frames": 2, "seed": 1,
    "camera": {"keys": [{"frame": 0, "eye": [0, 1, 4], "target": [0, 0, 0], "up": [0, 1, 0], "fov": 40}]},
    "materials": {"white": {"albedo": [0.7, 0.7, 0.7]}},
    "objects": [)" +
         object + R"(],
    "lights": [{"name": "light", "shape": "quad", "keys": [{"frame": 0, "translate": [0, 3, 0], "intensity": 5}]}]})";
}

inline bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Writes `main` (and `side`, when not empty) into `dir` as `kind`'s files and parses the scene that
// places them. Returns true if it loaded; false if it was rejected with an arena::Error naming the
// file at fault (the main file or its side file). Throws std::logic_error if a rejection does not name the file or loaded geometry breaks an
// invariant the tracer relies on (finite positions, unit normals, indices in range, finite
// materials and node matrices).
inline bool importAssetOrReject(AssetInput kind, const std::string& main, const std::string& side,
                                const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  // Each input starts from an empty folder: a file left by an earlier input ("mtllib a.glb") made a
  // finding depend on the process's history, and no single input reproduced it.
  std::error_code ec;
  std::vector<fs::path> leftovers;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) leftovers.push_back(e.path());
  for (const fs::path& f : leftovers) fs::remove_all(f, ec);
  const fs::path file = mainFileOf(kind, dir);
  writeBytes(file, main);
  fs::path sideFile = file;
  sideFile.replace_extension(kind == AssetInput::ObjWithMtl ? ".mtl" : ".bin");
  if (!side.empty() && kind != AssetInput::MeshObj) writeBytes(sideFile, side);
  Scene scene;
  try {
    scene = parseScene(sceneFor(kind, file), (dir / "fuzz.json").string());
  } catch (const Error& e) {
    // The file at fault is named: the main file, or the side file (an MTL line, or a texture that
    // resolves to the MTL itself -- "cannot decode the texture image" naming it, a fuzzer find).
    const std::string what = e.what();
    if (what.find(file.string()) == std::string::npos && what.find(sideFile.string()) == std::string::npos)
      throw std::logic_error(std::string("a rejection that does not name the file: ") + what);
    return false;
  }
  for (const Material& m : scene.materials)
    if (!finite(m.albedo) || !finite(m.emission) || !std::isfinite(m.roughness) ||
        !std::isfinite(m.metallic) || !std::isfinite(m.specular))
      throw std::logic_error("loaded a non-finite material '" + m.name + "'");
  for (const Object& o : scene.objects) {
    const MeshData mesh = makeMesh(o);
    if (mesh.triangles.empty()) throw std::logic_error("loaded an object without triangles");
    for (size_t v = 0; v < mesh.positions.size(); ++v)
      if (!finite(mesh.positions[v]) || !finite(mesh.normals[v]) ||
          !(std::abs(glm::length(mesh.normals[v]) - 1.0f) < 1e-3f))
        throw std::logic_error("loaded vertex " + std::to_string(v) + " at (" +
                               std::to_string(mesh.positions[v].x) + ", " + std::to_string(mesh.positions[v].y) +
                               ", " + std::to_string(mesh.positions[v].z) + ") whose position is not finite or " +
                               "whose normal (" + std::to_string(mesh.normals[v].x) + ", " +
                               std::to_string(mesh.normals[v].y) + ", " + std::to_string(mesh.normals[v].z) +
                               ") is not a unit vector");
    for (const glm::uvec3& t : mesh.triangles)
      if (t.x >= mesh.positions.size() || t.y >= mesh.positions.size() || t.z >= mesh.positions.size())
        throw std::logic_error("loaded a triangle whose index is out of range");
    for (int m : mesh.triangleMaterials)
      if (m < 0 || size_t(m) >= scene.materials.size())
        throw std::logic_error("loaded a triangle whose material is out of range");
    if (!o.asset) continue;
    const AssetData& a = *o.asset;
    for (uint32_t node : a.mesh.vertexNodes)
      if (node >= a.nodes.size()) throw std::logic_error("loaded a vertex of a missing node");
    for (size_t n = 0; n < a.nodes.size(); ++n)
      if (a.nodes[n].parent >= int(n)) throw std::logic_error("loaded a node after its child");
    if (!std::isfinite(a.durationSeconds())) throw std::logic_error("loaded a non-finite duration");
    for (float t : {0.0f, 0.5f * a.durationSeconds(), a.durationSeconds()}) {
      const std::vector<glm::mat4> matrices = a.nodeMatrices(t);
      for (uint32_t node : a.mesh.vertexNodes)
        for (int c = 0; c < 4; ++c)
          if (!finite(glm::vec3(matrices[node][c])) || !std::isfinite(matrices[node][c][3]))
            throw std::logic_error("loaded node " + std::to_string(node) +
                                   ", which carries triangles, with a matrix that is not finite at asset time " +
                                   std::to_string(t));
    }
  }
  return true;
}

// libFuzzer's bytes: the first picks the importer, the rest is the main file, then the side file
// after kSideFileSeparator.
inline bool importAssetBytesOrReject(const uint8_t* data, size_t size, const std::filesystem::path& dir) {
  if (size == 0) return false;
  const AssetInput kind = AssetInput(data[0] % 4);
  const std::string rest(reinterpret_cast<const char*>(data) + 1, size - 1);
  const size_t split = rest.find(kSideFileSeparator);
  if (split == std::string::npos) return importAssetOrReject(kind, rest, "", dir);
  return importAssetOrReject(kind, rest.substr(0, split), rest.substr(split + kSideFileSeparator.size()), dir);
}

}  // namespace arena::fuzz
