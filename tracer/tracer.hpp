#pragma once
// The Embree path tracer: pinhole primary rays through pixel centres (a noise-free G-buffer, as
// SVGF assumes), next-event estimation with MIS, Lambert diffuse + GGX specular, Russian roulette.
// The first vertex splits its contribution into a diffuse and a specular signal so denoisers can
// filter them separately.
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <vector>

#include "core/image.hpp"
#include "tracer/sampler.hpp"
#include "tracer/scene.hpp"
#include "tracer/scene_state.hpp"

namespace arena {

// A colour's luminance (core/image.hpp's weights), as the tracer weighs lobes and gradients.
inline float luminanceOf(glm::vec3 c) {
  return luminance(c.x, c.y, c.z);
}

// Embree device; one per process is enough. `config` is Embree's device configuration (a test
// pins the kernels' ISA with "isa=sse2" to show that hits do not depend on it).
class EmbreeDevice {
 public:
  explicit EmbreeDevice(const char* config = "verbose=0");
  ~EmbreeDevice();
  EmbreeDevice(const EmbreeDevice&) = delete;
  EmbreeDevice& operator=(const EmbreeDevice&) = delete;
  RTCDevice get() const { return device_; }

 private:
  RTCDevice device_;
};

// Everything a shading routine knows about a surface point.
struct SurfaceHit {
  int meshId = -1, primId = -1;
  float u = 0, v = 0;
  glm::vec3 position{0}, geometricNormal{0, 1, 0}, shadingNormal{0, 1, 0};
  int materialId = -1;  // -1 for lights
  int lightIndex = -1;  // >= 0 when the surface is a scene light
  glm::vec3 baseColor{0}, emission{0};
  float roughness = 1, metallic = 0, specularF0 = 0.04f;

  glm::vec3 diffuseAlbedo() const { return baseColor * (1.0f - metallic); }
  glm::vec3 f0() const { return glm::mix(glm::vec3(specularF0), baseColor, metallic); }
};

// A path vertex's BSDF (Lambert diffuse + GGX specular) seen from wo, with everything that does
// not depend on the incident direction computed once: a vertex evaluates its BSDF twice (towards
// the light sample and towards the sampled direction) and samples it once, and a reference's first
// vertex is shaded hundreds of times. The terms are the same operations on the same values as
// computing them at every call, so the numbers are the same bits.
struct VertexBsdf {
  glm::vec3 wo{0, 0, 1};
  glm::vec3 n{0, 0, 1}, ng{0, 0, 1};  // oriented towards wo (the shading normal falls back to ng)
  glm::vec3 origin{0};                // where the vertex's rays leave: the position lifted along ng
  glm::vec3 t{1, 0, 0}, b{0, 1, 0};   // an orthonormal basis around n (sampling)
  glm::vec3 diffuseOverPi{0};         // the Lambert lobe, diffuse albedo / pi
  glm::vec3 f0{0}, oneMinusF0{1};     // Schlick's Fresnel terms
  float NoV = 1;
  float a2 = 1;           // GGX alpha^2
  float G1V = 0;          // Smith's masking towards wo (0 where NoV <= 0)
  float pSpec = 0;        // the probability of sampling the specular lobe
  bool specular = false;  // f0 > 0 in some channel
  bool reflects = false;  // false for emitters and surfaces with neither lobe: no path leaves
};

// Specular albedo used for demodulation: the GGX directional albedo, Karis' analytic fit of the
// pre-integrated split-sum term ("Physically Based Shading on Mobile", 2014). Ours: any smooth,
// strictly positive estimate works for demodulation; this one tracks roughness and view angle.
glm::vec3 specularAlbedo(glm::vec3 f0, float roughness, float NoV);
// The probability that a path samples the specular lobe, from the luminances of the two lobes'
// albedos: 0 without specular, 1 without diffuse, else in proportion, within [0.1, 0.9].
float specularLobeProbability(float diffuseAlbedo, float specularAlbedo);

// A guide into a non-decreasing table of cumulative sums (a light's triangle areas): lowerBound
// gives std::lower_bound's answer, the first entry >= target, starting from the entry the target's
// bucket points at, in a step or two instead of a binary search (a sphere light has 2208
// triangles, searched once per light sample).
class CdfGuide {
 public:
  CdfGuide() = default;
  explicit CdfGuide(const std::vector<float>& cdf);
  size_t lowerBound(const std::vector<float>& cdf, float target) const {
    // A quad light's two triangles: a plain search is cheaper than the guide's arithmetic.
    if (first_.size() <= 8 || cdf.size() != first_.size())
      return size_t(std::lower_bound(cdf.begin(), cdf.end(), target) - cdf.begin());
    return guided(cdf, target);
  }

 private:
  size_t guided(const std::vector<float>& cdf, float target) const;
  float total_ = 0;
  std::vector<float> low_;        // bucket b covers [low_[b], low_[b + 1]): b x total / N
  std::vector<uint32_t> first_;   // the first entry >= low_[b]
};

// What a pass traced. `rays` counts every ray; `occlusionRays` those of them that only ask whether
// a segment is blocked (Embree's rtcOccluded, which stops at any hit: shadow rays to area lights,
// the joins of bidirectional references, the gradient samples' visibility); the rest find the
// closest hit. Embree spends less on an occlusion ray than on a closest-hit one, so the mix tells
// how a rate in Mrays/s compares with another tracer's.
struct RayCounts {
  uint64_t rays = 0, occlusionRays = 0, paths = 0;
  RayCounts& operator+=(const RayCounts& o) {
    rays += o.rays;
    occlusionRays += o.occlusionRays;
    paths += o.paths;
    return *this;
  }
};

// One animation state built into an Embree scene.
class FrameScene {
 public:
  FrameScene(const EmbreeDevice& device, const Scene& scene, const std::vector<MeshData>& meshes,
             const SceneState& state);
  ~FrameScene();
  FrameScene(const FrameScene&) = delete;
  FrameScene& operator=(const FrameScene&) = delete;

  const SceneState& state() const { return state_; }
  const Scene& scene() const { return scene_; }

  // Closest hit; fills meshId/primId/u/v and returns true on a hit.
  bool intersect(glm::vec3 origin, glm::vec3 dir, float tmax, SurfaceHit& hit, float& t, bool coherent = false) const;
  bool occluded(glm::vec3 origin, glm::vec3 dir, float tmax) const;
  // Surface attributes from (mesh, primitive, barycentrics): a pure function of the state, so
  // a point is shaded bit-identically whichever way it was found (ray or forward projection).
  SurfaceHit surface(int meshId, int primId, float u, float v) const;
  // World position of (mesh, primitive, barycentrics) in this state.
  glm::vec3 positionOf(int meshId, int primId, float u, float v) const;
  glm::vec3 sky(glm::vec3 dir) const;
  // The random dimensions a path of this scene can use (its vertices' 8 each, tracer.cpp): a
  // Sobol replicate hashes them once (Sampler::withHashes).
  uint32_t pathDimensions() const;
  // The eye path's share of them (a bidirectional reference's light path reads the rest).
  uint32_t eyePathDimensions() const;
  // The Sobol dimensions a path reads, for a batch of samples (Sampler::fillBatch): at each vertex
  // that samples, the light point's pair and the direction's pair; from the third on, roulette.
  Sampler::Reads sobolReads() const;

  struct Radiance {
    glm::vec3 diffuse{0}, specular{0};  // radiance reflected by the first vertex, not demodulated
    // Length of this sample's first continuation ray, whichever lobe it sampled (for a
    // dielectric mostly the diffuse one): infinity on a miss, 0 where no ray left the surface.
    // The specHitDist channel is specularHitDistance(), not this.
    float hitDistance = 0;
    // Sum over the diffuse signal's first-vertex contributions of luminance x incident direction
    // (the low-resolution buffer's "average direction", CAPCOM 2023 slide 21).
    glm::vec3 diffuseDirection{0};
  };
  // What a path's first vertex knows before its first random number: the surface and its BSDF
  // seen from the eye (wo, both normals turned towards it, the specular lobe's probability). A
  // reference shades hundreds of samples from one primary hit, so it prepares the vertex once per
  // pixel; shading a prepared vertex gives the same bits as shading the hit itself.
  struct PrimaryVertex {
    SurfaceHit hit;
    VertexBsdf bsdf;
  };
  PrimaryVertex prepare(const SurfaceHit& hit, glm::vec3 wo) const;
  // One path sample starting at the primary surface `hit` seen from direction wo (towards the eye).
  // Emission of `hit` itself is not included (it is the emission channel).
  Radiance shade(const SurfaceHit& hit, glm::vec3 wo, const Sampler& sampler, RayCounts& counts) const {
    return shade(prepare(hit, wo), sampler, counts);
  }
  Radiance shade(const PrimaryVertex& vertex, const Sampler& sampler, RayCounts& counts) const;
  // `count` (at most Sampler::kBatchLanes) path samples from one prepared vertex, out[l] from
  // samplers[l], as shade(vertex, samplers[l]) gives them: their first vertex's choices are made
  // for the whole batch, whose shadow rays Embree then traces as one packet (rtcOccluded16; a
  // reference's pixel loop; where Embree reports an error for the packet, one ray at a time).
  // Embree's packet and single-ray kernels are different code, which could disagree on a shadow
  // ray that grazes an edge or ends at a surface; the twelve scenes' references and frames gave
  // the same bits, and a test compares every lane with shade() under Embree's AVX-512, AVX2 and
  // SSE2 kernels.
  void shadeBatch(const PrimaryVertex& vertex, const Sampler* samplers, int count, Radiance* out,
                  RayCounts& counts) const;
  // The specular lobe's hit distance at a prepared primary vertex, from a ray of its own: one
  // GGX sample (the mirror direction where the sample falls below the surface), the way a
  // real-time tracer traces its specular rays separately from its diffuse ones (CAPCOM 2023
  // slide 42: "Tracing Diffuse" / "Tracing Specular"; NRD's specular hit distance input).
  // Infinity on a miss; 0 for an emitter. Its random numbers are dimensions no path uses.
  float specularHitDistance(const PrimaryVertex& vertex, const Sampler& sampler,
                            RayCounts& counts) const;

 private:
  struct Geometry {
    std::vector<glm::vec3> positions, normals;
    std::vector<glm::vec3> faceNormals;  // per triangle, world space
    const MeshData* local = nullptr;
    int materialId = -1, lightIndex = -1;
    glm::vec3 lightRadiance{0};
    std::vector<float> areaCdf;  // lights: cumulative triangle areas
    CdfGuide areaGuide;          // into areaCdf
    float area = 0;
    // Sphere lights: the sphere around the light's origin that holds its mesh. From outside it the
    // light is sampled by the solid angle of that sphere (sampleLight), not by area.
    bool sampledByCone = false;
    glm::vec3 coneCenter{0};
    float coneRadius2 = 0;
  };
  struct VertexSample;  // a sample's choices at a vertex before it traces (tracer.cpp)
  // A bidirectional reference's sample (scenes with "reference_estimator": "bidirectional";
  // tracer.cpp): the eye path from the prepared vertex, one light path, every join between them.
  Radiance shadeBidirectional(const PrimaryVertex& vertex, const Sampler& sampler,
                              RayCounts& counts) const;
  double bidirectionalWeight(int used, int k, const SurfaceHit* const* z,
                             const VertexBsdf& primary) const;
  VertexSample sampleVertex(const SurfaceHit& s, const VertexBsdf& v, const Sampler& sampler,
                            uint32_t dim) const;
  void chooseAtVertex(const SurfaceHit& s, const VertexBsdf& v, const Sampler& sampler,
                      uint32_t dim, VertexSample& out) const;
  Radiance shade(const PrimaryVertex& vertex, const VertexSample& first, const Sampler& sampler,
                 RayCounts& counts) const;
  // A light sample from `at`, whose rays leave `origin`: radiance, direction, pdf (solid angle)
  // and how its visibility is decided (LightSample in tracer.cpp).
  struct LightSample;
  LightSample sampleLight(const SurfaceHit& at, glm::vec3 origin, const Sampler& s,
                          uint32_t dim) const;
  // The pdf (solid angle) with which sampleLight at the vertex `from`, whose rays leave `origin`,
  // would have chosen the ray along `dir` that hit the light at lightHit.
  float lightPdf(const SurfaceHit& lightHit, glm::vec3 from, glm::vec3 origin, glm::vec3 dir) const;
  struct Cone;  // a sphere light's cone seen from a ray origin (tracer.cpp)
  bool coneSeenFrom(const Geometry& g, glm::vec3 origin, Cone& cone) const;
  bool reachesLight(glm::vec3 origin, glm::vec3 dir, int lightMesh) const;
  // The hit's (t, u, v) recomputed from its triangle, the same bits on every CPU (tracer.cpp).
  void exactHit(glm::vec3 origin, glm::vec3 dir, SurfaceHit& hit, float& t) const;

  const Scene& scene_;
  SceneState state_;
  RTCDevice device_ = nullptr;  // the device's errors, read after a packet (shadeBatch)
  RTCScene rtcScene_ = nullptr;
  std::vector<Geometry> geometries_;
  std::vector<int> selectableLights_;  // meshIds of lights with an area (radiance 0 included)
};

}  // namespace arena
