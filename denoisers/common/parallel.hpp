#pragma once
// Pixel loops run row-parallel with oneTBB, the CPU stand-in for a compute dispatch. Rows are the
// unit of work so each body walks contiguous memory in every plane.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <xmmintrin.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

#include "core/error.hpp"
#include "core/image.hpp"

namespace arena {

// Denormals flushed to zero (FTZ) and read as zero (DAZ) while a pixel loop runs, the previous
// mode restored after. Two reasons: the tracer leaves FTZ/DAZ on in the TBB workers it ran on
// (Embree asks for it) and not on the others, so without a fixed mode a filter's result would
// depend on which thread ran which row, breaking bit-identical reruns; and filter weights decay
// towards 0 (w^2 Var, c^128), where each denormal costs a ~100-cycle microcode assist.
class DenormalsAreZeroScope {
 public:
  DenormalsAreZeroScope() : saved_(_mm_getcsr()) {
    _mm_setcsr(saved_ | kFlushZero | kDenormalsZero);
  }
  ~DenormalsAreZeroScope() { _mm_setcsr(saved_); }
  DenormalsAreZeroScope(const DenormalsAreZeroScope&) = delete;
  DenormalsAreZeroScope& operator=(const DenormalsAreZeroScope&) = delete;

 private:
  static constexpr unsigned kFlushZero = 0x8000, kDenormalsZero = 0x0040;  // MXCSR bits 15, 6
  unsigned saved_;
};

// Calls rowBody(y) for every row 0..height-1, rows spread over the TBB workers, denormals zero.
template <class RowBody>
void parallelRows(int height, RowBody&& rowBody) {
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    const DenormalsAreZeroScope denormalsAreZero;
    for (int y = rows.begin(); y < rows.end(); ++y) rowBody(y);
  });
}

// dst[i] = src[i] for i < count, split across the TBB workers: a full-image copy is memory-bound,
// and one core does not use the whole bandwidth (history stores copy several planes per frame).
inline void parallelCopy(const float* src, size_t count, float* dst) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, count, size_t(1) << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      std::copy(src + r.begin(), src + r.end(), dst + r.begin());
                    });
}

// `to` = `from` (same shape), every plane copied as above.
inline void parallelCopy(const Image& from, Image& to) {
  if (!to.sameShape(from)) throw Error("parallelCopy: the images differ in shape");
  parallelCopy(from.raw().data(), from.raw().size(), to.raw().data());
}

// Neighbour fetches counted per row (no atomics, no per-frame allocation), so a pass whose
// footprint varies per pixel (3x3 fallback, spatial variance) can report its average fetch count.
class RowTapCounter {
 public:
  void setup(int height) { rows_.assign(size_t(height), 0); }
  void set(int y, int64_t taps) { rows_[size_t(y)] = taps; }
  double perPixel(size_t pixelCount) const {
    if (pixelCount == 0) return 0.0;
    return double(std::accumulate(rows_.begin(), rows_.end(), int64_t(0))) / double(pixelCount);
  }

 private:
  std::vector<int64_t> rows_;
};

}  // namespace arena
