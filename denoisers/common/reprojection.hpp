#pragma once
// Motion-vector reprojection with per-tap consistency tests (SVGF §4.1, Falcor's SVGFReproject):
// decided once per frame into a compact per-pixel record, then applied to every history image
// (colour, moments, history length) so they all share one decision.
#include <cstdint>
#include <vector>

#include "core/camera.hpp"
#include "core/fast_math.hpp"
#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/param_table.hpp"

namespace arena {

struct ReprojectionSettings {
  // Parameters "depthThreshold" and "normalThreshold": default, range and meaning in
  // reprojectionParams() (reprojection.cpp), the only place they are declared. A bare
  // ReprojectionSettings{} leaves them 0 (every tap rejected): a caller outside a denoiser's table
  // starts from reprojectionParams().defaults().
  float depthThreshold{}, normalThreshold{};
  // (0; 1] Falcor: the surviving bilinear weight must sum to at least 0.01.
  float minWeightSum = 0.01f;
  // SVGF §4.1: "if no tap is consistent, try a larger 3x3 filter to find thin geometry".
  bool fallback3x3 = true;
};

// The thresholds as parameters ("depthThreshold", "normalThreshold"), shared by every variant
// that reprojects (ParamTable::include); reprojectionParams().defaults() for a block on its own.
const ParamTable<ReprojectionSettings>& reprojectionParams();

enum class ReprojectionFootprint : uint8_t {
  Disoccluded = 0,  // no consistent tap: the history is discarded
  Bilinear2x2 = 1,  // taps (x0 + k % 2, y0 + k / 2), k = 0..3, bilinear weights renormalised
  Box3x3 = 2,       // taps (x0 + k % 3, y0 + k / 3), k = 0..8, consistent taps averaged
};

// Where one pixel's history comes from in the previous frame (28 bytes).
struct ReprojectionRecord {
  int32_t x0 = 0, y0 = 0;  // top-left tap of the footprint, previous-frame pixels
  uint16_t mask = 0;       // bit k: tap k passed every test and is read
  ReprojectionFootprint footprint = ReprojectionFootprint::Disoccluded;
  float weights[4] = {0, 0, 0, 0};  // 2x2: normalised weight of tap k; 3x3: weights[0] = 1/count
};

// One pixel's history taps as (index, weight) pairs, decoded once from its record and then
// applied to any number of previous-frame planes (accumulation reads colour, moments and history
// length through the same taps). apply() rounds exactly as Reprojection::sample().
struct HistoryTaps {
  int count = 0;              // taps read; 0 when disoccluded (apply() gives 0)
  bool average = false;       // Box3x3: the taps are summed, then scaled by 1/count
  float averageScale = 0.0f;  // 1/count for Box3x3
  size_t index[9];            // only the first `count` are set
  float weight[4];            // Bilinear2x2: each tap's normalised weight

  HistoryTaps() = default;  // no taps: apply() gives 0
  HistoryTaps(const ReprojectionRecord& record, int width) {
    const size_t w = size_t(width);
    switch (record.footprint) {
      case ReprojectionFootprint::Disoccluded:
        return;
      case ReprojectionFootprint::Bilinear2x2:
        for (int k = 0; k < 4; ++k)
          if ((record.mask >> k) & 1u) {
            index[count] = size_t(record.y0 + k / 2) * w + size_t(record.x0 + k % 2);
            weight[count++] = record.weights[k];
          }
        return;
      case ReprojectionFootprint::Box3x3:
        average = true;
        averageScale = record.weights[0];
        for (int k = 0; k < 9; ++k)
          if ((record.mask >> k) & 1u)
            index[count++] = size_t(record.y0 + k / 3) * w + size_t(record.x0 + k % 3);
        return;
    }
  }
  float apply(const float* plane) const {
    float sum = 0;
    if (average) {
      for (int k = 0; k < count; ++k) sum += plane[index[k]];
      return sum * averageScale;
    }
    for (int k = 0; k < count; ++k) sum += weight[k] * plane[index[k]];
    return sum;
  }
};

// Eight consecutive pixels' history taps, decoded once and applied to several planes eight lanes
// at a time (gathers); per lane, apply() rounds exactly as HistoryTaps::apply(). The 2x2
// footprints are read in lanes; a lane with the 3x3 box (rare: thin geometry) is read through
// its HistoryTaps.
struct HistoryLanes {
  LaneMask8 valid{}, box{};
  LaneMask8 index[4]{}, use[4]{};
  Lanes8 weight[4]{};
  const ReprojectionRecord* boxRecords = nullptr;  // lane 0's record, when some lane is a box
  int width = 0;

  // The 2x2 footprints of eight consecutive records (of either reprojection), read with gathers:
  // each record is `stride` int32 with x0, y0 at fields 0 and 1, the tap mask in the low
  // `maskBits` of field 2, the four weights from field `weightsField`; `bilinear` says which
  // lanes have the 2x2 footprint (lanes past the row's end must not).
  void gatherBilinear(const void* records, int stride, int maskBits, int weightsField,
                      LaneMask8 bilinear) {
    const int32_t* fields = static_cast<const int32_t*>(records);
    const LaneMask8 record = laneIndex(Lanes8{}) * stride;
    const LaneMask8 x0 = gatherIntLanes(fields, record, bilinear);
    const LaneMask8 y0 = gatherIntLanes(fields, record + 1, bilinear);
    const LaneMask8 mask = gatherIntLanes(fields, record + 2, bilinear) & ((1 << maskBits) - 1);
    valid |= bilinear;
    for (int k = 0; k < 4; ++k) {
      use[k] = bilinear & (((mask >> k) & 1) != 0);
      index[k] = (y0 + k / 2) * width + x0 + k % 2;
      weight[k] =
          gatherLanes(reinterpret_cast<const float*>(fields), record + weightsField + k, use[k]);
    }
  }
  Lanes8 apply(const float* plane) const {
    Lanes8 sum{};
    for (int k = 0; k < 4; ++k) sum += weight[k] * gatherLanes(plane, index[k], use[k]);
    if (boxRecords)
      for (int lane = 0; lane < 8; ++lane)
        if (box[lane]) sum[lane] = HistoryTaps(boxRecords[lane], width).apply(plane);
    return sum;
  }
};

class Reprojection {
 public:
  void setup(int width, int height);

  // Decides every pixel's history taps. `current`: depth, normal, meshId, motion (position
  // optional); `derivatives` from computeGeometryDerivatives(current); `previous`: the previous
  // frame's depth, normal, meshId. When both cameras and the position layer are given, the
  // depth test compares with the depth this surface point had in the previous view,
  //   z + previousCamera.viewDepth(x) - camera.viewDepth(x),
  // the quantity Falcor tests (its G-buffer stores the previous clip-space depth); without them
  // it compares with the current depth, which a camera moving along its axis breaks.
  void compute(const GBufferView& current, const Image& derivatives, const GBufferView& previous,
               const ReprojectionSettings& settings, const CameraState* camera = nullptr,
               const CameraState* previousCamera = nullptr);
  // First frame or camera cut: every pixel is a disocclusion.
  void invalidateAll();

  bool valid(size_t i) const { return records_[i].footprint != ReprojectionFootprint::Disoccluded; }
  const ReprojectionRecord& record(size_t i) const { return records_[i]; }

  // Pixels i .. i + count - 1 (count <= 8) as lanes.
  HistoryLanes lanes(size_t i, int count) const;
  // The history value of pixel i from one plane of a previous-frame image; 0 when disoccluded.
  float sample(size_t i, const float* historyPlane) const;
  // Every channel of `history` resampled into `out` (same shape); `fillDisoccluded` elsewhere.
  void resample(const Image& history, Image& out, float fillDisoccluded = 0.0f) const;

  // Previous-frame taps tested per pixel in the last compute() (4, plus 9 where the 3x3 ran).
  double testedTapsPerPixel() const { return testedTaps_.perPixel(records_.size()); }
  // Taps one resample reads per pixel, averaged over the image.
  double readTapsPerPixel() const { return readTaps_.perPixel(records_.size()); }
  double validFraction() const;

  int width() const { return width_; }
  int height() const { return height_; }

 private:
  int width_ = 0, height_ = 0;
  std::vector<ReprojectionRecord> records_;
  RowTapCounter testedTaps_, readTaps_;
};

}  // namespace arena
