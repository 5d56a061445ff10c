#pragma once
// Helpers shared by the tests: temporary directories and tiny renders of shipped scenes.
#include <filesystem>
#include <string>

#include "tracer/render.hpp"
#include "tracer/scene.hpp"

namespace arena::test {

// A fresh, empty directory under the system temp dir, unique per test.
std::filesystem::path freshDir(const std::string& name);
Scene shippedScene(const std::string& name);
// Tiny settings: resolution w x h, `frames` frames, `refSpp` fixed-sample references.
RenderSettings tinySettings(int w, int h, int frames, int refSpp);

}  // namespace arena::test
