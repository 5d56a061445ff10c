#pragma once
// Per-tile partial sums of a per-pixel metric: the spatial blocks of the bootstrap
// (metrics/statistics.hpp). A frame's metric is sum / count over all tiles, so a resample of
// tiles gives a resampled frame value without touching pixels again.
#include <cstddef>
#include <vector>
#include <span>

namespace arena {

// The image is cut into cols x rows tiles of (almost) equal size. 4x4 tiles at the quick preset's
// 256x144 are 64x36 pixels: larger than the à-trous and SSIM footprints that correlate errors.
struct TileGrid {
  int cols = 4, rows = 4;
  int count() const { return cols * rows; }
};

struct TileSums {
  std::vector<double> sum, count;  // per tile, row-major
  bool empty() const { return sum.empty(); }
  double totalSum() const;
  double totalCount() const;
};

// Accumulates (value, count) per pixel into tiles. Each image row has its own slots, so rows may be
// filled from parallel tasks; finish() adds rows in order, so the sums never depend on scheduling.
class TileAccumulator {
 public:
  TileAccumulator(int width, int height, TileGrid grid = {});
  void add(int x, int y, double value, double count) {
    const std::size_t slot =
        std::size_t(y) * std::size_t(grid_.cols) + std::size_t(tileColumn_[std::size_t(x)]);
    sum_[slot] += value;
    count_[slot] += count;
  }
  TileSums finish() const;

 private:
  int width_, height_;
  TileGrid grid_;
  std::vector<int> tileColumn_;
  std::vector<double> sum_, count_;  // height x cols
};

// Tile sums of a one-channel per-pixel map (e.g. a FLIP map): value = the map, count = 1 per pixel.
TileSums tileSumsOfMap(std::span<const float> map, int width, int height, TileGrid grid = {});

}  // namespace arena
