#include "tracer/asset.hpp"

#include <assimp/BaseImporter.h>
#include <assimp/DefaultIOSystem.h>
#include <assimp/GltfMaterial.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <unordered_map>
#include <utility>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"

namespace arena {

namespace fs = std::filesystem;

namespace {

// Normals the file lacks: per corner, the area-weighted sum of the normals of the faces sharing
// the corner's position whose normal lies within this angle of the corner's own face, so curved
// surfaces shade smoothly and hard edges (a cabinet's corners) stay hard. Ours; Java3D's
// NormalGenerator, which Sweet Home 3D uses for the same OBJ files, smooths with a crease angle
// too (44 degrees by default); 60 keeps coarse cylinders smooth.
constexpr float kCreaseAngleDegrees = 60.0f;

// `text` in ASCII lower case (file extensions, assimp's extension lists).
std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return text;
}

// Calls f(lineNumber, keyword, rest) for each line of an OBJ or MTL text that holds a statement
// (not blank, not a comment): the first word and the rest of the line without its surrounding blanks
// (a name may hold spaces, as assimp reads it). Lines end where assimp's readers end them: at '\n',
// '\r', '\f' and NUL (a comment "#x\0aniso 1" hid a statement from the MTL check until the fuzzer
// found it). lineNumber counts '\n'. Stops when f returns false.
template <class F>
void forEachStatement(const std::string& text, F f) {
  static const std::string kLineEnds("\n\r\f\0", 4);
  int lineNumber = 1;
  for (size_t at = 0; at < text.size();) {
    const size_t end = std::min(text.find_first_of(kLineEnds, at), text.size());
    const std::string line = text.substr(at, end - at);
    const int number = lineNumber;
    if (end < text.size() && text[end] == '\n') ++lineNumber;
    at = end + 1;
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    const size_t keywordEnd = std::min(line.find_first_of(" \t", first), line.size());
    const size_t restStart = line.find_first_not_of(" \t", keywordEnd);
    const std::string rest =
        restStart == std::string::npos ? "" : line.substr(restStart, line.find_last_not_of(" \t") + 1 - restStart);
    if (!f(number, line.substr(first, keywordEnd - first), rest)) return;
  }
}

// Opens files through assimp's default I/O but refuses oversized ones (before reading) and records
// every file the importer opened (the MTL, .bin buffers), which the content hash covers. For an OBJ
// every file other than the OBJ is a material library, whatever its name ("mtllib a.glb"), and is
// checked as one; the OBJ itself reached under another spelling is assimp 5.2's fallback for an
// unusable "mtllib" ("mtllib a.mtl/x/a.obj" opened "dir//a.obj" as the MTL) and is refused, since
// its MTL reader writes an OBJ's stray texture statement through a null material (a fuzzer find).
// A refused file ends the import at once, by throwing: assimp 5.2 catches it in its ReadFile and
// returns no scene. A null stream instead lets assimp go on, and on a path it found to exist but
// could not open it searches again without end (a stack overflow: "mtllib m://", which it reduces
// to the folder ".//", a fuzzer find).
class RecordingIOSystem : public Assimp::DefaultIOSystem {
 public:
  std::set<std::string> opened;
  std::string refused;  // the first file refused, with the reason

  // `objPath`: the OBJ being imported, as given to ReadFile ("" for glTF).
  explicit RecordingIOSystem(std::string objPath) : objPath_(std::move(objPath)) {
    std::error_code ec;
    if (!objPath_.empty()) objCanonical_ = fs::weakly_canonical(objPath_, ec).string();
  }

  Assimp::IOStream* Open(const char* file, const char* mode) override {
    std::error_code ec;
    if (fs::is_regular_file(file, ec)) {
      const uintmax_t size = fs::file_size(file, ec);
      if (!ec && size > kMaxAssetBytes)
        refuse(std::string(file) + ": " + std::to_string(size) + " bytes exceeds the " +
               std::to_string(kMaxAssetBytes) + "-byte limit");
    } else if (fs::exists(file, ec)) {
      refuse(std::string(file) + ": not a regular file (expected a material library or buffer file)");
    }
    if (std::string problem = sideFileProblem(file); !problem.empty()) refuse(problem);
    Assimp::IOStream* stream = DefaultIOSystem::Open(file, mode);
    if (stream) opened.insert(fs::weakly_canonical(file).string());
    return stream;
  }

 private:
  std::string objPath_, objCanonical_;

  [[noreturn]] void refuse(const std::string& why) {
    if (refused.empty()) refused = why;
    throw Error(why);
  }

  std::string sideFileProblem(const char* file) const {
    std::error_code ec;
    if (!objPath_.empty()) {
      if (file == objPath_) return "";
      if (fs::weakly_canonical(file, ec).string() == objCanonical_)
        return std::string(file) +
               ": the OBJ would be read as its own material library (assimp's fallback for a 'mtllib' "
               "line naming no readable file); expected 'mtllib' to name an existing .mtl file";
      return mtlProblem(file);
    }
    return lowercase(fs::path(file).extension().string()) == ".mtl" ? mtlProblem(file) : "";
  }

  // An MTL statement before the first "newmtl" belongs to no material, and assimp 5.2's MTL reader
  // writes a texture statement there ("map_Kd x.png", and any line starting with m, b or r, or
  // "disp", "norm") through a null material: a crash (found by scripts/fuzz.sh asset). Such a file
  // is refused before assimp reads it, naming the line. Returns "" when `file` is no such MTL.
  static std::string mtlProblem(const char* file) {
    std::string text;
    try {
      text = readText(file, kMaxAssetBytes);
    } catch (const Error&) {
      return "";  // unreadable: assimp's own open reports it
    }
    std::string problem;
    forEachStatement(text, [&](int lineNumber, const std::string& keyword, const std::string&) {
      if (keyword != "newmtl")
        problem = std::string(file) + ":" + std::to_string(lineNumber) + ": '" + keyword +
                  "' comes before any 'newmtl'; expected every MTL statement inside a material";
      return false;  // only the first statement matters
    });
    return problem;
  }
};

// The "mtllib" lines of an OBJ, refused naming the line where assimp 5.2 would misread them:
// - the OBJ itself: read as its own material library, a texture statement in it ("map_d") is
//   written through a null material (SEGV, a fuzzer find);
// - a name with "://": assimp reduces it to another path ("m://" to the folder ".//") and searches
//   without end when that cannot be opened (a fuzzer find);
// - a folder or other file that is not a regular file;
// and, where assimp would give the object its default grey without a word, a library that does not
// exist and a "usemtl" naming a material none of the OBJ's libraries defines (a library not copied
// beside the OBJ, a misspelt name).
void checkObjMaterialLibraries(const std::string& path, const std::string& bytes) {
  std::error_code ec;
  const std::string self = fs::weakly_canonical(path, ec).string();
  std::vector<fs::path> libraries;
  std::vector<std::pair<int, std::string>> uses;  // "usemtl" lines: number, material
  forEachStatement(bytes, [&](int lineNumber, const std::string& keyword, const std::string& rest) {
    if (keyword == "usemtl" && !rest.empty()) uses.emplace_back(lineNumber, rest);
    if (keyword != "mtllib" || rest.empty()) return true;
    const std::string where = path + ":" + std::to_string(lineNumber) + ": 'mtllib " + rest + "' ";
    const fs::path named = fs::path(path).parent_path() / rest;
    if (rest.find("://") != std::string::npos)
      throw Error(where + "looks like a URL; expected the path of a material library (.mtl) relative to the OBJ");
    if (fs::weakly_canonical(named, ec).string() == self)
      throw Error(where + "names the OBJ file itself; expected a material library (.mtl)");
    if (!fs::exists(named, ec))
      throw Error(where + "names " + named.string() +
                  ", which does not exist; expected a material library (.mtl) there (without it "
                  "every material would be a default grey)");
    if (!fs::is_regular_file(named, ec))
      throw Error(where + "names " + named.string() + ", which is not a regular file; expected a material library (.mtl)");
    libraries.push_back(named);
    return true;
  });
  if (libraries.empty()) return;  // no library: assimp's default material, as the OBJ asks
  std::set<std::string> defined;
  std::string names;
  for (const fs::path& library : libraries) {
    forEachStatement(readText(library, kMaxAssetBytes),
                     [&](int, const std::string& keyword, const std::string& rest) {
                       if (keyword == "newmtl") defined.insert(rest);
                       return true;
                     });
    names += (names.empty() ? "" : ", ") + library.filename().string();
  }
  for (const auto& [lineNumber, material] : uses)
    if (!defined.count(material))
      throw Error(path + ":" + std::to_string(lineNumber) + ": 'usemtl " + material +
                  "' names no material of its libraries (" + names + "); expected a 'newmtl " +
                  material + "' in one of them");
}

// A .gltf or .glb that neither of assimp's glTF readers accepts is refused before ReadFile: assimp
// would otherwise try its other importers on it by content (an OBJ importer reading a .glb made of
// OBJ text was one of the fuzzer's crashes).
// `ext`: the file's extension in lower case, without the dot.
void checkGltfIsReadable(const std::string& path, const std::string& ext, Assimp::Importer& importer,
                         Assimp::IOSystem* io) {
  for (size_t i = 0; i < importer.GetImporterCount(); ++i) {
    std::istringstream extensions(lowercase(importer.GetImporterInfo(i)->mFileExtensions));  // "gltf glb"
    bool listed = false;
    for (std::string word; extensions >> word;) listed = listed || word == ext;
    if (listed && importer.GetImporter(i)->CanRead(path, io, true)) return;
  }
  throw Error(path + ": not a readable glTF file (expected " +
              (ext == "glb" ? std::string("a binary glTF container: the magic 'glTF', version and chunks")
                            : std::string("a JSON object with an \"asset\" that gives its \"version\"")) +
              ")");
}

glm::mat4 toGlm(const aiMatrix4x4& m) {
  // assimp stores row-major (a1 a2 a3 a4 is the first row); glm is column-major.
  return glm::transpose(glm::make_mat4(&m.a1));
}

bool finite(glm::vec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// One kind of fallback, counted over the whole asset.
class WarningCounter {
 public:
  void add(const std::string& what, size_t n = 1, const std::string& example = "") {
    Entry& e = entries_[what];
    e.count += n;
    if (!example.empty() && e.examples.size() < 3 &&
        std::find(e.examples.begin(), e.examples.end(), example) == e.examples.end())
      e.examples.push_back(example);
  }
  std::vector<std::string> lines() const {
    std::vector<std::string> out;
    for (auto& [what, e] : entries_) {
      std::string line = what + ": " + std::to_string(e.count);
      if (!e.examples.empty()) {
        line += " (e.g.";
        for (auto& x : e.examples) line += " " + x;
        line += ")";
      }
      out.push_back(line);
    }
    return out;
  }

 private:
  struct Entry {
    size_t count = 0;
    std::vector<std::string> examples;
  };
  std::map<std::string, Entry> entries_;
};

struct Loader {
  const std::string& path;
  const aiScene& scene;
  bool gltf;
  AssetData& out;
  WarningCounter warnings;
  Hasher& hasher;
  std::map<std::pair<std::string, bool>, std::shared_ptr<const TextureImage>> textureCache;

  // The image a material names for `type` (index 0), with its sampler; an empty ref when there is
  // none or the file is missing (counted: the factor alone is used).
  TextureRef texture(const aiMaterial& m, aiTextureType type, bool srgb) {
    TextureRef ref;
    aiString name;
    aiTextureMapMode mode[2] = {aiTextureMapMode_Wrap, aiTextureMapMode_Wrap};
    unsigned uvIndex = 0;
    if (m.GetTexture(type, 0, &name, nullptr, &uvIndex, nullptr, nullptr, mode) != AI_SUCCESS)
      return ref;
    if (uvIndex != 0)
      warnings.add("textures on a texture coordinate set other than 0 (set 0 is used)", 1,
                   name.C_Str());
    // GetTexture reads the modes from $tex.mapmodeu/v only when present (glTF samplers).
    auto wrap = [](aiTextureMapMode mm) {
      if (mm == aiTextureMapMode_Clamp) return TextureWrap::Clamp;
      if (mm == aiTextureMapMode_Mirror) return TextureWrap::Mirror;
      return TextureWrap::Repeat;
    };
    ref.wrapU = wrap(mode[0]);
    ref.wrapV = wrap(mode[1]);
    std::string file = name.C_Str();
    std::replace(file.begin(), file.end(), '\\', '/');  // exporters on Windows
    // Trailing blanks are the MTL line's, not the name's: Sweet Home 3D's files end `map_Kd` lines
    // in tabs, and assimp keeps them.
    while (!file.empty() && (file.back() == ' ' || file.back() == '\t' || file.back() == '\r'))
      file.pop_back();
    auto key = std::make_pair(file, srgb);
    if (auto it = textureCache.find(key); it != textureCache.end()) {
      ref.image = it->second;
      return ref;
    }
    if (!file.empty() && file[0] == '*') {  // embedded (.glb): "*<index>"
      const aiTexture* t = scene.GetEmbeddedTexture(file.c_str());
      const std::string label = path + "#embedded" + file;
      if (!t) throw Error(path + ": material texture " + file + " names no embedded image");
      if (t->mHeight != 0)
        throw Error(label + ": uncompressed embedded textures are not supported");
      const std::string bytes(reinterpret_cast<const char*>(t->pcData), t->mWidth);
      ref.image = decodeTexture(bytes, label, srgb);
    } else {
      const fs::path resolved = fs::path(path).parent_path() / file;
      std::error_code ec;
      if (!fs::exists(resolved, ec)) {
        warnings.add("missing texture files (the material's factor colour is used)", 1, file);
        hasher.add("missing texture " + file);
        ++out.stats.missingTextures;
        textureCache[key] = nullptr;
        return ref;
      }
      const std::string bytes = readText(resolved, kMaxAssetBytes);
      hasher.add(file).add(bytes);
      ref.image = decodeTexture(bytes, resolved.string(), srgb);
    }
    textureCache[key] = ref.image;
    return ref;
  }

  float number(const aiMaterial& m, const char* key, unsigned type, unsigned idx, float fallback,
               bool* present = nullptr) {
    float v = fallback;
    const bool found = m.Get(key, type, idx, v) == AI_SUCCESS;
    if (present) *present = found;
    return found ? v : fallback;
  }
  glm::vec3 colour(const aiMaterial& m, const char* key, unsigned type, unsigned idx,
                   glm::vec3 fallback, bool* present = nullptr) {
    aiColor4D c;
    const bool found = m.Get(key, type, idx, c) == AI_SUCCESS;
    if (present) *present = found;
    return found ? glm::vec3(c.r, c.g, c.b) : fallback;
  }

  Material material(const aiMaterial& m, unsigned index) {
    Material mat;
    mat.name = m.GetName().length > 0 ? m.GetName().C_Str() : "material" + std::to_string(index);
    if (gltf) {
      // glTF 2.0 metallic-roughness: base colour factor x texture, metallic/roughness factors x
      // the texture's B/G channels, emissive factor x texture; dielectric F0 0.04 (glTF spec).
      bool hasBase = false;
      mat.albedo = colour(m, AI_MATKEY_BASE_COLOR, glm::vec3(1.0f), &hasBase);
      if (!hasBase) mat.albedo = colour(m, AI_MATKEY_COLOR_DIFFUSE, glm::vec3(1.0f));
      mat.baseColorTexture = texture(m, aiTextureType_BASE_COLOR, true);
      if (!mat.baseColorTexture) mat.baseColorTexture = texture(m, aiTextureType_DIFFUSE, true);
      mat.metallic = number(m, AI_MATKEY_METALLIC_FACTOR, 1.0f);
      mat.roughness = number(m, AI_MATKEY_ROUGHNESS_FACTOR, 1.0f);
      // AI_MATKEY_GLTF_PBRMETALLICROUGHNESS_METALLICROUGHNESS_TEXTURE is (UNKNOWN, 0).
      mat.metallicRoughnessTexture = texture(m, aiTextureType_UNKNOWN, false);
      mat.specular = 0.04f;
      mat.emission = colour(m, AI_MATKEY_COLOR_EMISSIVE, glm::vec3(0.0f)) *
                     number(m, AI_MATKEY_EMISSIVE_INTENSITY, 1.0f);
      aiString alphaMode;
      if (m.Get(AI_MATKEY_GLTF_ALPHAMODE, alphaMode) == AI_SUCCESS &&
          std::string(alphaMode.C_Str()) != "OPAQUE")
        warnings.add("materials with alphaMode MASK/BLEND (rendered opaque)", 1, mat.name);
    } else {
      // OBJ/MTL: Kd (x map_Kd) is the base colour. Roughness: Pr when present, else the
      // Blinn-Phong exponent Ns mapped to a microfacet alpha = sqrt(2 / (Ns + 2)) (Walter et al.
      // 2007, eq. 30, Phong <-> Beckmann, used for GGX as usual), and our roughness is sqrt(alpha)
      // (GGX alpha = roughness^2). Metallic: Pm when present, else 0. Dielectric F0 = 0.08 x
      // max(Ks) (Blender's Principled convention, specular 0.5 <-> F0 0.04, which is what its MTL
      // exporter writes as Ks). Ke (x map_Ke) is emission.
      mat.albedo = colour(m, AI_MATKEY_COLOR_DIFFUSE, glm::vec3(0.8f));
      mat.baseColorTexture = texture(m, aiTextureType_DIFFUSE, true);
      bool hasPr = false, hasPm = false;
      const float pr = number(m, AI_MATKEY_ROUGHNESS_FACTOR, 1.0f, &hasPr);
      const float ns = std::max(number(m, AI_MATKEY_SHININESS, 0.0f), 0.0f);
      mat.roughness = hasPr ? pr : std::sqrt(std::sqrt(2.0f / (ns + 2.0f)));
      mat.metallic = number(m, AI_MATKEY_METALLIC_FACTOR, 0.0f, &hasPm);
      const glm::vec3 ks = colour(m, AI_MATKEY_COLOR_SPECULAR, glm::vec3(0.0f));
      mat.specular = 0.08f * std::max({ks.x, ks.y, ks.z});
      mat.emission = colour(m, AI_MATKEY_COLOR_EMISSIVE, glm::vec3(0.0f));
      mat.emissionTexture = texture(m, aiTextureType_EMISSIVE, true);
      if (number(m, AI_MATKEY_OPACITY, 1.0f) < 1.0f)
        warnings.add("materials with dissolve d < 1 (rendered opaque)", 1, mat.name);
    }
    if (gltf) mat.emissionTexture = texture(m, aiTextureType_EMISSIVE, true);
    for (aiTextureType ignored :
         {aiTextureType_NORMALS, aiTextureType_HEIGHT, aiTextureType_OPACITY,
          aiTextureType_SPECULAR, aiTextureType_SHININESS, aiTextureType_LIGHTMAP,
          aiTextureType_AMBIENT_OCCLUSION, aiTextureType_DISPLACEMENT})
      if (m.GetTextureCount(ignored) > 0)
        warnings.add(std::string("ignored ") + aiTextureTypeToString(ignored) + " textures", 1,
                     mat.name);
    const glm::vec3 values[] = {mat.albedo, mat.emission,
                                glm::vec3(mat.roughness, mat.metallic, mat.specular)};
    for (glm::vec3 v : values)
      if (!finite(v)) throw Error(path + ": material '" + mat.name + "' has a non-finite value");
    // As the scene file's own emitters (kMaxRadiance): more would overflow the reference's
    // variance to Inf in the cache.
    const float emitted = std::max({mat.emission.x, mat.emission.y, mat.emission.z});
    if (emitted > kMaxRadiance)
      throw Error(path + ": material '" + mat.name + "' emits " + std::to_string(emitted) +
                  "; expected emission (Ke, emissiveFactor x strength) <= " +
                  std::to_string(kMaxRadiance));
    mat.albedo = glm::clamp(mat.albedo, 0.0f, 1.0f);
    mat.emission = glm::max(mat.emission, glm::vec3(0.0f));
    mat.roughness = std::clamp(mat.roughness, 0.0f, 1.0f);
    mat.metallic = std::clamp(mat.metallic, 0.0f, 1.0f);
    mat.specular = std::clamp(mat.specular, 0.0f, 1.0f);
    return mat;
  }

  // Appends the triangles of mesh `mi` placed at node `node`.
  void addMesh(unsigned mi, int node) {
    const aiMesh& mesh = *scene.mMeshes[mi];
    const std::string meshName =
        "mesh " + std::to_string(mi) +
        (mesh.mName.length ? " '" + std::string(mesh.mName.C_Str()) + "'" : "");
    if (mesh.mNumBones > 0)
      throw Error(path + ": " + meshName + " is skinned (" + std::to_string(mesh.mNumBones) +
                  " bones): skinning is not supported (only node TRS animation)");
    if (mesh.mMaterialIndex >= out.materials.size())
      throw Error(path + ": " + meshName + " uses material " + std::to_string(mesh.mMaterialIndex) +
                  " of " + std::to_string(out.materials.size()));
    if (mesh.mNumAnimMeshes > 0)
      warnings.add("meshes with morph targets (the base shape is used)", 1, meshName);
    MeshData& m = out.mesh;
    const size_t firstCorner = m.positions.size();
    std::vector<glm::vec3> faceNormals;  // unnormalised (twice the area)
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D& p = mesh.mVertices[v];
      // Beyond kMaxMeshCoordinate the triangle's cross product overflows and it would be
      // dropped as "degenerate": an error, not a miscounted fallback.
      if (!finite({p.x, p.y, p.z}) || std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) >
                                          kMaxMeshCoordinate)
        throw Error(path + ": " + meshName + " vertex " + std::to_string(v) +
                    " has a non-finite position or one beyond +-1e18 (" + std::to_string(p.x) +
                    ", " + std::to_string(p.y) + ", " + std::to_string(p.z) + ")");
      if (mesh.HasTextureCoords(0)) {
        const aiVector3D& t = mesh.mTextureCoords[0][v];
        if (!std::isfinite(t.x) || !std::isfinite(t.y))
          throw Error(path + ": " + meshName + " vertex " + std::to_string(v) +
                      " has a non-finite texture coordinate");
      }
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) {  // points and lines (triangulation split the polygons)
        ++out.stats.pointAndLinePrimitives;
        continue;
      }
      const unsigned i[3] = {face.mIndices[0], face.mIndices[1], face.mIndices[2]};
      glm::vec3 p[3];
      for (int k = 0; k < 3; ++k) {
        if (i[k] >= mesh.mNumVertices)
          throw Error(path + ": " + meshName + " face " + std::to_string(f) +
                      " references vertex " + std::to_string(i[k]) + " of " +
                      std::to_string(mesh.mNumVertices));
        const aiVector3D& q = mesh.mVertices[i[k]];
        p[k] = {q.x, q.y, q.z};
      }
      const glm::vec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
      if (i[0] == i[1] || i[1] == i[2] || i[0] == i[2] || !(glm::length(n) > 0.0f) || !finite(n)) {
        ++out.stats.degenerateTriangles;
        continue;
      }
      faceNormals.push_back(n);
      const unsigned base = unsigned(m.positions.size());
      for (int k = 0; k < 3; ++k) {
        m.positions.push_back(p[k]);
        glm::vec3 vn(0.0f);
        if (mesh.HasNormals()) {
          const aiVector3D& q = mesh.mNormals[i[k]];
          vn = {q.x, q.y, q.z};
        }
        m.normals.push_back(vn);  // zero: computed below
        const aiVector3D t = mesh.HasTextureCoords(0) ? mesh.mTextureCoords[0][i[k]] : aiVector3D();
        m.texcoords.push_back({t.x, t.y});
        m.vertexNodes.push_back(uint32_t(node));
      }
      m.triangles.push_back({base, base + 1, base + 2});
      m.triangleMaterials.push_back(int(mesh.mMaterialIndex));
    }
    if (!mesh.HasTextureCoords(0) && out.materials[mesh.mMaterialIndex].textured())
      warnings.add("textured materials on meshes without texture coordinates (uv 0 is sampled)", 1,
                   meshName);
    fillNormals(firstCorner, faceNormals);
  }

  // Corners [first, end) whose normal is missing, zero or non-finite get the crease-angle smooth
  // normal (kCreaseAngleDegrees) over the faces of this mesh sharing the position.
  void fillNormals(size_t first, const std::vector<glm::vec3>& faceNormals) {
    MeshData& m = out.mesh;
    struct Key {
      glm::vec3 p;
      bool operator==(const Key& o) const { return p == o.p; }
    };
    struct KeyHash {
      size_t operator()(const Key& k) const {
        return std::hash<float>()(k.p.x) ^ (std::hash<float>()(k.p.y) * 31u) ^
               (std::hash<float>()(k.p.z) * 1009u);
      }
    };
    std::unordered_map<Key, std::vector<uint32_t>, KeyHash> facesAt;
    for (size_t c = first; c < m.positions.size(); ++c)
      facesAt[Key{m.positions[c]}].push_back(uint32_t((c - first) / 3));
    const float cosCrease = std::cos(glm::radians(kCreaseAngleDegrees));
    // The face normals are twice the areas, up to ~|v|^2 (1e36 near kMaxMeshCoordinate): a mesh
    // that large sums them relative to the largest, so the area weights cannot overflow float
    // (any other sums them as they are).
    float faceScale = 0.0f;
    for (const glm::vec3& f : faceNormals)
      faceScale = std::max({faceScale, std::abs(f.x), std::abs(f.y), std::abs(f.z)});
    if (faceScale < 1e30f) faceScale = 1.0f;
    for (size_t c = first; c < m.positions.size(); ++c) {
      glm::vec3& n = m.normals[c];
      const glm::vec3 fileNormal = directionOr(n, glm::vec3(0.0f));
      if (fileNormal != glm::vec3(0.0f)) {
        n = fileNormal;
        continue;
      }
      const glm::vec3 own = directionOr(faceNormals[(c - first) / 3], glm::vec3(0, 1, 0));
      glm::vec3 sum(0.0f);
      for (uint32_t f : facesAt[Key{m.positions[c]}])
        if (glm::dot(directionOr(faceNormals[f], own), own) >= cosCrease) sum += faceNormals[f] / faceScale;
      n = directionOr(sum, own);
    }
  }

  void addNode(const aiNode& node, int parent) {
    AssetNode n;
    n.name = node.mName.C_Str();
    n.parent = parent;
    n.local = toGlm(node.mTransformation);
    const int index = int(out.nodes.size());
    out.nodes.push_back(n);
    for (unsigned k = 0; k < node.mNumMeshes; ++k) {
      if (node.mMeshes[k] >= scene.mNumMeshes)
        throw Error(path + ": node '" + n.name + "' references a missing mesh");
      addMesh(node.mMeshes[k], index);
    }
    for (unsigned c = 0; c < node.mNumChildren; ++c) addNode(*node.mChildren[c], index);
  }

  void addAnimation() {
    if (scene.mNumAnimations == 0) return;
    if (scene.mNumAnimations > 1)
      warnings.add("animations beyond the first (only animation 0 plays)",
                   scene.mNumAnimations - 1);
    const aiAnimation& a = *scene.mAnimations[0];
    if (a.mNumMorphMeshChannels > 0 || a.mNumMeshChannels > 0)
      throw Error(path + ": animation '" + std::string(a.mName.C_Str()) +
                  "' animates morph targets or meshes: not supported (only node TRS animation)");
    // assimp keeps keys in ticks; 0 ticks per second means "unspecified" (its docs: assume 25).
    const double tps = a.mTicksPerSecond > 0 ? a.mTicksPerSecond : 25.0;
    for (unsigned c = 0; c < a.mNumChannels; ++c) {
      const aiNodeAnim& ch = *a.mChannels[c];
      auto it = std::find_if(out.nodes.begin(), out.nodes.end(),
                             [&](const AssetNode& n) { return n.name == ch.mNodeName.C_Str(); });
      if (it == out.nodes.end())
        throw Error(path + ": animation channel targets node '" +
                    std::string(ch.mNodeName.C_Str()) + "', which does not exist");
      AssetNode& n = *it;
      n.animated = true;
      auto seconds = [&](double ticks) {
        const float s = float(ticks / tps);
        if (!std::isfinite(s)) throw Error(path + ": animation key time is not finite");
        return s;
      };
      for (unsigned k = 0; k < ch.mNumPositionKeys; ++k) {
        const aiVectorKey& key = ch.mPositionKeys[k];
        n.translation.push_back({seconds(key.mTime), {key.mValue.x, key.mValue.y, key.mValue.z}});
      }
      for (unsigned k = 0; k < ch.mNumScalingKeys; ++k) {
        const aiVectorKey& key = ch.mScalingKeys[k];
        n.scale.push_back({seconds(key.mTime), {key.mValue.x, key.mValue.y, key.mValue.z}});
      }
      for (unsigned k = 0; k < ch.mNumRotationKeys; ++k) {
        const aiQuatKey& key = ch.mRotationKeys[k];
        n.rotation.push_back({seconds(key.mTime),
                              glm::quat(key.mValue.w, key.mValue.x, key.mValue.y, key.mValue.z)});
      }
      // The node's own TRS fills the paths the channel does not drive.
      aiVector3D s, t;
      aiQuaternion r;
      const aiMatrix4x4 m = [&] {
        aiMatrix4x4 x;
        const glm::mat4 rowMajor = glm::transpose(n.local);
        std::memcpy(&x.a1, &rowMajor[0][0], sizeof x);
        return x;
      }();
      m.Decompose(s, r, t);
      if (n.translation.empty()) n.translation.push_back({0.0f, {t.x, t.y, t.z}});
      if (n.scale.empty()) n.scale.push_back({0.0f, {s.x, s.y, s.z}});
      if (n.rotation.empty()) n.rotation.push_back({0.0f, glm::quat(r.w, r.x, r.y, r.z)});
      for (auto* keys : {&n.translation, &n.scale}) {
        for (size_t k = 1; k < keys->size(); ++k)
          if (!((*keys)[k].first >= (*keys)[k - 1].first))
            throw Error(path + ": animation keys of node '" + n.name + "' are not in time order");
        for (auto& [time, v] : *keys)
          if (!finite(v))
            throw Error(path + ": animation of node '" + n.name + "' has a non-finite key");
      }
      for (size_t k = 1; k < n.rotation.size(); ++k)
        if (!(n.rotation[k].first >= n.rotation[k - 1].first))
          throw Error(path + ": animation keys of node '" + n.name + "' are not in time order");
      for (auto& [time, q] : n.rotation)
        if (!std::isfinite(q.w) || !finite({q.x, q.y, q.z}) || !(glm::length(q) > 0.0f))
          throw Error(path + ": animation of node '" + n.name + "' has an invalid rotation key");
    }
  }
};

template <class T, class Mix>
T keyAt(const std::vector<std::pair<float, T>>& keys, float t, Mix mix) {
  if (t <= keys.front().first) return keys.front().second;
  for (size_t k = 0; k + 1 < keys.size(); ++k)
    if (t < keys[k + 1].first) {
      const float span = keys[k + 1].first - keys[k].first;
      return mix(keys[k].second, keys[k + 1].second, span > 0 ? (t - keys[k].first) / span : 1.0f);
    }
  return keys.back().second;
}

// The matrix of every node that carries triangles, at time 0 and at every key, is finite: a
// transform given as 1e39 (Inf in float), or scales that overflow down the hierarchy, would place
// the triangles at infinity and they would vanish from the render.
void requireFiniteNodeMatrices(const std::string& path, const AssetData& asset) {
  const std::set<uint32_t> placed(asset.mesh.vertexNodes.begin(), asset.mesh.vertexNodes.end());
  std::set<float> times = {0.0f};
  for (const AssetNode& n : asset.nodes) {
    for (const auto& [time, v] : n.translation) times.insert(time);
    for (const auto& [time, v] : n.scale) times.insert(time);
    for (const auto& [time, q] : n.rotation) times.insert(time);
  }
  for (float t : times) {
    const std::vector<glm::mat4> matrices = asset.nodeMatrices(t);
    for (uint32_t i : placed)
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
          if (!std::isfinite(matrices[i][c][r]))
            throw Error(path + ": node '" + asset.nodes[i].name + "' has a non-finite transform at asset time " +
                        std::to_string(t) + " s (a value beyond float range, or scales that overflow down " +
                        "the hierarchy); its triangles would vanish from the render");
  }
}

}  // namespace

std::vector<glm::mat4> AssetData::nodeMatrices(float seconds) const {
  std::vector<glm::mat4> global(nodes.size());
  for (size_t i = 0; i < nodes.size(); ++i) {
    const AssetNode& n = nodes[i];
    glm::mat4 local = n.local;
    if (n.animated) {
      auto lerp3 = [](glm::vec3 a, glm::vec3 b, float s) { return glm::mix(a, b, s); };
      auto slerp = [](glm::quat a, glm::quat b, float s) {
        return glm::normalize(glm::slerp(glm::normalize(a), glm::normalize(b), s));
      };
      local = glm::translate(glm::mat4(1.0f), keyAt(n.translation, seconds, lerp3)) *
              glm::mat4_cast(keyAt(n.rotation, seconds, slerp)) *
              glm::scale(glm::mat4(1.0f), keyAt(n.scale, seconds, lerp3));
    }
    global[i] = n.parent >= 0 ? global[size_t(n.parent)] * local : assetToObject * local;
  }
  return global;
}

float AssetData::durationSeconds() const {
  float end = 0.0f;
  for (const AssetNode& n : nodes)
    if (n.animated)
      end = std::max(
          {end, n.translation.back().first, n.rotation.back().first, n.scale.back().first});
  return end;
}

// A binary glTF container's sizes checked against the file before assimp reads it: a 12-byte
// header (magic "glTF", version, total length) and chunks of (length, type, data). assimp 5.2
// allocates a chunk at its declared length before checking it, so a damaged length asked for
// 4 GiB (found by scripts/fuzz.sh asset); here it is an error naming the file and the chunk.
static void checkBinaryGltfSizes(const std::string& path, const std::string& bytes) {
  auto u32 = [&](size_t at) {
    uint32_t v = 0;
    std::memcpy(&v, bytes.data() + at, 4);
    return v;
  };
  if (bytes.size() < 12 || bytes.compare(0, 4, "glTF") != 0) return;  // not binary: assimp's text paths
  const uint64_t length = u32(8);
  if (length > bytes.size() || length < 20)
    throw Error(path + ": binary glTF header declares " + std::to_string(length) + " bytes, but the file has " +
                std::to_string(bytes.size()) + " (expected 20 or more and at most the file's size)");
  uint64_t at = 12;
  for (int chunk = 0; at + 8 <= length; ++chunk) {
    const uint64_t chunkLength = u32(size_t(at));
    if (chunkLength > length - at - 8)
      throw Error(path + ": binary glTF chunk " + std::to_string(chunk) + " declares " + std::to_string(chunkLength) +
                  " bytes, but " + std::to_string(length - at - 8) + " remain (a damaged file)");
    at += 8 + chunkLength;
  }
}

AssetData loadAsset(const std::string& path, const AssetRef& ref) {
  const std::string ext = lowercase(fs::path(path).extension().string());
  if (ext != ".obj" && ext != ".gltf" && ext != ".glb")
    throw Error(path + ": unsupported asset format '" + ext + "' (expected .obj, .gltf or .glb)");
  // Size and type before anything reads it.
  const std::string bytes = readText(path, kMaxAssetBytes);
  checkBinaryGltfSizes(path, bytes);
  AssetData out;
  out.file = path;
  Hasher hasher;
  hasher.add(bytes);

  if (ext == ".obj") checkObjMaterialLibraries(path, bytes);
  Assimp::Importer importer;
  auto* io = new RecordingIOSystem(ext == ".obj" ? path : "");  // the importer owns it
  importer.SetIOHandler(io);
  if (ext != ".obj") checkGltfIsReadable(path, ext.substr(1), importer, io);
  // Triangulate polygons; split points/lines into meshes of their own (counted and dropped).
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_ValidateDataStructure);
  if (!io->refused.empty()) throw Error(path + ": " + io->refused);
  if (!scene) throw Error(path + ": cannot import the asset: " + importer.GetErrorString());
  if ((scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) || !scene->mRootNode)
    throw Error(path + ": the asset is incomplete (no node hierarchy or meshes)");
  const std::string canonical = fs::weakly_canonical(path).string();
  for (const std::string& f : io->opened)
    if (f != canonical)  // side files: MTL, .bin buffers
      hasher.add(fs::relative(f, fs::path(canonical).parent_path()).string())
          .add(readText(f, kMaxAssetBytes));

  Loader loader{path, *scene, ext != ".obj", out, {}, hasher, {}};
  for (unsigned i = 0; i < scene->mNumMaterials; ++i)
    out.materials.push_back(loader.material(*scene->mMaterials[i], i));
  if (out.materials.empty()) out.materials.push_back(Material{});
  loader.addNode(*scene->mRootNode, -1);
  loader.addAnimation();
  requireFiniteNodeMatrices(path, out);
  out.stats.triangles = out.mesh.triangles.size();
  if (out.stats.degenerateTriangles > 0)
    loader.warnings.add("degenerate triangles (zero area or repeated vertices) dropped",
                        out.stats.degenerateTriangles);
  if (out.stats.pointAndLinePrimitives > 0)
    loader.warnings.add("point and line primitives dropped", out.stats.pointAndLinePrimitives);
  if (out.mesh.triangles.empty()) throw Error(path + ": the asset has no triangles");

  // Units and up axis: scale to metres, then turn +Z up into +Y up ((x, y, z) -> (x, z, -y)).
  glm::mat4 axis(1.0f);
  if (ref.upAxis == 'z')  // columns: the images of x, y, z (exact, unlike a rotate by 90 degrees)
    axis = glm::mat4(glm::vec4(1, 0, 0, 0), glm::vec4(0, 0, -1, 0), glm::vec4(0, 1, 0, 0),
                     glm::vec4(0, 0, 0, 1));
  out.assetToObject = axis * glm::scale(glm::mat4(1.0f), glm::vec3(ref.unitMeters));
  out.warnings = loader.warnings.lines();
  out.contentHash = hasher.hex();
  return out;
}

}  // namespace arena
