#include "denoisers/common/gbuffer.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "denoisers/common/parallel.hpp"

namespace arena {

namespace {

struct LayerShape {
  const char* name;
  int channels;
};
constexpr LayerShape kGuideLayers[] = {
    {"depth", 1}, {"normal", 3}, {"meshId", 1}, {"motion", 2}, {"position", 3}};

}  // namespace

GBufferView GBufferView::fromFrame(const LayerSet& frame, const std::vector<std::string>& required,
                                   const std::string& owner) {
  GBufferView view;
  bool first = true;
  for (const LayerShape& shape : kGuideLayers) {
    bool needed = std::find(required.begin(), required.end(), shape.name) != required.end();
    if (!frame.has(shape.name)) {
      if (needed) frame.get(shape.name, owner);  // throws, naming the layer and the denoiser
      continue;
    }
    const Image& image = frame.get(shape.name, owner);
    if (image.channels() != shape.channels)
      throw Error(owner + ": layer '" + shape.name + "' has " + std::to_string(image.channels()) +
                  " channels, expected " + std::to_string(shape.channels));
    if (first) {
      view.width = image.width();
      view.height = image.height();
      first = false;
    } else if (image.width() != view.width || image.height() != view.height) {
      throw Error(owner + ": layer '" + shape.name + "' is " + std::to_string(image.width()) + "x" +
                  std::to_string(image.height()) + ", the other layers " +
                  std::to_string(view.width) + "x" + std::to_string(view.height));
    }
    std::string name = shape.name;
    if (name == "depth") view.depth = image.plane(0);
    if (name == "meshId") view.meshId = image.plane(0);
    for (int c = 0; c < 3 && name == "normal"; ++c) view.normal[size_t(c)] = image.plane(c);
    for (int c = 0; c < 2 && name == "motion"; ++c) view.motion[size_t(c)] = image.plane(c);
    for (int c = 0; c < 3 && name == "position"; ++c) view.position[size_t(c)] = image.plane(c);
  }
  return view;
}

void GBufferHistory::setup(int width, int height) {
  depth_ = Image(width, height, 1);
  normal_ = Image(width, height, 3);
  meshId_ = Image(width, height, 1, -1.0f);
}

void GBufferHistory::store(const GBufferView& current) {
  if (current.width != depth_.width() || current.height != depth_.height())
    throw Error("G-buffer history: frame is " + std::to_string(current.width) + "x" +
                std::to_string(current.height) + " but setup() was for " +
                std::to_string(depth_.width()) + "x" + std::to_string(depth_.height()));
  size_t n = current.pixelCount();
  std::copy_n(current.depth, n, depth_.plane(0));
  std::copy_n(current.meshId, n, meshId_.plane(0));
  for (int c = 0; c < 3; ++c) std::copy_n(current.normal[size_t(c)], n, normal_.plane(c));
}

GBufferView GBufferHistory::view() const {
  GBufferView v;
  v.width = depth_.width();
  v.height = depth_.height();
  v.depth = depth_.plane(0);
  v.meshId = meshId_.plane(0);
  for (int c = 0; c < 3; ++c) v.normal[size_t(c)] = normal_.plane(c);
  return v;
}

void computeGeometryDerivatives(const GBufferView& g, Image& derivatives) {
  if (!g.depth || !g.normal[0] || !g.meshId)
    throw Error("computeGeometryDerivatives: needs the depth, normal and meshId layers");
  const int w = g.width, h = g.height;
  float* dzdx = derivatives.plane(kDepthDx);
  float* dzdy = derivatives.plane(kDepthDy);
  float* normalFwidth = derivatives.plane(kNormalFwidth);

  // One-sided differences of depth and normal from p towards q (q = p +- step); a neighbour off
  // the image, in the sky or on another mesh does not count.
  struct Difference {
    bool exists = false;
    float dz = 0, dn[3] = {0, 0, 0};
    float normalLength() const { return std::sqrt(dn[0] * dn[0] + dn[1] * dn[1] + dn[2] * dn[2]); }
  };
  auto difference = [&](size_t p, size_t q, float sign) {
    Difference d;
    if (g.meshId[q] != g.meshId[p]) return d;
    d.exists = true;
    d.dz = sign * (g.depth[q] - g.depth[p]);
    for (size_t c = 0; c < 3; ++c) d.dn[c] = sign * (g.normal[c][q] - g.normal[c][p]);
    return d;
  };
  auto smaller = [](const Difference& a, const Difference& b) {
    if (!a.exists) return b;
    if (!b.exists) return a;
    return std::abs(a.dz) + a.normalLength() <= std::abs(b.dz) + b.normalLength() ? a : b;
  };

  parallelRows(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      size_t p = size_t(y) * size_t(w) + size_t(x);
      if (g.isSky(p)) {
        dzdx[p] = dzdy[p] = normalFwidth[p] = 0.0f;
        continue;
      }
      Difference none;
      Difference dx = smaller(x + 1 < w ? difference(p, p + 1, 1.0f) : none,
                              x > 0 ? difference(p, p - 1, -1.0f) : none);
      Difference dy = smaller(y + 1 < h ? difference(p, p + size_t(w), 1.0f) : none,
                              y > 0 ? difference(p, p - size_t(w), -1.0f) : none);
      dzdx[p] = dx.dz;
      dzdy[p] = dy.dz;
      float f[3];
      for (size_t c = 0; c < 3; ++c) f[c] = std::abs(dx.dn[c]) + std::abs(dy.dn[c]);
      normalFwidth[p] = std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    }
  });
}

}  // namespace arena
