#include "tracer/tracer.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "core/error.hpp"
#include "core/fast_math.hpp"
#include "core/image.hpp"

namespace arena {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;
// Random dimensions used at each path vertex (8 per vertex, fixed order): vertex v (0 = the primary
// hit, v = bounce) uses dimensions 8v + Dim. The light point (kLightU, kLightV) and the scattered
// direction (kDirU, kDirV) are drawn as pairs (Sampler::get2), which the reference sampler
// stratifies jointly (a 2D Sobol net); it derives the light, triangle and lobe choices from the
// pairs' first coordinates (rescaled, see sampleLight and reuseForLobe), so kLightSelect,
// kLightTriangle and kLobe go unused there; roulette is 1D Sobol.
enum Dim : uint32_t { kLightSelect, kLightTriangle, kLightU, kLightV, kLobe, kDirU, kDirV, kRoulette, kDimsPerVertex };
// The specular hit-distance ray's pair (FrameScene::specularHitDistance): far beyond any path
// vertex's dimensions, so the path's numbers, and hence its radiance, are untouched by it.
constexpr uint32_t kSpecularRayDim = 1u << 20;

float maxComponent(glm::vec3 c) { return std::max(c.x, std::max(c.y, c.z)); }

void orthonormalBasis(glm::vec3 n, glm::vec3& t, glm::vec3& b) {
  // Duff et al. 2017, "Building an Orthonormal Basis, Revisited".
  float sign = std::copysign(1.0f, n.z);
  float a = -1.0f / (sign + n.z);
  float bb = n.x * n.y * a;
  t = glm::vec3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
  b = glm::vec3(bb, sign + n.y * n.y * a, -n.y);
}

glm::vec3 offsetOrigin(glm::vec3 p, glm::vec3 n) {
  float scale = 1e-4f * (1.0f + maxComponent(glm::abs(p)));
  return p + n * scale;
}

// A light sample's shadow ray: the segment from the shading point's offset origin to the light
// point lifted off its emitter (sampleLight's shadowEnd). Both ends are offset. A segment from the
// offset origin along the direction seen from the unlifted point, stopped a fixed fraction short
// of the light point (as it was until tracer version 7), ends past the emitter wherever the
// origin's offset points towards the light by more than that fraction of the distance, and the
// emitter then occludes its own sample: surfaces near a light were too dark (hard_light's
// reference by 30%, the ceiling under its sphere light; docs/references.md).
struct Segment {
  glm::vec3 dir;
  float length;
};
Segment shadowSegment(glm::vec3 origin, glm::vec3 end) {
  const glm::vec3 d = end - origin;
  const float length = std::sqrt(glm::dot(d, d));
  return {length > 0 ? d / length : glm::vec3(0, 1, 0), length};
}

// A surface oriented towards the viewer: both normals on the side of wo.
struct Oriented {
  glm::vec3 n, ng;
};
Oriented orient(const SurfaceHit& s, glm::vec3 wo) {
  Oriented o{s.shadingNormal, s.geometricNormal};
  if (glm::dot(o.ng, wo) < 0) {
    o.ng = -o.ng;
    o.n = -o.n;
  }
  if (glm::dot(o.n, wo) <= 1e-4f) o.n = o.ng;  // interpolated normal facing away at a silhouette
  return o;
}

struct Lobes {
  glm::vec3 diffuse{0}, specular{0};  // BRDF values f_d, f_s
  float pdf = 0;                      // mixture pdf of the sampling strategy (solid angle)
  float NoL = 0;                      // the cosine towards wi, dot(n, wi)
};

// A uniform point on the triangle (p0, p1, p2) from u in [0, 1)^2 (the square-root warp).
glm::vec3 uniformPointOnTriangle(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2, glm::vec2 u) {
  const float su = std::sqrt(u.x), b1 = 1.0f - su, b2 = u.y * su;
  return (1.0f - b1 - b2) * p0 + b1 * p1 + b2 * p2;
}

// Mixture sampling weights: specular lobe chosen in proportion to its Fresnel-weighted albedo.
float specularProbability(const SurfaceHit& s, float NoV) {
  return specularLobeProbability(luminanceOf(s.diffuseAlbedo()),
                                 luminanceOf(specularAlbedo(s.f0(), s.roughness, NoV)));
}

float ggxAlpha(float roughness) { return std::max(roughness * roughness, 1e-3f); }

// Smith's separable masking for GGX (alpha^2 = a2) at cosine x.
float smithG1(float a2, float x) {
  return 2.0f * x / (x + std::sqrt(a2 + (1.0f - a2) * x * x));
}

// The BSDF of surface s seen from wo (towards the previous vertex), its direction-free terms
// computed once (VertexBsdf).
VertexBsdf vertexBsdf(const SurfaceHit& s, glm::vec3 wo) {
  VertexBsdf v;
  v.wo = wo;
  const Oriented o = orient(s, wo);
  v.n = o.n;
  v.ng = o.ng;
  v.origin = offsetOrigin(s.position, o.ng);
  v.NoV = glm::dot(o.n, wo);
  v.pSpec = specularProbability(s, v.NoV);
  const glm::vec3 diffuseAlbedo = s.diffuseAlbedo();
  v.reflects = !(v.pSpec <= 0 && maxComponent(diffuseAlbedo) <= 0);
  orthonormalBasis(v.n, v.t, v.b);
  v.diffuseOverPi = diffuseAlbedo / kPi;
  v.f0 = s.f0();
  v.oneMinusF0 = 1.0f - v.f0;
  v.specular = maxComponent(v.f0) > 0;
  const float alpha = ggxAlpha(s.roughness);
  v.a2 = alpha * alpha;
  v.G1V = !(v.NoV <= 0) ? smithG1(v.a2, v.NoV) : 0.0f;  // evaluate() reads it where !(NoV <= 0)
  return v;
}

Lobes evaluate(const VertexBsdf& v, glm::vec3 wi) {
  Lobes out;
  const float NoL = glm::dot(v.n, wi), NoV = v.NoV;
  out.NoL = NoL;
  if (NoL <= 0 || NoV <= 0) return out;
  out.diffuse = v.diffuseOverPi;
  float pdfDiffuse = NoL / kPi, pdfSpecular = 0;
  if (v.specular) {
    const glm::vec3 h = glm::normalize(v.wo + wi);
    const float NoH = std::max(glm::dot(v.n, h), 0.0f), VoH = std::max(glm::dot(v.wo, h), 1e-6f);
    const float a2 = v.a2;
    const float dd = NoH * NoH * (a2 - 1.0f) + 1.0f;
    const float D = a2 / (kPi * dd * dd);
    const float m = 1.0f - VoH, m2 = m * m;
    const glm::vec3 F = v.f0 + v.oneMinusF0 * (m2 * m2 * m);  // Schlick
    out.specular = D * v.G1V * smithG1(a2, NoL) * F / (4.0f * NoL * NoV);
    pdfSpecular = D * NoH / (4.0f * VoH);
  }
  out.pdf = v.pSpec * pdfSpecular + (1.0f - v.pSpec) * pdfDiffuse;
  return out;
}

// evaluate() for eight incident directions at once (a reference's first vertex, shadeBatch), in
// the lanes of core/fast_math.hpp: the same IEEE operations in the same order as evaluate(), lane
// by lane (glm's dot is (x + y) + z, its normalize v * (1 / sqrt(dot(v, v))), std::max(a, b) is
// a < b ? b : a, and the early return's test is kept as written, NaN included), so each lane
// holds the bits evaluate() gives that direction; a lane below the surface holds its NoL and
// zeros, as evaluate()'s early return leaves them.
struct LobeLanes {
  Lanes8 diffuse[3], specular[3], pdf, NoL;
};
LobeLanes evaluateLanes(const VertexBsdf& v, const Lanes8 (&wi)[3]) {
  const Lanes8 zero = splatLanes(0.0f);
  LobeLanes out;
  const Lanes8 NoL = (v.n.x * wi[0] + v.n.y * wi[1]) + v.n.z * wi[2];
  const float NoV = v.NoV;
  out.NoL = NoL;
  const LaneMask8 valid =
      !(NoV <= 0) ? ~LaneMask8(NoL <= zero) : LaneMask8{};  // !(NoL <= 0 || NoV <= 0)
  const Lanes8 pdfDiffuse = NoL / kPi;
  Lanes8 pdfSpecular = zero;
  for (int c = 0; c < 3; ++c) {
    out.diffuse[c] = selectFloat(valid, splatLanes(v.diffuseOverPi[c]), zero);
    out.specular[c] = zero;
  }
  if (v.specular) {
    const Lanes8 sx = v.wo.x + wi[0], sy = v.wo.y + wi[1], sz = v.wo.z + wi[2];
    const Lanes8 inverseLength = 1.0f / sqrtLanes((sx * sx + sy * sy) + sz * sz);
    const Lanes8 hx = sx * inverseLength, hy = sy * inverseLength, hz = sz * inverseLength;
    const Lanes8 NoHd = (v.n.x * hx + v.n.y * hy) + v.n.z * hz;
    const Lanes8 VoHd = (v.wo.x * hx + v.wo.y * hy) + v.wo.z * hz;
    const Lanes8 NoH = selectFloat(NoHd < 0.0f, zero, NoHd);
    const Lanes8 VoH = selectFloat(VoHd < 1e-6f, splatLanes(1e-6f), VoHd);
    const float a2 = v.a2;
    const Lanes8 dd = NoH * NoH * (a2 - 1.0f) + 1.0f;
    const Lanes8 D = a2 / (kPi * dd * dd);
    const Lanes8 m = 1.0f - VoH, m2 = m * m;
    const Lanes8 schlick = m2 * m2 * m;
    const Lanes8 G1L = 2.0f * NoL / (NoL + sqrtLanes(a2 + (1.0f - a2) * NoL * NoL));
    const Lanes8 DG = D * v.G1V * G1L, denominator = 4.0f * NoL * NoV;
    for (int c = 0; c < 3; ++c) {
      const Lanes8 F = v.f0[c] + v.oneMinusF0[c] * schlick;
      out.specular[c] = selectFloat(valid, DG * F / denominator, zero);
    }
    pdfSpecular = D * NoH / (4.0f * VoH);
  }
  out.pdf = selectFloat(valid, v.pSpec * pdfSpecular + (1.0f - v.pSpec) * pdfDiffuse, zero);
  return out;
}

// The lobe choice for the reference sampler: the pair's first coordinate picks the lobe and is
// rescaled to [0, 1) within it (as for the light choice in sampleLight), keeping the pair stratified.
void reuseForLobe(float pSpec, float& uLobe, float& u1) {
  uLobe = u1;
  if (u1 < pSpec)
    u1 = std::min(u1 / pSpec, kOneMinusEpsilon);
  else
    u1 = std::min((u1 - pSpec) / (1.0f - pSpec), kOneMinusEpsilon);
}

// A cosine-weighted direction about n (t, b, n orthonormal) from u1, u2 in [0, 1): Malley's
// method, a uniform point on the unit disc (radius sqrt(u1), angle 2 pi u2) lifted to the
// hemisphere.
glm::vec3 cosineDirection(glm::vec3 t, glm::vec3 b, glm::vec3 n, float u1, float u2) {
  const float r = std::sqrt(u1), phi = 2.0f * kPi * u2;
  return t * (r * std::cos(phi)) + b * (r * std::sin(phi)) +
         n * std::sqrt(std::max(0.0f, 1.0f - u1));
}

// A direction from the lobe mixture (the specular lobe where uLobe < pSpec); false where it falls
// below the shading surface.
bool sampleDirection(const VertexBsdf& v, float pSpec, float uLobe, float u1, float u2,
                     glm::vec3& wi) {
  const glm::vec3 n = v.n, t = v.t, b = v.b, wo = v.wo;
  if (uLobe < pSpec) {  // GGX distribution of normals, D(h) cos(h)
    float phi = 2.0f * kPi * u1;
    float cosTheta = std::sqrt((1.0f - u2) / (1.0f + (v.a2 - 1.0f) * u2));
    float sinTheta = std::sqrt(std::max(0.0f, 1.0f - cosTheta * cosTheta));
    glm::vec3 h = glm::normalize(t * (sinTheta * std::cos(phi)) + b * (sinTheta * std::sin(phi)) + n * cosTheta);
    wi = 2.0f * glm::dot(wo, h) * h - wo;
  } else {
    wi = cosineDirection(t, b, n, u1, u2);
  }
  return glm::dot(wi, n) > 0;
}

}  // namespace

float specularLobeProbability(float diffuseAlbedo, float specularAlbedo) {
  // A lobe with no albedo is never sampled; where both reflect, each keeps at least 10 % of the
  // samples. (Before issue 34 this was one std::clamp whose bounds crossed, lo > hi, for a
  // metal or a surface without specular: undefined behaviour, which gave metals 0.9, not 1.)
  if (specularAlbedo <= 0) return 0;
  if (diffuseAlbedo <= 0) return 1;
  return std::clamp(specularAlbedo / (diffuseAlbedo + specularAlbedo), 0.1f, 0.9f);
}

glm::vec3 specularAlbedo(glm::vec3 f0, float roughness, float NoV) {
  const glm::vec4 c0(-1.0f, -0.0275f, -0.572f, 0.022f), c1(1.0f, 0.0425f, 1.04f, -0.04f);
  glm::vec4 r = roughness * c0 + c1;
  float a004 = std::min(r.x * r.x, std::exp2(-9.28f * std::max(NoV, 0.0f))) * r.x + r.y;
  glm::vec2 ab = glm::vec2(-1.04f, 1.04f) * a004 + glm::vec2(r.z, r.w);
  return glm::max(f0 * ab.x + ab.y, glm::vec3(0.0f));
}

EmbreeDevice::EmbreeDevice(const char* config) {
  device_ = rtcNewDevice(config);
  if (!device_) throw Error("Embree: cannot create a device (error " + std::to_string(rtcGetDeviceError(nullptr)) + ")");
}
EmbreeDevice::~EmbreeDevice() { rtcReleaseDevice(device_); }

FrameScene::FrameScene(const EmbreeDevice& device, const Scene& scene,
                       const std::vector<MeshData>& meshes, const SceneState& state)
    : scene_(scene), state_(state), device_(device.get()) {
  rtcScene_ = rtcNewScene(device.get());
  rtcSetSceneBuildQuality(rtcScene_, RTC_BUILD_QUALITY_HIGH);
  const size_t count = scene.objects.size() + scene.lights.size();
  if (meshes.size() != count || state.toWorld.size() != count) throw Error("FrameScene: mesh/state count mismatch");
  geometries_.resize(count);
  for (size_t id = 0; id < count; ++id) {
    Geometry& g = geometries_[id];
    g.local = &meshes[id];
    const glm::mat4& m = state.toWorld[id];
    if (g.local->vertexNodes.empty()) {
      const glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(m)));
      for (size_t i = 0; i < g.local->positions.size(); ++i) {
        g.positions.push_back(glm::vec3(m * glm::vec4(g.local->positions[i], 1.0f)));
        g.normals.push_back(glm::normalize(normalMatrix * g.local->normals[i]));
      }
    } else {  // an asset: each vertex lies in its node's space, placed by this frame's matrices
      const std::vector<glm::mat4>& nodes = state.nodeMatrices.at(id);
      std::vector<glm::mat4> toWorld(nodes.size());
      std::vector<glm::mat3> normalMatrices(nodes.size());
      for (size_t k = 0; k < nodes.size(); ++k) {
        toWorld[k] = m * nodes[k];
        normalMatrices[k] = glm::transpose(glm::inverse(glm::mat3(toWorld[k])));
      }
      for (size_t i = 0; i < g.local->positions.size(); ++i) {
        const uint32_t node = g.local->vertexNodes[i];
        g.positions.push_back(glm::vec3(toWorld[node] * glm::vec4(g.local->positions[i], 1.0f)));
        g.normals.push_back(glm::normalize(normalMatrices[node] * g.local->normals[i]));
      }
    }
    for (const glm::uvec3& tri : g.local->triangles) {
      glm::vec3 n = glm::cross(g.positions[tri.y] - g.positions[tri.x], g.positions[tri.z] - g.positions[tri.x]);
      g.faceNormals.push_back(glm::length(n) > 0 ? glm::normalize(n) : glm::vec3(0, 1, 0));
    }
    if (id < scene.objects.size()) {
      g.materialId = scene.objects[id].material;
    } else {
      g.lightIndex = int(id - scene.objects.size());
      const LightValue& lv = state.lights[size_t(g.lightIndex)];
      g.lightRadiance = lv.color * lv.intensity;
      for (const glm::uvec3& tri : g.local->triangles) {
        glm::vec3 e1 = g.positions[tri.y] - g.positions[tri.x], e2 = g.positions[tri.z] - g.positions[tri.x];
        g.area += 0.5f * glm::length(glm::cross(e1, e2));
        g.areaCdf.push_back(g.area);
      }
      // Every light with an area is selectable, switched off or not (A-SVGF §3.3): a gradient
      // sample re-shaded with the previous frame's random numbers must pick the same light, or a
      // light switching anywhere changes every pixel's light choice and fakes a gradient where
      // nothing changed. A light with zero radiance contributes 0 (its pdf is 0 below).
      if (g.area > 0) selectableLights_.push_back(int(id));
      g.areaGuide = CdfGuide(g.areaCdf);
      if (scene.lights[size_t(g.lightIndex)].shape == Shape::Sphere && g.area > 0) {
        // The sphere around the light's origin that holds every vertex (its scale may differ per
        // axis), widened by a relative 1e-5 against rounding: a part of the mesh outside it would
        // never be light-sampled, yet weighted as if it were.
        g.sampledByCone = true;
        g.coneCenter = glm::vec3(m * glm::vec4(0, 0, 0, 1));
        for (const glm::vec3& p : g.positions)
          g.coneRadius2 = std::max(g.coneRadius2, glm::dot(p - g.coneCenter, p - g.coneCenter));
        g.coneRadius2 *= 1.0f + 1e-5f;
      }
    }
    RTCGeometry geom = rtcNewGeometry(device.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), g.positions.size()));
    for (size_t i = 0; i < g.positions.size(); ++i) {
      v[3 * i] = g.positions[i].x;
      v[3 * i + 1] = g.positions[i].y;
      v[3 * i + 2] = g.positions[i].z;
    }
    auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                               3 * sizeof(unsigned), g.local->triangles.size()));
    std::memcpy(idx, g.local->triangles.data(), g.local->triangles.size() * 3 * sizeof(unsigned));
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(rtcScene_, geom, unsigned(id));
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(rtcScene_);
}

FrameScene::~FrameScene() { rtcReleaseScene(rtcScene_); }

bool FrameScene::intersect(glm::vec3 o, glm::vec3 d, float tmax, SurfaceHit& hit, float& t, bool coherent) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  if (coherent) ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  RTCRayHit rh;
  rh.ray.org_x = o.x, rh.ray.org_y = o.y, rh.ray.org_z = o.z;
  rh.ray.dir_x = d.x, rh.ray.dir_y = d.y, rh.ray.dir_z = d.z;
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = tmax;
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xFFFFFFFFu;  // Debian's Embree has ray masks on: a zero mask misses everything
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(rtcScene_, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
  hit.meshId = int(rh.hit.geomID);
  hit.primId = int(rh.hit.primID);
  hit.u = rh.hit.u;
  hit.v = rh.hit.v;
  t = rh.ray.tfar;
  exactHit(o, d, hit, t);
  return true;
}

// Embree finds the triangle; where on it the ray lands is computed here. Embree's own (t, u, v)
// come from kernels chosen for the CPU at run time (SSE, AVX2, AVX-512), whose approximate
// reciprocals (rcpps, vrcp14ps) differ between ISAs and between Intel and AMD: the same ray gave
// other bits on another machine, so pixels, references and the evaluation golden depended on the
// CPU. Moeller-Trumbore in float on the world-space vertices (IEEE operations only, no contraction:
// -ffp-contract=off) gives the same bits on every CPU that runs this build. Embree's values stay
// only for a ray in the triangle's plane (determinant 0). Still Embree's, and so still able to
// differ between machines in exact ties: which of two triangles sharing an edge is hit, and
// occlusion (the SSE kernels' BVH4 against the AVX2 and AVX-512 kernels' BVH8; measured:
// FidelityTracer.HitsAreTheSameBitsWhicheverKernelsEmbreeRuns, and the evaluation golden's run
// differs between the sse2 and avx2 kernels).
void FrameScene::exactHit(glm::vec3 o, glm::vec3 d, SurfaceHit& hit, float& t) const {
  const Geometry& g = geometries_[size_t(hit.meshId)];
  const glm::uvec3& tri = g.local->triangles[size_t(hit.primId)];
  const glm::vec3& p0 = g.positions[tri.x];
  const glm::vec3 e1 = g.positions[tri.y] - p0, e2 = g.positions[tri.z] - p0;
  const glm::vec3 p = glm::cross(d, e2);
  const float det = glm::dot(e1, p);
  if (det == 0.0f) return;
  const float inv = 1.0f / det;
  const glm::vec3 s = o - p0, q = glm::cross(s, e1);
  float u = glm::dot(s, p) * inv, v = glm::dot(d, q) * inv;
  const float tt = glm::dot(e2, q) * inv;
  u = std::clamp(u, 0.0f, 1.0f);
  v = std::clamp(v, 0.0f, 1.0f);
  if (u + v > 1.0f) {
    const float sum = u + v;
    u /= sum;
    v /= sum;
  }
  hit.u = u;
  hit.v = v;
  if (tt > 0) t = tt;
}

bool FrameScene::occluded(glm::vec3 o, glm::vec3 d, float tmax) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay ray;
  ray.org_x = o.x, ray.org_y = o.y, ray.org_z = o.z;
  ray.dir_x = d.x, ray.dir_y = d.y, ray.dir_z = d.z;
  ray.tnear = 0.0f;
  ray.tfar = tmax;
  ray.time = 0.0f;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(rtcScene_, &ctx, &ray);
  return ray.tfar < 0.0f;
}

// A cone sample is seen where its direction reaches the light's mesh, from the front, before
// anything else.
bool FrameScene::reachesLight(glm::vec3 o, glm::vec3 d, int lightMesh) const {
  SurfaceHit h;
  float t;
  return intersect(o, d, kInf, h, t) && h.meshId == lightMesh &&
         glm::dot(geometries_[size_t(h.meshId)].faceNormals[size_t(h.primId)], d) < 0;
}

glm::vec3 FrameScene::positionOf(int meshId, int primId, float u, float v) const {
  const Geometry& g = geometries_[size_t(meshId)];
  const glm::uvec3 tri = g.local->triangles[size_t(primId)];
  return (1.0f - u - v) * g.positions[tri.x] + u * g.positions[tri.y] + v * g.positions[tri.z];
}

SurfaceHit FrameScene::surface(int meshId, int primId, float u, float v) const {
  SurfaceHit s;
  s.meshId = meshId;
  s.primId = primId;
  s.u = u;
  s.v = v;
  const Geometry& g = geometries_[size_t(meshId)];
  const glm::uvec3 tri = g.local->triangles[size_t(primId)];
  const float w = 1.0f - u - v;
  s.position = w * g.positions[tri.x] + u * g.positions[tri.y] + v * g.positions[tri.z];
  s.geometricNormal = g.faceNormals[size_t(primId)];
  glm::vec3 ns = w * g.normals[tri.x] + u * g.normals[tri.y] + v * g.normals[tri.z];
  s.shadingNormal = glm::length(ns) > 0 ? glm::normalize(ns) : s.geometricNormal;
  if (g.lightIndex >= 0) {
    s.lightIndex = g.lightIndex;
    s.emission = g.lightRadiance;
    s.baseColor = glm::vec3(0.0f);
    s.specularF0 = 0.0f;
    return s;
  }
  // Assets carry a material per triangle; shapes (and overridden assets) one per object.
  const int materialId = g.local->triangleMaterials.empty()
                             ? g.materialId
                             : g.local->triangleMaterials[size_t(primId)];
  const Material& m = scene_.materials[size_t(materialId)];
  s.materialId = materialId;
  s.baseColor = m.albedo;
  if (m.checker) {  // object-space checker, so the pattern moves with the object
    glm::vec3 lp = w * g.local->positions[tri.x] + u * g.local->positions[tri.y] + v * g.local->positions[tri.z];
    glm::ivec3 cell = glm::ivec3(glm::floor(lp * m.checkerScale + 1e-4f));
    if (((cell.x + cell.y + cell.z) & 1) != 0) s.baseColor = m.checkerAlbedo;
  }
  s.roughness = m.roughness;
  s.metallic = m.metallic;
  s.specularF0 = m.specular;
  s.emission = m.emission;
  if (m.textured()) {  // only textured (asset) materials pay for the lookups
    const std::vector<glm::vec2>& tc = g.local->texcoords;
    const glm::vec2 uv =
        tc.empty() ? glm::vec2(0.0f) : w * tc[tri.x] + u * tc[tri.y] + v * tc[tri.z];
    if (m.baseColorTexture) s.baseColor *= glm::vec3(m.baseColorTexture.sample(uv));
    if (m.metallicRoughnessTexture) {  // glTF 2.0: G = roughness, B = metallic (linear)
      const glm::vec4 mr = m.metallicRoughnessTexture.sample(uv);
      s.roughness = std::clamp(s.roughness * mr.g, 0.0f, 1.0f);
      s.metallic = std::clamp(s.metallic * mr.b, 0.0f, 1.0f);
    }
    if (m.emissionTexture) s.emission *= glm::vec3(m.emissionTexture.sample(uv));
    s.baseColor = glm::clamp(s.baseColor, 0.0f, 1.0f);
  }
  return s;
}

uint32_t FrameScene::eyePathDimensions() const {
  // Vertices 0..maxBounces-1 sample (the last bounce's hit only adds its emission).
  return uint32_t(std::max(scene_.maxBounces, 1)) * kDimsPerVertex;
}

// A bidirectional reference's light path reads its numbers after the eye path's: at eyeDims the
// light and triangle choice (a pair), at + 2 the point on the triangle, at + 4 the emitted
// direction, then per bounce j = 1.. a pair for the direction and one number for the lobe (the
// independent sampler's; the Sobol sampler takes the lobe from the pair, as the eye path does).
constexpr uint32_t kLightPathFirstBounce = 6, kDimsPerLightBounce = 3;

uint32_t FrameScene::pathDimensions() const {
  if (scene_.referenceEstimator != ReferenceEstimator::Bidirectional) return eyePathDimensions();
  const uint32_t bounces = uint32_t(std::max(scene_.maxBounces - 2, 0));
  return eyePathDimensions() + kLightPathFirstBounce + bounces * kDimsPerLightBounce;
}

Sampler::Reads FrameScene::sobolReads() const {
  Sampler::Reads reads;
  for (uint32_t v = 0; v < uint32_t(std::max(scene_.maxBounces, 1)); ++v) {
    const uint32_t dim = v * kDimsPerVertex;
    if (dim + kDimsPerVertex > Sampler::kMaxHashedDims) break;  // the rest are computed per draw
    reads.pairs |= (1ull << (dim + kLightU)) | (1ull << (dim + kDirU));
    if (v >= 2) reads.singles |= 1ull << (dim + kRoulette);  // Russian roulette after two bounces
  }
  if (scene_.referenceEstimator == ReferenceEstimator::Bidirectional) {
    const uint32_t base = eyePathDimensions();
    for (uint32_t d = base; d < pathDimensions(); ++d) {
      const uint32_t k = d - base;
      const bool pair = k < kLightPathFirstBounce
                            ? k % 2 == 0
                            : (k - kLightPathFirstBounce) % kDimsPerLightBounce == 0;
      if (pair && d + 1 < Sampler::kMaxHashedDims) reads.pairs |= 1ull << d;
    }
  }
  return reads;
}

glm::vec3 FrameScene::sky(glm::vec3 dir) const {
  return glm::mix(scene_.skyBottom, scene_.skyTop, 0.5f * (dir.y + 1.0f));
}

// A light sample. An area sample (meshId -1) names its point, and a shadow ray to shadowEnd decides
// whether it is seen. A cone sample names only a direction: it is seen where the first thing a
// ray along wi meets is the light's own mesh (meshId) from the front, which one closest-hit ray
// decides (chooseAtVertex); between the mesh and the sphere around it the direction meets nothing
// of the light and the sample is 0, as its pdf over the whole cone counts.
struct FrameScene::LightSample {
  glm::vec3 le{0};         // emitted radiance; 0 with pdf 0: no sample
  glm::vec3 wi{0};         // unit direction from the shading point
  float pdf = 0;           // solid angle, the light's choice included
  glm::vec3 shadowEnd{0};  // area samples: the light point, lifted off the emitter
  int meshId = -1;         // cone samples: the light the direction must reach
  // Area samples: the point on the light and its triangle's normal (bidirectional references
  // weigh the sample by where it lies).
  glm::vec3 point{0}, normal{0};
  int areaMesh = -1;
};

// The cone of directions a sphere light's bounding sphere subtends from a ray origin outside it:
// its axis (unit, towards the centre), 1 - cos(theta_max) (written without the cancellation of
// 1 - sqrt(1 - sin^2) for small cones) and the solid angle pdf of a uniform direction in it, the
// light's choice among n included. False from inside (or on) the sphere: area sampling there.
struct FrameScene::Cone {
  glm::vec3 axis{0};
  float oneMinusCosMax = 0, pdf = 0;
};
bool FrameScene::coneSeenFrom(const Geometry& g, glm::vec3 origin, Cone& cone) const {
  const glm::vec3 toCenter = g.coneCenter - origin;
  const float d2 = glm::dot(toCenter, toCenter);
  if (!(d2 > g.coneRadius2)) return false;
  const float sin2 = g.coneRadius2 / d2;
  cone.axis = toCenter / std::sqrt(d2);
  cone.oneMinusCosMax = sin2 / (1.0f + std::sqrt(1.0f - sin2));
  cone.pdf = 1.0f / (2.0f * kPi * cone.oneMinusCosMax * float(selectableLights_.size()));
  return true;
}

FrameScene::LightSample FrameScene::sampleLight(const SurfaceHit& at, glm::vec3 origin,
                                                const Sampler& s, uint32_t dim) const {
  LightSample out;
  if (selectableLights_.empty()) return out;
  const size_t n = selectableLights_.size();
  glm::vec2 uv = s.get2(dim + kLightU);
  // The reference sampler reuses the pair's first coordinate for the discrete choices (light, then
  // triangle), rescaled to [0, 1) within the chosen interval, so the pair's 2D stratification
  // carries over to the point on the chosen light instead of being split at random between lights
  // and triangles. The frames' independent sampler keeps its own dimensions.
  const bool reuse = s.kind() == SamplerKind::OwenSobol;
  float uSelect = reuse ? uv.x * float(n) : s.get(dim + kLightSelect) * float(n);
  const size_t li = std::min(size_t(uSelect), n - 1);
  const Geometry& g = geometries_[size_t(selectableLights_[li])];
  Cone cone;
  if (g.sampledByCone && coneSeenFrom(g, origin, cone)) {
    // A sphere light seen from outside the sphere that holds its mesh: a direction uniform in that
    // sphere's cone (pbrt-v4's Sphere::Sample(ctx, u), here over the bounding sphere of a mesh).
    // Area sampling wastes the half of its points that face away and weights the rest by
    // cos / distance^2, which varies most near the light (hard_light's ceiling, 0.11 below its
    // sphere): this halves hard_light's reference error at equal samples (docs/references.md).
    // The cone is seen from the ray origin (offset off the surface), where its ray leaves and
    // where a BSDF-sampled ray leaves too: every ray from there that meets the mesh lies in it.
    if (maxComponent(g.lightRadiance) <= 0) return out;  // switched off: pdf stays 0
    const float u = reuse ? std::min(uSelect - float(li), kOneMinusEpsilon) : uv.x;
    const float oneMinusCos = u * cone.oneMinusCosMax;
    const float cosTheta = 1.0f - oneMinusCos;
    const float sinTheta = std::sqrt(std::max(0.0f, oneMinusCos * (2.0f - oneMinusCos)));
    const float phi = 2.0f * kPi * uv.y;
    glm::vec3 t, b;
    orthonormalBasis(cone.axis, t, b);
    out.wi =
        glm::normalize(cosTheta * cone.axis + sinTheta * (std::cos(phi) * t + std::sin(phi) * b));
    out.pdf = cone.pdf;
    out.le = g.lightRadiance;
    out.meshId = selectableLights_[li];
    return out;
  }
  // Triangle in proportion to its area, then a uniform point on it.
  float target = (reuse ? std::min(uSelect - float(li), kOneMinusEpsilon) : s.get(dim + kLightTriangle)) * g.area;
  const size_t ti = std::min(g.areaGuide.lowerBound(g.areaCdf, target), g.areaCdf.size() - 1);
  if (reuse) {
    const float lo = ti > 0 ? g.areaCdf[ti - 1] : 0.0f, width = g.areaCdf[ti] - lo;
    uv.x = width > 0 ? std::clamp((target - lo) / width, 0.0f, kOneMinusEpsilon) : 0.0f;
  }
  const glm::uvec3 tri = g.local->triangles[ti];
  const glm::vec3 lp =
      uniformPointOnTriangle(g.positions[tri.x], g.positions[tri.y], g.positions[tri.z], uv);
  const glm::vec3 ln = g.faceNormals[ti];  // normalize(cross(p1 - p0, p2 - p0)), computed once per frame
  glm::vec3 d = lp - at.position;
  float dist2 = glm::dot(d, d);
  const float dist = std::sqrt(dist2);
  if (dist <= 0) return out;
  out.wi = d / dist;
  float cosLight = glm::dot(ln, -out.wi);
  if (cosLight <= 0) return out;                       // one-sided emitters
  if (maxComponent(g.lightRadiance) <= 0) return out;  // switched off: pdf stays 0
  out.pdf = dist2 / (cosLight * g.area * float(n));
  out.shadowEnd = offsetOrigin(lp, ln);  // off the emitter, on the side it lights (cosLight > 0)
  out.le = g.lightRadiance;
  out.point = lp;
  out.normal = ln;
  out.areaMesh = selectableLights_[li];
  return out;
}

CdfGuide::CdfGuide(const std::vector<float>& cdf) : total_(cdf.empty() ? 0.0f : cdf.back()) {
  for (size_t b = 0; b < cdf.size(); ++b) {
    low_.push_back(float(b) * (total_ / float(cdf.size())));
    first_.push_back(uint32_t(std::lower_bound(cdf.begin(), cdf.end(), low_.back()) - cdf.begin()));
  }
}

size_t CdfGuide::guided(const std::vector<float>& cdf, float target) const {
  const size_t n = first_.size();
  // Target's bucket, moved down while its lower end lies above target (rounding): every entry before
  // first_[b] is then below target. Forward from there to the first entry that reaches it.
  const float bucket = total_ > 0 && target > 0 ? target / total_ * float(n) : 0.0f;
  size_t b = bucket < float(n - 1) ? size_t(bucket) : n - 1;
  while (b > 0 && low_[b] > target) --b;
  size_t i = first_[b];
  while (i < n && cdf[i] < target) ++i;
  return i;
}

float FrameScene::lightPdf(const SurfaceHit& lightHit, glm::vec3 from, glm::vec3 origin,
                           glm::vec3 dir) const {
  if (lightHit.lightIndex < 0 || selectableLights_.empty()) return 0;
  const Geometry& g = geometries_[size_t(lightHit.meshId)];
  if (maxComponent(g.lightRadiance) <= 0) return 0;
  Cone cone;
  if (g.sampledByCone && coneSeenFrom(g, origin, cone)) {  // the choice sampleLight makes there
    // A ray from the cone's apex that meets the mesh lies in the cone; the test only keeps a
    // rounding at its edge from weighting a direction light sampling cannot take. Its front face
    // the caller has checked along `dir`, as a cone sample's ray is checked.
    return 1.0f - glm::dot(dir, cone.axis) > cone.oneMinusCosMax ? 0.0f : cone.pdf;
  }
  glm::vec3 d = from - lightHit.position;
  float dist2 = glm::dot(d, d);
  float cosLight = glm::dot(lightHit.geometricNormal, d / std::sqrt(dist2));
  if (cosLight <= 0) return 0;
  return dist2 / (cosLight * g.area * float(selectableLights_.size()));
}

float FrameScene::specularHitDistance(const PrimaryVertex& vertex, const Sampler& sampler,
                                      RayCounts& counts) const {
  const SurfaceHit& primary = vertex.hit;
  if (primary.lightIndex >= 0) return 0;
  const VertexBsdf& v = vertex.bsdf;
  const glm::vec3 wo = v.wo;
  const glm::vec2 u = sampler.get2(kSpecularRayDim);
  glm::vec3 wi;
  // One GGX sample of the specular lobe alone (pSpec 1); below the surface, the mirror direction
  // (a sample is never discarded: the channel has a distance wherever a specular ray could leave).
  if (!sampleDirection(v, 1.0f, 0.0f, u.x, u.y, wi) || glm::dot(wi, v.ng) <= 0)
    wi = 2.0f * glm::dot(wo, v.n) * v.n - wo;
  if (glm::dot(wi, v.ng) <= 0) return 0;
  SurfaceHit h;
  float t;
  counts.rays++;
  return intersect(v.origin, wi, kInf, h, t) ? t : kInf;
}

FrameScene::PrimaryVertex FrameScene::prepare(const SurfaceHit& hit, glm::vec3 wo) const {
  PrimaryVertex v;
  v.hit = hit;
  v.bsdf.wo = wo;
  if (hit.lightIndex >= 0) return v;  // emitters do not reflect
  v.bsdf = vertexBsdf(hit, wo);
  return v;
}

// What a sample decides at a vertex before any ray leaves it: its light sample and its scattered
// direction, each with the BSDF evaluated towards it. Nothing here waits on a ray, so a reference
// decides its first vertex for a batch of samples at once and traces their area samples' shadow
// rays as one packet (shadeBatch).
struct FrameScene::VertexSample {
  // After chooseAtVertex: the light sample lies above the surface; after settle, the BSDF also
  // reflects it, and it takes a ray: an area sample's shadow ray to shadowEnd, a cone sample's
  // closest-hit ray that must reach coneLight first.
  bool towardsLight = false;
  glm::vec3 le{0}, wiLight{0};
  glm::vec3 shadowEnd{0};  // area samples: the light point lifted off the emitter
  int coneLight = -1;      // cone samples: the light's mesh id (LightSample::meshId)
  glm::vec3 lightPoint{0}, lightNormal{0};  // area samples (LightSample::point, normal, areaMesh)
  int areaLight = -1;
  float pdfLight = 0;
  Lobes fLight;
  // The shadow ray's answer where a packet traced it already (0 or 1), else -1.
  int8_t occluded = -1;
  // After chooseAtVertex: the sampled direction lies above the surface; after settle, its pdf is
  // positive too, and the path goes on.
  bool scatters = false;
  glm::vec3 wi{0};
  Lobes f;
  // With the BSDF evaluated towards both (fLight, f): a light sample the BSDF does not reflect
  // takes no shadow ray, and a direction of zero pdf ends the path.
  void settle() {
    if (towardsLight)
      towardsLight = !(fLight.pdf <= 0 && maxComponent(fLight.diffuse + fLight.specular) <= 0);
    if (scatters) scatters = !(f.pdf <= 0);
  }
};

namespace {
// Lane l of a packet: a ray from o along d over [0, tfar], every field set as for one ray.
void setPacketRay(RTCRay16& r, int l, glm::vec3 o, glm::vec3 d, float tfar) {
  r.org_x[l] = o.x, r.org_y[l] = o.y, r.org_z[l] = o.z;
  r.dir_x[l] = d.x, r.dir_y[l] = d.y, r.dir_z[l] = d.z;
  r.tnear[l] = 0.0f;
  r.tfar[l] = tfar;
  r.time[l] = 0.0f;
  r.mask[l] = 0xFFFFFFFFu;
  r.id[l] = unsigned(l);
  r.flags[l] = 0;
}
}  // namespace

// A sample's random choices at a vertex: the light sample and the scattered direction, and which
// of them lie above the surface (towardsLight, scatters: set so far only from the geometry).
void FrameScene::chooseAtVertex(const SurfaceHit& s, const VertexBsdf& v, const Sampler& sampler,
                                uint32_t dim, VertexSample& out) const {
  const LightSample light = sampleLight(s, v.origin, sampler, dim);
  out.le = light.le;
  out.wiLight = light.wi;
  out.pdfLight = light.pdf;
  out.shadowEnd = light.shadowEnd;
  out.coneLight = light.meshId;
  out.lightPoint = light.point;
  out.lightNormal = light.normal;
  out.areaLight = light.areaMesh;
  out.towardsLight = !(out.pdfLight <= 0 || glm::dot(out.wiLight, v.ng) <= 0);
  glm::vec2 u = sampler.get2(dim + kDirU);
  float lobe = 0;
  if (sampler.kind() == SamplerKind::OwenSobol)
    reuseForLobe(v.pSpec, lobe, u.x);
  else
    lobe = sampler.get(dim + kLobe);
  out.scatters =
      !(!sampleDirection(v, v.pSpec, lobe, u.x, u.y, out.wi) || glm::dot(out.wi, v.ng) <= 0);
}

FrameScene::VertexSample FrameScene::sampleVertex(const SurfaceHit& s, const VertexBsdf& v,
                                                  const Sampler& sampler, uint32_t dim) const {
  VertexSample out;
  chooseAtVertex(s, v, sampler, dim, out);
  if (out.towardsLight) out.fLight = evaluate(v, out.wiLight);
  if (out.scatters) out.f = evaluate(v, out.wi);
  out.settle();
  return out;
}

FrameScene::Radiance FrameScene::shade(const PrimaryVertex& vertex, const Sampler& sampler, RayCounts& counts) const {
  if (!vertex.bsdf.reflects) {
    counts.paths++;
    return {};
  }
  return shade(vertex, sampleVertex(vertex.hit, vertex.bsdf, sampler, 0), sampler, counts);
}

void FrameScene::shadeBatch(const PrimaryVertex& vertex, const Sampler* samplers, int count,
                            Radiance* out, RayCounts& counts) const {
  if (count > int(Sampler::kBatchLanes)) throw Error("shadeBatch: more samples than a batch holds");
  if (scene_.referenceEstimator == ReferenceEstimator::Bidirectional) {
    for (int l = 0; l < count; ++l) out[l] = shadeBidirectional(vertex, samplers[l], counts);
    return;
  }
  if (!vertex.bsdf.reflects) {  // no path leaves
    for (int l = 0; l < count; ++l) {
      counts.paths++;
      out[l] = {};
    }
    return;
  }
  VertexSample first[Sampler::kBatchLanes];
  // Their choices one by one; the BSDF towards their 32 directions eight lanes at a time
  // (evaluateLanes: the bits evaluate() gives).
  for (int l = 0; l < count; ++l)
    chooseAtVertex(vertex.hit, vertex.bsdf, samplers[l], 0, first[l]);
  for (int half = 0; half < 2 && 8 * half < count; ++half) {
    VertexSample* lanes = first + 8 * half;
    for (const bool light : {true, false}) {
      Lanes8 wi[3] = {};
      for (int c = 0; c < 3; ++c)
        for (int l = 0; l < 8; ++l) wi[c][l] = light ? lanes[l].wiLight[c] : lanes[l].wi[c];
      const LobeLanes f = evaluateLanes(vertex.bsdf, wi);
      for (int l = 0; l < 8 && 8 * half + l < count; ++l) {
        VertexSample& lane = lanes[l];
        if (!(light ? lane.towardsLight : lane.scatters))
          continue;  // left unevaluated, as sampleVertex leaves it
        Lobes& lobes = light ? lane.fLight : lane.f;
        lobes.diffuse = glm::vec3(f.diffuse[0][l], f.diffuse[1][l], f.diffuse[2][l]);
        lobes.specular = glm::vec3(f.specular[0][l], f.specular[1][l], f.specular[2][l]);
        lobes.pdf = f.pdf[l];
        lobes.NoL = f.NoL[l];
      }
    }
  }
  for (int l = 0; l < count; ++l) first[l].settle();
  // Their area samples' shadow rays leave one point towards the same lights: one coherent packet
  // (cone samples were decided in chooseAtVertex and stay out of it). (The
  // scattered rays as a packet too were measured: no faster, and Embree's packet kernels chose
  // the other triangle of a shared edge for some of living_room's rays.)
  static_assert(Sampler::kBatchLanes == 16, "the packet is Embree's RTCRay16");
  const glm::vec3 origin = vertex.bsdf.origin;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  alignas(64) int valid[16];
  alignas(64) RTCRay16 shadow;
  for (int l = 0; l < 16; ++l) {
    valid[l] = l < count && first[l].towardsLight && first[l].coneLight < 0 ? -1 : 0;
    const Segment ray = shadowSegment(origin, first[l].shadowEnd);
    setPacketRay(shadow, l, origin, ray.dir, ray.length);
  }
  rtcOccluded16(valid, rtcScene_, &ctx, &shadow);
  // Should Embree refuse the packet (an error, the rays left untraced), shade() traces them
  // one at a time.
  if (rtcGetDeviceError(device_) == RTC_ERROR_NONE)
    for (int l = 0; l < count; ++l)
      if (valid[l]) first[l].occluded = shadow.tfar[l] < 0.0f ? 1 : 0;
  for (int l = 0; l < count; ++l) out[l] = shade(vertex, first[l], samplers[l], counts);
}

FrameScene::Radiance FrameScene::shade(const PrimaryVertex& vertex, const VertexSample& first,
                                       const Sampler& sampler, RayCounts& counts) const {
  Radiance out;
  counts.paths++;
  // The light sample's contribution, if seen (its ray, or the answer a packet gave),
  // MIS-weighted against BSDF sampling (power heuristic).
  auto nextEvent = [&](const VertexBsdf& v, const VertexSample& vs, glm::vec3& diffuse,
                       glm::vec3& specular, glm::vec3* direction) {
    if (!vs.towardsLight) return;
    counts.rays++;
    if (vs.coneLight < 0)
      counts.occlusionRays++;  // an area sample's shadow ray (or its packet lane)
    const glm::vec3 origin = v.origin, wi = vs.wiLight, le = vs.le;
    if (vs.occluded >= 0) {
      if (vs.occluded != 0) return;
    } else if (vs.coneLight >= 0) {
      if (!reachesLight(origin, wi, vs.coneLight)) return;
    } else {
      const Segment ray = shadowSegment(origin, vs.shadowEnd);
      if (occluded(origin, ray.dir, ray.length)) return;
    }
    const Lobes& f = vs.fLight;
    const float pdfLight = vs.pdfLight;
    float weight = pdfLight * pdfLight / (pdfLight * pdfLight + f.pdf * f.pdf);
    const float cosine = f.NoL;
    diffuse += f.diffuse * le * (cosine * weight / pdfLight);
    specular += f.specular * le * (cosine * weight / pdfLight);
    if (direction) *direction += wi * luminanceOf(f.diffuse * le * (cosine * weight / pdfLight));
  };

  // Vertex 0: split direct light and the continuation between the diffuse and specular signals.
  const SurfaceHit& primary = vertex.hit;
  const VertexBsdf& v0 = vertex.bsdf;
  nextEvent(v0, first, out.diffuse, out.specular, &out.diffuseDirection);
  if (!first.scatters) return out;
  const glm::vec3 wi = first.wi;
  const Lobes& f0 = first.f;
  const float cos0 = f0.NoL;
  const glm::vec3 weightDiffuse = f0.diffuse * (cos0 / f0.pdf), weightSpecular = f0.specular * (cos0 / f0.pdf);

  // Radiance arriving along wi from the rest of the path.
  glm::vec3 incoming(0), throughput(1);
  glm::vec3 origin = v0.origin, dir = wi;
  float prevPdf = f0.pdf;
  // The previous vertex as sampleLight saw it (not the ray's offset origin): the light-sampling
  // pdf of a light hit here is the one its light sample would have had.
  glm::vec3 prevPosition = primary.position;
  for (int depth = 1; depth <= scene_.maxBounces; ++depth) {
    SurfaceHit h;
    float t;
    counts.rays++;
    const bool hitSomething = intersect(origin, dir, kInf, h, t);
    if (depth == 1) out.hitDistance = hitSomething ? t : kInf;
    if (!hitSomething) {
      incoming += throughput * sky(dir);
      break;
    }
    SurfaceHit s = surface(h.meshId, h.primId, h.u, h.v);
    if (maxComponent(s.emission) > 0 && glm::dot(s.geometricNormal, -dir) > 0) {
      float pl = lightPdf(s, prevPosition, origin, dir);
      float weight = pl > 0 ? prevPdf * prevPdf / (prevPdf * prevPdf + pl * pl) : 1.0f;
      incoming += throughput * s.emission * weight;
    }
    if (depth == scene_.maxBounces || s.lightIndex >= 0) break;
    const uint32_t dim = uint32_t(depth) * kDimsPerVertex;
    const VertexBsdf v = vertexBsdf(s, -dir);
    if (!v.reflects) break;
    const VertexSample vs = sampleVertex(s, v, sampler, dim);
    glm::vec3 direct(0);
    nextEvent(v, vs, direct, direct, nullptr);
    incoming += throughput * direct;
    if (!vs.scatters) break;
    const glm::vec3 next = vs.wi;
    const Lobes& f = vs.f;
    throughput *= (f.diffuse + f.specular) * (f.NoL / f.pdf);
    if (depth >= 2) {  // Russian roulette after two bounces
      float q = std::clamp(maxComponent(throughput), 0.05f, 0.95f);
      if (sampler.get(dim + kRoulette) >= q) break;
      throughput /= q;
    }
    origin = v.origin;
    prevPosition = s.position;
    dir = next;
    prevPdf = f.pdf;
  }
  out.diffuse += weightDiffuse * incoming;
  out.specular += weightSpecular * incoming;
  out.diffuseDirection += wi * luminanceOf(weightDiffuse * incoming);
  return out;
}

// ---- Bidirectional references ---------------------------------------------------------------
//
// Bidirectional path tracing (Veach's thesis, 1997, chapter 10; the vertex bookkeeping as in
// pbrt-v3's BDPT, Pharr, Jakob and Humphreys, 3rd edition, section 16.3), for the references of
// scenes that ask for it ("reference_estimator": "bidirectional"): one sample traces the eye path
// from the pixel's primary vertex and one light path from a point on a light, and counts every
// way its two paths build a path of k <= maxBounces reflections: the eye path meeting a light
// (s = 0), the eye vertex's light sample (s = 1), and eye vertex x_i joined to light vertex y_j
// by a shadow ray (s = j + 1, k = i + j). Interpretations, written out in docs/references.md: no
// strategy joins a light vertex to the camera (pbrt's t = 1: it would add to other pixels, and a
// reference's pixels and tiles take their samples independently), so a path's weights run over
// s = 0..k; the weights are the power heuristic (as the path tracer's light sample) over products
// of each strategy's area pdfs; the light sample's pdf is sampleLight's (a sphere light's cone),
// the light path's point is uniform by area and its direction cosine-distributed; neither path
// uses Russian roulette; a light path's reflections carry Veach's correction for shading normals.

namespace {
// A vertex of either path: its surface, the throughput that reached it (the eye's from its second
// vertex on; the light's emitted radiance over the pdfs) and its BSDF seen from where it was
// reached.
struct PathVertex {
  SurfaceHit s;
  glm::vec3 beta{0};
  VertexBsdf v;
};

float areaPdf(float solidAnglePdf, glm::vec3 from, const SurfaceHit& to) {
  const glm::vec3 d = to.position - from;
  const float d2 = glm::dot(d, d);
  return solidAnglePdf * std::abs(glm::dot(to.geometricNormal, d / std::sqrt(d2))) / d2;
}

// Veach's adjoint BSDF factor for light transported through a surface with a shading normal
// (thesis eq. 5.17): |wo . ns| |wi . ng| / (|wo . ng| |wi . ns|), wo towards the light's side,
// wi towards the eye's. 1 where ns = ng.
float shadingNormalCorrection(const VertexBsdf& v, glm::vec3 wo, glm::vec3 wi) {
  const float den = std::abs(glm::dot(wo, v.ng)) * std::abs(glm::dot(wi, v.n));
  return den > 0 ? std::abs(glm::dot(wo, v.n)) * std::abs(glm::dot(wi, v.ng)) / den : 0.0f;
}
}  // namespace

// The power-heuristic weight of strategy `used` for the path z[1..k+1] (z[1] the primary vertex
// seen through `primary`, z[k+1] on a light): each strategy's pdf is the product of the area
// pdfs of the vertices it samples, the eye's from z[2] on and the light's from z[k+1] down.
double FrameScene::bidirectionalWeight(int used, int k, const SurfaceHit* const* z,
                                       const VertexBsdf& primary) const {
  double eyePdf[kMaxBidirectionalBounces + 2] = {}, lightPdf_[kMaxBidirectionalBounces + 2] = {};
  auto towards = [&](int a, int b) { return glm::normalize(z[b]->position - z[a]->position); };
  // The pdf of the BSDF sampling at z[at] reached from z[from] choosing z[to].
  auto bsdfPdf = [&](int at, int from, int to) {
    return evaluate(vertexBsdf(*z[at], towards(at, from)), towards(at, to)).pdf;
  };
  for (int j = 2; j <= k + 1; ++j)
    eyePdf[j] = areaPdf(j == 2 ? evaluate(primary, towards(1, 2)).pdf : bsdfPdf(j - 1, j - 2, j),
                        z[j - 1]->position, *z[j]);
  const SurfaceHit& light = *z[k + 1];
  const Geometry& g = geometries_[size_t(light.meshId)];
  lightPdf_[k + 1] = 1.0 / (double(selectableLights_.size()) * double(g.area));
  const float cosEmitted = glm::dot(light.geometricNormal, towards(k + 1, k));
  lightPdf_[k] = cosEmitted > 0 ? areaPdf(cosEmitted / kPi, light.position, *z[k]) : 0.0f;
  for (int j = k - 1; j >= 2; --j)
    lightPdf_[j] = areaPdf(bsdfPdf(j + 1, j + 2, j), z[j + 1]->position, *z[j]);
  const double lightSample = areaPdf(
      lightPdf(light, z[k]->position, z[k]->position, towards(k, k + 1)), z[k]->position, light);
  double strategy[kMaxBidirectionalBounces + 2] = {}, sum = 0;
  for (int s = 0; s <= k; ++s) {
    const int lastEye =
        k + 1 - s;  // z[2..lastEye] from the eye, z[lastEye + 1..k + 1] from the light
    double p = 1;
    for (int j = 2; j <= lastEye; ++j) p *= eyePdf[j];
    if (s == 1) p *= lightSample;
    if (s >= 2)
      for (int j = lastEye + 1; j <= k + 1; ++j) p *= lightPdf_[j];
    strategy[s] = p;
    sum += p * p;
  }
  return sum > 0 ? strategy[used] * strategy[used] / sum : 0.0;
}

FrameScene::Radiance FrameScene::shadeBidirectional(const PrimaryVertex& vertex,
                                                    const Sampler& sampler,
                                                    RayCounts& counts) const {
  Radiance out;
  counts.paths++;
  const VertexBsdf& v1 = vertex.bsdf;
  if (!v1.reflects) return out;
  const int maxBounces = scene_.maxBounces;
  // The scene loader refuses more; a Scene built in code may not.
  if (maxBounces > kMaxBidirectionalBounces)
    throw Error("bidirectional reference: max_bounces " + std::to_string(maxBounces) + " above " +
                std::to_string(kMaxBidirectionalBounces));
  const bool sobol = sampler.kind() == SamplerKind::OwenSobol;

  // The light path: y[0] on a light, y[1..] where it reflects (at most maxBounces - 1 of them:
  // a joined path keeps at least one eye vertex).
  PathVertex y[kMaxBidirectionalBounces];
  int lightVertices = 0;
  if (!selectableLights_.empty()) {
    const uint32_t base = eyePathDimensions();
    const size_t n = selectableLights_.size();
    const glm::vec2 choice = sampler.get2(base), onTriangle = sampler.get2(base + 2),
                    emitted = sampler.get2(base + 4);
    const size_t li = std::min(size_t(choice.x * float(n)), n - 1);
    const int mesh = selectableLights_[li];
    const Geometry& g = geometries_[size_t(mesh)];
    if (maxComponent(g.lightRadiance) > 0) {
      const size_t ti =
          std::min(g.areaGuide.lowerBound(g.areaCdf, choice.y * g.area), g.areaCdf.size() - 1);
      const glm::uvec3 tri = g.local->triangles[ti];
      y[0].s.position = uniformPointOnTriangle(g.positions[tri.x], g.positions[tri.y],
                                               g.positions[tri.z], onTriangle);
      y[0].s.geometricNormal = y[0].s.shadingNormal = g.faceNormals[ti];
      y[0].s.meshId = mesh;
      y[0].s.lightIndex = g.lightIndex;
      lightVertices = 1;
      // A cosine-distributed direction on the emitting side: radiance / (pdf_area pdf_dir) =
      // Le cos / ((1 / (n A)) (cos / pi)).
      glm::vec3 tangent, bitangent;
      const glm::vec3 ln = y[0].s.geometricNormal;
      orthonormalBasis(ln, tangent, bitangent);
      glm::vec3 dir = glm::normalize(cosineDirection(tangent, bitangent, ln, emitted.x, emitted.y));
      glm::vec3 beta = g.lightRadiance * (kPi * float(n) * g.area);
      glm::vec3 origin = offsetOrigin(y[0].s.position, ln);
      for (int j = 1; j < maxBounces; ++j) {
        SurfaceHit h;
        float t;
        counts.rays++;
        if (!intersect(origin, dir, kInf, h, t)) break;
        const SurfaceHit s = surface(h.meshId, h.primId, h.u, h.v);
        if (s.lightIndex >= 0) break;  // emitters do not reflect
        const VertexBsdf v = vertexBsdf(s, -dir);
        if (!v.reflects) break;
        y[j] = {s, beta, v};
        lightVertices = j + 1;
        if (j + 1 == maxBounces) break;
        const uint32_t dim = base + kLightPathFirstBounce + uint32_t(j - 1) * kDimsPerLightBounce;
        glm::vec2 u = sampler.get2(dim);
        float lobe = 0;
        if (sobol)
          reuseForLobe(v.pSpec, lobe, u.x);
        else
          lobe = sampler.get(dim + 2);
        glm::vec3 wi;
        if (!sampleDirection(v, v.pSpec, lobe, u.x, u.y, wi) || glm::dot(wi, v.ng) <= 0) break;
        const Lobes f = evaluate(v, wi);
        if (!(f.pdf > 0)) break;
        beta *= (f.diffuse + f.specular) * (f.NoL / f.pdf) * shadingNormalCorrection(v, -dir, wi);
        origin = v.origin;
        dir = wi;
      }
    }
  }

  // The eye path: at each vertex x_i its light sample and its joins to the light path, then on.
  // x[1]'s contributions split between the signals by lobe; x[i >= 2]'s arrive along the first
  // direction and are split by the first vertex's lobe weights, as in shade().
  PathVertex x[kMaxBidirectionalBounces + 1];
  x[1] = {vertex.hit, glm::vec3(1), v1};
  glm::vec3 incoming(0), weightDiffuse(0), weightSpecular(0);
  const SurfaceHit* z[kMaxBidirectionalBounces + 2];
  auto add = [&](int i, const Lobes& f, glm::vec3 rest) {  // f at x[i] times what lies beyond it
    if (i == 1) {
      out.diffuse += f.diffuse * rest;
      out.specular += f.specular * rest;
    } else {
      incoming += x[i].beta * (f.diffuse + f.specular) * rest;
    }
  };
  for (int i = 1; i <= maxBounces; ++i) {
    const PathVertex& xi = x[i];
    for (int a = 1; a <= i; ++a) z[a] = &x[a].s;
    const VertexSample vs = sampleVertex(xi.s, xi.v, sampler, uint32_t(i - 1) * kDimsPerVertex);
    if (vs.towardsLight) {  // s = 1
      counts.rays++;
      SurfaceHit light;
      bool seen = false;
      if (vs.coneLight >= 0) {  // where its ray meets the light's mesh first, from the front
        float t;
        if (intersect(xi.v.origin, vs.wiLight, kInf, light, t) && light.meshId == vs.coneLight) {
          light = surface(light.meshId, light.primId, light.u, light.v);
          seen = glm::dot(light.geometricNormal, -vs.wiLight) > 0;
        }
      } else {
        counts.occlusionRays++;
        const Segment ray = shadowSegment(xi.v.origin, vs.shadowEnd);
        seen = !occluded(xi.v.origin, ray.dir, ray.length);
        light.position = vs.lightPoint;
        light.geometricNormal = light.shadingNormal = vs.lightNormal;
        light.meshId = vs.areaLight;
        light.lightIndex = geometries_[size_t(vs.areaLight)].lightIndex;
      }
      if (seen) {
        z[i + 1] = &light;
        const double w = bidirectionalWeight(1, i, z, v1);
        add(i, vs.fLight, vs.le * float(vs.fLight.NoL * w / vs.pdfLight));
      }
    }
    for (int j = 1; j < lightVertices && i + j <= maxBounces; ++j) {  // s = j + 1
      const PathVertex& yj = y[j];
      const glm::vec3 d = yj.s.position - xi.s.position;
      const float dist2 = glm::dot(d, d);
      const glm::vec3 dir = d / std::sqrt(dist2);
      if (glm::dot(dir, xi.v.ng) <= 0 || glm::dot(-dir, yj.v.ng) <= 0) continue;
      const Lobes fx = evaluate(xi.v, dir), fy = evaluate(yj.v, -dir);
      if (!(fx.NoL > 0) || !(fy.NoL > 0)) continue;
      if (maxComponent(fy.diffuse + fy.specular) <= 0 ||
          maxComponent(fx.diffuse + fx.specular) <= 0)
        continue;
      counts.rays++;
      counts.occlusionRays++;
      const Segment ray = shadowSegment(xi.v.origin, yj.v.origin);
      if (occluded(xi.v.origin, ray.dir, ray.length)) continue;
      for (int a = 0; a <= j; ++a) z[i + 1 + a] = &y[j - a].s;
      const double w = bidirectionalWeight(j + 1, i + j, z, v1);
      // f_y cos_y (with the shading-normal correction) G's other cosine and distance, y's
      // throughput.
      const float geometry = fx.NoL * fy.NoL * shadingNormalCorrection(yj.v, yj.v.wo, -dir) / dist2;
      add(i, fx, (fy.diffuse + fy.specular) * yj.beta * float(geometry * w));
    }
    if (!vs.scatters) break;
    const glm::vec3 beta =
        i == 1 ? glm::vec3(1) : xi.beta * (vs.f.diffuse + vs.f.specular) * (vs.f.NoL / vs.f.pdf);
    if (i == 1) {
      weightDiffuse = vs.f.diffuse * (vs.f.NoL / vs.f.pdf);
      weightSpecular = vs.f.specular * (vs.f.NoL / vs.f.pdf);
    }
    SurfaceHit h;
    float t;
    counts.rays++;
    if (!intersect(xi.v.origin, vs.wi, kInf, h, t)) {
      incoming += beta * sky(vs.wi);  // the sky: no light path starts there
      break;
    }
    const SurfaceHit s = surface(h.meshId, h.primId, h.u, h.v);
    if (maxComponent(s.emission) > 0 && glm::dot(s.geometricNormal, -vs.wi) > 0) {  // s = 0
      double w = 1;  // an emitter no light path starts from (an emissive material)
      if (s.lightIndex >= 0 && geometries_[size_t(s.meshId)].area > 0) {
        z[i + 1] = &s;
        w = bidirectionalWeight(0, i, z, v1);
      }
      incoming += beta * s.emission * float(w);
    }
    if (s.lightIndex >= 0 || i == maxBounces) break;
    x[i + 1] = {s, beta, vertexBsdf(s, -vs.wi)};
    if (!x[i + 1].v.reflects) break;
  }
  out.diffuse += weightDiffuse * incoming;
  out.specular += weightSpecular * incoming;
  return out;
}

}  // namespace arena
