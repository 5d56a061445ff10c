#pragma once
// The contract tests' shared fixture (cli_test, scene_test, results_test, compare_test,
// run_matrix_test, ...): the built `arena` run through the shell, a small valid scene that a test
// breaks one field of, and the smallest runs.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "harness/run_matrix.hpp"
#include "tests/test_util.hpp"
#include "tracer/scene.hpp"

namespace arena::contract {

namespace fs = std::filesystem;
using nlohmann::json;
using CliResult = test::CommandResult;

// Runs `arena ARGS` through the shell (so tests can use redirections and ulimit).
inline CliResult arenaCli(const std::string& args, const std::string& prefix = "") {
  return test::runCommand(prefix + std::string(ARENA_BINARY) + " " + args);
}

// A small valid scene; tests change one field to make it invalid.
inline json minimalScene() {
  return json::parse(R"({
    "purpose": "test", "resolution": [16, 8], "frames": 3, "seed": 1,
    "camera": {"keys": [{"frame": 0, "eye": [0, 1, 4], "target": [0, 1, 0], "up": [0, 1, 0], "fov": 40}]},
    "materials": {"white": {"albedo": [0.7, 0.7, 0.7]}, "lamp": {"emission": [4, 4, 4]}},
    "objects": [{"name": "floor", "shape": "quad", "material": "white",
                 "keys": [{"frame": 0, "scale": [4, 1, 4]}]}],
    "lights": [{"name": "light", "shape": "quad", "keys": [{"frame": 0, "translate": [0, 3, 0], "intensity": 5}]}]
  })");
}

// The Error message of parsing `scene`, or "" when it parsed.
inline std::string sceneError(const json& scene, const std::string& path = "scenes/t.json") {
  try {
    parseScene(scene.dump(), path);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

inline fs::path writeScene(const fs::path& dir, const std::string& name, const json& scene) {
  fs::create_directories(dir);
  fs::path p = dir / (name + ".json");
  writeTextAtomically(p, scene.dump(1));
  return p;
}

inline RunConfig tinyRun(const std::string& name) {
  RunConfig c;
  c.name = name;
  c.out = test::freshDir("class5_" + name);
  c.cache = test::freshDir("class5_cache_" + name);
  c.render = test::tinySettings(16, 8, 3, 2);
  c.scenes = {test::shippedScene("cornell_static")};
  c.denoisers = {{"passthrough", {}, ""}};
  c.baselines = false;
  c.warmup = 1;
  c.flip = "none";
  c.keepFrames = "none";
  return c;
}

// A tiny CLI run of cornell_static into dir/NAME (cache dir/cache); extra flags appended.
inline CliResult tinyCliRun(const fs::path& dir, const std::string& name, const std::string& flags) {
  return arenaCli("run --scenes cornell_static --denoisers passthrough --no-baselines --resolution 8x8 "
                  "--ref-spp 1 --flip none --keep-frames none --cache " +
                  (dir / "cache").string() + " --out " + (dir / name).string() + " " + flags);
}

// The Error message of parsing the scene text `text`, or "" when it parsed.
inline std::string sceneTextError(const std::string& text) {
  try {
    parseScene(text, "scenes/t.json");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace arena::contract
