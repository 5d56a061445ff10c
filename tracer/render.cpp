#include "tracer/render.hpp"

#include <pmmintrin.h>
#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>
#include <xmmintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/image.hpp"
#include "core/sequence.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr int kTracerVersion = 7;  // bump when a change alters pixels: invalidates every cache
constexpr float kMissHitDist = 1e6f;
constexpr uint32_t kStratumPickSample = 0xFFFFF;  // sample index reserved for stratum picks
constexpr uint32_t kLowresFirstSample = 0x80000;  // low-res paths: independent of frame and reference

// Embree warns about denormals; flush them in every worker (called at the top of each task).
void flushDenormals() {
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

// The 1-spp colour of a surface seen from `eye`, exactly as a frame computes it; used both for
// frames and for the re-shaded gradient samples so equal inputs give bit-equal luminance.
struct PixelShade {
  FrameScene::Radiance radiance;
  glm::vec3 emission{0};
  glm::vec3 color() const { return radiance.diffuse + radiance.specular + emission; }
};
PixelShade shadePixel(const FrameScene& fs, const FrameScene::PrimaryVertex& vertex, const Sampler& sampler,
                      RayCounts& counts) {
  PixelShade out;
  if (glm::dot(vertex.hit.geometricNormal, vertex.bsdf.wo) > 0) out.emission = vertex.hit.emission;
  out.radiance = fs.shade(vertex, sampler, counts);
  return out;
}
FrameScene::PrimaryVertex primaryVertex(const FrameScene& fs, const SurfaceHit& s, glm::vec3 eye) {
  return fs.prepare(s, glm::normalize(eye - s.position));
}
PixelShade shadePixel(const FrameScene& fs, const SurfaceHit& s, glm::vec3 eye, const Sampler& sampler,
                      RayCounts& counts) {
  return shadePixel(fs, primaryVertex(fs, s, eye), sampler, counts);
}

template <class Body>
void forEachPixelRow(int height, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, height, 2), [&](const tbb::blocked_range<int>& rows) {
    flushDenormals();
    for (int y = rows.begin(); y != rows.end(); ++y) body(y);
  });
}

}  // namespace

RenderSettings RenderSettings::fromPreset(const std::string& name) {
  RenderSettings s;
  s.preset = name;
  if (name == "quick") {
    // 512 spp at most: glossy reflections of area lights would otherwise take 1024 spp per frame
    // and the whole suite would not render in 10 minutes on two cores (see the README).
    s.referenceSpp = 512;
    s.referenceMinSpp = 64;
    // Reference relMSE <= 1e-4 (was 9e-4 with the independent sampler, which left the reference
    // noisier than the best denoiser's error on three scenes; issue 13). Capped references say so.
    s.referenceRelError = 0.01;
  } else if (name == "paper") {
    s.width = 1280;
    s.height = 720;
    s.referenceSpp = 4096;
    s.referenceMinSpp = 4096;
    s.referenceRelError = 0;
  } else {
    throw Error("unknown preset '" + name + "': expected quick or paper");
  }
  return s;
}

json RenderSettings::pixelSettings(const Scene& scene) const {
  json px = {{"width", resolvedWidth(scene)},
             {"height", resolvedHeight(scene)},
             {"frames", resolvedFrames(scene)},
             {"referenceSpp", referenceSpp},
             {"referenceMinSpp", referenceMinSpp},
             {"referenceRelError", referenceRelError},
             {"maxBounces", resolvedMaxBounces(scene)},
             {"tracerVersion", kTracerVersion},
             {"referenceSampler", referenceSampler},
             {"referenceReplicates", referenceReplicates},
             {"referenceTile", referenceTile},
             {"preset", preset}};
  if (inputSeed != 0) px["inputSeed"] = inputSeed;  // absent by default: existing caches keep their hash
  if (lowresFactor > 0) {
    px["lowresFactor"] = lowresFactor;
    px["lowresSpp"] = lowresSpp;
  }
  return px;
}

SequenceRenderer::SequenceRenderer(const Scene& scene, const RenderSettings& settings)
    : scene_(scene), settings_(settings) {
  width_ = settings.resolvedWidth(scene);
  height_ = settings.resolvedHeight(scene);
  frames_ = settings.resolvedFrames(scene);
  if (width_ < 1 || height_ < 1 || frames_ < 1) throw Error("render settings: resolution and frames must be positive");
  if (settings.lowresFactor < 0 || settings.lowresFactor == 1 || settings.lowresSpp < 1 || settings.lowresSpp > 4096)
    throw Error("render settings: lowresFactor " + std::to_string(settings.lowresFactor) + " / lowresSpp " +
                std::to_string(settings.lowresSpp) + ": expected factor 0 (off) or >= 2 and spp in [1, 4096]");
  if (settings.maxBounces > 0) scene_.maxBounces = settings.maxBounces;
  if (settings.referenceSampler != "sobol" && settings.referenceSampler != "independent")
    throw Error("render settings: reference sampler '" + settings.referenceSampler +
                "' is unknown (expected sobol or independent)");
  if (settings.referenceReplicates < 2 || settings.referenceReplicates > 64)
    throw Error("render settings: reference replicates " + std::to_string(settings.referenceReplicates) +
                " out of range (expected 2..64)");
  if (settings.referenceTile < 0 || settings.referenceTile > 1024)
    throw Error("render settings: reference tile " + std::to_string(settings.referenceTile) +
                " out of range (expected 0 (one tile) .. 1024 pixels)");
  for (const Object& o : scene_.objects) meshes_.push_back(makeMesh(o));
  for (const Light& l : scene_.lights) meshes_.push_back(makeMesh(l.shape));
}

SequenceRenderer::~SequenceRenderer() = default;

uint32_t SequenceRenderer::frameSeed() const {
  if (settings_.inputSeed == 0) return scene_.seed;
  return uint32_t(Hasher().add(std::to_string(scene_.seed)).add(std::to_string(settings_.inputSeed)).value());
}

uint64_t SequenceRenderer::stateHash(int t) const {
  return evaluateState(scene_, t, width_, height_).hash();
}

const FrameScene& SequenceRenderer::frameScene(int t) {
  auto it = cache_.find(t);
  if (it != cache_.end()) return *it->second;
  // Keep only the frames a render still needs (current and previous).
  for (auto i = cache_.begin(); i != cache_.end();)
    i = (i->first < t - 1 || i->first > t) ? cache_.erase(i) : std::next(i);
  auto fs = std::make_unique<FrameScene>(device_, scene_, meshes_, evaluateState(scene_, t, width_, height_));
  return *cache_.emplace(t, std::move(fs)).first->second;
}

SequenceRenderer::FrameResult SequenceRenderer::renderFrame(int t) {
  const FrameScene& prev = frameScene(std::max(t - 1, 0));
  const FrameScene& cur = frameScene(t);
  const CameraState& cam = cur.state().camera;
  const CameraState& prevCam = prev.state().camera;
  const int w = width_, h = height_;
  Image diffuse(w, h, 3), specular(w, h, 3), emission(w, h, 3), color(w, h, 3), albedo(w, h, 3), specAlbedo(w, h, 3),
      normal(w, h, 3), position(w, h, 3), depth(w, h, 1), roughness(w, h, 1), meshId(w, h, 1, -1.0f),
      materialId(w, h, 1, -1.0f), motion(w, h, 2), specHitDist(w, h, 1), specHitDistMirror(w, h, 1);
  std::vector<RayCounts> rowCounts(static_cast<size_t>(h));
  auto put2 = [](Image& img, int x, int y, glm::vec2 v) {
    img.at(x, y, 0) = v.x;
    img.at(x, y, 1) = v.y;
  };
  auto put3 = [](Image& img, int x, int y, glm::vec3 v) {
    img.at(x, y, 0) = v.x;
    img.at(x, y, 1) = v.y;
    img.at(x, y, 2) = v.z;
  };
  forEachPixelRow(h, [&](int y) {
    RayCounts& counts = rowCounts[size_t(y)];
    for (int x = 0; x < w; ++x) {
      const glm::vec2 centre(float(x) + 0.5f, float(y) + 0.5f);
      const glm::vec3 dir = cam.rayDirection(centre.x, centre.y);
      SurfaceHit hit;
      float tHit;
      counts.rays++;
      if (!cur.intersect(cam.eye, dir, std::numeric_limits<float>::infinity(), hit, tHit, true)) {
        glm::vec3 sky = cur.sky(dir);
        put3(emission, x, y, sky);
        put3(color, x, y, sky);
        glm::vec2 prevPixel;
        if (prevCam.projectDirection(dir, prevPixel)) put2(motion, x, y, prevPixel - centre);
        continue;
      }
      const SurfaceHit s = cur.surface(hit.meshId, hit.primId, hit.u, hit.v);
      const glm::vec3 wo = glm::normalize(cam.eye - s.position);
      glm::vec3 n = glm::dot(s.geometricNormal, wo) < 0 ? -s.shadingNormal : s.shadingNormal;
      const float NoV = std::max(glm::dot(n, wo), 0.0f);
      put3(normal, x, y, n);
      put3(position, x, y, s.position);
      depth.at(x, y) = cam.viewDepth(s.position);
      roughness.at(x, y) = s.roughness;
      meshId.at(x, y) = float(s.meshId);
      materialId.at(x, y) = float(s.materialId);
      glm::vec2 prevPixel;
      if (prevCam.project(prev.positionOf(hit.meshId, hit.primId, hit.u, hit.v), prevPixel))
        put2(motion, x, y, prevPixel - centre);
      const glm::vec3 diffAlb = s.diffuseAlbedo();
      const glm::vec3 specAlb = s.lightIndex >= 0 ? glm::vec3(0) : specularAlbedo(s.f0(), s.roughness, NoV);
      put3(albedo, x, y, diffAlb);
      put3(specAlbedo, x, y, specAlb);
      if (s.lightIndex < 0) {  // the noise-free mirror ray's length: the oracle channel
        glm::vec3 r = 2.0f * glm::dot(wo, n) * n - wo;
        SurfaceHit mh;
        float tm;
        counts.rays++;
        float ng = glm::dot(s.geometricNormal, wo) < 0 ? -1.0f : 1.0f;
        glm::vec3 o = s.position + s.geometricNormal * ng * 1e-4f * (1.0f + glm::length(s.position));
        specHitDistMirror.at(x, y) =
            cur.intersect(o, r, std::numeric_limits<float>::infinity(), mh, tm) ? tm : kMissHitDist;
      }
      const Sampler sampler(frameSeed(), uint32_t(t), uint32_t(y * w + x), 0);
      // Prepared once: the path and the specular ray start from it.
      const FrameScene::PrimaryVertex vertex = primaryVertex(cur, s, cam.eye);
      const PixelShade px = shadePixel(cur, vertex, sampler, counts);
      // What a real-time tracer has: its own specular ray's length (one GGX sample, noisy), not
      // the path's continuation, which for a dielectric mostly took the diffuse lobe.
      if (s.lightIndex < 0)
        specHitDist.at(x, y) =
            std::min(cur.specularHitDistance(vertex, sampler, counts), kMissHitDist);
      // Demodulation (SVGF; Falcor divides by max(albedo, 0.001)).
      put3(diffuse, x, y, px.radiance.diffuse / glm::max(diffAlb, glm::vec3(1e-3f)));
      put3(specular, x, y, px.radiance.specular / glm::max(specAlb, glm::vec3(1e-3f)));
      put3(emission, x, y, px.emission);
      put3(color, x, y, px.color());
    }
  });

  FrameResult result;
  for (const RayCounts& c : rowCounts) result.counts += c;
  result.frame.set("diffuse", std::move(diffuse));
  result.frame.set("specular", std::move(specular));
  result.frame.set("emission", std::move(emission));
  result.frame.set("color", std::move(color));
  result.frame.set("albedo", std::move(albedo));
  result.frame.set("specAlbedo", std::move(specAlbedo));
  result.frame.set("normal", std::move(normal));
  result.frame.set("position", std::move(position));
  result.frame.set("depth", std::move(depth));
  result.frame.set("roughness", std::move(roughness));
  result.frame.set("meshId", std::move(meshId));
  result.frame.set("materialId", std::move(materialId));
  result.frame.set("motion", std::move(motion));
  result.frame.set("specHitDist", std::move(specHitDist));
  result.frame.set("specHitDistMirror", std::move(specHitDistMirror));
  if (t == 0) return result;

  // A-SVGF gradient samples (Schied et al. 2018, sec. 4): one previous-frame pixel per 3x3
  // stratum, forward-projected into frame t and re-shaded with frame t-1's random numbers.
  const int S = kGradientStratum;
  const int sw = (w + S - 1) / S, sh = (h + S - 1) / S;
  struct Candidate {
    bool valid = false;
    int qx = 0, qy = 0;
    float lumNew = 0, lumOld = 0;
  };
  std::vector<Candidate> candidates(size_t(sw) * size_t(sh));
  std::vector<RayCounts> stratumCounts(static_cast<size_t>(sh));
  forEachPixelRow(sh, [&](int sy) {
    RayCounts& counts = stratumCounts[size_t(sy)];
    for (int sx = 0; sx < sw; ++sx) {
      const int stratum = sy * sw + sx;
      const Sampler pick(frameSeed(), uint32_t(t - 1), uint32_t(stratum), kStratumPickSample);
      const int spanX = std::min(S, w - sx * S), spanY = std::min(S, h - sy * S);
      const int px = sx * S + std::min(int(pick.get(0) * float(spanX)), spanX - 1);
      const int py = sy * S + std::min(int(pick.get(1) * float(spanY)), spanY - 1);
      SurfaceHit hit;
      float tHit;
      counts.rays++;
      if (!prev.intersect(prevCam.eye, prevCam.rayDirection(float(px) + 0.5f, float(py) + 0.5f),
                          std::numeric_limits<float>::infinity(), hit, tHit, true))
        continue;  // the sky has no surface to follow
      const glm::vec3 pNow = cur.positionOf(hit.meshId, hit.primId, hit.u, hit.v);
      glm::vec2 q;
      if (!cam.project(pNow, q) || q.x < 0 || q.y < 0 || q.x >= float(w) || q.y >= float(h)) continue;
      const glm::vec3 toPoint = pNow - cam.eye;
      const float dist = glm::length(toPoint);
      counts.rays++;
      counts.occlusionRays++;
      if (cur.occluded(cam.eye, toPoint / dist, dist * (1.0f - 1e-4f))) continue;  // hidden at frame t
      const Sampler previousNumbers(frameSeed(), uint32_t(t - 1), uint32_t(py * w + px), 0);
      const SurfaceHit sPrev = prev.surface(hit.meshId, hit.primId, hit.u, hit.v);
      const SurfaceHit sNow = cur.surface(hit.meshId, hit.primId, hit.u, hit.v);
      Candidate& c = candidates[size_t(stratum)];
      c.valid = true;
      c.qx = int(q.x);
      c.qy = int(q.y);
      c.lumOld = luminanceOf(shadePixel(prev, sPrev, prevCam.eye, previousNumbers, counts).color());
      c.lumNew = luminanceOf(shadePixel(cur, sNow, cam.eye, previousNumbers, counts).color());
    }
  });
  // Each sample lands in the current-frame stratum containing its pixel; the first claim (in
  // source-stratum order) wins, which keeps the result independent of thread scheduling.
  Image grad(sw, sh, 5);
  for (const Candidate& c : candidates) {
    if (!c.valid) continue;
    const int dx = c.qx / S, dy = c.qy / S;
    if (grad.at(dx, dy, 4) != 0) continue;
    grad.at(dx, dy, 0) = float(c.qx);
    grad.at(dx, dy, 1) = float(c.qy);
    grad.at(dx, dy, 2) = c.lumNew;
    grad.at(dx, dy, 3) = c.lumOld;
    grad.at(dx, dy, 4) = 1.0f;
  }
  result.gradients.set("gradient", std::move(grad));
  for (const RayCounts& c : stratumCounts) result.counts += c;
  return result;
}

int SequenceRenderer::referenceReplicates() const {
  // At least 2 (a spread needs two), even (colorHalf takes half of them).
  return std::max(2, settings_.referenceReplicates + (settings_.referenceReplicates & 1));
}

ReferenceSums SequenceRenderer::emptyReferenceSums(int firstReplicate, int count) const {
  ReferenceSums sums;
  sums.width = width_;
  sums.height = height_;
  sums.replicates = count;
  sums.firstReplicate = firstReplicate;
  sums.tileSize = settings_.referenceTile > 0 ? settings_.referenceTile : std::max(width_, height_);
  sums.tileSamples.assign(size_t(sums.tilesX()) * size_t(sums.tilesY()), 0);
  sums.sum.assign(size_t(width_) * size_t(height_) * size_t(count) * ReferenceSums::kValues, 0.0);
  return sums;
}

void SequenceRenderer::extendReference(int t, ReferenceSums& sums, int perReplicate, RayCounts& total) {
  if (sums.replicates == 0) sums = emptyReferenceSums(0, referenceReplicates());
  std::vector<int> target = sums.tileSamples;
  for (int& n : target) n = std::max(n, perReplicate);
  extendReference(t, sums, target, total);
}

void SequenceRenderer::extendReference(int t, ReferenceSums& sums, const std::vector<int>& tileTarget,
                                       RayCounts& total) {
  const FrameScene& cur = frameScene(t);
  const int w = width_, h = height_;
  const size_t n = size_t(w) * size_t(h);
  constexpr int V = ReferenceSums::kValues;
  if (sums.replicates == 0) sums = emptyReferenceSums(0, referenceReplicates());
  if (sums.width != w || sums.height != h || sums.sum.size() != n * size_t(sums.replicates) * V || sums.tileSize < 1 ||
      sums.tileSamples.size() != size_t(sums.tilesX()) * size_t(sums.tilesY()) ||
      tileTarget.size() != sums.tileSamples.size())
    throw Error("reference sums of " + std::to_string(sums.width) + "x" + std::to_string(sums.height) + " (" +
                std::to_string(sums.tileSamples.size()) + " tiles) do not match the render's " + std::to_string(w) +
                "x" + std::to_string(h) + " (" + std::to_string(tileTarget.size()) + " tiles)");
  const int K = sums.replicates, allReplicates = referenceReplicates();
  if (sums.firstReplicate < 0 || sums.firstReplicate + K > allReplicates)
    throw Error("reference sums hold replicates " + std::to_string(sums.firstReplicate) + ".." +
                std::to_string(sums.firstReplicate + K - 1) + ", beyond the settings' " +
                std::to_string(allReplicates));
  bool grows = false;
  for (size_t i = 0; i < tileTarget.size(); ++i) grows |= tileTarget[i] > sums.tileSamples[i];
  if (!grows) return;
  std::vector<RayCounts> rowCounts(static_cast<size_t>(h));
  forEachPixelRow(h, [&](int y) {
    for (int x = 0; x < w; ++x) {
      const int tile = sums.tileOf(x, y), begin = sums.tileSamples[size_t(tile)];
      const int end = std::max(begin, tileTarget[size_t(tile)]);
      if (end > begin) extendPixel(t, cur, sums, x, y, begin, end, rowCounts[size_t(y)]);  // else it keeps its samples
    }
  });
  for (size_t i = 0; i < tileTarget.size(); ++i) sums.tileSamples[i] = std::max(sums.tileSamples[i], tileTarget[i]);
  for (const RayCounts& c : rowCounts) total += c;
}

void SequenceRenderer::extendPixel(int t, const FrameScene& cur, ReferenceSums& sums, int x, int y, int begin, int end,
                                   RayCounts& counts) const {
  const CameraState& cam = cur.state().camera;
  constexpr int V = ReferenceSums::kValues;
  const size_t i = size_t(y) * size_t(width_) + size_t(x);
  const int K = sums.replicates, allReplicates = referenceReplicates();
  const bool sobol = settings_.referenceSampler == "sobol";
  // The primary hit through the pixel centre is the same for every sample (as in the frames).
  const glm::vec3 dir = cam.rayDirection(float(x) + 0.5f, float(y) + 0.5f);
  SurfaceHit hit;
  float tHit;
  counts.rays++;
  const bool hasHit = cur.intersect(cam.eye, dir, std::numeric_limits<float>::infinity(), hit, tHit, true);
  SurfaceHit s;
  FrameScene::PrimaryVertex vertex;  // prepared once: every sample of the pixel starts here
  glm::vec3 demodDiffuse(0), demodSpecular(0);
  if (hasHit) {
    s = cur.surface(hit.meshId, hit.primId, hit.u, hit.v);
    vertex = primaryVertex(cur, s, cam.eye);
    const glm::vec3 wo = vertex.bsdf.wo;
    const glm::vec3 nrm = glm::dot(s.geometricNormal, wo) < 0 ? -s.shadingNormal : s.shadingNormal;
    const glm::vec3 specAlb =
        s.lightIndex >= 0 ? glm::vec3(0) : specularAlbedo(s.f0(), s.roughness, std::max(glm::dot(nrm, wo), 0.0f));
    demodDiffuse = 1.0f / glm::max(s.diffuseAlbedo(), glm::vec3(1e-3f));
    demodSpecular = 1.0f / glm::max(specAlb, glm::vec3(1e-3f));
  }
  const glm::vec3 sky = hasHit ? glm::vec3(0) : cur.sky(dir);
  // The emitted part of every sample's colour (shadePixel's), and the Sobol dimensions a path
  // reads.
  const glm::vec3 emission = hasHit && glm::dot(vertex.hit.geometricNormal, vertex.bsdf.wo) > 0
                                 ? vertex.hit.emission
                                 : glm::vec3(0);
  const Sampler::Reads reads = cur.sobolReads();
  const bool shades = hasHit && vertex.bsdf.reflects;  // else no path leaves: no numbers to fill
  for (int r = 0; r < K; ++r) {
    double* acc = &sums.sum[(i * size_t(K) + size_t(r)) * V];
    const int replicate = sums.firstReplicate + r;
    // The replicate's Sobol key and the dimensions' hashes, computed once per replicate.
    Sampler::DimensionHashes hashes;
    const Sampler sobolReplicate =
        sobol && hasHit ? Sampler::owenSobol(scene_.seed, uint32_t(t), uint32_t(i), uint32_t(replicate), 0)
                              .withHashes(hashes, cur.pathDimensions())
                        : Sampler(0, 0, 0, 0);
    // kBatchLanes samples at a time: their Sobol numbers filled together (Sampler::fillBatch),
    // shaded together (FrameScene::shadeBatch); summed in sample order.
    Sampler::Batch batch;
    for (int first = begin; first < end; first += int(Sampler::kBatchLanes)) {
      const int count = std::min(end - first, int(Sampler::kBatchLanes));
      Sampler samplers[Sampler::kBatchLanes];
      FrameScene::Radiance radiance[Sampler::kBatchLanes];
      if (hasHit) {
        if (sobol && shades) sobolReplicate.fillBatch(batch, reads, uint32_t(first));
        for (int l = 0; l < count; ++l)
          // Independent: sample ids 1.. (0 is the noisy frame's), interleaved over replicates.
          samplers[l] = sobol ? sobolReplicate.inBatch(batch, uint32_t(first), uint32_t(l))
                              : Sampler(scene_.seed, uint32_t(t), uint32_t(i),
                                        uint32_t(1 + (first + l) * allReplicates + replicate));
        cur.shadeBatch(vertex, samplers, count, radiance, counts);
      }
      for (int l = 0; l < count; ++l) {
        glm::vec3 c = sky, d(0), sp(0);
        if (hasHit) {
          c = PixelShade{radiance[l], emission}.color();
          d = radiance[l].diffuse * demodDiffuse;
          sp = radiance[l].specular * demodSpecular;
        }
        const float v[V] = {c.x, c.y, c.z, d.x, d.y, d.z, sp.x, sp.y, sp.z};
        for (int j = 0; j < V; ++j) acc[j] += v[j];
      }
    }
  }
}

void SequenceRenderer::extendTile(int t, ReferenceSums& sums, int tile, int perReplicate, RayCounts& total) {
  const int begin = sums.tileSamples[size_t(tile)];
  if (perReplicate <= begin) return;
  const FrameScene& cur = frameScene(t);
  const ReferenceSums::TileRect r = sums.tileRect(tile);
  const int tw = r.x1 - r.x0, th = r.y1 - r.y0;
  std::vector<RayCounts> pixelCounts(size_t(tw) * size_t(th));
  // A tile is a few dozen pixels: one pixel per task keeps both cores busy to its end.
  tbb::parallel_for(
      tbb::blocked_range<int>(0, tw * th, 1),
      [&](const tbb::blocked_range<int>& pixels) {
        flushDenormals();
        for (int p = pixels.begin(); p != pixels.end(); ++p)
          extendPixel(t, cur, sums, r.x0 + p % tw, r.y0 + p / tw, begin, perReplicate, pixelCounts[size_t(p)]);
      },
      tbb::simple_partitioner());
  sums.tileSamples[size_t(tile)] = perReplicate;
  for (const RayCounts& c : pixelCounts) total += c;
}

namespace {

// Per pixel and value j: the mean of the replicate means, the variance of that mean from their
// spread, and the mean of the first half of the replicates.
struct ReplicateStats {
  double mean, varOfMean, half;
};
ReplicateStats replicateStats(const ReferenceSums& sums, size_t pixel, int j) {
  const int K = sums.replicates;
  const double n = double(sums.samplesOfPixel(pixel));
  const double* base = &sums.sum[pixel * size_t(K) * ReferenceSums::kValues];
  double total = 0, half = 0;
  for (int r = 0; r < K; ++r) {
    total += base[r * ReferenceSums::kValues + j];
    if (r == K / 2 - 1) half = total;
  }
  const double mean = total / (n * K);
  double ss = 0;
  for (int r = 0; r < K; ++r) {
    const double d = base[r * ReferenceSums::kValues + j] / n - mean;
    ss += d * d;
  }
  return {mean, ss / (double(K) * double(K - 1)), half / (n * (K / 2))};
}

}  // namespace

LayerSet referenceLayersFromSums(const ReferenceSums& sums) {
  if (sums.tileSamples.empty() || sums.minPerReplicate() < 1 || sums.replicates < 2)
    throw Error("a reference needs >= 2 replicates of >= 1 sample");
  const int w = sums.width, h = sums.height;
  const size_t n = size_t(w) * size_t(h);
  LayerSet out;
  const char* names[3] = {"color", "diffuse", "specular"};
  const char* varNames[3] = {"colorVar", "diffuseVar", "specularVar"};
  Image colorHalf(w, h, 3);
  for (int l = 0; l < 3; ++l) {
    Image mean(w, h, 3), varMean(w, h, 3);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) {
        const ReplicateStats st = replicateStats(sums, i, l * 3 + c);
        mean.plane(c)[i] = float(st.mean);
        varMean.plane(c)[i] = float(st.varOfMean);
        if (l == 0) colorHalf.plane(c)[i] = float(st.half);
      }
    out.set(names[l], std::move(mean));
    out.set(varNames[l], std::move(varMean));
  }
  out.set("colorHalf", std::move(colorHalf));
  return out;
}

double referenceTileShare(const ReferenceSums& sums, int tile) {
  const ReferenceSums::TileRect r = sums.tileRect(tile);
  double share = 0;
  for (int y = r.y0; y < r.y1; ++y)
    for (int x = r.x0; x < r.x1; ++x)
      for (int c = 0; c < 3; ++c) {
        const ReplicateStats st = replicateStats(sums, size_t(y) * size_t(sums.width) + size_t(x), c);
        share += st.varOfMean / (st.mean * st.mean + 0.01);  // metrics.md's eps
      }
  return share;
}

std::vector<double> referenceTileShares(const ReferenceSums& sums) {
  std::vector<double> shares(sums.tileSamples.size(), 0.0);
  tbb::parallel_for(0, int(shares.size()), [&](int tile) { shares[size_t(tile)] = referenceTileShare(sums, tile); });
  return shares;
}

namespace {
// The estimate from the tiles' shares, summed in tile order: the stopping decision is deterministic.
double relMseOfShares(const ReferenceSums& sums, const std::vector<double>& shares) {
  double total = 0;
  for (double share : shares) total += share;
  return total / (double(sums.width) * double(sums.height) * 3);
}
}  // namespace

double estimatedReferenceRelMse(const ReferenceSums& sums) {
  return relMseOfShares(sums, referenceTileShares(sums));
}

Scene withIndependentSeed(Scene scene) {
  scene.seed = uint32_t(mix64(uint64_t(scene.seed) ^ 0x676f6c645f736565ull) >> 32);  // any fixed offset
  return scene;
}

ReferenceResult SequenceRenderer::renderReference(int t) {
  ReferenceSums sums;
  return continueReference(t, sums, settings_.referenceRelError * settings_.referenceRelError, settings_.referenceSpp);
}

ReferenceResult SequenceRenderer::continueReference(int t, ReferenceSums& sums, double targetRelMse, int maxSpp) {
  ReferenceResult result;
  const int K = referenceReplicates();
  const int maxPer = std::max(1, (std::max(1, maxSpp) + K - 1) / K);
  const int minPer = std::min(std::max(1, (settings_.referenceMinSpp + K - 1) / K), maxPer);
  if (sums.replicates == 0) sums = emptyReferenceSums(0, K);
  // Without a target every pixel gets the cap at once (the same bits as any schedule up to it).
  std::vector<int> pilot = sums.tileSamples;
  for (int& n : pilot) n = std::max(n, targetRelMse > 0 ? minPer : maxPer);
  extendReference(t, sums, pilot, result.counts);
  std::vector<double> shares = referenceTileShares(sums);
  result.estimatedRelMse = relMseOfShares(sums, shares);
  // A round left part way under another cap is planned again (its counts may exceed this one).
  if (sums.roundPending() && *std::max_element(sums.roundTarget.begin(), sums.roundTarget.end()) > maxPer)
    sums.roundTarget.clear();
  while (targetRelMse > 0 && !(result.estimatedRelMse <= targetRelMse)) {  // NaN: not met
    if (!sums.roundPending()) {
      sums.roundTarget = nextReferenceAllocation(sums, maxPer);
      if (sums.roundTarget == sums.tileSamples) {
        result.capped = true;
        break;
      }
    }
    // The round's tiles in order of the error each saves per sample added: a tile going from n to
    // n' samples saves share (1 - n / n') for (n' - n) P samples, i.e. share / (n' P). The tiles a
    // stopped round has not reached still hold what they held when it was planned, so a continued
    // round takes them in the same order.
    std::vector<int> order;
    for (size_t i = 0; i < shares.size(); ++i)
      if (sums.roundTarget[i] > sums.tileSamples[i]) order.push_back(int(i));
    auto saving = [&](int i) {  // a tile whose share is not a number goes last (a strict weak order)
      const double v = shares[size_t(i)] / (double(sums.roundTarget[size_t(i)]) * sums.tilePixels(i));
      return std::isfinite(v) ? v : -std::numeric_limits<double>::infinity();
    };
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return saving(a) > saving(b); });
    for (int tile : order) {
      extendTile(t, sums, tile, sums.roundTarget[size_t(tile)], result.counts);
      shares[size_t(tile)] = referenceTileShare(sums, tile);
      result.estimatedRelMse = relMseOfShares(sums, shares);
      if (result.estimatedRelMse <= targetRelMse) break;
    }
  }
  if (!sums.roundPending()) sums.roundTarget.clear();
  result.spp = sums.spp();
  result.sppMin = sums.minPerReplicate() * sums.replicates;
  result.sppMax = sums.maxPerReplicate() * sums.replicates;
  result.targetRelMse = targetRelMse;
  result.layers = referenceLayersFromSums(sums);
  return result;
}

bool ReferenceSums::roundPending() const {
  if (roundTarget.size() != tileSamples.size()) return false;
  for (size_t i = 0; i < tileSamples.size(); ++i)
    if (roundTarget[i] > tileSamples[i]) return true;
  return false;
}

ReferenceSums::TileRect ReferenceSums::tileRect(int tile) const {
  const int x0 = (tile % tilesX()) * tileSize, y0 = (tile / tilesX()) * tileSize;
  return {x0, y0, std::min(width, x0 + tileSize), std::min(height, y0 + tileSize)};
}

int ReferenceSums::tilePixels(int tile) const {
  const TileRect r = tileRect(tile);
  return (r.x1 - r.x0) * (r.y1 - r.y0);
}

double ReferenceSums::meanSpp() const {
  double samples = 0;
  for (size_t tile = 0; tile < tileSamples.size(); ++tile) samples += double(tileSamples[tile]) * tilePixels(int(tile));
  return samples * replicates / (double(width) * double(height));
}

int ReferenceSums::minPerReplicate() const {
  return *std::min_element(tileSamples.begin(), tileSamples.end());
}
int ReferenceSums::maxPerReplicate() const {
  return *std::max_element(tileSamples.begin(), tileSamples.end());
}

std::vector<int> nextReferenceAllocation(const ReferenceSums& sums, int maxPer, double growth,
                                         double maxMeanPerReplicate) {
  const size_t tiles = sums.tileSamples.size();
  // Each tile's share of the estimate (before the division by the pixel and channel count), in a
  // fixed order: the allocation is deterministic.
  const std::vector<double> share = referenceTileShares(sums);
  std::vector<double> weight(tiles), pixels(tiles);
  double budget = 0, capBudget = 0;
  bool canGrow = false;
  for (size_t i = 0; i < tiles; ++i) {
    pixels[i] = sums.tilePixels(int(i));
    const int n = sums.tileSamples[i];
    weight[i] = std::sqrt(share[i] * n / pixels[i]);  // sqrt(u_T / P_T)
    budget += growth * n * pixels[i];
    capBudget += double(std::max(n, maxPer)) * pixels[i];
    canGrow |= weight[i] > 0 && n < maxPer;
  }
  if (maxMeanPerReplicate > 0) budget = std::min(budget, maxMeanPerReplicate * double(sums.width) * sums.height);
  if (!canGrow) return sums.tileSamples;
  auto clamped = [&](size_t i, double n) {
    return std::clamp(n, double(sums.tileSamples[i]), double(std::max(sums.tileSamples[i], maxPer)));
  };
  // The water level lambda with sum_T P_T clamp(lambda w_T) = budget (bisection: deterministic).
  double lo = 0, hi = 1;
  auto spent = [&](double lambda) {
    double total = 0;
    for (size_t i = 0; i < tiles; ++i) total += pixels[i] * clamped(i, lambda * weight[i]);
    return total;
  };
  const double reachable = std::min(budget, capBudget);
  for (int i = 0; i < 200 && spent(hi) < reachable; ++i) hi *= 2;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (spent(mid) < reachable ? lo : hi) = mid;
  }
  std::vector<int> next(tiles);
  bool grew = false;
  for (size_t i = 0; i < tiles; ++i) {
    const double ideal = clamped(i, hi * weight[i]);
    int pow2 = 1;
    while (pow2 < ideal) pow2 *= 2;
    if (double(pow2) * M_SQRT1_2 > ideal) pow2 /= 2;  // nearest power of two in log2
    next[i] = int(clamped(i, double(std::max(pow2, 1))));
    grew |= next[i] > sums.tileSamples[i];
  }
  if (!grew) {
    // Rounding kept everything: double tiles in order of error saved per sample added (share_T /
    // (2 n_T P_T)) while the budget lasts, and at least the first.
    std::vector<size_t> order;
    for (size_t i = 0; i < tiles; ++i)
      if (weight[i] > 0 && sums.tileSamples[i] < maxPer) order.push_back(i);
    auto saved = [&](size_t i) { return share[i] / (double(sums.tileSamples[i]) * pixels[i]); };
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return saved(a) > saved(b); });
    double used = 0;
    for (size_t i = 0; i < tiles; ++i) used += double(sums.tileSamples[i]) * pixels[i];
    for (size_t k = 0; k < order.size(); ++k) {
      const size_t i = order[k];
      const int doubled = int(clamped(i, 2.0 * sums.tileSamples[i]));
      const double cost = double(doubled - sums.tileSamples[i]) * pixels[i];
      if (k > 0 && used + cost > reachable) break;
      next[i] = doubled;
      used += cost;
    }
  }
  return next;
}

// CAPCOM 2023 slides 19-21: "120x67, 16-64 rays" beside the 1-spp frame. Each texel re-traces its
// anchor pixel's primary ray (so its G-buffer is the frame's) and averages lowresSpp independent
// paths: demodulated diffuse and specular, and the diffuse signal's luminance-weighted mean
// incident direction (slide 21: "color / average direction"). Extra input rays: they follow
// inputSeed.
LayerSet SequenceRenderer::renderLowres(int t, RayCounts& total) {
  const FrameScene& cur = frameScene(t);
  const CameraState& cam = cur.state().camera;
  const int f = settings_.lowresFactor, spp = settings_.lowresSpp;
  const int lw = lowresSize(width_, f), lh = lowresSize(height_, f);
  Image diffuse(lw, lh, 3), specular(lw, lh, 3), direction(lw, lh, 3);
  std::vector<RayCounts> rowCounts(static_cast<size_t>(lh));
  forEachPixelRow(lh, [&](int ly) {
    RayCounts& counts = rowCounts[size_t(ly)];
    const int y = lowresAnchor(ly, f, height_);
    for (int lx = 0; lx < lw; ++lx) {
      const int x = lowresAnchor(lx, f, width_);
      SurfaceHit hit;
      float tHit;
      counts.rays++;
      if (!cur.intersect(cam.eye, cam.rayDirection(float(x) + 0.5f, float(y) + 0.5f),
                         std::numeric_limits<float>::infinity(), hit, tHit, true))
        continue;  // sky: no reflected light
      const SurfaceHit s = cur.surface(hit.meshId, hit.primId, hit.u, hit.v);
      const glm::vec3 wo = glm::normalize(cam.eye - s.position);
      const glm::vec3 n = glm::dot(s.geometricNormal, wo) < 0 ? -s.shadingNormal : s.shadingNormal;
      const glm::vec3 specAlb =
          s.lightIndex >= 0 ? glm::vec3(0) : specularAlbedo(s.f0(), s.roughness, std::max(glm::dot(n, wo), 0.0f));
      glm::vec3 d(0), sp(0), dir(0);
      const FrameScene::PrimaryVertex vertex = cur.prepare(s, wo);
      for (int k = 0; k < spp; ++k) {
        const Sampler sampler(frameSeed(), uint32_t(t), uint32_t(y * width_ + x), kLowresFirstSample + uint32_t(k));
        const FrameScene::Radiance r = cur.shade(vertex, sampler, counts);
        d += r.diffuse;
        sp += r.specular;
        dir += r.diffuseDirection;
      }
      const float weight = luminanceOf(d);
      const glm::vec3 meanDir = weight > 0 ? dir / weight : glm::vec3(0);
      const glm::vec3 dMean = d / float(spp) / glm::max(s.diffuseAlbedo(), glm::vec3(1e-3f));
      const glm::vec3 sMean = sp / float(spp) / glm::max(specAlb, glm::vec3(1e-3f));
      for (int c = 0; c < 3; ++c) {
        diffuse.at(lx, ly, c) = dMean[c];
        specular.at(lx, ly, c) = sMean[c];
        direction.at(lx, ly, c) = meanDir[c];
      }
    }
  });
  for (const RayCounts& c : rowCounts) total += c;
  LayerSet out;
  out.set("diffuse", std::move(diffuse));
  out.set("specular", std::move(specular));
  out.set("direction", std::move(direction));
  return out;
}

}  // namespace arena
