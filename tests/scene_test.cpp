// Scene parser: the shipped scenes load; every malformed input is an error naming file and path.
#include "tracer/scene.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.hpp"
#include "tests/contract_fixture.hpp"
#include "tests/test_util.hpp"
#include "tracer/scene_state.hpp"

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

TEST(Scene, ReferenceEstimatorIsOneOfTwoAndBoundsTheBounces) {
  EXPECT_EQ(loadScene(writeScene("estimator_default", kMinimal)).referenceEstimator,
            ReferenceEstimator::Path);
  const std::string bidirectional = replaced(
      kMinimal, R"("frames": 4,)", R"("frames": 4, "reference_estimator": "bidirectional",)");
  EXPECT_EQ(loadScene(writeScene("estimator_bidirectional", bidirectional)).referenceEstimator,
            ReferenceEstimator::Bidirectional);
  std::string e = errorOf(
      replaced(kMinimal, R"("frames": 4,)", R"("frames": 4, "reference_estimator": "bdpt",)"));
  EXPECT_NE(e.find("$.reference_estimator"), std::string::npos) << e;
  EXPECT_NE(e.find("expected path or bidirectional, got 'bdpt'"), std::string::npos) << e;
  e = errorOf(replaced(bidirectional, R"("frames": 4,)", R"("frames": 4, "max_bounces": 17,)"));
  EXPECT_NE(e.find("$.max_bounces"), std::string::npos) << e;
  EXPECT_NE(e.find("at most 16"), std::string::npos) << e;
}

TEST(Scene, MissingRequiredFieldIsNamed) {
  std::string e = errorOf(replaced(kMinimal, R"("purpose": "test",)", ""));
  EXPECT_NE(e.find("$.purpose"), std::string::npos) << e;
  EXPECT_NE(e.find("missing"), std::string::npos) << e;
}

// A number below the smallest double reads as 0: refused where it is written, not reported later as
// "got 0" by a range it never was in.
TEST(Scene, ANumberTooSmallToStoreIsRefusedAsWritten) {
  std::string e = errorOf(replaced(kMinimal, R"("fov": 40)", R"("fov": 1e-400)"));
  EXPECT_NE(e.find("$.camera.keys[0].fov: 1e-400 is too small to be stored as a number (it would "
                   "read as 0)"),
            std::string::npos)
      << e;
  // One too large is named where it is too (it read as an unplaced "number overflow").
  e = errorOf(replaced(kMinimal, R"("fov": 40)", R"("fov": 1e999)"));
  EXPECT_NE(e.find("$.camera.keys[0].fov: 1e999 is too large to be stored as a number"),
            std::string::npos)
      << e;
  e = errorOf(replaced(kMinimal, R"("resolution": [16, 8])", R"("resolution": [16, -1e999])"));
  EXPECT_NE(e.find("$.resolution[1]: -1e999 is too large"), std::string::npos) << e;
  e = errorOf(replaced(kMinimal, R"("resolution": [16, 8])", R"("resolution": [16, 0.0000e-999])"));
  EXPECT_EQ(e.find("too small"), std::string::npos) << e;  // a zero written as zero is a zero
  EXPECT_NE(e.find("$.resolution: expected two integers [width, height] in [1, 16384], got 0"),
            std::string::npos)
      << e;
  e = errorOf(replaced(kMinimal, R"("resolution": [16, 8])", R"("resolution": [16, 2.5e-324000])"));
  EXPECT_NE(e.find("$.resolution[1]: 2.5e-324000 is too small"), std::string::npos) << e;
  // A range's bounds and the value read back as they are written, not as %f's six decimals.
  e = errorOf(replaced(kMinimal, R"("fov": 40)", R"("fov": 0.5)"));
  EXPECT_NE(e.find("$.camera.keys[0].fov: expected a value in [1, 170], got 0.5"),
            std::string::npos)
      << e;
}

TEST(Scene, AMisspeltRequiredFieldIsNamedWithTheFieldMeant) {
  // The scene has "camra": the required "camera" is missing, and the message names what was
  // written.
  std::string e = errorOf(replaced(kMinimal, R"("camera":)", R"("camra":)"));
  EXPECT_NE(e.find("$.camera: missing; expected an object (the object has \"camra\": a misspelling "
                   "of \"camera\"?)"),
            std::string::npos)
      << e;
  // An optional field misspelt is an unknown field, named with the field it most likely is (case
  // aside); one not close to any field the object may hold is not.
  e = errorOf(replaced(kMinimal, R"("fov": 40)", R"("FOV": 40)"));
  EXPECT_NE(e.find("$.camera.keys[0].FOV: unknown field: a misspelling of \"fov\"? (unknown fields "
                   "are errors)"),
            std::string::npos)
      << e;
  e = errorOf(replaced(kMinimal, R"("frames": 4,)", R"("frames": 4, "albedo": 1,)"));
  EXPECT_NE(e.find("$.albedo: unknown field (check the spelling"), std::string::npos) << e;
  // Nothing close: the message stays as it was.
  e = errorOf(replaced(kMinimal, R"("purpose": "test",)", R"("intent": "test",)"));
  EXPECT_NE(e.find("$.purpose: missing; expected a string"), std::string::npos) << e;
  EXPECT_EQ(e.find("misspelling"), std::string::npos) << e;
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

// An event is measured against the frames before it: at frame 0 the metrics would skip it.
TEST(Scene, AnEventAtFrameZeroIsRejected) {
  std::string e = errorOf(replaced(kMinimal, R"({"frame": 2, "kind")", R"({"frame": 0, "kind")"));
  EXPECT_NE(e.find("$.events[0].frame"), std::string::npos) << e;
  EXPECT_NE(e.find("expected a frame in [1, 3]"), std::string::npos) << e;
  EXPECT_NE(e.find("got 0"), std::string::npos) << e;
  e = errorOf(R"({"purpose": "test", "resolution": [16, 8], "frames": 1,
    "camera": {"keys": [{"frame": 0, "eye": [0, 1, 3], "target": [0, 1, 0], "fov": 40}]},
    "materials": {"white": {"albedo": [0.5, 0.5, 0.5]}},
    "objects": [{"name": "floor", "shape": "quad", "material": "white", "keys": [{"frame": 0}]}],
    "lights": [{"name": "lamp", "shape": "quad", "keys": [{"frame": 0, "translate": [0, 2, 0], "intensity": 5}]}],
    "events": [{"frame": 0, "kind": "light_off", "what": "lamp"}]})");
  EXPECT_NE(e.find("a scene of one frame has no frame for an event"), std::string::npos) << e;
}

// A cut the camera does not make would be measured (recovery, old-view leak) as if it happened.
TEST(Scene, ACameraCutNeedsTheCameraToJumpThere) {
  const std::string cut = R"({"frame": 2, "kind": "camera_cut"})";
  std::string e =
      errorOf(replaced(kMinimal, R"({"frame": 2, "kind": "light_off", "what": "lamp"})", cut));
  EXPECT_NE(e.find("$.events[0].frame"), std::string::npos) << e;
  EXPECT_NE(e.find("needs a camera key there with \"step\": true"), std::string::npos) << e;
  const std::string jumping = replaced(
      replaced(kMinimal, R"({"frame": 2, "kind": "light_off", "what": "lamp"})", cut),
      R"("fov": 40}]})",
      R"("fov": 40}, {"frame": 2, "step": true, "eye": [1, 1, 3], "target": [0, 1, 0]}]})");
  EXPECT_EQ(errorOf(jumping), "");
  e = errorOf(
      replaced(jumping, R"("kind": "camera_cut")", R"("kind": "camera_cut", "what": "lamp")"));
  EXPECT_NE(e.find("$.events[0].what: a camera_cut names no object or light"), std::string::npos)
      << e;
  // The camera's first key has nothing to jump from, step or not: the view holds it before.
  const std::string firstStep = replaced(
      replaced(kMinimal, R"({"frame": 2, "kind": "light_off", "what": "lamp"})", cut),
      R"({"keys": [{"frame": 0, "eye": [0, 1, 3], "target": [0, 1, 0], "fov": 40}]})",
      R"({"keys": [{"frame": 2, "step": true, "eye": [0, 1, 3], "target": [0, 1, 0], "fov": 40}]})");
  e = errorOf(firstStep);
  EXPECT_NE(e.find("needs a camera key there with \"step\": true"), std::string::npos) << e;
}

// An event names something of its kind: a light's switch a light, a move the object that moves
// (the ghosting figures follow its trail); the same event twice is a mistake.
TEST(Scene, AnEventNamesSomethingOfItsKind) {
  const std::string off = R"({"frame": 2, "kind": "light_off", "what": "lamp"})";
  std::string e =
      errorOf(replaced(kMinimal, off, R"({"frame": 2, "kind": "light_off", "what": "floor"})"));
  EXPECT_NE(e.find("$.events[0].what: a light_off event names a light (one of $.lights); 'floor' "
                   "is an object"),
            std::string::npos)
      << e;
  e = errorOf(replaced(kMinimal, off, R"({"frame": 2, "kind": "object_moves", "what": "lamp"})"));
  EXPECT_NE(e.find("an object_moves event names the object that moves (one of $.objects); 'lamp' "
                   "is a light"),
            std::string::npos)
      << e;
  e = errorOf(replaced(kMinimal, off, R"({"frame": 2, "kind": "object_moves"})"));
  EXPECT_NE(e.find("$.events[0].what: an object_moves event names the object that moves"),
            std::string::npos)
      << e;
  e = errorOf(replaced(kMinimal, off, off + ", " + off));
  EXPECT_NE(e.find("$.events[1].kind: this event (light_off lamp at frame 2) is given twice"),
            std::string::npos)
      << e;
  EXPECT_EQ(errorOf(replaced(kMinimal, off, R"({"frame": 2, "kind": "light_off"})")),
            "");  // some light
}

// A zero scale collapses an object, which then vanishes without a word: refused where the shape
// needs the axis (a quad's y does not matter).
TEST(Scene, AScaleThatCollapsesAnObjectIsRefused) {
  const std::string floor = R"("shape": "quad", "material": "white", "keys": [{"frame": 0}])";
  auto withKey = [&](const std::string& shape, const std::string& scale) {
    return replaced(kMinimal, floor,
                    R"("shape": ")" + shape +
                        R"(", "material": "white", "keys": [{"frame": 0, "scale": )" + scale +
                        "}]");
  };
  for (const auto& [shape, scale] :
       std::vector<std::pair<std::string, std::string>>{{"quad", "[0, 0, 0]"},
                                                        {"quad", "[0, 1, 1]"},
                                                        {"box", "[1, 0, 1]"},
                                                        {"sphere", "[1, 1, 0]"}}) {
    const std::string e = errorOf(withKey(shape, scale));
    EXPECT_NE(e.find("$.objects[0].keys[0].scale: a scale that collapses the object"),
              std::string::npos)
        << shape << " " << scale << ": " << e;
  }
  EXPECT_EQ(errorOf(withKey("quad", "[2, 0, 2]")), "");  // flat along its own normal: the same quad
}

// A light switched off for a while is an event; nothing ever emitting is a mistake.
TEST(Scene, ASceneWhereNothingEverEmitsIsRejected) {
  const std::string dark = replaced(kMinimal, R"("intensity": 5})", R"("intensity": 0})");
  std::string e = errorOf(dark);
  EXPECT_NE(e.find("$.lights"), std::string::npos) << e;
  EXPECT_NE(e.find("expected something to emit"), std::string::npos) << e;
  // An emissive material or a sky is enough.
  EXPECT_EQ(errorOf(replaced(dark, R"("albedo": [0.5, 0.5, 0.5]})",
                             R"("albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1]})")),
            "");
  EXPECT_EQ(errorOf(replaced(dark, R"("frames": 4,)",
                             R"("frames": 4, "sky": {"color": [0.2, 0.2, 0.2]},)")),
            "");
  EXPECT_EQ(errorOf(kMinimal), "");  // off from frame 2 on: an event, accepted
}

TEST(Scene, UnorderedKeysAreRejected) {
  std::string e = errorOf(replaced(kMinimal, R"({"frame": 2, "intensity": 0)", R"({"frame": 0, "intensity": 0)"));
  EXPECT_NE(e.find("strictly increasing"), std::string::npos) << e;
}

TEST(Scene, MissingMeshFileIsNamed) {
  std::string e = errorOf(replaced(kMinimal, R"("shape": "quad", "material")", R"("shape": "mesh", "file": "nope.obj", "material")"));
  EXPECT_NE(e.find("nope.obj"), std::string::npos) << e;
}


// ---- Contract: bad input and state ------------------------------------------------------------

namespace fs = std::filesystem;
using nlohmann::json;

TEST(SceneContract, DeeplyNestedJsonIsRejectedBeforeAnyRecursiveWalk) {
  for (const std::string& open : {std::string("["), std::string("{\"a\":")}) {
    std::string text;
    for (int i = 0; i < 100000; ++i) text += open;
    try {
      parseScene(text, "deep.json");
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("deep.json: JSON nested deeper than 64 levels"),
                std::string::npos)
          << e.what();
    }
  }
  // A file's name that cannot name the scene's folders: refused, quoted (a newline wrote images/a
  // and b/; a byte that is not UTF-8 stopped the render with a library's message; ".." wrote into
  // the run's root: a bad-input trial).
  for (const std::string name : {"a\nb", "caf\xe9", "..", "a b", "a,b"})
    EXPECT_NE(contract::sceneError(contract::minimalScene(), "scenes/" + name + ".json")
                  .find("cannot name a scene"),
              std::string::npos)
        << name;
  EXPECT_NE(contract::sceneError(contract::minimalScene(), "scenes/a\nb.json")
                .find("the file's name \"a\\nb\" cannot name a scene"),
            std::string::npos);
  // Brackets inside strings are text, not nesting.
  json s = contract::minimalScene();
  s["purpose"] = std::string(1000, '[');
  EXPECT_EQ(contract::sceneError(s), "");
  // Through the CLI: exit 2 with the file named, not a segfault (exit 139).
  fs::path dir = test::freshDir("deep_cli");
  writeTextAtomically(dir / "deep.json", std::string(200000, '['));
  contract::CliResult r = contract::arenaCli("scenes --scenes-dir " + dir.string());
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("deep.json: JSON nested deeper"), std::string::npos) << r.output;
}

TEST(SceneContract, UnusableCamerasAreErrorsNamingTheJsonPath) {
  auto withKey = [](const json& key) {
    json s = contract::minimalScene();
    for (auto& [k, v] : key.items()) s["camera"]["keys"][0][k] = v;
    return contract::sceneError(s);
  };
  EXPECT_NE(withKey({{"up", {0, 0, 0}}})
                .find("scenes/t.json: $.camera.keys[0].up: expected a usable camera basis: up "
                      "is the zero vector"),
            std::string::npos)
      << withKey({{"up", {0, 0, 0}}});
  EXPECT_NE(withKey({{"up", {0, 0, -1}}, {"eye", {0, 0, 4}}, {"target", {0, 0, 0}}})
                .find("is parallel to the view"),
            std::string::npos);
  EXPECT_NE(withKey({{"eye", {1e39, 0, 0}}})
                .find("$.camera.keys[0].eye: expected values that fit a float"),
            std::string::npos);
  EXPECT_NE(withKey({{"eye", {1e7, 0, 0}}}).find("$.camera.keys[0].eye: expected values within"),
            std::string::npos);
  EXPECT_NE(withKey({{"target", {0, 1, 4}}}).find("target equals the eye"), std::string::npos);
  // Each key is fine, the interpolation between them is not: up passes through zero at frame 1.
  json s = contract::minimalScene();
  s["camera"]["keys"].push_back({{"frame", 2}, {"up", {0, -1, 0}}});
  EXPECT_NE(
      contract::sceneError(s).find(
          "$.camera.keys: the interpolated camera at frame 1 is unusable: up is the zero vector"),
      std::string::npos)
      << contract::sceneError(s);
}

TEST(SceneContract, IntegersBeyondTheirRangeAreErrorsNotWrapped) {
  struct Case {
    const char* pointer;
    json value;
    const char* message;
  };
  const std::vector<Case> cases = {
      {"/frames", 4294967300LL, "$.frames: expected an integer in [1, 100000], got 4294967300"},
      {"/frames", 0, "$.frames: expected an integer in [1, 100000], got 0"},
      {"/seed", 4294967297LL, "$.seed: expected an integer in [0, 2147483647], got 4294967297"},
      {"/seed", -1, "$.seed: expected an integer in [0, 2147483647], got -1"},
      {"/max_bounces", 2147483648LL,
       "$.max_bounces: expected an integer in [1, 64], got 2147483648"},
      {"/resolution", json::array({4294967312LL, 8}), "$.resolution: expected two integers"},
      {"/resolution", json::array({1e39, 8}), "$.resolution: expected two integers"},
      {"/camera/keys/0/frame", 4294967296LL,
       "$.camera.keys[0].frame: expected an integer in [-2147483648"},
      {"/frames", 18446744073709551615ULL, "got 18446744073709551615"},
  };
  for (const Case& c : cases) {
    json s = contract::minimalScene();
    s[json::json_pointer(c.pointer)] = c.value;
    EXPECT_NE(contract::sceneError(s).find(c.message), std::string::npos)
        << c.pointer << ": " << contract::sceneError(s);
  }
  // The CLI's integers are range-checked too (CLI11 rejects what does not fit an int).
  contract::CliResult r = contract::arenaCli("render cornell_static --frames 4294967300 --cache /nonexistent/never");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("--frames"), std::string::npos) << r.output;
}

TEST(SceneContract, RadianceAndCoordinatesThatOverflowFloatAreRejected) {
  json s = contract::minimalScene();
  s["materials"]["lamp"]["emission"] = {1e30, 0, 0};
  EXPECT_NE(contract::sceneError(s).find("$.materials.lamp.emission: expected values within"),
            std::string::npos)
      << contract::sceneError(s);
  s = contract::minimalScene();
  s["lights"][0]["keys"][0]["color"] = {1e6, 1, 1};
  s["lights"][0]["keys"][0]["intensity"] = 1e9;
  EXPECT_NE(contract::sceneError(s).find("$.lights[0].keys[0].color: expected intensity * color"),
            std::string::npos);
  s = contract::minimalScene();
  s["objects"][0]["keys"][0]["translate"] = {0, 3e38, 0};
  EXPECT_NE(contract::sceneError(s).find("$.objects[0].keys[0].translate: expected values within"),
            std::string::npos);
  // A light scaled to nothing, or mirrored (its emitting side turned away), is refused: it would
  // render a darker or black scene without a word.
  for (const json& scale : {json{0, 1, 0.5}, json{-0.5, 1, 0.5}, json{0.5, 0, 0.5}}) {
    s = contract::minimalScene();
    s["lights"][0]["keys"][0]["scale"] = scale;
    EXPECT_NE(contract::sceneError(s).find(
                  "$.lights[0].keys[0].scale: expected every component > 0 for a light"),
              std::string::npos)
        << scale << ": " << contract::sceneError(s);
  }
}

// A mesh object "m" reading `file` (relative to the scene file), in the white material.
json meshObject(const std::string& file) {
  return {{"name", "m"},
          {"shape", "mesh"},
          {"file", file},
          {"material", "white"},
          {"keys", json::array({{{"frame", 0}}})}};
}

TEST(SceneContract, MeshFilesMustBeBoundedRegularFiles) {
  fs::path dir = test::freshDir("mesh_files");
  auto meshScene = [&](const std::string& file) {
    json s = contract::minimalScene();
    s["objects"].push_back(meshObject(file));
    return contract::sceneError(s, (dir / "t.json").string());
  };
  EXPECT_NE(meshScene("/dev/zero").find("$.objects[1].file: /dev/zero: not a regular file"),
            std::string::npos)
      << meshScene("/dev/zero");
  fs::create_directories(dir / "folder.obj");
  EXPECT_NE(meshScene("folder.obj").find("not a regular file"), std::string::npos);
  {  // a sparse file just over the limit: costs no disk
    FILE* f = std::fopen((dir / "huge.obj").c_str(), "wb");
    ASSERT_TRUE(f);
    std::fclose(f);
    fs::resize_file(dir / "huge.obj", kMaxMeshBytes + 1);
  }
  EXPECT_NE(meshScene("huge.obj").find("-byte limit"), std::string::npos) << meshScene("huge.obj");
}

TEST(SceneContract, CollidingNamesAndDuplicateKeysAreErrorsNamingBothPlaces) {
  json s = contract::minimalScene();
  s["objects"].push_back(s["objects"][0]);
  EXPECT_NE(contract::sceneError(s).find("$.objects[1].name: 'floor' is already the name of $.objects[0]"),
            std::string::npos)
      << contract::sceneError(s);
  s = contract::minimalScene();
  s["lights"].push_back(s["lights"][0]);
  EXPECT_NE(contract::sceneError(s).find("$.lights[1].name: 'light' is already the name of $.lights[0]"),
            std::string::npos)
      << contract::sceneError(s);
  s = contract::minimalScene();
  s["lights"][0]["name"] = "floor";
  EXPECT_NE(contract::sceneError(s).find("$.lights[0].name: 'floor' is already the name of $.objects[0]"),
            std::string::npos)
      << contract::sceneError(s);
  // Keys given twice: nlohmann would keep one of them silently. Each case inserts a member
  // right after `after` in the scene's text; the error names the object's path and both members.
  struct Case {
    std::string after, member, message;
  };
  const std::vector<Case> cases = {
      {"{", "\"frames\": 7,", "scenes/t.json: $: key \"frames\" is given twice (members 1 and "},
      {"\"materials\":{", "\"white\":{\"albedo\":[0.1,0.1,0.1]},",
       "$.materials: key \"white\" is given twice"},
      {"\"keys\":[{", "\"fov\":30,", "$.camera.keys[0]: key \"fov\" is given twice"},
  };
  for (const Case& c : cases) {
    std::string text = contract::minimalScene().dump();
    text.insert(text.find(c.after) + c.after.size(), c.member);
    EXPECT_NE(contract::sceneTextError(text).find(c.message), std::string::npos) << contract::sceneTextError(text);
  }
  EXPECT_EQ(contract::sceneTextError(contract::minimalScene().dump()), "");
}

// The renderer builds a mesh object from the bytes loadScene read and hashed, never from the file
// again: an OBJ edited during a study renders under its own hash, not the first one's.
TEST(SceneContract, AMeshObjectKeepsTheFileAsLoadedAndHashed) {
  fs::path dir = test::freshDir("mesh_as_loaded");
  writeTextAtomically(dir / "m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  json s = contract::minimalScene();
  s["objects"].push_back(meshObject("m.obj"));
  writeTextAtomically(dir / "t.json", s.dump());
  const Scene first = loadScene((dir / "t.json").string());
  const Object& mesh = first.objects.back();
  ASSERT_EQ(mesh.shape, Shape::Mesh);
  ASSERT_EQ(makeMesh(mesh).triangles.size(), 1u);
  writeTextAtomically(dir / "m.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n");
  EXPECT_EQ(makeMesh(mesh).triangles.size(), 1u) << "the mesh was read from the edited file";
  const Scene second = loadScene((dir / "t.json").string());
  EXPECT_EQ(makeMesh(second.objects.back()).triangles.size(), 2u);
  EXPECT_NE(first.contentHash, second.contentHash);
  // A mesh object that never went through loadScene is an error, not an empty mesh.
  Object bare;
  bare.name = "bare";
  bare.shape = Shape::Mesh;
  EXPECT_THROW(makeMesh(bare), Error);
}

TEST(SceneContract, UnusableVerticesAndOverbrightAssetsAreErrorsNamingFileAndElement) {
  fs::path dir = test::freshDir("vanishing_geometry");
  auto meshError = [&](const std::string& obj) {
    writeTextAtomically(dir / "m.obj", obj);
    json s = contract::minimalScene();
    s["objects"].push_back(meshObject("m.obj"));
    return contract::sceneError(s, (dir / "t.json").string());
  };
  EXPECT_EQ(meshError("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "");
  std::string e = meshError("v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
  EXPECT_NE(e.find("$.objects[1].file"), std::string::npos) << e;
  EXPECT_NE(e.find("m.obj:2: vertex 2: coordinate 2 is 'nan'"), std::string::npos) << e;
  e = meshError("# a comment\nv 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n");
  EXPECT_NE(e.find("m.obj:4: vertex 3: coordinate 2 is '1e39'"), std::string::npos) << e;
  // Assets: a vertex whose triangle's cross product overflows, an emitter beyond kMaxRadiance.
  auto assetError = [&](const std::string& obj, const std::string& mtl) {
    writeTextAtomically(dir / "a.obj", "mtllib a.mtl\n" + obj);
    writeTextAtomically(dir / "a.mtl", mtl);
    json s = contract::minimalScene();
    s["objects"].push_back({{"name", "thing"},
                            {"asset", {{"file", "a.obj"}, {"unitMeters", 1.0}, {"upAxis", "y"}}},
                            {"keys", json::array({{{"frame", 0}}})}});
    return contract::sceneError(s, (dir / "t.json").string());
  };
  const std::string tri = "usemtl lamp\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  EXPECT_EQ(assetError(tri, "newmtl lamp\nKe 4 4 4\n"), "");
  e = assetError(tri, "newmtl lamp\nKe 1e20 1e20 1e20\n");
  EXPECT_NE(e.find("material 'lamp' emits"), std::string::npos) << e;
  EXPECT_NE(e.find("a.obj"), std::string::npos) << e;
  e = assetError("usemtl lamp\nv 0 0 0\nv 1e30 0 0\nv 0 1 0\nf 1 2 3\n", "newmtl lamp\nKd 1 1 1\n");
  EXPECT_NE(e.find("has a non-finite position or one beyond +-1e18"), std::string::npos) << e;
}

// The emitter check reads an asset's own materials, and only those of the object that uses them:
// with the scene's light off, an asset whose material emits lights it; overridden by a material
// that does not, nothing does.
TEST(SceneContract, AnAssetsOwnEmittingMaterialCountsAsLightUnlessOverridden) {
  fs::path dir = test::freshDir("asset_emitter");
  writeTextAtomically(dir / "a.obj",
                      "mtllib a.mtl\nusemtl glow\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  writeTextAtomically(dir / "a.mtl", "newmtl glow\nKd 0 0 0\nKe 2 2 2\n");
  json s = contract::minimalScene();
  s["lights"][0]["keys"][0]["intensity"] = 0;
  s["materials"].erase("lamp");
  const std::string file = (dir / "t.json").string();
  EXPECT_NE(contract::sceneError(s, file).find("expected something to emit"), std::string::npos);
  s["objects"].push_back({{"name", "thing"},
                          {"asset", {{"file", "a.obj"}, {"unitMeters", 1.0}, {"upAxis", "y"}}},
                          {"keys", json::array({{{"frame", 0}}})}});
  EXPECT_EQ(contract::sceneError(s, file), "");
  s["objects"][1]["material"] = "white";
  EXPECT_NE(contract::sceneError(s, file).find("expected something to emit"), std::string::npos);
}

}  // namespace
}  // namespace arena
