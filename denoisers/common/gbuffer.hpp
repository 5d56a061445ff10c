#pragma once
// The noise-free G-buffer a filter guides itself with: read-only views of the frame's planes, the
// copy of the previous frame's depth/normal/meshId that SVGF keeps in its history (SVGF §4: "our
// history buffer holds ... the depth, normals and mesh ids of the previous frame"), and the
// screen-space derivatives that reprojection (fwidth) and the depth edge-stopping term need.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "core/exr_io.hpp"
#include "core/fast_math.hpp"
#include "core/image.hpp"

namespace arena {

// Planes of one frame's G-buffer, or nullptr where a layer was not requested and is absent.
// Layer names and meanings are those of core/sequence.hpp.
struct GBufferView {
  int width = 0, height = 0;
  const float* depth = nullptr;            // linear view depth; 0 for sky
  std::array<const float*, 3> normal{};    // world shading normal, facing the viewer
  const float* meshId = nullptr;           // object index; -1 for sky
  std::array<const float*, 2> motion{};    // previous-frame position minus pixel centre, pixels
  std::array<const float*, 3> position{};  // world position

  // Views `frame`'s layers. Every layer in `required` must be present with the expected channel
  // count (an Error names `owner` and the layer); the others are viewed when present.
  static GBufferView fromFrame(const LayerSet& frame, const std::vector<std::string>& required,
                               const std::string& owner);

  size_t pixelCount() const { return size_t(width) * size_t(height); }
  // Sky pixels carry no surface: filters never gather from them nor reproject them.
  bool isSky(size_t i) const { return meshId != nullptr && meshId[i] < 0.0f; }
  float normalDot(size_t p, size_t q) const {
    return normal[0][p] * normal[0][q] + normal[1][p] * normal[1][q] + normal[2][p] * normal[2][q];
  }
};

// The previous frame's depth, normal and meshId, copied without allocation after setup().
class GBufferHistory {
 public:
  void setup(int width, int height);
  void store(const GBufferView& current);
  GBufferView view() const;

 private:
  Image depth_, normal_, meshId_;
};

// Channels of the image computeGeometryDerivatives() fills.
enum GeometryDerivative : int {
  kDepthDx = 0,       // dz/dx, signed, view depth per pixel
  kDepthDy = 1,       // dz/dy
  kNormalFwidth = 2,  // length(|dn/dx| + |dn/dy|), Falcor's fwidth of the normal
  kGeometryDerivativeChannels = 3,
};

// Screen-space derivatives of depth and normal (the CPU counterpart of ddx/ddy). Each direction
// takes the one-sided difference to a neighbour on the same mesh, the smaller of the two when both
// exist, so a silhouette never lends its depth jump to the surface beside it (hardware ddx would
// across a 2x2 quad). Needs depth, normal and meshId; sky pixels get 0.
void computeGeometryDerivatives(const GBufferView& gbuffer, Image& derivatives);

// The depth derivative the reprojection tests use: Falcor's max(|dz/dx|, |dz/dy|)
// (SVGFPackLinearZAndNormal), not HLSL fwidth's sum.
inline float depthFwidth(const Image& derivatives, size_t i) {
  return std::max(std::abs(derivatives.plane(kDepthDx)[i]),
                  std::abs(derivatives.plane(kDepthDy)[i]));
}

// Calls visit(q) for every pixel q of the 3x3 neighbourhood of (x, y) (row-major, centre
// included unless `skipCentre`) that lies inside the w x h image and is not sky in `skyMask`
// (nullptr: no sky test). The one neighbourhood walk of the median, mask blur, anti-firefly and
// stabilisation passes.
template <class Visit>
inline void forEachNeighbour3x3(int x, int y, int w, int h, const GBufferView* skyMask,
                                bool skipCentre, Visit&& visit) {
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int qx = x + dx, qy = y + dy;
      if ((skipCentre && dx == 0 && dy == 0) || qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
      const size_t q = size_t(qy) * size_t(w) + size_t(qx);
      if (skyMask && skyMask->isSky(q)) continue;
      visit(q);
    }
}

// The same neighbourhood for eight pixels (x0 .. x0 + 7, y) at once: for tap j (row-major, the
// centre is j = 4) the index of lane 0's neighbour and the lanes whose neighbour lies inside the
// image and is not sky in `meshId` (nullptr: no sky test; lanes past the row's end have none).
// Loads at offset[j] masked by present[j] read the neighbours of the median, anti-firefly and
// stabilisation passes' lane loops.
struct Neighbourhood3x3Lanes {
  size_t p;  // index of lane 0's pixel
  LaneMask8 inRow;
  size_t offset[9];
  LaneMask8 present[9];
  Neighbourhood3x3Lanes(int x0, int y, int w, int h, const float* meshId) {
    p = size_t(y) * size_t(w) + size_t(x0);
    const LaneMask8 x = laneIndex(Lanes8{}) + x0;
    inRow = x < w;
    for (int j = 0; j < 9; ++j) {
      const int dx = j % 3 - 1, dy = j / 3 - 1;
      const bool rowInside = y + dy >= 0 && y + dy < h;
      offset[j] = p + size_t(std::ptrdiff_t(dy) * w + dx);
      present[j] =
          inRow & (x + dx >= 0) & (x + dx < w) & (rowInside ? LaneMask8{} - 1 : LaneMask8{});
      if (meshId) present[j] &= loadLanes(meshId + offset[j], present[j]) >= 0.0f;
    }
  }
};

}  // namespace arena
