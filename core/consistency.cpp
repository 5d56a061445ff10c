#include "core/consistency.hpp"

#include <algorithm>

namespace arena {

SurfaceDerivatives surfaceDerivatives(const Image& depth, const Image& normal, const Image& meshId, int x, int y) {
  const int w = depth.width(), h = depth.height();
  const int id = int(meshId.at(x, y));
  auto n = [&](int px, int py) { return glm::vec3(normal.at(px, py, 0), normal.at(px, py, 1), normal.at(px, py, 2)); };
  SurfaceDerivatives d;
  // Per axis, the smaller one-sided difference to a neighbour on the same mesh (a forward or backward
  // difference across a silhouette would make the test accept anything there).
  auto axis = [&](int dx, int dy) {
    float bestZ = -1, bestN = -1;
    for (int s : {-1, 1}) {
      int px = x + s * dx, py = y + s * dy;
      if (px < 0 || py < 0 || px >= w || py >= h || int(meshId.at(px, py)) != id) continue;
      float dz = std::abs(depth.at(px, py) - depth.at(x, y));
      float dn = glm::length(n(px, py) - n(x, y));
      bestZ = bestZ < 0 ? dz : std::min(bestZ, dz);
      bestN = bestN < 0 ? dn : std::min(bestN, dn);
    }
    d.depth += std::max(bestZ, 0.0f);
    d.normal += std::max(bestN, 0.0f);
  };
  axis(1, 0);
  axis(0, 1);
  return d;
}

}  // namespace arena
