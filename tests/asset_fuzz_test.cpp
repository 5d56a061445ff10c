// The asset importers under deterministic random mutation (always runs; the libFuzzer target
// tests/fuzz/asset_fuzzer.cpp explores further when clang is there). Every mutant of every seed in
// tests/fuzz/asset_seeds/ (a small OBJ + MTL, glTF with its buffer inline and as a .bin, a .glb, a
// mesh OBJ) must either load into geometry the tracer can use or be rejected with an arena::Error
// naming the file; under ARENA_SANITIZE this also catches memory errors and undefined behaviour.
#include <gtest/gtest.h>

#include <random>

#include "core/atomic_file.hpp"
#include "tests/fuzz/asset_fuzz_target.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;
using fuzz::AssetInput;
using nlohmann::json;

// Numbers that broke importers before: float overflow, NaN and infinity spelled out, wrapping
// and negative indices, zero.
const std::vector<std::string> kNastyNumbers = {"nan",  "-nan", "inf",        "1e39",        "-1e39",
                                                "1e30", "0",    "-0",         "-1",          "-2",
                                                "65536", "4294967295", "4294967296", "-2147483649", "1e-45",
                                                "999999999", ""};

json nastyJson(std::mt19937& rng) {
  static const std::vector<json> values = {0, -1, 1, 3, 4294967295LL, 4294967296LL, 1e39, -1e39, 1e30, 1e-45,
                                           -0.0, "", "a.bin", "data:,", "/dev/zero", true, nullptr,
                                           json::array(), json::object(), json::array({0, 0, 0}),
                                           json::array({1e39, 0, 0}), json::array({0, 0, 0, 0}),
                                           json::array({1, 2})};
  return values[std::uniform_int_distribution<size_t>(0, values.size() - 1)(rng)];
}

void collectPointers(const json& j, const json::json_pointer& at, std::vector<json::json_pointer>& out) {
  out.push_back(at);
  if (j.is_object())
    for (auto& [k, v] : j.items()) collectPointers(v, at / k, out);
  else if (j.is_array())
    for (size_t i = 0; i < j.size(); ++i) collectPointers(j[i], at / i, out);
}

// A glTF document with one value replaced, a member deleted or an array element repeated.
std::string mutateJson(const std::string& text, std::mt19937& rng) {
  json doc = json::parse(text);
  std::vector<json::json_pointer> pointers;
  collectPointers(doc, json::json_pointer(), pointers);
  const json::json_pointer p = pointers[std::uniform_int_distribution<size_t>(1, pointers.size() - 1)(rng)];
  json& parent = doc[p.parent_pointer()];
  switch (std::uniform_int_distribution<int>(0, 3)(rng)) {
    case 0:
      if (parent.is_object())
        parent.erase(p.back());
      else if (!parent.empty())
        parent.erase(parent.begin());
      break;
    case 1:
      if (parent.is_array() && !parent.empty()) parent.push_back(parent.front());
      break;
    default:
      doc[p] = nastyJson(rng);
  }
  return doc.dump();
}

// A text file (OBJ, MTL) with one number replaced, a line deleted or repeated.
std::string mutateLines(const std::string& text, std::mt19937& rng) {
  std::vector<std::string> lines;
  for (size_t at = 0; at < text.size();) {
    const size_t end = text.find('\n', at);
    lines.push_back(text.substr(at, end == std::string::npos ? std::string::npos : end - at));
    at = end == std::string::npos ? text.size() : end + 1;
  }
  if (lines.empty()) return text;
  const size_t l = std::uniform_int_distribution<size_t>(0, lines.size() - 1)(rng);
  switch (std::uniform_int_distribution<int>(0, 3)(rng)) {
    case 0:
      lines.erase(lines.begin() + std::ptrdiff_t(l));
      break;
    case 1:
      lines.insert(lines.begin() + std::ptrdiff_t(l), lines[l]);
      break;
    default: {  // a number (or an index in "1/2/3") of the line
      std::string& line = lines[l];
      std::vector<std::pair<size_t, size_t>> numbers;
      for (size_t i = 0; i < line.size();) {
        if (std::isdigit(static_cast<unsigned char>(line[i])) || line[i] == '-' || line[i] == '.') {
          size_t j = i;
          while (j < line.size() && (std::isalnum(static_cast<unsigned char>(line[j])) || line[j] == '.' ||
                                     line[j] == '-' || line[j] == '+'))
            ++j;
          numbers.push_back({i, j - i});
          i = j;
        } else {
          ++i;
        }
      }
      if (numbers.empty()) break;
      const auto [at, length] = numbers[std::uniform_int_distribution<size_t>(0, numbers.size() - 1)(rng)];
      line.replace(at, length,
                   kNastyNumbers[std::uniform_int_distribution<size_t>(0, kNastyNumbers.size() - 1)(rng)]);
    }
  }
  std::string out;
  for (const std::string& line : lines) out += line + "\n";
  return out;
}

// 1-4 bytes replaced, inserted or deleted, or the file cut short.
std::string mutateBytes(std::string bytes, std::mt19937& rng) {
  if (bytes.empty()) return bytes;
  if (std::uniform_int_distribution<int>(0, 4)(rng) == 0)
    return bytes.substr(0, std::uniform_int_distribution<size_t>(0, bytes.size() - 1)(rng));
  const int edits = std::uniform_int_distribution<int>(1, 4)(rng);
  for (int e = 0; e < edits && !bytes.empty(); ++e) {
    const size_t at = std::uniform_int_distribution<size_t>(0, bytes.size() - 1)(rng);
    const char c = char(std::uniform_int_distribution<int>(0, 255)(rng));
    switch (std::uniform_int_distribution<int>(0, 2)(rng)) {
      case 0:
        bytes[at] = c;
        break;
      case 1:
        bytes.insert(at, 1, c);
        break;
      default:
        bytes.erase(at, 1);
    }
  }
  return bytes;
}

struct Seed {
  std::string name;
  AssetInput kind;
  std::string main, side;
};

std::vector<Seed> readSeeds() {
  std::vector<Seed> seeds;
  for (const char* name : {"obj_mtl", "gltf_inline", "gltf_bin", "glb", "mesh_obj"}) {
    const std::string bytes = readText(std::string(ARENA_SOURCE_DIR) + "/tests/fuzz/asset_seeds/" + name);
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
  // A face of a mesh OBJ that tinyobjloader cannot read: the scene's error, not the first frame's.
  EXPECT_NE(error(AssetInput::MeshObj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "")
                .find("$.objects[0].file: " + (dir / "m.obj").string() + ": "),
            std::string::npos)
      << error(AssetInput::MeshObj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "");
  // Normals without a direction ("vn 0 0 0", 1e39 read as Inf) fall back to the face's: finite
  // unit normals (importAssetOrReject checks them).
  EXPECT_TRUE(fuzz::importAssetOrReject(AssetInput::MeshObj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvn 1e39 0 0\nf 1//1 2//2 3//1\n", "", dir));
  EXPECT_TRUE(fuzz::importAssetOrReject(AssetInput::ObjWithMtl, "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n", "", dir));
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
