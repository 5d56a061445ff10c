#pragma once
// The scene parser's fuzz contract, shared by the libFuzzer target (scene_fuzzer.cpp, clang only)
// and the deterministic mutation test that always runs (tests/robustness_test.cpp): any bytes
// either parse into a scene that passes the parser's own invariants or are rejected with an
// arena::Error. Any other exception, a crash or a sanitizer report is a bug.
#include <cmath>
#include <string>

#include "core/error.hpp"
#include "tracer/scene.hpp"

namespace arena::fuzz {

// Returns true if the text parsed; throws std::logic_error if a parsed scene breaks an invariant
// the tracer relies on. arena::Error (a clear rejection) is swallowed and returns false.
inline bool parseSceneOrReject(const std::string& text) {
  Scene s;
  try {
    s = parseScene(text, "fuzz/scene.json");
  } catch (const Error&) {
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
