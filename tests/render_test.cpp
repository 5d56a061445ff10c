// The optional low-resolution, many-sample buffer (CAPCOM 2023 "disocclusion rays", slides 19-21):
// off by default and then invisible to the cache hash; when on, one texel per block at the block's
// anchor pixel, converging towards the reference faster than the 1-spp frame, resumable.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/error.hpp"
#include "core/sequence.hpp"
#include "tests/test_util.hpp"
#include "tracer/render.hpp"

namespace arena {
namespace {

namespace fs = std::filesystem;

TEST(LowresBuffer, OffByDefaultLeavesTheHashAndTheCacheAsTheyWere) {
  const Scene scene = test::shippedScene("cornell_static");
  RenderSettings plain = test::tinySettings(24, 14, 2, 16);
  EXPECT_EQ(plain.lowresFactor, 0);
  EXPECT_FALSE(plain.pixelSettings(scene).contains("lowresFactor"));
  EXPECT_FALSE(plain.pixelSettings(scene).contains("lowresSpp"));
  RenderSettings changedSppOnly = plain;
  changedSppOnly.lowresSpp = 64;  // meaningless while the buffer is off
  EXPECT_EQ(sequenceHash(scene, plain), sequenceHash(scene, changedSppOnly));
  RenderSettings on = plain;
  on.lowresFactor = 4;
  EXPECT_NE(sequenceHash(scene, plain), sequenceHash(scene, on));
  RenderSettings onMoreSpp = on;
  onMoreSpp.lowresSpp = 32;
  EXPECT_NE(sequenceHash(scene, on), sequenceHash(scene, onMoreSpp));
}

TEST(LowresBuffer, AnchorsAreBlockCentresClampedToTheImage) {
  EXPECT_EQ(lowresSize(24, 8), 3);
  EXPECT_EQ(lowresSize(25, 8), 4);
  EXPECT_EQ(lowresAnchor(0, 8, 24), 4);
  EXPECT_EQ(lowresAnchor(2, 8, 24), 20);
  EXPECT_EQ(lowresAnchor(3, 8, 25), 24);  // the partial last block: its centre 28 is clamped
}

TEST(LowresBuffer, BadSettingsAreErrorsNamingTheValue) {
  const Scene scene = test::shippedScene("cornell_static");
  RenderSettings s = test::tinySettings(24, 14, 2, 16);
  s.lowresFactor = 1;
  try {
    SequenceRenderer r(scene, s);
    FAIL() << "factor 1 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lowresFactor 1"), std::string::npos) << e.what();
  }
  s.lowresFactor = 4;
  s.lowresSpp = 0;
  EXPECT_THROW(SequenceRenderer(scene, s), Error);
}

// Mean over texels and channels of (x - ref)^2 / (ref^2 + 0.01) at the anchor pixels.
double relMseAtAnchors(const Image& lowres, const Image& full, const Image& reference, int factor,
                       bool fromLowres) {
  double sum = 0;
  int n = 0;
  for (int ly = 0; ly < lowres.height(); ++ly)
    for (int lx = 0; lx < lowres.width(); ++lx) {
      const int x = lowresAnchor(lx, factor, full.width()),
                y = lowresAnchor(ly, factor, full.height());
      for (int c = 0; c < 3; ++c) {
        const double v = fromLowres ? lowres.at(lx, ly, c) : full.at(x, y, c),
                     r = reference.at(x, y, c);
        sum += (v - r) * (v - r) / (r * r + 0.01);
        ++n;
      }
    }
  return sum / n;
}

TEST(LowresBuffer, ManySamplesPerTexelConvergeAndCarryADirection) {
  const Scene scene = test::shippedScene("cornell_static");
  RenderSettings s = test::tinySettings(48, 28, 2, 64);
  s.lowresFactor = 4;
  s.lowresSpp = 32;
  const fs::path cache = test::freshDir("lowres_render");
  const fs::path dir = renderSequence(scene, s, cache, nullptr);
  const Sequence seq = Sequence::open(dir);
  EXPECT_EQ(seq.info().lowresFactor(), 4);
  EXPECT_EQ(seq.info().lowresSpp(), 32);
  const LayerSet low = seq.lowres(1), frame = seq.frame(1), ref = seq.reference(1);
  const Image& diffuse = low.get("diffuse");
  ASSERT_EQ(diffuse.width(), 12);
  ASSERT_EQ(diffuse.height(), 7);
  // 32 paths against 1: the error at the anchors falls by well over 4x (1/spp in expectation).
  const double lowErr = relMseAtAnchors(diffuse, frame.get("diffuse"), ref.get("diffuse"), 4, true);
  const double oneErr =
      relMseAtAnchors(diffuse, frame.get("diffuse"), ref.get("diffuse"), 4, false);
  EXPECT_LT(lowErr * 4, oneErr) << "lowres " << lowErr << " vs 1 spp " << oneErr;
  // The mean direction is a convex combination of unit vectors over the hemisphere of the normal.
  const Image& direction = low.get("direction");
  const Image& normal = frame.get("normal");
  int lit = 0;
  for (int ly = 0; ly < direction.height(); ++ly)
    for (int lx = 0; lx < direction.width(); ++lx) {
      const int x = lowresAnchor(lx, 4, 48), y = lowresAnchor(ly, 4, 28);
      const float dx = direction.at(lx, ly, 0), dy = direction.at(lx, ly, 1),
                  dz = direction.at(lx, ly, 2);
      const float len = std::sqrt(dx * dx + dy * dy + dz * dz);
      EXPECT_LE(len, 1.0f + 1e-4f);
      if (len < 1e-3f) continue;
      ++lit;
      EXPECT_GT(dx * normal.at(x, y, 0) + dy * normal.at(x, y, 1) + dz * normal.at(x, y, 2), 0.0f)
          << "texel " << lx << "," << ly;
    }
  EXPECT_GT(lit, 60);
  // Resume: a lost low-res file is rendered alone, bit-identically.
  fs::remove(Sequence::lowresPath(dir, 1));
  std::vector<std::string> lines;
  renderSequence(scene, s, cache, [&](const std::string& l) { lines.push_back(l); });
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find("lowres_0001.exr"), std::string::npos) << lines[0];
  EXPECT_TRUE(samePixels(seq.lowres(1).get("diffuse"), diffuse));
}

TEST(LowresBuffer, ASequenceWithoutItSaysSo) {
  const Scene scene = test::shippedScene("cornell_static");
  const fs::path dir = renderSequence(scene, test::tinySettings(16, 8, 1, 4),
                                      test::freshDir("lowres_none"), nullptr);
  try {
    Sequence::open(dir).lowres(0);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--lowres-factor"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace arena
