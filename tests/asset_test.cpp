// Asset objects (issue 18): textures, OBJ+MTL, glTF 2.0 through assimp, node animation, and the
// bad-asset contract. Files from Debian's assimp-testmodels are read where that package is
// installed (scripts/setup.sh installs it); each such test says so when it skips.
#include "tracer/asset.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"
#include <cstdio>
#include <regex>

namespace arena {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

const std::string kTestModels = "/usr/share/assimp/models/glTF2";

#define REQUIRE_TEST_MODEL(path) \
  if (!fs::exists(path))         \
  GTEST_SKIP() << "assimp-testmodels is not installed (scripts/setup.sh installs it): no " << (path)

void writeFile(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

// A quad [-0.5, 0.5]^2 in the XZ plane facing +Y, uv = (x + 0.5, 0.5 - z): the file's top-left
// corner (x -0.5, z -0.5) is uv (0, 1), the image's top-left texel.
const char* kQuadObj = R"(mtllib quad.mtl
v -0.5 0 -0.5
v -0.5 0 0.5
v 0.5 0 0.5
v 0.5 0 -0.5
vt 0 1
vt 0 0
vt 1 0
vt 1 1
vn 0 1 0
usemtl %s
f 1/1/1 2/2/1 3/3/1
f 1/1/1 3/3/1 4/4/1
)";

std::string quadObj(const std::string& material) {
  char buf[1024];
  std::snprintf(buf, sizeof buf, kQuadObj, material.c_str());
  return buf;
}

// A 4x4 8-bit texture of distinct colours (as sRGB-encoded bytes, BGR in OpenCV's order).
cv::Mat testTexture() {
  cv::Mat img(4, 4, CV_8UC3);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) img.at<cv::Vec3b>(y, x) = cv::Vec3b(40 + 50 * x, 60 + 40 * y, 200);
  return img;
}

// Scene around one asset object: a camera looking straight down at the origin, one quad light.
json assetScene(const json& assetObject, int frames = 1) {
  json s = json::parse(R"({
    "purpose": "asset test", "resolution": [24, 24], "frames": 1, "seed": 3, "max_bounces": 2,
    "camera": {"keys": [{"frame": 0, "eye": [0, 1.2, 0], "target": [0, 0, 0], "up": [0, 0, -1], "fov": 40}]},
    "materials": {"flat": {"albedo": [1, 1, 1], "specular": 0}},
    "objects": [],
    "lights": [{"name": "lamp", "shape": "quad", "keys": [{"frame": 0, "translate": [0.3, 2, 0.2], "rotate": [180, 0, 0], "intensity": 4}]}]
  })");
  s["frames"] = frames;
  s["objects"].push_back(assetObject);
  return s;
}

json assetObject(const std::string& file, double unitMeters = 1.0, const std::string& up = "y") {
  return {{"name", "thing"},
          {"asset", {{"file", file}, {"unitMeters", unitMeters}, {"upAxis", up}}},
          {"keys", json::array({{{"frame", 0}}})}};
}

Scene parseIn(const fs::path& dir, const json& scene) {
  const fs::path path = dir / "scene.json";
  writeFile(path, scene.dump(1));
  return loadScene(path.string());
}

std::string parseError(const fs::path& dir, const json& scene) {
  try {
    parseIn(dir, scene);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// --- Textures --------------------------------------------------------------------------------

TEST(AssetTexture, DecodesSrgbAndSamplesBilinearlyWithEachWrapMode) {
  cv::Mat img(1, 2, CV_8UC3);
  img.at<cv::Vec3b>(0, 0) = cv::Vec3b(0, 0, 255);  // red (BGR)
  img.at<cv::Vec3b>(0, 1) = cv::Vec3b(0, 128, 0);  // green 128: sRGB 0.50196 -> linear 0.21586
  std::vector<uchar> png;
  cv::imencode(".png", img, png);
  TextureRef t;
  t.image = decodeTexture(std::string(png.begin(), png.end()), "t.png", true);
  ASSERT_EQ(t.image->width, 2);
  const float g = srgbToLinear(128.0f / 255.0f);
  EXPECT_NEAR(g, 0.21586f, 1e-5f);  // IEC 61966-2-1
  // Texel centres are at u = 0.25 and 0.75; between them the lookup is linear.
  EXPECT_NEAR(t.sample({0.25f, 0.5f}).r, 1.0f, 1e-6f);
  EXPECT_NEAR(t.sample({0.75f, 0.5f}).g, g, 1e-6f);
  EXPECT_NEAR(t.sample({0.5f, 0.5f}).r, 0.5f, 1e-6f);
  EXPECT_NEAR(t.sample({0.5f, 0.5f}).g, 0.5f * g, 1e-6f);
  // At u = 0 (half a texel left of the first centre): repeat blends in the last texel, clamp
  // keeps the first, mirror reflects the first onto itself.
  EXPECT_NEAR(t.sample({0.0f, 0.5f}).r, 0.5f, 1e-6f);
  t.wrapU = TextureWrap::Clamp;
  EXPECT_NEAR(t.sample({0.0f, 0.5f}).r, 1.0f, 1e-6f);
  EXPECT_NEAR(t.sample({-7.3f, 0.5f}).r, 1.0f, 1e-6f);
  t.wrapU = TextureWrap::Mirror;
  EXPECT_NEAR(t.sample({0.0f, 0.5f}).r, 1.0f, 1e-6f);
  EXPECT_NEAR(t.sample({1.25f, 0.5f}).g, g, 1e-6f);  // mirrored: u 1.25 reads u 0.75
  // 16-bit and linear (non-colour) data.
  cv::Mat wide(1, 1, CV_16UC1, cv::Scalar(32768));
  cv::imencode(".png", wide, png);
  auto linear = decodeTexture(std::string(png.begin(), png.end()), "w.png", false);
  EXPECT_NEAR(linear->texels[0].r, 32768.0f / 65535.0f, 1e-6f);
  EXPECT_THROW(decodeTexture("not an image", "bad.png", true), Error);
}

// --- OBJ + MTL -------------------------------------------------------------------------------

TEST(AssetObj, MapsTheMtlPerFaceWithSmoothNormalsWhereTheFileHasNone) {
  fs::path dir = test::freshDir("asset_obj");
  // A bent strip (no vn) in one material: a shallow fold (20 degrees, between faces 1-2) is
  // smoothed, a steep one (70 degrees, between faces 3-4) stays hard; a lone triangle in another
  // material. Normals are smoothed within one material's mesh.
  writeFile(dir / "strip.obj", R"(mtllib strip.mtl
v 0 0 0
v 0 0 1
v 1 0 1
v 1 0 0
v 2 0.36397 1
v 2 0.36397 0
v 2 1.36397 1
v 5 0 0
v 6 0 0
v 5 0 1
usemtl shiny
f 1 2 3
f 1 3 4
f 4 3 5
f 4 5 6
f 6 5 7
usemtl matte
f 8 9 10
)");
  writeFile(dir / "strip.mtl", R"(newmtl shiny
Kd 0.5 0.4 0.3
Ks 0.5 0.5 0.5
Ns 98
newmtl matte
Kd 0.2 0.2 0.2
Ns 96
Pr 0.25
Pm 0.5
)");
  AssetData a = loadAsset((dir / "strip.obj").string(), AssetRef{});
  ASSERT_EQ(a.materials.size(), 3u);  // assimp's default material, then the file's
  const Material& shiny = a.materials[1];
  const Material& matte = a.materials[2];
  EXPECT_EQ(shiny.name, "shiny");
  EXPECT_NEAR(shiny.albedo.y, 0.4f, 1e-6f);
  // Ns 98: alpha = sqrt(2 / 100), roughness = sqrt(alpha) = 0.37606.
  EXPECT_NEAR(shiny.roughness, 0.376060f, 1e-5f);
  EXPECT_NEAR(shiny.specular, 0.04f, 1e-6f);  // 0.08 x Ks
  EXPECT_EQ(shiny.metallic, 0.0f);
  EXPECT_NEAR(matte.roughness, 0.25f, 1e-6f);  // Pr wins over Ns
  EXPECT_NEAR(matte.metallic, 0.5f, 1e-6f);
  EXPECT_EQ(matte.specular, 0.0f);  // no Ks: a pure Lambert surface
  ASSERT_EQ(a.mesh.triangles.size(), 6u);
  EXPECT_EQ(a.mesh.triangleMaterials, (std::vector<int>{1, 1, 1, 1, 1, 2}));
  // Vertex 3 (1, 0, 1) of face 0 lies on the 20-degree fold: its normal tilts towards the folded
  // face (area-weighted over faces 0, 1, 2: atan(0.364 / 3) = 6.9 degrees); at the far corner
  // (0, 0, 0) it is the plane's normal.
  const glm::vec3 up(0, 1, 0);
  auto normalAt = [&](size_t tri, int corner) { return a.mesh.normals[3 * tri + size_t(corner)]; };
  EXPECT_NEAR(std::abs(normalAt(0, 0).y), 1.0f, 1e-6f);
  const float tilt = glm::degrees(std::acos(std::abs(glm::dot(normalAt(0, 2), up))));
  EXPECT_GT(tilt, 5.0f);
  EXPECT_LT(tilt, 15.0f);
  // Face 4 stands at 70 degrees to face 3 (beyond the 60-degree crease): its corners keep the
  // face's own normal.
  const glm::vec3 n4 = glm::normalize(glm::cross(a.mesh.positions[13] - a.mesh.positions[12],
                                                 a.mesh.positions[14] - a.mesh.positions[12]));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(std::abs(glm::dot(normalAt(4, k), n4)), 1.0f, 1e-5f);
  EXPECT_TRUE(a.warnings.empty()) << a.warnings.front();
}

TEST(AssetObj, UnitsAndUpAxisPlaceTheAssetInMetresWithYUp) {
  fs::path dir = test::freshDir("asset_units");
  writeFile(dir / "quad.obj", quadObj("m"));
  writeFile(dir / "quad.mtl", "newmtl m\nKd 1 1 1\n");
  // A z-up asset in centimetres: its +Z becomes +Y, 100 units one metre.
  AssetRef ref;
  ref.unitMeters = 0.01f;
  ref.upAxis = 'z';
  AssetData a = loadAsset((dir / "quad.obj").string(), ref);
  const glm::mat4 m = a.nodeMatrices(0.0f).front();
  const glm::vec3 p = glm::vec3(m * glm::vec4(0.5f, 0.25f, 1.0f, 1.0f));
  // (x, y, z) -> (x, z, -y) x 0.01, exactly.
  EXPECT_EQ(p, glm::vec3(0.5f * 0.01f, 1.0f * 0.01f, -(0.25f * 0.01f)));
}

// --- Demodulation ----------------------------------------------------------------------------

// The textured quad's demodulated diffuse equals the untextured one's: the quad (no specular,
// nothing else to reflect) receives the same light whatever its albedo, and the G-buffer's albedo
// is the very texel value the path tracer multiplied in. Tolerance 2e-6 relative: float rounding
// of one product and one quotient.
TEST(AssetTextures, TexturedQuadDemodulatesToTheUntexturedDiffuseExactly) {
  fs::path dir = test::freshDir("asset_demod");
  writeFile(dir / "quad.obj", quadObj("tex"));
  writeFile(dir / "quad.mtl", "newmtl tex\nKd 1 1 1\nKs 0 0 0\nmap_Kd tex.png\n");
  cv::imwrite((dir / "tex.png").string(), testTexture());
  json obj = assetObject("quad.obj");
  obj["keys"][0]["scale"] = {1.2, 1, 1.2};
  const Scene textured = parseIn(dir, assetScene(obj));
  obj["material"] = "flat";
  const Scene flat = parseIn(dir, assetScene(obj));
  ASSERT_TRUE(textured.materials.back().baseColorTexture);
  EXPECT_NE(textured.contentHash, flat.contentHash);
  const int w = 24, h = 24;
  auto texturedFrame =
      SequenceRenderer(textured, test::tinySettings(w, h, 1, 4)).renderFrame(0).frame;
  auto flatFrame = SequenceRenderer(flat, test::tinySettings(w, h, 1, 4)).renderFrame(0).frame;
  const Image &dt = texturedFrame.get("diffuse"), &df = flatFrame.get("diffuse");
  const Image& albedo = texturedFrame.get("albedo");
  const Image& position = texturedFrame.get("position");
  TextureRef tex = textured.materials.back().baseColorTexture;
  int quadPixels = 0, lit = 0;
  std::set<float> distinctAlbedo;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (texturedFrame.get("meshId").at(x, y) != 0.0f) continue;
      ++quadPixels;
      // The albedo channel is the texture at the pixel centre's uv (from its object position).
      const glm::vec2 uv(position.at(x, y, 0) / 1.2f + 0.5f, 0.5f - position.at(x, y, 2) / 1.2f);
      const glm::vec3 expected = glm::vec3(tex.sample(uv));
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(albedo.at(x, y, c), expected[c], 2e-5f) << x << "," << y;
        const float a = dt.at(x, y, c), b = df.at(x, y, c);
        EXPECT_NEAR(a, b, 2e-6f * std::max(std::abs(b), 1e-3f)) << x << "," << y << " c" << c;
        if (b > 0) ++lit;
      }
      distinctAlbedo.insert(albedo.at(x, y, 1) + 10.0f * albedo.at(x, y, 2));
    }
  EXPECT_GT(quadPixels, w * h / 2);
  EXPECT_GT(lit, quadPixels);            // the light reaches the quad
  EXPECT_GE(distinctAlbedo.size(), 8u);  // the texture is really there
  EXPECT_EQ(flatFrame.get("albedo").at(w / 2, h / 2, 0), 1.0f);
}

// Sweet Home 3D's MTL files end `map_Kd` lines in tabs; the name is the file's without them.
TEST(AssetTextures, TrailingBlanksOfAMapLineAreNotPartOfTheFileName) {
  fs::path dir = test::freshDir("asset_tab_tex");
  writeFile(dir / "quad.obj", quadObj("tex"));
  writeFile(dir / "quad.mtl", "newmtl tex\nKd 1 1 1\nmap_Kd tex.png\t\t \n");
  cv::imwrite((dir / "tex.png").string(), testTexture());
  const Scene scene = parseIn(dir, assetScene(assetObject("quad.obj")));
  EXPECT_TRUE(scene.materials.back().baseColorTexture) << "the texture was not found";
}

TEST(AssetTextures, MissingTextureFallsBackToTheFactorAndIsCounted) {
  fs::path dir = test::freshDir("asset_missing_tex");
  writeFile(dir / "quad.obj", quadObj("tex"));
  writeFile(dir / "quad.mtl", "newmtl tex\nKd 0.3 0.6 0.9\nmap_Kd gone.png\n");
  const Scene s = parseIn(dir, assetScene(assetObject("quad.obj")));
  EXPECT_FALSE(s.materials.back().baseColorTexture);
  EXPECT_NEAR(s.materials.back().albedo.z, 0.9f, 1e-6f);
  EXPECT_EQ(s.objects[0].asset->stats.missingTextures, 1u);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("missing texture files (the material's factor colour is used): 1"),
            std::string::npos)
      << s.warnings[0];
  EXPECT_NE(s.warnings[0].find("gone.png"), std::string::npos) << s.warnings[0];
  // Supplying the texture later changes the scene's hash (so no stale cache is trusted).
  cv::imwrite((dir / "gone.png").string(), testTexture());
  const Scene fixed = parseIn(dir, assetScene(assetObject("quad.obj")));
  EXPECT_TRUE(fixed.warnings.empty());
  EXPECT_NE(fixed.contentHash, s.contentHash);
  cv::Mat other = testTexture();
  other.at<cv::Vec3b>(0, 0) = cv::Vec3b(1, 2, 3);
  cv::imwrite((dir / "gone.png").string(), other);
  EXPECT_NE(parseIn(dir, assetScene(assetObject("quad.obj"))).contentHash, fixed.contentHash);
}

// --- glTF 2.0 --------------------------------------------------------------------------------

// An independent reading of a glTF file (the JSON and its buffers, no assimp): the triangles its
// scene draws, how many of them are degenerate (repeated indices or a zero cross product, in
// float as the loader computes it) and their world-space bounds; float positions, mode 4.
struct GltfFacts {
  size_t triangles = 0, degenerate = 0;
  glm::vec3 lo{1e30f}, hi{-1e30f};
};

GltfFacts readGltfFacts(const std::string& file) {
  const std::string bytes = readText(file);
  json doc;
  std::string bin;
  if (bytes.compare(0, 4, "glTF") == 0) {  // GLB: header, JSON chunk, BIN chunk
    uint32_t jsonLength;
    std::memcpy(&jsonLength, bytes.data() + 12, 4);
    doc = json::parse(bytes.substr(20, jsonLength));
    const size_t binAt = 20 + jsonLength;
    uint32_t binLength;
    std::memcpy(&binLength, bytes.data() + binAt, 4);
    bin = bytes.substr(binAt + 8, binLength);
  } else {
    doc = json::parse(bytes);
    bin = readText((fs::path(file).parent_path() / doc["buffers"][0]["uri"].get<std::string>()));
  }
  // Element k of an accessor: its bytes (stride from the buffer view, else tightly packed).
  auto element = [&](const json& accessor, size_t k, size_t size) {
    const json& view = doc["bufferViews"][accessor["bufferView"].get<size_t>()];
    const size_t stride = view.value("byteStride", size);
    return bin.data() + view.value("byteOffset", size_t(0)) +
           accessor.value("byteOffset", size_t(0)) + k * stride;
  };
  auto index = [&](const json& accessor, size_t k) -> uint32_t {
    const int type = accessor["componentType"].get<int>();
    const size_t size = type == 5121 ? 1 : type == 5123 ? 2 : 4;
    uint32_t v = 0;
    std::memcpy(&v, element(accessor, k, size), size);  // little-endian
    return v;
  };
  GltfFacts f;
  std::function<void(int, glm::mat4)> visit = [&](int ni, glm::mat4 parent) {
    const json& node = doc["nodes"][size_t(ni)];
    glm::mat4 local(1.0f);
    if (node.contains("matrix")) {
      std::vector<float> m = node["matrix"].get<std::vector<float>>();
      local = glm::make_mat4(m.data());  // column-major, as glm
    } else {
      std::vector<float> t = node.value("translation", std::vector<float>{0, 0, 0});
      std::vector<float> r = node.value("rotation", std::vector<float>{0, 0, 0, 1});
      std::vector<float> s = node.value("scale", std::vector<float>{1, 1, 1});
      local = glm::translate(glm::mat4(1.0f), {t[0], t[1], t[2]}) *
              glm::mat4_cast(glm::quat(r[3], r[0], r[1], r[2])) *
              glm::scale(glm::mat4(1.0f), {s[0], s[1], s[2]});
    }
    const glm::mat4 global = parent * local;
    if (node.contains("mesh"))
      for (const json& prim : doc["meshes"][node["mesh"].get<size_t>()]["primitives"]) {
        if (prim.value("mode", 4) != 4) continue;
        const json& pa = doc["accessors"][prim["attributes"]["POSITION"].get<size_t>()];
        std::vector<glm::vec3> p(pa["count"].get<size_t>());
        for (size_t v = 0; v < p.size(); ++v) {
          std::memcpy(&p[v], element(pa, v, 12), 12);
          const glm::vec3 wp = glm::vec3(global * glm::vec4(p[v], 1.0f));
          f.lo = glm::min(f.lo, wp);
          f.hi = glm::max(f.hi, wp);
        }
        std::vector<uint32_t> idx;
        if (prim.contains("indices")) {
          const json& ia = doc["accessors"][prim["indices"].get<size_t>()];
          for (size_t k = 0; k < ia["count"].get<size_t>(); ++k) idx.push_back(index(ia, k));
        } else {
          for (uint32_t k = 0; k < p.size(); ++k) idx.push_back(k);
        }
        for (size_t t = 0; t + 2 < idx.size(); t += 3) {
          ++f.triangles;
          const uint32_t a = idx[t], b = idx[t + 1], c = idx[t + 2];
          if (a == b || b == c || a == c ||
              !(glm::length(glm::cross(p[b] - p[a], p[c] - p[a])) > 0.0f))
            ++f.degenerate;
        }
      }
    for (const json& c : node.value("children", json::array())) visit(c.get<int>(), global);
  };
  for (const json& n : doc["scenes"][doc.value("scene", 0)]["nodes"])
    visit(n.get<int>(), glm::mat4(1.0f));
  return f;
}

// The asset's triangles placed at time 0 in object space: count and bounds.
GltfFacts loadedFacts(const AssetData& a) {
  GltfFacts f;
  f.triangles = a.mesh.triangles.size();
  const std::vector<glm::mat4> nodes = a.nodeMatrices(0.0f);
  for (size_t i = 0; i < a.mesh.positions.size(); ++i) {
    const glm::vec3 p =
        glm::vec3(nodes[a.mesh.vertexNodes[i]] * glm::vec4(a.mesh.positions[i], 1.0f));
    f.lo = glm::min(f.lo, p);
    f.hi = glm::max(f.hi, p);
  }
  return f;
}

void expectMatchesFile(const std::string& file, size_t minPixels) {
  const GltfFacts expected = readGltfFacts(file);
  fs::path dir = test::freshDir("asset_gltf");
  json obj = assetObject(file);
  const Scene s = parseIn(dir, assetScene(obj));
  const AssetData& a = *s.objects[0].asset;
  const GltfFacts got = loadedFacts(a);
  EXPECT_EQ(got.triangles, expected.triangles - expected.degenerate) << file;
  EXPECT_EQ(a.stats.degenerateTriangles, expected.degenerate) << file;
  const float extent = glm::length(expected.hi - expected.lo);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(got.lo[k], expected.lo[k], 1e-5f * extent) << file << " axis " << k;
    EXPECT_NEAR(got.hi[k], expected.hi[k], 1e-5f * extent) << file << " axis " << k;
  }
  // Renders: frame the whole asset and count the pixels it covers.
  json scene = assetScene(obj);
  const glm::vec3 centre = 0.5f * (expected.lo + expected.hi);
  scene["camera"]["keys"][0]["target"] = {centre.x, centre.y, centre.z};
  scene["camera"]["keys"][0]["eye"] = {centre.x + 0.8f * extent, centre.y + 0.6f * extent,
                                       centre.z + 1.2f * extent};
  scene["camera"]["keys"][0]["up"] = {0, 1, 0};
  scene["lights"][0]["keys"][0]["translate"] = {centre.x, centre.y + extent, centre.z};
  scene["lights"][0]["keys"][0]["scale"] = {extent, 1, extent};
  const Scene framed = parseIn(dir, scene);
  auto frame = SequenceRenderer(framed, test::tinySettings(32, 24, 1, 4)).renderFrame(0).frame;
  size_t covered = 0, finite = 0;
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 32; ++x) {
      if (frame.get("meshId").at(x, y) != 0.0f) continue;
      ++covered;
      bool ok = true;
      for (int c = 0; c < 3; ++c) ok = ok && std::isfinite(frame.get("color").at(x, y, c));
      if (ok) ++finite;
    }
  EXPECT_GE(covered, minPixels) << file;
  EXPECT_EQ(finite, covered) << file;
}

TEST(AssetGltf, BoxTexturedLoadsWithTheFilesTrianglesBoundsAndTexture) {
  const std::string file = kTestModels + "/BoxTextured-glTF/BoxTextured.gltf";
  REQUIRE_TEST_MODEL(file);
  expectMatchesFile(file, 100);
  const Scene s = parseIn(test::freshDir("asset_box"), assetScene(assetObject(file)));
  EXPECT_EQ(s.objects[0].asset->mesh.triangles.size(), 12u);  // BoxTextured: 36 indices
  const Material& m = s.materials[size_t(s.objects[0].assetMaterialBase)];
  ASSERT_TRUE(m.baseColorTexture);
  const cv::Mat logo = cv::imread(kTestModels + "/BoxTextured-glTF/CesiumLogoFlat.png");
  EXPECT_EQ(m.baseColorTexture.image->width, logo.cols);
  EXPECT_EQ(m.baseColorTexture.image->height, logo.rows);
  EXPECT_EQ(m.roughness, 1.0f);
  EXPECT_EQ(m.metallic, 0.0f);
}

TEST(AssetGltf, TwoCylinderEngineGlbLoadsWithTheFilesTrianglesAndBounds) {
  const std::string file = kTestModels + "/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  REQUIRE_TEST_MODEL(file);
  expectMatchesFile(file, 60);
  // The file itself has many triangles with a repeated index (10413 of its 75730 mesh triangles):
  // dropped and counted, never drawn.
  const Scene s = parseIn(test::freshDir("asset_engine"), assetScene(assetObject(file)));
  EXPECT_GT(s.objects[0].asset->stats.degenerateTriangles, 10000u);
  ASSERT_FALSE(s.warnings.empty());
  EXPECT_NE(s.warnings[0].find("degenerate triangles"), std::string::npos) << s.warnings[0];
}

// --- Animation -------------------------------------------------------------------------------

// tests/data/assets/animated_box.gltf (make_animated_box.py): node "mover" under "root"
// (translation (0, 0.5, 0)) slides from x = -1 to x = 1 and turns 0 -> 90 degrees about +Y over
// 0..1 s, LINEAR.
const std::string kAnimatedBox = std::string(ARENA_TEST_DATA) + "/assets/animated_box.gltf";

TEST(AssetAnimation, AnimatedNodeMovesAsTheFileSays) {
  AssetData a = loadAsset(kAnimatedBox, AssetRef{});
  EXPECT_FLOAT_EQ(a.durationSeconds(), 1.0f);
  const glm::vec3 corner(0.5f, 0.5f, 0.5f);  // a box corner in the mover's space
  auto cornerAt = [&](float seconds) {
    const std::vector<glm::mat4> m = a.nodeMatrices(seconds);
    return glm::vec3(m[a.mesh.vertexNodes[0]] * glm::vec4(corner, 1.0f));
  };
  auto expected = [&](float s) {
    const float angle = glm::radians(90.0f * s), x = -1.0f + 2.0f * s;
    // Rotation about +Y by angle: (cx, cz) -> (cx cos + cz sin, -cx sin + cz cos).
    return glm::vec3(x + 0.5f * std::cos(angle) + 0.5f * std::sin(angle), 0.5f + 0.5f,
                     -0.5f * std::sin(angle) + 0.5f * std::cos(angle));
  };
  for (float s : {0.0f, 0.25f, 0.5f, 1.0f}) {
    const glm::vec3 got = cornerAt(s), want = expected(s);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(got[k], want[k], 1e-5f) << "t=" << s << " axis " << k;
  }
  EXPECT_EQ(cornerAt(3.0f), cornerAt(1.0f));   // holds the last key after the end
  EXPECT_EQ(cornerAt(-1.0f), cornerAt(0.0f));  // and the first before the start

  // In a scene: frame f is asset time f / fps.
  fs::path dir = test::freshDir("asset_anim");
  json obj = assetObject(kAnimatedBox);
  obj["asset"]["fps"] = 20;
  const Scene s = parseIn(dir, assetScene(obj, 30));
  const SceneState st = evaluateState(s, 10, 16, 16);  // 0.5 s
  ASSERT_EQ(st.nodeMatrices.size(), 1u);
  const glm::vec3 p =
      glm::vec3(st.nodeMatrices[0][a.mesh.vertexNodes[0]] * glm::vec4(corner, 1.0f));
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(p[k], expected(0.5f)[k], 1e-5f);
  // Animated frames are distinct states (their own references); after the end they are equal.
  EXPECT_NE(evaluateState(s, 3, 16, 16).hash(), evaluateState(s, 4, 16, 16).hash());
  EXPECT_EQ(evaluateState(s, 20, 16, 16).hash(), evaluateState(s, 25, 16, 16).hash());
  EXPECT_NE(s.materials[size_t(s.objects[0].assetMaterialBase)].name.find("red"),
            std::string::npos);
}

// --- The bad-asset contract ------------------------------------------------------------------

TEST(AssetContract, BadAssetsAreErrorsNamingTheFileAndTheProblem) {
  fs::path dir = test::freshDir("asset_contract");
  auto errorOf = [&](const std::string& file) {
    return parseError(dir, assetScene(assetObject(file)));
  };
  auto expectError = [&](const std::string& file, const std::string& what) {
    const std::string e = errorOf(file);
    EXPECT_NE(e.find("$.objects[0].asset.file"), std::string::npos) << e;
    EXPECT_NE(e.find(what), std::string::npos) << "expected '" << what << "' in: " << e;
  };
  // Missing files, in the scene's folder and in the extracted-asset cache.
  expectError("nothing.obj", "asset file not found");
  expectError("assets:blendswap-cc-0/none/none.obj", "bash scripts/setup.sh");
  // Unsupported format.
  writeFile(dir / "a.fbx", "x");
  expectError("a.fbx", "unsupported asset format '.fbx'");
  // Too big: a sparse file just over the limit is refused before it is read (costs no disk).
  {
    std::ofstream(dir / "huge.glb").close();
    fs::resize_file(dir / "huge.glb", kMaxAssetBytes + 1);
  }
  expectError("huge.glb", "-byte limit");
  // Non-finite vertices: 1e39 overflows float.
  writeFile(dir / "inf.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n");
  expectError("inf.obj", "non-finite position");
  // Nothing to draw.
  writeFile(dir / "empty.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  EXPECT_NE(errorOf("empty.obj"), "");
  // A texture file that is not an image.
  writeFile(dir / "quad.obj", quadObj("tex"));
  writeFile(dir / "quad.mtl", "newmtl tex\nmap_Kd junk.png\n");
  writeFile(dir / "junk.png", "this is not a PNG");
  expectError("quad.obj", "junk.png: cannot decode the texture image");
  writeFile(dir / "quad.mtl", "newmtl tex\nKd 1 1 1\n");
  EXPECT_EQ(errorOf("quad.obj"), "");
  // Where assimp would give a default grey without a word: a library that is not there, a
  // material no library defines.
  {
    std::string text = quadObj("tex");
    writeFile(dir / "nolib.obj", text.replace(0, text.find('\n'), "mtllib gone.mtl"));
  }
  expectError("nolib.obj", "nolib.obj:1: 'mtllib gone.mtl' names");
  expectError("nolib.obj", "which does not exist; expected a material library (.mtl) there");
  writeFile(dir / "misspelt.obj", quadObj("texx"));
  expectError(
      "misspelt.obj",
      "'usemtl texx' names no material of its libraries (quad.mtl); expected a 'newmtl texx'");
  // Scene-level fields.
  json bad = assetScene(assetObject("quad.obj", 1.0, "x"));
  EXPECT_NE(parseError(dir, bad).find("$.objects[0].asset.upAxis"), std::string::npos);
  bad = assetScene(assetObject("quad.obj", 0.0));
  EXPECT_NE(parseError(dir, bad).find("$.objects[0].asset.unitMeters"), std::string::npos);
  bad = assetScene(assetObject("quad.obj"));
  bad["objects"][0]["material"] = "nope";
  EXPECT_NE(parseError(dir, bad).find("unknown material 'nope'"), std::string::npos);
}

TEST(AssetContract, DegenerateTrianglesAreDroppedAndCounted) {
  fs::path dir = test::freshDir("asset_degenerate");
  writeFile(dir / "d.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 3\n");
  const Scene s = parseIn(dir, assetScene(assetObject("d.obj")));
  EXPECT_EQ(s.objects[0].asset->stats.triangles, 1u);
  EXPECT_EQ(s.objects[0].asset->stats.degenerateTriangles, 2u);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("degenerate triangles (zero area or repeated vertices) dropped: 2"),
            std::string::npos)
      << s.warnings[0];
}

TEST(AssetContract, UnsupportedGltfFeaturesFromTheTestModelsAreErrors) {
  fs::path dir = test::freshDir("asset_unsupported");
  const std::string morph =
      kTestModels + "/glTF-Sample-Models/AnimatedMorphCube-glTF/AnimatedMorphCube.gltf";
  REQUIRE_TEST_MODEL(morph);
  auto errorOf = [&](const std::string& file) {
    return parseError(dir, assetScene(assetObject(file)));
  };
  std::string e = errorOf(morph);
  EXPECT_NE(e.find("AnimatedMorphCube.gltf"), std::string::npos) << e;
  EXPECT_NE(e.find("morph targets"), std::string::npos) << e;
  const std::string infinite = kTestModels + "/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb";
  e = errorOf(infinite);
  EXPECT_NE(e.find("BoxWithInfinites.glb"), std::string::npos) << e;
  EXPECT_NE(e.find("non-finite"), std::string::npos) << e;
  const std::string missingBin = kTestModels + "/MissingBin/BoxTextured.gltf";
  e = errorOf(missingBin);
  EXPECT_NE(e.find("MissingBin/BoxTextured.gltf"), std::string::npos) << e;
}

TEST(AssetScene, CreditsAreStoredAndAssetsComeFromTheCacheDirectory) {
  fs::path dir = test::freshDir("asset_credits");
  fs::path cache = dir / "cache";
  fs::create_directories(cache / "kit");
  writeFile(cache / "kit" / "quad.obj", quadObj("m"));
  writeFile(cache / "kit" / "quad.mtl", "newmtl m\nKd 0.5 0.5 0.5\n");
  setenv("ARENA_ASSET_DIR", cache.c_str(), 1);
  json scene = assetScene(assetObject("assets:kit/quad.obj"));
  scene["credits"] = json::array(
      {{{"asset", "quad"}, {"author", "Someone"}, {"license", "CC0-1.0"}, {"source", "here"}}});
  const Scene s = parseIn(dir, scene);
  ASSERT_EQ(s.credits.size(), 1u);
  EXPECT_EQ(s.credits[0].author, "Someone");
  EXPECT_EQ(s.credits[0].license, "CC0-1.0");
  EXPECT_EQ(s.objects[0].assetRef.file, (cache / "kit" / "quad.obj").string());
  EXPECT_EQ(s.materials.back().name, "thing/m");
  scene["credits"][0].erase("author");
  EXPECT_NE(parseError(dir, scene).find("$.credits[0].author"), std::string::npos);
  unsetenv("ARENA_ASSET_DIR");
}


// ---- Fidelity to the paper and the reference implementation ------------------------------
// The realistic scenes of issue 18 (scenes/living_room.json, scenes/foliage_window.json) and the
// script that extracts their furniture from Debian's sweethome3d-furniture package
// (scripts/extract_assets.py): its contract (clear errors, nothing half-extracted, idempotent)
// and tiny end-to-end renders of both scenes.

namespace fs = std::filesystem;
using nlohmann::json;

const std::string kScript = std::string(ARENA_SOURCE_DIR) + "/scripts/extract_assets.py";
const std::string kArchive = "/usr/share/sweethome3d/furniture/BlendSwap-CC-0.sh3f";

using Result = test::CommandResult;

// Runs the script with the archive and asset cache given through its environment variables.
Result extract(const std::string& archive, const fs::path& assetDir, const std::string& models) {
  return test::runCommand("ARENA_SH3F_ARCHIVE='" + archive + "' ARENA_ASSET_DIR='" + assetDir.string() +
                          "' python3 " + kScript + " " + models);
}

std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> out;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  return out;
}

// A zip holding blendswap-cc-0/<model>/ with two stored files, written by Python's zipfile;
// `corruptSecond` flips a byte of the second file's data, so its CRC check fails mid-extraction.
fs::path writeZip(const fs::path& dir, const std::string& model, bool corruptSecond,
                  const std::string& secondName = "b.mtl") {
  const fs::path zip = dir / "test.sh3f";
  const std::string py =
      "import zipfile,sys\n"
      "p,m,second,corrupt=sys.argv[1],sys.argv[2],sys.argv[3],sys.argv[4]=='1'\n"
      "with zipfile.ZipFile(p,'w',zipfile.ZIP_STORED) as z:\n"
      "  z.writestr('blendswap-cc-0/'+m+'/a.obj','v 0 0 0\\n'*64)\n"
      "  z.writestr('blendswap-cc-0/'+m+'/'+second,'SECOND-MEMBER-DATA'*16)\n"
      "if corrupt:\n"
      "  d=bytearray(open(p,'rb').read()); i=d.index(b'SECOND-MEMBER-DATA'); d[i]^=0xff\n"
      "  open(p,'wb').write(bytes(d))\n";
  std::ofstream(dir / "make_zip.py") << py;
  const std::string cmd = "python3 '" + (dir / "make_zip.py").string() + "' '" + zip.string() +
                          "' " + model + " '" + secondName + "' " + (corruptSecond ? "1" : "0");
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return zip;
}

TEST(ExtractAssets, MissingArchiveIsAClearErrorAndExtractsNothing) {
  const fs::path dir = test::freshDir("extract_missing");
  const std::string missing = (dir / "no-such.sh3f").string();
  Result r = extract(missing, dir / "assets", "sofa2");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("archive not found: " + missing), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("sweethome3d-furniture"), std::string::npos) << r.output;
  EXPECT_TRUE(entries(dir / "assets" / "sweethome3d").empty());
}

TEST(ExtractAssets, ACorruptMemberLeavesNoHalfExtractedModel) {
  const fs::path dir = test::freshDir("extract_corrupt");
  const fs::path zip = writeZip(dir, "model", true);
  Result r = extract(zip.string(), dir / "assets", "model");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("extract_assets: error:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("b.mtl"), std::string::npos) << "names the bad member: " << r.output;
  // The first member was written before the second failed: only a temporary held it.
  EXPECT_TRUE(entries(dir / "assets" / "sweethome3d").empty());

  // The same archive intact: the model appears whole, and a second run leaves it alone.
  const fs::path good = writeZip(dir, "model", false);
  r = extract(good.string(), dir / "assets", "model");
  ASSERT_EQ(r.status, 0) << r.output;
  const fs::path model = dir / "assets" / "sweethome3d" / "model";
  EXPECT_EQ(fs::file_size(model / "a.obj"), 64u * 8u);
  EXPECT_EQ(fs::file_size(model / "b.mtl"), 18u * 16u);
  const auto written = fs::last_write_time(model / "a.obj");
  fs::remove(good);  // an extracted model needs no archive
  r = extract(good.string(), dir / "assets", "model");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(r.output, "");
  EXPECT_EQ(fs::last_write_time(model / "a.obj"), written);
}

TEST(ExtractAssets, UnknownModelsAndEscapingMembersAreRejected) {
  const fs::path dir = test::freshDir("extract_bad");
  const fs::path zip = writeZip(dir, "model", false, "../../escaped.txt");
  Result r = extract(zip.string(), dir / "assets", "model");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("escapes the model folder"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "escaped.txt"));
  EXPECT_FALSE(fs::exists(dir / "assets" / "escaped.txt"));
  EXPECT_TRUE(entries(dir / "assets" / "sweethome3d").empty());

  r = extract(zip.string(), dir / "assets", "sofa");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("no model 'sofa'"), std::string::npos) << r.output;
  r = extract(zip.string(), dir / "assets", "'../model'");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("model name '../model'"), std::string::npos) << r.output;
  EXPECT_TRUE(entries(dir / "assets" / "sweethome3d").empty());
}

// Leftovers of a killed run (a .partial-* folder) are removed and the model extracted whole.
TEST(ExtractAssets, ATemporaryOfAKilledRunIsReplaced) {
  const fs::path dir = test::freshDir("extract_stale");
  const fs::path zip = writeZip(dir, "model", false);
  const fs::path stale = dir / "assets" / "sweethome3d" / ".partial-model-99999";
  fs::create_directories(stale);
  std::ofstream(stale / "a.obj") << "half";
  Result r = extract(zip.string(), dir / "assets", "model");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_EQ(entries(dir / "assets" / "sweethome3d"), std::vector<std::string>{"model"});
}

// The furniture models a shipped scene names ("assets:sweethome3d/<model>/...") that are not in the
// asset cache; empty when the scene can render.
std::vector<std::string> missingModels(const std::string& scene) {
  const std::string text = readText(defaultScenesDir() + "/" + scene + ".json");
  const fs::path root = fs::path(assetCacheDir()) / "sweethome3d";
  std::vector<std::string> missing;
  const std::regex ref("assets:sweethome3d/([A-Za-z0-9_]+)/");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), ref); it != std::sregex_iterator();
       ++it)
    if (!fs::is_directory(root / (*it)[1].str())) missing.push_back((*it)[1].str());
  return missing;
}

#define SKIP_WITHOUT_ASSETS(scene)                                                                 \
  if (auto missing = missingModels(scene); !missing.empty())                                       \
  GTEST_SKIP() << scene << ": furniture not extracted (" << missing.front()                        \
               << " and others missing): run python3 scripts/extract_assets.py (scripts/setup.sh " \
                  "does)"

bool allFinite(const Image& img) {
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < img.channels(); ++c)
        if (!std::isfinite(img.at(x, y, c))) return false;
  return true;
}

// The object index (= meshId) of the object named `name`.
int objectIndex(const Scene& s, const std::string& name) {
  for (size_t i = 0; i < s.objects.size(); ++i)
    if (s.objects[i].name == name) return int(i);
  ADD_FAILURE() << "no object " << name << " in " << s.file;
  return -1;
}

TEST(RealisticScenes, LivingRoomShowsItsFurnitureAndTheLampSwitchesOff) {
  SKIP_WITHOUT_ASSETS("living_room");
  const Scene scene = test::shippedScene("living_room");
  ASSERT_EQ(scene.events.size(), 1u);
  EXPECT_EQ(scene.events[0].kind, arena::EventKind::LightOff);
  EXPECT_EQ(scene.events[0].what, "lamp");
  SequenceRenderer renderer(scene, test::tinySettings(64, 36, 0, 16));
  const auto frame = renderer.renderFrame(0);
  for (const auto& [name, image] : frame.frame.all()) EXPECT_TRUE(allFinite(image)) << name;
  const Image& meshId = frame.frame.get("meshId");
  std::set<int> visible;
  for (int y = 0; y < meshId.height(); ++y)
    for (int x = 0; x < meshId.width(); ++x) visible.insert(int(meshId.at(x, y)));
  for (const char* name : {"couch", "table", "chair_front", "chair_side", "plant", "armchair",
                           "pendant", "tatami_10", "wall_back_left"})
    EXPECT_TRUE(visible.count(objectIndex(scene, name))) << name << " not in view at frame 0";

  // At the event the pendant lamp goes dark and with it a good part of the room's light (the
  // window still lights the rest).
  const int event = scene.events[0].frame;
  auto meanLuminance = [&](int t) {
    const ReferenceResult ref = renderer.renderReference(t);
    const Image& c = ref.layers.get("color");
    EXPECT_TRUE(allFinite(c));
    double sum = 0;
    for (int y = 0; y < c.height(); ++y)
      for (int x = 0; x < c.width(); ++x)
        sum += 0.2126 * c.at(x, y, 0) + 0.7152 * c.at(x, y, 1) + 0.0722 * c.at(x, y, 2);
    return sum / (double(c.width()) * c.height());
  };
  const double before = meanLuminance(event - 1), after = meanLuminance(event);
  std::printf("living_room 64x36: mean luminance %.4f before the event, %.4f after\n", before,
              after);
  EXPECT_GT(after, 0.0);
  EXPECT_LT(after, 0.75 * before);
}

TEST(RealisticScenes, FoliageWindowIsThinGeometryAgainstABrightBackground) {
  SKIP_WITHOUT_ASSETS("foliage_window");
  const Scene scene = test::shippedScene("foliage_window");
  SequenceRenderer renderer(scene, test::tinySettings(64, 36, 0, 16));
  const auto frame = renderer.renderFrame(0);
  for (const auto& [name, image] : frame.frame.all()) EXPECT_TRUE(allFinite(image)) << name;
  const ReferenceResult ref = renderer.renderReference(0);
  const Image& color = ref.layers.get("color");
  const Image& meshId = frame.frame.get("meshId");
  const int plant = objectIndex(scene, "plant");
  auto isPlant = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < meshId.width() && y < meshId.height() &&
           int(meshId.at(x, y)) == plant;
  };
  // Thin: the window shows through the crown (sky pixels with plant on both sides in their row),
  // and much of the plant is silhouette. Bright: the window outshines the plant.
  int plantPixels = 0, silhouette = 0, skyPixels = 0, holes = 0;
  double plantLum = 0, skyLum = 0;
  for (int y = 0; y < meshId.height(); ++y) {
    int firstPlant = meshId.width(), lastPlant = -1;
    for (int x = 0; x < meshId.width(); ++x)
      if (isPlant(x, y)) firstPlant = std::min(firstPlant, x), lastPlant = x;
    for (int x = 0; x < meshId.width(); ++x) {
      const double lum =
          0.2126 * color.at(x, y, 0) + 0.7152 * color.at(x, y, 1) + 0.0722 * color.at(x, y, 2);
      if (isPlant(x, y)) {
        ++plantPixels;
        plantLum += lum;
        if (!isPlant(x - 1, y) || !isPlant(x + 1, y) || !isPlant(x, y - 1) || !isPlant(x, y + 1))
          ++silhouette;
      } else if (meshId.at(x, y) < 0) {
        ++skyPixels;
        skyLum += lum;
        if (x > firstPlant && x < lastPlant) ++holes;
      }
    }
  }
  const double pixels = double(meshId.width()) * meshId.height();
  std::printf(
      "foliage_window 64x36: plant %.3f, sky %.3f of the frame; silhouette %.3f, holes %.3f "
      "of the plant; sky/plant luminance %.1f\n",
      plantPixels / pixels, skyPixels / pixels, double(silhouette) / plantPixels,
      double(holes) / plantPixels, (skyLum / skyPixels) / (plantLum / plantPixels));
  EXPECT_GT(plantPixels / pixels, 0.1);
  EXPECT_GT(skyPixels / pixels, 0.3);
  EXPECT_GT(double(silhouette) / plantPixels, 0.25);
  EXPECT_GT(double(holes) / plantPixels, 0.04);
  EXPECT_GT(skyLum / skyPixels, 5.0 * plantLum / plantPixels);
}

}  // namespace
}  // namespace arena
