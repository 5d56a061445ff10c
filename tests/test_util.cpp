#include "tests/test_util.hpp"

#include <unistd.h>

namespace arena::test {

std::filesystem::path freshDir(const std::string& name) {
  auto dir =
      std::filesystem::temp_directory_path() / ("arena_test_" + std::to_string(getpid())) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

Scene shippedScene(const std::string& name) {
  return loadScene(defaultScenesDir() + "/" + name + ".json");
}

RenderSettings tinySettings(int w, int h, int frames, int refSpp) {
  RenderSettings s;
  s.preset = "test";
  s.width = w;
  s.height = h;
  s.frames = frames;
  s.referenceSpp = refSpp;
  s.referenceMinSpp = refSpp;
  s.referenceRelError = 0;
  return s;
}

float hashUniform(uint32_t a, uint32_t b, uint32_t c) {
  uint32_t v = a * 747796405u + b * 2891336453u + c * 277803737u + 12345u;
  v = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
  v = (v >> 22u) ^ v;
  return float(v >> 8) / float(1u << 24);
}

FrameContext stillCameraContext(int t, int w, int h) {
  FrameContext ctx;
  ctx.frameIndex = t;
  ctx.width = w;
  ctx.height = h;
  ctx.camera = CameraState::lookAt({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 45.0f, w, h);
  ctx.previousCamera = ctx.camera;
  ctx.reset = t == 0;
  return ctx;
}

}  // namespace arena::test
