#include "denoisers/common/gbuffer.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "denoisers/common/gpu_traffic.hpp"
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
  parallelCopy(current.depth, n, depth_.plane(0));
  parallelCopy(current.meshId, n, meshId_.plane(0));
  for (int c = 0; c < 3; ++c) parallelCopy(current.normal[size_t(c)], n, normal_.plane(c));
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
  if (derivatives.width() != w || derivatives.height() != h ||
      derivatives.channels() != kGeometryDerivativeChannels)
    throw Error("computeGeometryDerivatives: the output must be 3 channels of the G-buffer's size");
  if (gpu::recording()) {  // the pixel and its four axis neighbours
    using namespace gpu_buffers;
    gpu::dispatch(w, h);
    for (const GpuBuffer& b : {kDepth, kNormal, kMeshId}) gpu::read(b, w, h, 5);
    gpu::write(kDerivatives, w, h);
  }
  float* dzdx = derivatives.plane(kDepthDx);
  float* dzdy = derivatives.plane(kDepthDy);
  float* normalFwidth = derivatives.plane(kNormalFwidth);

  // One-sided differences of depth and normal from p towards q (q = p +- step), eight pixels at
  // a time; a neighbour off the image, in the sky or on another mesh does not exist.
  struct Difference {
    LaneMask8 exists;
    Lanes8 dz, dn[3];
    Lanes8 size() const {  // |dz| + |dn|, what "smaller" compares
      return absFloat(dz) + sqrtLanes(dn[0] * dn[0] + dn[1] * dn[1] + dn[2] * dn[2]);
    }
  };
  struct Centre {
    size_t p;
    LaneMask8 inRow;
    Lanes8 id, z, n[3];
  };
  auto difference = [&](const Centre& c, std::ptrdiff_t step, LaneMask8 inside, float sign) {
    Difference d;
    const size_t q = c.p + size_t(step);
    d.exists = inside & (loadLanes(g.meshId + q, inside) == c.id);
    d.dz = selectFloat(d.exists, sign * (loadLanes(g.depth + q, inside) - c.z), Lanes8{});
    for (size_t k = 0; k < 3; ++k)
      d.dn[k] =
          selectFloat(d.exists, sign * (loadLanes(g.normal[k] + q, inside) - c.n[k]), Lanes8{});
    return d;
  };
  // The smaller of the two that exist (the forward one on a tie); zero where neither does.
  auto smaller = [](const Difference& a, const Difference& b) {
    const LaneMask8 useA = a.exists & (~b.exists | (a.size() <= b.size()));
    Difference d;
    d.exists = a.exists | b.exists;
    d.dz = selectFloat(useA, a.dz, b.dz);
    for (size_t k = 0; k < 3; ++k) d.dn[k] = selectFloat(useA, a.dn[k], b.dn[k]);
    return d;
  };

  parallelRows(h, [&](int y) {
    const LaneMask8 all = LaneMask8{} - 1;
    for (int x0 = 0; x0 < w; x0 += 8) {
      Centre c;
      c.p = size_t(y) * size_t(w) + size_t(x0);
      const LaneMask8 x = laneIndex(Lanes8{}) + x0;
      c.inRow = x < w;
      c.id = loadLanes(g.meshId + c.p, c.inRow);
      c.z = loadLanes(g.depth + c.p, c.inRow);
      for (size_t k = 0; k < 3; ++k) c.n[k] = loadLanes(g.normal[k] + c.p, c.inRow);
      const Difference dx = smaller(difference(c, 1, c.inRow & (x + 1 < w), 1.0f),
                                    difference(c, -1, c.inRow & (x > 0), -1.0f));
      const Difference dy =
          smaller(difference(c, w, c.inRow & (y + 1 < h ? all : LaneMask8{}), 1.0f),
                  difference(c, -w, c.inRow & (y > 0 ? all : LaneMask8{}), -1.0f));
      const LaneMask8 sky = c.id < 0.0f;
      Lanes8 f[3];
      for (size_t k = 0; k < 3; ++k) f[k] = absFloat(dx.dn[k]) + absFloat(dy.dn[k]);
      const Lanes8 fwidth = sqrtLanes(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
      storeLanes(dzdx + c.p, selectFloat(sky, Lanes8{}, dx.dz), c.inRow);
      storeLanes(dzdy + c.p, selectFloat(sky, Lanes8{}, dy.dz), c.inRow);
      storeLanes(normalFwidth + c.p, selectFloat(sky, Lanes8{}, fwidth), c.inRow);
    }
  });
}

}  // namespace arena
