#pragma once
// Hit-point ("virtual motion") reprojection for glossy and mirror reflections (the CEDEC 2021
// talk p. "4.2.2 Hit Point Reprojection"; NRD's virtual motion; AMD's parallax): the reflection
// seen at a pixel behaves like an object *behind* the mirror, at the primary ray extended by the
// reflected ray's length,
//   virtual = eye + dir * (|x - eye| + specHitDist),   dir = (x - eye) / |x - eye|,
// so projecting that virtual point with the previous camera finds where the reflection was last
// frame, where surface motion vectors leave it glued to the floor. A miss (specHitDist 1e6) puts
// the point at near-infinity (a sky reflection moves like the sky); 0 (sky, lights) gives the
// surface point itself. Validity: each of the 2x2 bilinear taps at the previous pixel must show
// the same surface in the previous frame's G-buffer -- same mesh id, similar normal, and on the
// tangent plane of the current surface point (the previous position rebuilt from the previous
// camera and depth). Motion of the mirror itself is not modelled (the talk's form).
#include <cstdint>
#include <string>
#include <vector>

#include "core/camera.hpp"
#include "core/image.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/param_table.hpp"

namespace arena {

struct HitPointReprojectionSettings {
  // A tap is on the same surface when |n.(x_prev(q) - x)| <= planeThreshold * z (ours, 2 %
  // of the view depth) ...
  float planeThreshold = 0.02f;
  // ... and n.n_prev >= normalThreshold (ours, about 18 degrees).
  float normalThreshold = 0.95f;
  // Falcor-style: the consistent bilinear weight must sum to at least this.
  float minWeightSum = 0.01f;
};

// The "hitDistance" parameter (sampled | mirror) of the variants that reproject by hit point: the
// channel their specular guides read, "specHitDist" (the 1-spp sample's ray length) or
// "specHitDistMirror" (the noise-free mirror ray, an oracle).
const ParamTable<std::string>& hitDistanceParams();

// The virtual point of a surface point x seen from `camera` with reflected-ray length hitDist.
glm::vec3 virtualHitPoint(const CameraState& camera, glm::vec3 surface, float hitDist);

class HitPointReprojection {
 public:
  void setup(int width, int height);
  // Decides every pixel's taps from the current G-buffer (depth, normal, meshId, position), its
  // specHitDist plane, both cameras and the previous frame's G-buffer (depth, normal, meshId).
  void compute(const GBufferView& current, const float* hitDistance, const CameraState& camera,
               const CameraState& previousCamera, const GBufferView& previous,
               const HitPointReprojectionSettings& settings);
  void invalidateAll();

  bool valid(size_t i) const { return records_[i].mask != 0; }
  // The history value of pixel i from one plane of a previous-frame image; 0 when invalid.
  float sample(size_t i, const float* historyPlane) const;
  // Pixel i's taps decoded once, for several planes; apply() rounds exactly as sample().
  HistoryTaps taps(size_t i) const;
  // Pixels i .. i + count - 1 (count <= 8) as lanes.
  HistoryLanes lanes(size_t i, int count) const;
  // Continuous previous-frame pixel position of pixel i's virtual point (valid or not).
  float previousX(size_t i) const { return records_[i].px; }
  float previousY(size_t i) const { return records_[i].py; }
  double validFraction() const;

 private:
  struct Record {
    int32_t x0 = 0, y0 = 0;
    uint8_t mask = 0;
    float px = 0, py = 0;
    float weights[4] = {0, 0, 0, 0};
  };
  int width_ = 0, height_ = 0;
  std::vector<Record> records_;
};

}  // namespace arena
