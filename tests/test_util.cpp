#include "tests/test_util.hpp"

#include <unistd.h>

namespace arena::test {

std::filesystem::path freshDir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() / ("arena_test_" + std::to_string(getpid())) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

Scene shippedScene(const std::string& name) { return loadScene(defaultScenesDir() + "/" + name + ".json"); }

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

}  // namespace arena::test
