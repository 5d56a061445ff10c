// Issue 15's tracer changes: the specular hit distance a real-time tracer has (item 3).
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
  EXPECT_EQ(ma.raw(), mb.raw());
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

}  // namespace
}  // namespace arena
