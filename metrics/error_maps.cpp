#include "metrics/error_maps.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.hpp"
#include "metrics/error.hpp"

namespace arena {

const ColorMap& magmaColorMap() {
  static const ColorMap map = {"magma",
                               {{{0, 0, 4},
                                 {10, 8, 34},
                                 {29, 17, 71},
                                 {54, 16, 107},
                                 {81, 18, 124},
                                 {106, 28, 129},
                                 {131, 38, 129},
                                 {156, 46, 127},
                                 {183, 55, 121},
                                 {208, 65, 111},
                                 {231, 82, 99},
                                 {245, 107, 92},
                                 {252, 137, 97},
                                 {254, 167, 114},
                                 {254, 196, 136},
                                 {253, 226, 163},
                                 {252, 253, 191}}}};
  return map;
}

const ColorMap& viridisColorMap() {
  static const ColorMap map = {"viridis",
                               {{{68, 1, 84},
                                 {72, 24, 106},
                                 {71, 45, 123},
                                 {66, 64, 134},
                                 {59, 82, 139},
                                 {51, 99, 141},
                                 {44, 114, 142},
                                 {38, 130, 142},
                                 {33, 145, 140},
                                 {31, 160, 136},
                                 {40, 174, 128},
                                 {63, 188, 115},
                                 {94, 201, 98},
                                 {132, 212, 75},
                                 {173, 220, 48},
                                 {216, 226, 25},
                                 {253, 231, 37}}}};
  return map;
}

std::array<std::array<uint8_t, 3>, 256> colorTable(const ColorMap& map) {
  std::array<std::array<uint8_t, 3>, 256> table{};
  const size_t segments = map.stops.size() - 1;
  for (size_t i = 0; i < 256; ++i) {
    const double x = double(i) / 255.0 * double(segments);
    const size_t k = std::min(segments - 1, size_t(x));
    const double f = x - double(k);
    for (int c = 0; c < 3; ++c)
      table[i][size_t(c)] =
          uint8_t(std::lround((1 - f) * map.stops[k][size_t(c)] + f * map.stops[k + 1][size_t(c)]));
  }
  return table;
}

Image applyColorMap(const Image& values, const ColorMap& map) {
  if (values.channels() != 1)
    throw Error(std::string("applyColorMap: expected a one-channel image, got ") +
                std::to_string(values.channels()) + " channels");
  const auto table = colorTable(map);
  Image out(values.width(), values.height(), 3);
  for (size_t i = 0; i < values.pixelCount(); ++i) {
    const float v = values.plane(0)[i];
    const size_t index = std::isfinite(v) ? size_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f))
                                          : (v > 0 ? size_t(255) : size_t(0));
    for (int c = 0; c < 3; ++c) out.plane(c)[i] = float(table[index][size_t(c)]) / 255.0f;
  }
  return out;
}

std::vector<float> decodeColorMap(std::span<const uint8_t> rgb, const ColorMap& map) {
  if (rgb.size() % 3 != 0)
    throw Error("decodeColorMap: " + std::to_string(rgb.size()) + " bytes is not whole RGB pixels");
  const auto table = colorTable(map);
  // Neighbouring entries can round to the same colour where the map changes slowly; such a colour
  // decodes to the middle of its run of entries.
  std::map<uint32_t, std::pair<int, int>> exact;  // colour -> (sum of indices, count)
  for (int i = 0; i < 256; ++i) {
    auto& e = exact[uint32_t(table[size_t(i)][0]) << 16 | uint32_t(table[size_t(i)][1]) << 8 |
                    table[size_t(i)][2]];
    e.first += i;
    ++e.second;
  }
  std::vector<float> out(rgb.size() / 3);
  for (size_t p = 0; p < out.size(); ++p) {
    const uint8_t* px = &rgb[3 * p];
    auto it = exact.find(uint32_t(px[0]) << 16 | uint32_t(px[1]) << 8 | px[2]);
    if (it != exact.end()) {
      out[p] = float(it->second.first) / float(it->second.second) / 255.0f;
      continue;
    }
    int best = 0, bestDistance = 1 << 30;  // not from this map (resampled, edited): the nearest
    for (int i = 0; i < 256; ++i) {
      int d = 0;
      for (int c = 0; c < 3; ++c)
        d += (px[c] - table[size_t(i)][size_t(c)]) * (px[c] - table[size_t(i)][size_t(c)]);
      if (d < bestDistance) bestDistance = d, best = i;
    }
    out[p] = float(best) / 255.0f;
  }
  return out;
}

Image relativeSquaredError(const Image& d, const Image& r) {
  if (!d.sameShape(r) || d.channels() < 3)
    throw Error(
        "relativeSquaredError: the test and reference images must have the same shape and 3 colour "
        "channels");
  Image m(d.width(), d.height(), 1);
  for (size_t i = 0; i < d.pixelCount(); ++i) {
    double s = 0;
    for (int c = 0; c < 3; ++c) {
      const double diff = double(d.plane(c)[i]) - r.plane(c)[i];
      s += diff * diff / (double(r.plane(c)[i]) * r.plane(c)[i] + kRelMseEpsilon);
    }
    m.plane(0)[i] = float(s / 3);
  }
  return m;
}

Image relativeErrorMap(const Image& d, const Image& r) {
  return relativeErrorMap(relativeSquaredError(d, r));
}

Image relativeErrorMap(Image v) {
  const double span = kRelErrorMapLog10Max - kRelErrorMapLog10Min;
  for (float& x : v.raw())
    x = float((std::log10(std::max(double(x), 1e-30)) - kRelErrorMapLog10Min) / span);
  return applyColorMap(v, viridisColorMap());
}

Image blockMeans(const Image& values, int block) {
  const int w = values.width(), h = values.height();
  const int bw = (w + block - 1) / block, bh = (h + block - 1) / block;
  std::vector<double> sum(size_t(bw) * size_t(bh), 0.0);
  std::vector<int> count(sum.size(), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t k = size_t(y / block) * size_t(bw) + size_t(x / block);
      sum[k] += double(values.at(x, y, 0));
      ++count[k];
    }
  Image out(bw, bh, 1);
  for (size_t k = 0; k < sum.size(); ++k) out.raw()[k] = float(sum[k] / count[k]);
  return out;
}

double relativeErrorOfMapValue(double value) {
  return std::pow(10.0,
                  kRelErrorMapLog10Min + value * (kRelErrorMapLog10Max - kRelErrorMapLog10Min));
}

}  // namespace arena
