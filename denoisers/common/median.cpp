#include "denoisers/common/median.hpp"

#include <algorithm>

#include "core/error.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

double median3x3(const Image& in, const GBufferView* g, Image& out) {
  const int w = in.width(), h = in.height();
  if (!out.sameShape(in) || &in == &out)
    throw Error("median 3x3: in/out must be distinct, equal-shaped images");
  parallelRows(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * size_t(w) + size_t(x);
      if (g && g->isSky(p)) {
        for (int c = 0; c < in.channels(); ++c) out.plane(c)[p] = in.plane(c)[p];
        continue;
      }
      size_t taps[9];
      int count = 0;
      forEachNeighbour3x3(x, y, w, h, g, false, [&](size_t q) { taps[count++] = q; });
      for (int c = 0; c < in.channels(); ++c) {
        float values[9];
        for (int k = 0; k < count; ++k) values[k] = in.plane(c)[taps[k]];
        // Lower median for an even count (a value that exists, never an average of two).
        std::nth_element(values, values + (count - 1) / 2, values + count);
        out.plane(c)[p] = values[(count - 1) / 2];
      }
    }
  });
  return 9.0;
}

}  // namespace arena
