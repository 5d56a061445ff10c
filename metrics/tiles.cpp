#include "metrics/tiles.hpp"

#include <algorithm>

#include "core/error.hpp"

namespace arena {

double TileSums::totalSum() const {
  double s = 0;
  for (double v : sum) s += v;
  return s;
}

double TileSums::totalCount() const {
  double s = 0;
  for (double v : count) s += v;
  return s;
}

TileAccumulator::TileAccumulator(int width, int height, TileGrid grid)
    : width_(width),
      height_(height),
      grid_(grid),
      tileColumn_(size_t(std::max(width, 0))),
      sum_(size_t(std::max(height, 0)) * size_t(std::max(grid.cols, 0)), 0.0),
      count_(sum_.size(), 0.0) {
  if (grid.cols < 1 || grid.rows < 1) throw Error("tile grid: expected at least 1x1 tiles");
  for (int x = 0; x < width; ++x) tileColumn_[size_t(x)] = int(long(x) * grid.cols / width);
}

TileSums TileAccumulator::finish() const {
  TileSums out{std::vector<double>(size_t(grid_.count()), 0.0),
               std::vector<double>(size_t(grid_.count()), 0.0)};
  for (int y = 0; y < height_; ++y) {
    const size_t tileRow = size_t(long(y) * grid_.rows / height_);
    for (int c = 0; c < grid_.cols; ++c) {
      const size_t slot = size_t(y) * size_t(grid_.cols) + size_t(c);
      out.sum[tileRow * size_t(grid_.cols) + size_t(c)] += sum_[slot];
      out.count[tileRow * size_t(grid_.cols) + size_t(c)] += count_[slot];
    }
  }
  return out;
}

TileSums tileSumsOfMap(std::span<const float> map, int width, int height, TileGrid grid) {
  if (map.size() != size_t(width) * size_t(height))
    throw Error("tile sums: map size does not match the image");
  TileAccumulator acc(width, height, grid);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) acc.add(x, y, map[size_t(y) * size_t(width) + size_t(x)], 1.0);
  return acc.finish();
}

}  // namespace arena
