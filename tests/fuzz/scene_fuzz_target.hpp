#pragma once
// The scene parser's fuzz contract, shared by the libFuzzer target (scene_fuzzer.cpp, clang only)
// and the deterministic mutation test that always runs (tests/scene_fuzz_test.cpp): any bytes
// either parse into a scene that passes the parser's own invariants or are rejected with an
// arena::Error. Any other exception, a crash or a sanitizer report is a bug.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/error.hpp"
#include "tracer/scene.hpp"

namespace arena::fuzz {

// Returns true if the text parsed; throws std::logic_error if a parsed scene breaks an invariant
// the tracer relies on, or a rejection does not name the file. arena::Error (a clear rejection)
// is swallowed and returns false.
inline bool parseSceneOrReject(const std::string& text) {
  const std::string path = "fuzz/scene.json";
  Scene s;
  try {
    s = parseScene(text, path);
  } catch (const Error& e) {
    if (std::string(e.what()).rfind(path, 0) != 0)
      throw std::logic_error(std::string("a rejection that does not start with the file: ") +
                             e.what());
    return false;
  }
  auto finite = [](glm::vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
  };
  if (s.width < 1 || s.height < 1 || s.width > kMaxSceneResolution ||
      s.height > kMaxSceneResolution || s.frames < 1 || s.frames > kMaxSceneFrames)
    throw std::logic_error("parsed scene with out-of-range resolution or frames");
  for (int t = 0; t < s.frames; t += std::max(1, s.frames / 64)) {
    CameraKey c = s.camera.at(float(t));
    glm::vec3 view = c.target - c.eye;
    if (!finite(c.eye) || !finite(c.target) || !finite(c.up) ||
        glm::length(glm::cross(view, c.up)) <= 0.0f)
      throw std::logic_error("parsed scene whose camera has no basis at frame " +
                             std::to_string(t));
  }
  for (const Material& m : s.materials)
    if (!finite(m.emission) || !finite(m.albedo))
      throw std::logic_error("non-finite material " + m.name);
  return true;
}

}  // namespace arena::fuzz
