// Issue 15's two tracer changes: the specular hit distance a real-time tracer has (item 3) and a
// light selection that keeps switched-off lights (item 11).
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "core/sequence.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

// Item 3: `specHitDist` is the 1-spp sample's own first ray length -- it changes from frame to
// frame under a still camera on a rough surface -- while `specHitDistMirror` (the oracle) does not.
TEST(FidelityTracer, SampledHitDistanceIsNoisyAndTheMirrorOracleIsNot) {
  Scene scene = test::shippedScene("cornell_static");
  SequenceRenderer r(scene, test::tinySettings(32, 18, 3, 4));
  const LayerSet a = r.renderFrame(1).frame, b = r.renderFrame(2).frame;
  const Image &sa = a.get("specHitDist"), &sb = b.get("specHitDist");
  const Image &ma = a.get("specHitDistMirror"), &mb = b.get("specHitDistMirror");
  EXPECT_TRUE(samePixels(ma, mb));
  int surface = 0, changed = 0;
  for (size_t i = 0; i < sa.pixelCount(); ++i) {
    if (a.get("meshId").plane(0)[i] < 0) continue;
    ++surface;
    changed += sa.plane(0)[i] != sb.plane(0)[i];
    EXPECT_GE(sa.plane(0)[i], 0.0f);
    EXPECT_LE(sa.plane(0)[i], 1e6f);
  }
  ASSERT_GT(surface, 100);
  EXPECT_GT(double(changed) / surface, 0.5) << changed << "/" << surface;
}

// Item 11: a floor lit by one light, and a second light under the floor facing away from
// everything (it never contributes) that switches off at frame 2. Nothing visible changes, so
// every gradient sample of frame 2 -- frame 1's path re-shaded with frame 1's random numbers --
// must reproduce its old luminance exactly. Selecting among the *active* lights instead moved
// every light choice when the hidden light went off.
TEST(FidelityTracer, SwitchingOffAnInvisibleLightFakesNoGradient) {
  const auto dir = test::freshDir("fidelity_hidden_light");
  const auto path = dir / "hidden_light.json";
  std::ofstream(path) << R"({
    "purpose": "hidden light switch", "resolution": [24, 15], "frames": 3, "max_bounces": 2,
    "camera": {"keys": [{"frame": 0, "eye": [0, 1.5, 2], "target": [0, 0, 0], "fov": 50}]},
    "materials": {"white": {"albedo": [0.7, 0.7, 0.7]}},
    "objects": [{"name": "floor", "shape": "quad", "material": "white",
                 "keys": [{"frame": 0, "scale": [3, 1, 3]}]}],
    "lights": [
      {"name": "lamp", "shape": "quad",
       "keys": [{"frame": 0, "translate": [0, 2, 0], "rotate": [180, 0, 0], "scale": [0.5, 1, 0.5],
                 "intensity": 10}]},
      {"name": "hidden", "shape": "quad",
       "keys": [{"frame": 0, "translate": [0, -1, 0], "rotate": [180, 0, 0], "scale": [0.5, 1, 0.5],
                 "intensity": 10},
                {"frame": 2, "intensity": 0, "step": true}]}
    ]})";
  Scene scene = loadScene(path.string());
  SequenceRenderer r(scene, test::tinySettings(24, 15, 3, 4));
  const auto rendered = r.renderFrame(2);  // kept alive while g is read
  const Image& g = rendered.gradients.get("gradient");
  int valid = 0, differing = 0;
  for (int y = 0; y < g.height(); ++y)
    for (int x = 0; x < g.width(); ++x) {
      if (g.at(x, y, 4) == 0) continue;
      ++valid;
      differing += g.at(x, y, 2) != g.at(x, y, 3);
    }
  std::printf("hidden light off: %d of %d gradient samples differ\n", differing, valid);
  ASSERT_GT(valid, 10);
  EXPECT_EQ(differing, 0);
}

}  // namespace
}  // namespace arena
