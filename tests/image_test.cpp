// core/image: planes are cache-line aligned; a borrowed image reads and writes somebody else's
// planes in place (the C plugin adapter's zero copy), and copies/assignments never write into them.
#include "core/image.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "core/error.hpp"

namespace arena {
namespace {

TEST(Image, PlanesAreCacheLineAligned) {
  for (int w : {1, 3, 17, 1280}) {
    const Image image(w, 3, 3);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(image.plane(0)) % 64, 0u) << w;
  }
}

TEST(Image, BorrowedImageReadsAndWritesTheOwnersPlanesInPlace) {
  std::vector<float> planes = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};  // 2x2, 3 channels
  Image view = Image::borrow(planes.data(), 2, 2, 3);
  EXPECT_TRUE(view.borrowed());
  EXPECT_EQ(view.plane(0), planes.data());
  EXPECT_EQ(view.plane(2), planes.data() + 8);
  EXPECT_EQ(view.at(1, 1, 1), 8.0f);
  view.at(0, 1, 2) = -1.0f;
  EXPECT_EQ(planes[10], -1.0f);
  view.fill(0.5f);
  for (float v : planes) EXPECT_EQ(v, 0.5f);
  EXPECT_EQ(view.raw().size(), planes.size());
}

TEST(Image, CopiesOwnMovesKeepTheViewAssignmentsRebind) {
  std::vector<float> planes(8, 2.0f);
  Image view = Image::borrow(planes.data(), 4, 2, 1);

  Image copy = view;  // an owning copy: writing it leaves the owner's planes alone
  EXPECT_FALSE(copy.borrowed());
  EXPECT_NE(copy.plane(0), planes.data());
  copy.fill(9.0f);
  EXPECT_EQ(planes[3], 2.0f);
  EXPECT_TRUE(samePixels(Image(4, 2, 1, 2.0f), view));

  Image moved = std::move(view);  // still the same planes
  EXPECT_TRUE(moved.borrowed());
  EXPECT_EQ(moved.plane(0), planes.data());
  EXPECT_TRUE(view.empty());  // NOLINT(bugprone-use-after-move): the moved-from state is defined

  moved = Image(4, 2, 1, 7.0f);  // rebinds to its own storage, the owner's planes untouched
  EXPECT_FALSE(moved.borrowed());
  EXPECT_EQ(planes[0], 2.0f);
  Image again = Image::borrow(planes.data(), 4, 2, 1);
  again = copy;  // copy-assignment too
  EXPECT_FALSE(again.borrowed());
  EXPECT_EQ(planes[0], 2.0f);
  EXPECT_EQ(again.at(0, 0), 9.0f);
}

TEST(Image, OwningMoveKeepsThePlanes) {
  Image a(3, 3, 2, 1.0f);
  const float* planes = a.plane(0);
  Image b = std::move(a);
  EXPECT_EQ(b.plane(0), planes);
  Image c;
  c = std::move(b);
  EXPECT_EQ(c.plane(0), planes);
  EXPECT_EQ(c.at(2, 2, 1), 1.0f);
}

TEST(Image, SamePixelsComparesShapeAndValues) {
  Image a(2, 2, 1, 1.0f), b(2, 2, 1, 1.0f), c(4, 1, 1, 1.0f);
  EXPECT_TRUE(samePixels(a, b));
  EXPECT_FALSE(samePixels(a, c));  // the same values in another shape
  b.at(1, 0) = 1.5f;
  EXPECT_FALSE(samePixels(a, b));
}

TEST(Image, BorrowRejectsANegativeSizeOrNoPlanes) {
  float x = 0;
  EXPECT_THROW(Image::borrow(&x, -1, 1, 1), Error);
  EXPECT_THROW(Image::borrow(nullptr, 2, 2, 1), Error);
  EXPECT_TRUE(Image::borrow(nullptr, 0, 0, 0).empty());
}

}  // namespace
}  // namespace arena
