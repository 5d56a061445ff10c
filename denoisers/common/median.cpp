#include "denoisers/common/median.hpp"

#include <limits>

#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "denoisers/common/gpu_traffic.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

namespace {

// Orders a pair: a <= b afterwards.
inline void sortPair(Lanes8& a, Lanes8& b) {
  const Lanes8 low = minFloat(a, b);
  b = maxFloat(a, b);
  a = low;
}

// The median of nine values per lane, in p[4], by the 19-comparison exchange network of Paeth's
// "Median finding on a 3x3 grid" (Graphics Gems, 1990).
inline Lanes8 medianOfNine(Lanes8 p[9]) {
  constexpr int kPairs[19][2] = {{1, 2}, {4, 5}, {7, 8}, {0, 1}, {3, 4}, {6, 7}, {1, 2},
                                 {4, 5}, {7, 8}, {0, 3}, {5, 8}, {4, 7}, {3, 6}, {1, 4},
                                 {2, 5}, {4, 7}, {4, 2}, {6, 4}, {4, 2}};
  for (const auto& pair : kPairs) sortPair(p[pair[0]], p[pair[1]]);
  return p[4];
}

}  // namespace

double median3x3(const Image& in, const GBufferView* g, Image& out, bool edgeAware) {
  const int w = in.width(), h = in.height();
  if (!out.sameShape(in) || &in == &out)
    throw Error("median 3x3: in/out must be distinct, equal-shaped images");
  if (g && (g->width != w || g->height != h))
    throw Error("median 3x3: the G-buffer's size differs from the image's");
  const float* meshId = g ? g->meshId : nullptr;
  if (edgeAware && (!meshId || !g->normal[0] || !g->normal[1] || !g->normal[2]))
    throw Error("median 3x3: the edge-aware median needs the G-buffer's meshId and normal");
  if (gpu::recording()) {
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    gpu::read(kRadiance, w, h, 9);
    if (meshId) gpu::read(kMeshId, w, h, 9);
    if (edgeAware) gpu::read(kNormal, w, h, 9);
    gpu::write(kRadiance, w, h);
  }
  constexpr float kMinNormalCosine = 0.8f;
  constexpr float kInfinity = std::numeric_limits<float>::infinity();
  // Eight pixels at a time. A tap off the image or in the sky is missing; with k of the nine
  // missing, ceil(k/2) are replaced by -inf and the rest by +inf (in tap order), so the fifth of
  // the nine is the lower median of the values that are there: index 4 - ceil(k/2) =
  // (count - 1) / 2 of the count = 9 - k present.
  parallelRows(h, [&](int y) {
    for (int x0 = 0; x0 < w; x0 += 8) {
      const Neighbourhood3x3Lanes n(x0, y, w, h, meshId);
      const size_t p = n.p;
      const LaneMask8 inRow = n.inRow;
      LaneMask8 present[9];
      for (int j = 0; j < 9; ++j) present[j] = n.present[j];
      const size_t* offset = n.offset;
      if (edgeAware) {  // same mesh and a similar normal, or missing
        const Lanes8 id = loadLanes(meshId + p, inRow);
        Lanes8 normal[3];
        for (int c = 0; c < 3; ++c) normal[c] = loadLanes(g->normal[size_t(c)] + p, inRow);
        for (int j = 0; j < 9; ++j) {
          if (j == 4) continue;
          Lanes8 cosine{};
          for (int c = 0; c < 3; ++c)
            cosine += normal[c] * loadLanes(g->normal[size_t(c)] + offset[j], present[j]);
          present[j] &=
              (loadLanes(meshId + offset[j], present[j]) == id) & (cosine >= kMinNormalCosine);
        }
      }
      LaneMask8 missing{};
      for (int j = 0; j < 9; ++j) missing -= present[j] == 0;  // comparisons give -1
      const LaneMask8 lowPads = (missing + 1) >> 1;
      Lanes8 pad[9];
      LaneMask8 missingBefore{};
      for (int j = 0; j < 9; ++j) {
        pad[j] = selectFloat(missingBefore < lowPads, Lanes8{} - kInfinity, Lanes8{} + kInfinity);
        missingBefore -= present[j] == 0;
      }
      const LaneMask8 sky = present[4] == 0;  // the centre (inside the row) is missing: sky
      for (int c = 0; c < in.channels(); ++c) {
        const float* plane = in.plane(c);
        Lanes8 values[9];
        for (int j = 0; j < 9; ++j)
          values[j] = selectFloat(present[j], loadLanes(plane + offset[j], present[j]), pad[j]);
        const Lanes8 median = medianOfNine(values);
        storeLanes(out.plane(c) + p, selectFloat(sky, loadLanes(plane + p, inRow), median), inRow);
      }
    }
  });
  return 9.0;
}

}  // namespace arena
