// The asset importers under deterministic random mutation (always runs; the libFuzzer target
// tests/fuzz/asset_fuzzer.cpp explores further when clang is there). Every mutant of every seed in
// tests/fuzz/asset_seeds/ (a small OBJ + MTL, glTF with its buffer inline and as a .bin, a .glb, a
// mesh OBJ) must either load into geometry the tracer can use or be rejected with an arena::Error
// naming the file; under ARENA_SANITIZE this also catches memory errors and undefined behaviour.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "core/atomic_file.hpp"
#include "tests/fuzz/asset_fuzz_target.hpp"
#include "tests/fuzz/mutations.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using fuzz::AssetInput;
using fuzz::mutateBytes;
using fuzz::mutateJson;
using fuzz::mutateLines;
using nlohmann::json;

struct Seed {
  std::string name;
  AssetInput kind;
  std::string main, side;
};

std::vector<Seed> readSeeds() {
  std::vector<Seed> seeds;
  for (const char* name : {"obj_mtl", "gltf_inline", "gltf_bin", "glb", "mesh_obj"}) {
    const std::string bytes = readText((fs::path(ARENA_SOURCE_DIR) / "tests/fuzz/asset_seeds" / name).string());
    const std::string rest = bytes.substr(1);
    const size_t split = rest.find(fuzz::kSideFileSeparator);
    seeds.push_back({name, AssetInput(bytes[0] % 4), rest.substr(0, split),
                     split == std::string::npos ? "" : rest.substr(split + fuzz::kSideFileSeparator.size())});
  }
  return seeds;
}

TEST(AssetFuzz, EverySeedLoads) {
  const fs::path dir = test::freshDir("asset_fuzz_seeds");
  for (const Seed& s : readSeeds()) EXPECT_TRUE(fuzz::importAssetOrReject(s.kind, s.main, s.side, dir)) << s.name;
}

// What `scripts/fuzz.sh asset` found, each now a clear error naming the file and the element, or
// a documented fallback.
TEST(AssetFuzz, FindingsOfTheFuzzerAreClearErrorsOrFallbacks) {
  const fs::path dir = test::freshDir("asset_fuzz_findings");
  const std::string triangle = "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  // The message of the rejection (importAssetOrReject writes the files and checks the contract).
  auto error = [&](AssetInput kind, const std::string& main, const std::string& side) -> std::string {
    if (fuzz::importAssetOrReject(kind, main, side, dir)) return "";
    try {
      parseScene(fuzz::sceneFor(kind, fuzz::mainFileOf(kind, dir)), (dir / "fuzz.json").string());
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  // A texture statement before any "newmtl": assimp 5.2 wrote it through a null material (SEGV).
  EXPECT_NE(error(AssetInput::ObjWithMtl, triangle, "# made by hand\nmap_Kd x.png\nnewmtl m\n")
                .find((dir / "a.mtl").string() + ":2: 'map_Kd' comes before any 'newmtl'"),
            std::string::npos)
      << error(AssetInput::ObjWithMtl, triangle, "# made by hand\nmap_Kd x.png\nnewmtl m\n");
  EXPECT_EQ(error(AssetInput::ObjWithMtl, triangle, "# made by hand\nnewmtl m\nmap_Kd x.png\n"), "");
  // A statement after a NUL or a carriage return ends the comment before it, as assimp reads it
  // ("#x\0aniso 1": a write through the null material at 0x50e0, a fuzzer find).
  {
    const std::string nul = std::string("#newmtl") + '\0' + "aniso 1\nnewmtl m\n";
    EXPECT_NE(error(AssetInput::ObjWithMtl, triangle, nul).find((dir / "a.mtl").string() + ":1: 'aniso' comes before"),
              std::string::npos)
        << error(AssetInput::ObjWithMtl, triangle, nul);
    EXPECT_NE(error(AssetInput::ObjWithMtl, triangle, "# a\raniso 1\nnewmtl m\n").find(":1: 'aniso' comes before"),
              std::string::npos);
    // Windows line ends stay one line each.
    EXPECT_EQ(error(AssetInput::ObjWithMtl, triangle, "# made by hand\r\nnewmtl m\r\nKd 1 1 1\r\n"), "");
  }
  // The OBJ read as its own material library, where assimp 5.2 wrote "map_d" through a null
  // material (SEGV, the fuzzer's recurring find once each input started from an empty folder):
  // named by "mtllib" itself, or reached by assimp's fallback for an unusable "mtllib" path.
  {
    const std::string self = error(AssetInput::ObjWithMtl, "mtllib a.obj\nmap_d\n", "");
    EXPECT_NE(self.find((dir / "a.obj").string() + ":1: 'mtllib a.obj' names the OBJ file itself"), std::string::npos)
        << self;
    // A library that does not exist is refused before assimp opens anything (the importer's own
    // refusal of the fallback stays behind it).
    const std::string fallback =
        error(AssetInput::ObjWithMtl, "mtllib a.mtl/x/a.obj\nmap_Kd missing.png\n", "0.5\n");
    EXPECT_NE(fallback.find(":1: 'mtllib a.mtl/x/a.obj' names"), std::string::npos) << fallback;
    EXPECT_NE(fallback.find("which does not exist"), std::string::npos) << fallback;
  }
  // A material library named like a URL: assimp 5.2 reduced "m[://" to the folder ".//" and, given
  // no stream for it, searched again without end (a stack overflow, the fuzzer's input below). The
  // line is refused first; a folder named directly too.
  {
    const std::string found = std::string("mtllib m[://\n`") + '\0' + ".";
    const std::string url = error(AssetInput::ObjWithMtl, found, "");
    EXPECT_NE(url.find((dir / "a.obj").string() + ":1: 'mtllib m[://' looks like a URL"), std::string::npos) << url;
    EXPECT_NE(error(AssetInput::ObjWithMtl, "mtllib a://\n" + triangle.substr(13), "").find(":1: 'mtllib a://' looks like a URL"),
              std::string::npos);
    const std::string folder = error(AssetInput::ObjWithMtl, "mtllib .\n" + triangle.substr(13), "");
    EXPECT_NE(folder.find(":1: 'mtllib .' names " + (dir / ".").string() + ", which is not a regular file"),
              std::string::npos)
        << folder;
  }
  // Any other file assimp opens and we refuse ends its import at once, whatever path assimp made of
  // the name ("q/." it also tries as ".//.", a folder): the refusal, never a null stream.
  {
    const std::string made = error(AssetInput::ObjWithMtl, "mtllib q/.\n" + triangle.substr(13), "");
    EXPECT_NE(made.find(":1: 'mtllib q/.' names"), std::string::npos)
        << made;  // before assimp, now
    EXPECT_NE(made.find("which does not exist"), std::string::npos) << made;
  }
  // Any file an OBJ names as its material library is checked as one, whatever its extension.
  {
    const fs::path other = test::freshDir("asset_fuzz_findings_lib");
    fuzz::writeBytes(other / "x.obj", "mtllib lib.txt\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    fuzz::writeBytes(other / "lib.txt", "map_Kd x.png\nnewmtl m\n");
    EXPECT_NE(test::errorOf([&] { loadAsset((other / "x.obj").string(), AssetRef{}); })
                  .find((other / "lib.txt").string() + ":1: 'map_Kd' comes before any 'newmtl'"),
              std::string::npos)
        << test::errorOf([&] { loadAsset((other / "x.obj").string(), AssetRef{}); });
    fuzz::writeBytes(other / "lib.txt", "newmtl m\nmap_Kd x.png\n");
    EXPECT_EQ(test::errorOf([&] { loadAsset((other / "x.obj").string(), AssetRef{}); }), "(no error)");
  }
  // A .glb made of OBJ text: refused before assimp hands it to another importer by its content.
  {
    const std::string message = error(AssetInput::Glb, "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "");
    EXPECT_NE(message.find((dir / "a.glb").string() + ": not a readable glTF file (expected a binary glTF container"),
              std::string::npos)
        << message;
    const std::string text = error(AssetInput::Gltf, "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "");
    EXPECT_NE(text.find((dir / "a.gltf").string() + ": not a readable glTF file (expected a JSON object"),
              std::string::npos)
        << text;
  }
  // A face of a mesh OBJ that tinyobjloader cannot read: the scene's error, not the first frame's.
  EXPECT_NE(error(AssetInput::MeshObj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "")
                .find("$.objects[0].file: " + (dir / "m.obj").string() + ": "),
            std::string::npos)
      << error(AssetInput::MeshObj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "");
  // Normals without a direction ("vn 0 0 0", 1e39 read as Inf) fall back to the face's: finite
  // unit normals (importAssetOrReject checks them).
  EXPECT_TRUE(fuzz::importAssetOrReject(AssetInput::MeshObj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvn 1e39 0 0\nf 1//1 2//2 3//1\n", "", dir));
  EXPECT_TRUE(fuzz::importAssetOrReject(AssetInput::ObjWithMtl, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n", "", dir));
  // A texture that resolves to the MTL itself (a fuzzer find: "map_Kd ... a.mtl"): an error naming
  // the texture path it could not decode, which is the side file.
  EXPECT_NE(error(AssetInput::ObjWithMtl, "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl m\nf 1/1 2/1 3/1\n",
                  "newmtl m\nKd 1 1 1\nmap_Kd a.mtl\n")
                .find((dir / "a.mtl").string() + ": cannot decode the texture image"),
            std::string::npos);
  // Indices near INT_MAX: the bounds check multiplied them by 3 in int (signed overflow, found by
  // UBSan under scripts/sanitize.sh). A vertex index is an error naming the face, a normal index a
  // fallback to the face's normal.
  EXPECT_NE(error(AssetInput::MeshObj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2147483647\n", "").find("references a missing vertex"),
            std::string::npos);
  EXPECT_TRUE(fuzz::importAssetOrReject(AssetInput::MeshObj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//2147483647 2//1 3//1\n", "", dir));
  // A .glb chunk declaring 4 GiB: assimp 5.2 allocated it before checking (the fuzzer's OOM); now
  // the container's sizes are checked first, naming the file and the chunk.
  {
    const Seed glb = readSeeds()[3];  // a copy: the vector is a temporary
    ASSERT_EQ(glb.kind, AssetInput::Glb);
    std::string damaged = glb.main;
    const uint32_t huge = 4294965827u;
    std::memcpy(&damaged[12], &huge, 4);
    const std::string message = error(AssetInput::Glb, damaged, "");
    EXPECT_NE(message.find((dir / "a.glb").string() + ": binary glTF chunk 0 declares 4294965827 bytes"),
              std::string::npos)
        << message;
    // The extension's case does not matter (the glTF readers are matched in lower case).
    const fs::path upper = test::freshDir("asset_fuzz_upper") / "A.GLB";
    fuzz::writeBytes(upper, glb.main);
    EXPECT_EQ(test::errorOf([&] { loadAsset(upper.string(), AssetRef{}); }), "(no error)");
    std::memcpy(&damaged[8], &huge, 4);  // and a total length beyond the file
    EXPECT_NE(error(AssetInput::Glb, damaged, "").find("binary glTF header declares 4294965827 bytes"), std::string::npos)
        << error(AssetInput::Glb, damaged, "");
  }
  // A node transform beyond float range places its triangles at infinity: an error naming the node.
  json gltf = json::parse(readSeeds()[1].main);
  gltf["nodes"][0]["translation"] = {1e39, 0, 0};
  EXPECT_NE(error(AssetInput::Gltf, gltf.dump(), "").find((dir / "a.gltf").string() +
                                                          ": node 'mover' has a non-finite transform at asset time 0"),
            std::string::npos)
      << error(AssetInput::Gltf, gltf.dump(), "");
}

TEST(AssetFuzz, RandomMutationsOfSmallAssetsLoadOrAreRejectedNamingTheFile) {
  constexpr int kMutantsPerSeed = 300;  // 5 seeds: 1500 imports, a few seconds in Release
  std::mt19937 rng(30);                 // fixed: the same mutants on every run
  const fs::path dir = test::freshDir("asset_fuzz");
  int loaded = 0, rejected = 0;
  for (const Seed& seed : readSeeds()) {
    for (int i = 0; i < kMutantsPerSeed; ++i) {
      std::string main = seed.main, side = seed.side;
      // The side file (MTL, .bin) a quarter of the time when there is one.
      const bool mutateSide = !side.empty() && std::uniform_int_distribution<int>(0, 3)(rng) == 0;
      std::string& target = mutateSide ? side : main;
      const bool binary = mutateSide ? seed.kind != AssetInput::ObjWithMtl : seed.kind == AssetInput::Glb;
      const bool gltfText = !mutateSide && seed.kind == AssetInput::Gltf;
      if (binary || std::uniform_int_distribution<int>(0, 2)(rng) == 0)
        target = mutateBytes(target, rng);
      else
        target = gltfText ? mutateJson(target, rng) : mutateLines(target, rng);
      try {
        (fuzz::importAssetOrReject(seed.kind, main, side, dir) ? loaded : rejected)++;
      } catch (const std::exception& e) {
        ADD_FAILURE() << seed.name << " mutant " << i << " escaped as a non-arena exception: " << e.what()
                      << "\n--- main:\n"
                      << main.substr(0, 1500) << "\n--- side:\n"
                      << side.substr(0, 500);
      }
    }
  }
  // Both outcomes must occur, or the mutator is not exercising the importers.
  EXPECT_GT(loaded, 300);
  EXPECT_GT(rejected, 200);
  RecordProperty("mutants", loaded + rejected);
  std::printf("asset fuzz: %d mutants, %d loaded, %d rejected\n", loaded + rejected, loaded, rejected);
}

}  // namespace
}  // namespace arena
