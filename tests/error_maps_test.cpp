// Error maps for eyes (metrics/error_maps): the colour maps' ends, the exact round trip of an
// 8-bit colour-mapped image, the relative-error map's stated log scale, and bad input.
#include "metrics/error_maps.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.hpp"

namespace arena {
namespace {

// An image through the map, as the 8-bit interleaved RGB a PNG holds.
std::vector<uint8_t> asBytes(const Image& rgb) {
  std::vector<uint8_t> out;
  for (size_t i = 0; i < rgb.pixelCount(); ++i)
    for (int c = 0; c < 3; ++c) out.push_back(uint8_t(std::lround(rgb.plane(c)[i] * 255.0f)));
  return out;
}

TEST(ErrorMaps, MagmaEndsAreTheFlipToolsColours) {
  Image v(3, 1, 1);
  v.at(0, 0) = 0.0f, v.at(1, 0) = 1.0f, v.at(2, 0) = NAN;
  const std::vector<uint8_t> b = asBytes(applyColorMap(v, magmaColorMap()));
  EXPECT_EQ(std::vector<uint8_t>(b.begin(), b.begin() + 3), (std::vector<uint8_t>{0, 0, 4}));
  EXPECT_EQ(std::vector<uint8_t>(b.begin() + 3, b.begin() + 6),
            (std::vector<uint8_t>{252, 253, 191}));
  EXPECT_EQ(std::vector<uint8_t>(b.begin() + 6, b.end()),
            (std::vector<uint8_t>{0, 0, 4}));  // NaN -> 0
}

TEST(ErrorMaps, EightBitColourMapsDecodeBackToTheirValues) {
  for (const ColorMap* map : {&magmaColorMap(), &viridisColorMap()}) {
    Image ramp(256, 1, 1);
    for (int i = 0; i < 256; ++i) ramp.at(i, 0) = float(i) / 255.0f;
    const std::vector<float> back = decodeColorMap(asBytes(applyColorMap(ramp, *map)), *map);
    int exact = 0;
    for (int i = 0; i < 256; ++i) {
      // Where neighbouring entries round to one colour the middle of the run comes back: at most
      // a few 1/255 steps off, and exact wherever the colour is unique.
      EXPECT_NEAR(back[size_t(i)], float(i) / 255.0f, 3.0f / 255.0f) << map->name << " " << i;
      exact += std::abs(back[size_t(i)] - float(i) / 255.0f) < 1e-6f;
    }
    EXPECT_GT(exact, 200) << map->name;
  }
  // A colour not in the map decodes to the nearest entry.
  const std::vector<uint8_t> offMap = {1, 1, 5};
  EXPECT_NEAR(decodeColorMap(offMap, magmaColorMap())[0], 0.0f, 2.0f / 255.0f);
}

TEST(ErrorMaps, RelativeErrorMapHasAFixedLogScale) {
  // Reference 1 everywhere; test values chosen so the relative squared error is 1e-4, 1e-2 and 1
  // (relSE = diff^2 / (1 + 0.01)), and one far beyond the top of the scale.
  Image r(4, 1, 3, 1.0f), d(4, 1, 3, 1.0f);
  const double target[] = {1e-4, 1e-2, 1.0, 1e6};
  for (int x = 0; x < 4; ++x)
    for (int c = 0; c < 3; ++c) d.at(x, 0, c) = float(1.0 + std::sqrt(target[x] * 1.01));
  const Image se = relativeSquaredError(d, r);
  for (int x = 0; x < 3; ++x) EXPECT_NEAR(se.at(x, 0), target[x], target[x] * 1e-4);
  const std::vector<float> v = decodeColorMap(asBytes(relativeErrorMap(d, r)), viridisColorMap());
  for (int x = 0; x < 3; ++x)  // 5 decades over 255 steps: within 5% after the round trip
    EXPECT_NEAR(relativeErrorOfMapValue(v[size_t(x)]), target[x], 0.05 * target[x]) << x;
  EXPECT_NEAR(relativeErrorOfMapValue(v[3]), 10.0, 0.5);  // clamped at the top, 1e1
  EXPECT_NEAR(relativeErrorOfMapValue(0.0), 1e-4, 1e-12);
}

TEST(ErrorMaps, BadInputIsAClearError) {
  EXPECT_THROW(applyColorMap(Image(2, 2, 3), magmaColorMap()), Error);
  EXPECT_THROW(relativeSquaredError(Image(2, 2, 3), Image(3, 2, 3)), Error);
  const std::vector<uint8_t> notRgb = {1, 2};
  try {
    decodeColorMap(notRgb, magmaColorMap());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not whole RGB pixels"), std::string::npos);
  }
}

// The kept values: each block's mean, edge blocks over the pixels they hold (a 10x9 image in 8x8
// blocks: 2 x 2 blocks of 64, 16, 8 and 2 pixels), so that any union of whole blocks sums exactly.
TEST(ErrorMaps, BlockMeansAverageEachBlocksOwnPixels) {
  Image v(10, 9, 1);
  for (int y = 0; y < 9; ++y)
    for (int x = 0; x < 10; ++x) v.at(x, y, 0) = float(x + 10 * y);
  const Image b = blockMeans(v, 8);
  ASSERT_EQ(b.width(), 2);
  ASSERT_EQ(b.height(), 2);
  EXPECT_FLOAT_EQ(b.at(0, 0, 0), 3.5f + 10 * 3.5f);  // x 0-7, y 0-7
  EXPECT_FLOAT_EQ(b.at(1, 0, 0), 8.5f + 10 * 3.5f);  // x 8-9
  EXPECT_FLOAT_EQ(b.at(0, 1, 0), 3.5f + 10 * 8.0f);  // y 8
  EXPECT_FLOAT_EQ(b.at(1, 1, 0), 8.5f + 10 * 8.0f);
  double whole = 0;
  for (float x : v.raw()) whole += x;
  const double fromBlocks =
      64 * b.at(0, 0, 0) + 16 * b.at(1, 0, 0) + 8 * b.at(0, 1, 0) + 2 * b.at(1, 1, 0);
  EXPECT_NEAR(fromBlocks, whole, 1e-9 * whole);
}

}  // namespace
}  // namespace arena
