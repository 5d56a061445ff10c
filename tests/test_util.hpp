#pragma once
// Helpers shared by the tests: temporary directories, tiny renders of shipped scenes,
// deterministic noise and frame contexts.
#include <cstdint>
#include <filesystem>
#include <string>

#include "denoisers/denoiser.hpp"
#include "tracer/render.hpp"
#include "tracer/scene.hpp"

namespace arena::test {

// A fresh, empty directory under the system temp dir, unique per test.
std::filesystem::path freshDir(const std::string& name);
Scene shippedScene(const std::string& name);
// Tiny settings: resolution w x h, `frames` frames, `refSpp` fixed-sample references.
RenderSettings tinySettings(int w, int h, int frames, int refSpp);

// Deterministic noise in [0, 1) (a PCG hash of the arguments), identical on every platform.
float hashUniform(uint32_t a, uint32_t b = 0, uint32_t c = 0);

// Frame t of a w x h sequence seen by a still camera at the origin looking down -Z (45 degrees);
// frame 0 resets the history.
FrameContext stillCameraContext(int t, int w, int h);

}  // namespace arena::test
