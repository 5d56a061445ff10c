// Scene parser: the shipped scenes load; every malformed input is an error naming file and path.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "tests/test_util.hpp"
#include "tracer/scene.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;

// One file per test and process: ctest runs tests in parallel processes.
std::string writeScene(const std::string& name, const std::string& text) {
  const fs::path dir = test::processDir() / "scenes";
  fs::create_directories(dir);
  fs::path p = dir / (name + ".json");
  std::ofstream(p) << text;
  return p.string();
}

const char* kMinimal = R"({
  "purpose": "test",
  "resolution": [16, 8],
  "frames": 4,
  "camera": {"keys": [{"frame": 0, "eye": [0, 1, 3], "target": [0, 1, 0], "fov": 40}]},
  "materials": {"white": {"albedo": [0.5, 0.5, 0.5]}},
  "objects": [{"name": "floor", "shape": "quad", "material": "white", "keys": [{"frame": 0}]}],
  "lights": [{"name": "lamp", "shape": "quad", "keys": [{"frame": 0, "translate": [0, 2, 0], "intensity": 5},
                                                       {"frame": 2, "intensity": 0, "step": true}]}],
  "events": [{"frame": 2, "kind": "light_off", "what": "lamp"}]
})";

std::string errorOf(const std::string& text) {
  try {
    loadScene(writeScene(std::string("bad_") + ::testing::UnitTest::GetInstance()->current_test_info()->name(), text));
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  size_t p = text.find(from);
  EXPECT_NE(p, std::string::npos) << from;
  return text.replace(p, from.size(), to);
}

TEST(Scene, ShippedScenesLoadWithPurpose) {
  auto files = listSceneFiles(defaultScenesDir());
  ASSERT_GE(files.size(), 1u);
  for (auto& f : files) {
    Scene s = loadScene(f);
    EXPECT_FALSE(s.purpose.empty()) << f;
    EXPECT_GT(s.frames, 0) << f;
  }
}

TEST(Scene, MinimalSceneParsesAndStepKeysSwitchInstantly) {
  Scene s = loadScene(writeScene("minimal", kMinimal));
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_FLOAT_EQ(s.lights[0].emission.at(1.0f).intensity, 5.0f);
  EXPECT_FLOAT_EQ(s.lights[0].emission.at(1.99f).intensity, 5.0f);
  EXPECT_FLOAT_EQ(s.lights[0].emission.at(2.0f).intensity, 0.0f);
  // Unspecified fields are inherited from the previous key (the light did not move).
  EXPECT_FLOAT_EQ(s.lights[0].transform.at(3.0f).translate.y, 2.0f);
  ASSERT_EQ(s.events.size(), 1u);
  EXPECT_EQ(s.events[0].kind, arena::EventKind::LightOff);
}

TEST(Scene, LinearKeyframesInterpolate) {
  std::string text = replaced(kMinimal, R"("keys": [{"frame": 0}])",
                              R"("keys": [{"frame": 0, "translate": [0, 0, 0]}, {"frame": 2, "translate": [2, 0, 0]}])");
  Scene s = loadScene(writeScene("lerp", text));
  EXPECT_FLOAT_EQ(s.objects[0].transform.at(1.0f).translate.x, 1.0f);
  EXPECT_FLOAT_EQ(s.objects[0].transform.at(3.0f).translate.x, 2.0f);
}

TEST(Scene, MalformedJsonNamesTheFile) {
  std::string e = errorOf("{ \"purpose\": ");
  EXPECT_NE(e.find("bad_MalformedJsonNamesTheFile.json"), std::string::npos) << e;
  EXPECT_NE(e.find("malformed JSON"), std::string::npos) << e;
}

TEST(Scene, UnknownFieldIsAnErrorWithItsPath) {
  std::string e =
      errorOf(replaced(kMinimal, R"({"albedo": [0.5, 0.5, 0.5]})", R"({"albedo": [0.5, 0.5, 0.5], "rougness": 1})"));
  EXPECT_NE(e.find("$.materials.white.rougness"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown field"), std::string::npos) << e;
}

TEST(Scene, MissingMaterialIsNamed) {
  std::string e = errorOf(replaced(kMinimal, R"("material": "white")", R"("material": "marble")"));
  EXPECT_NE(e.find("$.objects[0].material"), std::string::npos) << e;
  EXPECT_NE(e.find("marble"), std::string::npos) << e;
}

TEST(Scene, WrongTypeIsNamed) {
  std::string e = errorOf(replaced(kMinimal, R"("frames": 4)", R"("frames": "four")"));
  EXPECT_NE(e.find("$.frames"), std::string::npos) << e;
  EXPECT_NE(e.find("expected an integer"), std::string::npos) << e;
}

TEST(Scene, NegativeResolutionIsRejected) {
  std::string e = errorOf(replaced(kMinimal, "[16, 8]", "[-16, 8]"));
  EXPECT_NE(e.find("$.resolution"), std::string::npos) << e;
}

TEST(Scene, KeyBeyondTheSequenceIsRejected) {
  std::string e = errorOf(replaced(kMinimal, R"({"frame": 2, "intensity": 0)", R"({"frame": 9, "intensity": 0)"));
  EXPECT_NE(e.find("$.lights[0].keys[1].frame"), std::string::npos) << e;
  EXPECT_NE(e.find("4 frames"), std::string::npos) << e;
}

TEST(Scene, MissingRequiredFieldIsNamed) {
  std::string e = errorOf(replaced(kMinimal, R"("purpose": "test",)", ""));
  EXPECT_NE(e.find("$.purpose"), std::string::npos) << e;
  EXPECT_NE(e.find("missing"), std::string::npos) << e;
}

TEST(Scene, EventNamingNothingIsRejected) {
  std::string e = errorOf(replaced(kMinimal, R"("what": "lamp")", R"("what": "lmap")"));
  EXPECT_NE(e.find("$.events[0].what"), std::string::npos) << e;
}

// docs/extending.md, "An event kind": the kinds are one list (core/sequence.cpp), which the error names.
TEST(Scene, UnknownEventKindIsRejectedListingTheKinds) {
  std::string e = errorOf(replaced(kMinimal, R"("kind": "light_off")", R"("kind": "light_of")"));
  EXPECT_NE(e.find("$.events[0].kind"), std::string::npos) << e;
  for (const char* kind : {"light_off", "light_on", "light_change", "object_moves", "camera_cut"})
    EXPECT_NE(e.find(kind), std::string::npos) << kind << ": " << e;
}

TEST(Scene, UnorderedKeysAreRejected) {
  std::string e = errorOf(replaced(kMinimal, R"({"frame": 2, "intensity": 0)", R"({"frame": 0, "intensity": 0)"));
  EXPECT_NE(e.find("strictly increasing"), std::string::npos) << e;
}

TEST(Scene, MissingMeshFileIsNamed) {
  std::string e = errorOf(replaced(kMinimal, R"("shape": "quad", "material")", R"("shape": "mesh", "file": "nope.obj", "material")"));
  EXPECT_NE(e.find("nope.obj"), std::string::npos) << e;
}

}  // namespace
}  // namespace arena
