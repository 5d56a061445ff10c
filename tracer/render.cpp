#include "tracer/render.hpp"

#include <tbb/blocked_range2d.h>
#include <tbb/parallel_for.h>
#include <xmmintrin.h>
#include <pmmintrin.h>

#include <chrono>
#include <cmath>
#include <cstdio>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/image.hpp"
#include "core/sequence.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr int kTracerVersion = 2;  // bump when a change alters pixels: invalidates every cache
constexpr float kMissHitDist = 1e6f;
constexpr uint32_t kStratumPickSample = 0xFFFFF;  // sample index reserved for stratum picks

// Embree warns about denormals; flush them in every worker (called at the top of each task).
void flushDenormals() {
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

float lum(glm::vec3 c) { return luminance(c.x, c.y, c.z); }

// The 1-spp colour of a surface seen from `eye`, exactly as a frame computes it; used both for
// frames and for the re-shaded gradient samples so equal inputs give bit-equal luminance.
struct PixelShade {
  FrameScene::Radiance radiance;
  glm::vec3 emission{0};
  glm::vec3 color() const { return radiance.diffuse + radiance.specular + emission; }
};
PixelShade shadePixel(const FrameScene& fs, const SurfaceHit& s, glm::vec3 eye, const Sampler& sampler,
                      RayCounts& counts) {
  PixelShade out;
  glm::vec3 wo = glm::normalize(eye - s.position);
  if (glm::dot(s.geometricNormal, wo) > 0) out.emission = s.emission;
  out.radiance = fs.shade(s, wo, sampler, counts);
  return out;
}

template <class Body>
void forEachPixelRow(int height, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<int>(0, height, 2), [&](const tbb::blocked_range<int>& rows) {
    flushDenormals();
    for (int y = rows.begin(); y != rows.end(); ++y) body(y);
  });
}

std::string formatSeconds(double s) {
  char buf[32];
  int total = int(std::lround(s));
  std::snprintf(buf, sizeof buf, "%d:%02d", total / 60, total % 60);
  return buf;
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
    s.referenceRelError = 0.03;  // reference relMSE <= 9e-4, ~10-40x below the denoisers' errors
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
  json px = {{"width", resolvedWidth(scene)}, {"height", resolvedHeight(scene)}, {"frames", resolvedFrames(scene)},
          {"referenceSpp", referenceSpp}, {"referenceMinSpp", referenceMinSpp},
          {"referenceRelError", referenceRelError},
          {"maxBounces", maxBounces > 0 ? maxBounces : scene.maxBounces}, {"tracerVersion", kTracerVersion},
          {"preset", preset}};
  if (inputSeed != 0) px["inputSeed"] = inputSeed;  // absent by default: existing caches keep their hash
  return px;
}

std::string sequenceHash(const Scene& scene, const RenderSettings& settings) {
  json px = settings.pixelSettings(scene);
  px.erase("preset");  // a name; the values it stands for are hashed
  return Hasher().add(scene.contentHash).add(px.dump()).hex();
}

fs::path sequenceDir(const Scene& scene, const RenderSettings& settings, const fs::path& cacheRoot) {
  return cacheRoot / (scene.name + "-" + sequenceHash(scene, settings).substr(0, 12));
}

SequenceRenderer::SequenceRenderer(const Scene& scene, const RenderSettings& settings)
    : scene_(scene), settings_(settings) {
  width_ = settings.resolvedWidth(scene);
  height_ = settings.resolvedHeight(scene);
  frames_ = settings.resolvedFrames(scene);
  if (width_ < 1 || height_ < 1 || frames_ < 1) throw Error("render settings: resolution and frames must be positive");
  if (settings.maxBounces > 0) scene_.maxBounces = settings.maxBounces;
  for (const Object& o : scene_.objects) meshes_.push_back(makeMesh(o.shape, o.meshFile));
  for (const Light& l : scene_.lights) meshes_.push_back(makeMesh(l.shape, ""));
}

SequenceRenderer::~SequenceRenderer() = default;

uint32_t SequenceRenderer::frameSeed() const {
  if (settings_.inputSeed == 0) return scene_.seed;
  return uint32_t(Hasher().add(std::to_string(scene_.seed)).add(std::to_string(settings_.inputSeed)).value());
}

uint64_t SequenceRenderer::stateHash(int t) const { return evaluateState(scene_, t, width_, height_).hash(); }

const FrameScene& SequenceRenderer::frameScene(int t) {
  auto it = cache_.find(t);
  if (it != cache_.end()) return *it->second;
  // Keep only the frames a render still needs (current and previous).
  for (auto i = cache_.begin(); i != cache_.end();) i = (i->first < t - 1 || i->first > t) ? cache_.erase(i) : std::next(i);
  auto fs = std::make_unique<FrameScene>(device_, scene_, meshes_, evaluateState(scene_, t, width_, height_));
  return *cache_.emplace(t, std::move(fs)).first->second;
}

SequenceRenderer::FrameResult SequenceRenderer::renderFrame(int t) {
  const FrameScene& prev = frameScene(std::max(t - 1, 0));
  const FrameScene& cur = frameScene(t);
  const CameraState& cam = cur.state().camera;
  const CameraState& prevCam = prev.state().camera;
  const int w = width_, h = height_;
  Image diffuse(w, h, 3), specular(w, h, 3), emission(w, h, 3), color(w, h, 3), albedo(w, h, 3),
      specAlbedo(w, h, 3), normal(w, h, 3), position(w, h, 3), depth(w, h, 1), roughness(w, h, 1),
      meshId(w, h, 1, -1.0f), materialId(w, h, 1, -1.0f), motion(w, h, 2), specHitDist(w, h, 1),
      specHitDistMirror(w, h, 1);
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
      const PixelShade px = shadePixel(cur, s, cam.eye, sampler, counts);
      // What a real-time tracer has: the 1-spp sample's own hit distance (noisy).
      if (s.lightIndex < 0) specHitDist.at(x, y) = std::min(px.radiance.hitDistance, kMissHitDist);
      // Demodulation (SVGF; Falcor divides by max(albedo, 0.001)).
      put3(diffuse, x, y, px.radiance.diffuse / glm::max(diffAlb, glm::vec3(1e-3f)));
      put3(specular, x, y, px.radiance.specular / glm::max(specAlb, glm::vec3(1e-3f)));
      put3(emission, x, y, px.emission);
      put3(color, x, y, px.color());
    }
  });

  FrameResult result;
  for (const RayCounts& c : rowCounts) {
    result.counts.rays += c.rays;
    result.counts.paths += c.paths;
  }
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
      if (cur.occluded(cam.eye, toPoint / dist, dist * (1.0f - 1e-4f))) continue;  // hidden at frame t
      const Sampler previousNumbers(frameSeed(), uint32_t(t - 1), uint32_t(py * w + px), 0);
      const SurfaceHit sPrev = prev.surface(hit.meshId, hit.primId, hit.u, hit.v);
      const SurfaceHit sNow = cur.surface(hit.meshId, hit.primId, hit.u, hit.v);
      Candidate& c = candidates[size_t(stratum)];
      c.valid = true;
      c.qx = int(q.x);
      c.qy = int(q.y);
      c.lumOld = lum(shadePixel(prev, sPrev, prevCam.eye, previousNumbers, counts).color());
      c.lumNew = lum(shadePixel(cur, sNow, cam.eye, previousNumbers, counts).color());
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
  for (const RayCounts& c : stratumCounts) {
    result.counts.rays += c.rays;
    result.counts.paths += c.paths;
  }
  return result;
}

LayerSet SequenceRenderer::renderReference(int t, int& spp, RayCounts& total) {
  const FrameScene& cur = frameScene(t);
  const CameraState& cam = cur.state().camera;
  const int w = width_, h = height_;
  const size_t n = size_t(w) * size_t(h);
  // Running sums per pixel of (colour, diffuse, specular) x RGB, and of their squares.
  std::vector<double> sum(n * 9, 0.0), sumSq(n * 9, 0.0);
  std::vector<SurfaceHit> primary(n);
  std::vector<uint8_t> hasHit(n, 0);
  std::vector<glm::vec3> demodDiffuse(n), demodSpecular(n), skyColor(n);
  std::vector<RayCounts> rowCounts(static_cast<size_t>(h));
  forEachPixelRow(h, [&](int y) {  // primary hits are the same for every sample (pixel centres)
    for (int x = 0; x < w; ++x) {
      size_t i = size_t(y) * w + x;
      glm::vec3 dir = cam.rayDirection(float(x) + 0.5f, float(y) + 0.5f);
      SurfaceHit hit;
      float tHit;
      rowCounts[size_t(y)].rays++;
      if (!cur.intersect(cam.eye, dir, std::numeric_limits<float>::infinity(), hit, tHit, true)) {
        skyColor[i] = cur.sky(dir);
        continue;
      }
      hasHit[i] = 1;
      primary[i] = cur.surface(hit.meshId, hit.primId, hit.u, hit.v);
      const SurfaceHit& s = primary[i];
      glm::vec3 wo = glm::normalize(cam.eye - s.position);
      glm::vec3 nrm = glm::dot(s.geometricNormal, wo) < 0 ? -s.shadingNormal : s.shadingNormal;
      glm::vec3 specAlb = s.lightIndex >= 0 ? glm::vec3(0)
                                            : specularAlbedo(s.f0(), s.roughness, std::max(glm::dot(nrm, wo), 0.0f));
      demodDiffuse[i] = 1.0f / glm::max(s.diffuseAlbedo(), glm::vec3(1e-3f));
      demodSpecular[i] = 1.0f / glm::max(specAlb, glm::vec3(1e-3f));
    }
  });
  auto estimatedRelMse = [&](int samples) {
    // Mean over pixels and colour channels of Var(mean) / (mean^2 + 0.01) (metrics.md eps).
    std::vector<double> rowSums(size_t(h), 0.0);
    tbb::parallel_for(0, h, [&](int y) {
      double acc = 0;
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) {
          size_t k = (size_t(y) * w + x) * 9 + c;
          double mean = sum[k] / samples;
          double var = std::max(0.0, sumSq[k] / samples - mean * mean) * samples / std::max(samples - 1, 1);
          acc += (var / samples) / (mean * mean + 0.01);
        }
      rowSums[size_t(y)] = acc;
    });
    double relMse = 0;
    for (double r : rowSums) relMse += r;  // fixed order: the stopping decision is deterministic
    return relMse / double(n * 3);
  };
  const int maxSpp = std::max(1, settings_.referenceSpp);
  const int minSpp = std::min(std::max(1, settings_.referenceMinSpp), maxSpp);
  int done = 0, batch = std::min(minSpp, maxSpp);
  while (done < maxSpp) {
    const int begin = done, end = std::min(maxSpp, done + batch);
    forEachPixelRow(h, [&](int y) {
      RayCounts& counts = rowCounts[size_t(y)];
      for (int x = 0; x < w; ++x) {
        size_t i = size_t(y) * w + x;
        double* s = &sum[i * 9];
        double* s2 = &sumSq[i * 9];
        for (int k = begin; k < end; ++k) {
          glm::vec3 c = skyColor[i], d(0), sp(0);
          if (hasHit[i]) {
            // Samples 1.. are independent of the noisy frame's sample 0.
            const Sampler sampler(scene_.seed, uint32_t(t), uint32_t(i), uint32_t(k + 1));
            PixelShade px = shadePixel(cur, primary[i], cam.eye, sampler, counts);
            c = px.color();
            d = px.radiance.diffuse * demodDiffuse[i];
            sp = px.radiance.specular * demodSpecular[i];
          }
          const float v[9] = {c.x, c.y, c.z, d.x, d.y, d.z, sp.x, sp.y, sp.z};
          for (int j = 0; j < 9; ++j) {
            s[j] += v[j];
            s2[j] += double(v[j]) * v[j];
          }
        }
      }
    });
    done = end;
    if (settings_.referenceRelError > 0 && done >= minSpp &&
        estimatedRelMse(done) <= settings_.referenceRelError * settings_.referenceRelError)
      break;
    batch = done;  // doubling schedule
  }
  spp = done;
  LayerSet out;
  const char* names[3] = {"color", "diffuse", "specular"};
  const char* varNames[3] = {"colorVar", "diffuseVar", "specularVar"};
  for (int l = 0; l < 3; ++l) {
    Image mean(w, h, 3), varMean(w, h, 3);
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) {
        size_t k = i * 9 + size_t(l) * 3 + c;
        double m = sum[k] / done;
        double var = std::max(0.0, sumSq[k] / done - m * m) * done / std::max(done - 1, 1);
        mean.plane(c)[i] = float(m);
        varMean.plane(c)[i] = float(var / done);
      }
    out.set(names[l], std::move(mean));
    out.set(varNames[l], std::move(varMean));
  }
  for (const RayCounts& c : rowCounts) {
    total.rays += c.rays;
    total.paths += c.paths;
  }
  return out;
}

namespace {

// A cached file is trusted only if it is a complete EXR with every expected channel, written for
// this exact hash, kind and index.
bool cachedFileValid(const fs::path& path, const std::string& hash, const std::string& kind, int index,
                     const std::vector<LayerSpec>& specs, std::string& why) {
  if (!fs::exists(path)) {
    why = "missing";
    return false;
  }
  try {
    // A full read: a truncated tile or line only shows when its pixels are decoded.
    ExrContents contents = readExr(path, specs);
    auto attr = [&](const char* name) {
      auto it = contents.attributes.find(name);
      return it == contents.attributes.end() ? std::string() : it->second;
    };
    if (attr("arena.hash") != hash || attr("arena.kind") != kind || attr("arena.index") != std::to_string(index)) {
      why = "written for another scene/settings (foreign or stale)";
      return false;
    }
  } catch (const std::exception& e) {
    why = e.what();
    if (why.find("Early end of file") != std::string::npos || why.find("truncated") != std::string::npos)
      why = "truncated";
    return false;
  }
  return true;
}

}  // namespace

fs::path renderSequence(const Scene& scene, const RenderSettings& settings, const fs::path& cacheRoot,
                        const ProgressFn& progress) {
  const std::string hash = sequenceHash(scene, settings);
  const fs::path dir = sequenceDir(scene, settings, cacheRoot);
  fs::create_directories(dir);
  SequenceRenderer renderer(scene, settings);
  const int frames = renderer.frames();
  auto say = [&](const std::string& s) {
    if (progress) progress(s);
  };

  SequenceInfo info;
  info.scene = scene.name;
  info.purpose = scene.purpose;
  info.hash = hash;
  info.width = renderer.width();
  info.height = renderer.height();
  info.frames = frames;
  info.settings = settings.pixelSettings(scene);
  for (const SceneEvent& e : scene.events)
    if (e.frame < frames) info.events.push_back({e.frame, e.kind, e.what});
  // Frames with equal animation state share one reference.
  std::map<uint64_t, int> referenceOfState;
  std::vector<int> firstFrameOfReference;
  for (int t = 0; t < frames; ++t) {
    SceneState st = evaluateState(renderer.scene(), t, renderer.width(), renderer.height());
    info.cameras.push_back(st.camera);
    auto [it, inserted] = referenceOfState.emplace(st.hash(), int(firstFrameOfReference.size()));
    if (inserted) firstFrameOfReference.push_back(t);
    info.referenceOfFrame.push_back(it->second);
  }
  const fs::path infoPath = dir / "sequence.json";

  const auto start = std::chrono::steady_clock::now();
  const int jobs = frames + int(firstFrameOfReference.size());
  int jobsDone = 0, jobsRendered = 0;
  auto report = [&](const std::string& what, const RayCounts& c, double seconds) {
    ++jobsDone;
    ++jobsRendered;
    double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    double eta = elapsed / jobsRendered * (jobs - jobsDone);
    char buf[256];
    std::snprintf(buf, sizeof buf, "[%s] %s (%d/%d)  %.2f Mpaths/s %.2f Mrays/s  ETA %s", scene.name.c_str(),
                  what.c_str(), jobsDone, jobs, double(c.paths) / seconds * 1e-6, double(c.rays) / seconds * 1e-6,
                  formatSeconds(eta).c_str());
    say(buf);
  };
  auto attributes = [&](const char* kind, int index) {
    return ExrAttributes{{"arena.hash", hash}, {"arena.kind", kind}, {"arena.index", std::to_string(index)},
                         {"arena.scene", scene.name}};
  };

  for (int t = 0; t < frames; ++t) {
    std::string why, whyGrad;
    const fs::path fp = Sequence::framePath(dir, t), gp = Sequence::gradientPath(dir, t);
    bool frameOk = cachedFileValid(fp, hash, "frame", t, channels::frameLayers(), why);
    bool gradOk = t == 0 || cachedFileValid(gp, hash, "gradients", t, channels::gradientLayers(), whyGrad);
    if (frameOk && gradOk) {
      ++jobsDone;
      continue;
    }
    if (fs::exists(fp) && !frameOk) say("[" + scene.name + "] re-rendering " + fp.filename().string() + ": " + why);
    if (t > 0 && fs::exists(gp) && !gradOk)
      say("[" + scene.name + "] re-rendering " + gp.filename().string() + ": " + whyGrad);
    auto t0 = std::chrono::steady_clock::now();
    SequenceRenderer::FrameResult r = renderer.renderFrame(t);
    double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    writeExr(fp, r.frame, channels::frameLayers(), attributes("frame", t));
    if (t > 0) writeExr(gp, r.gradients, channels::gradientLayers(), attributes("gradients", t));
    report("frame " + std::to_string(t), r.counts, sec);
  }
  info.referenceSpp.assign(firstFrameOfReference.size(), 0);
  for (size_t r = 0; r < firstFrameOfReference.size(); ++r) {
    std::string why;
    const fs::path rp = Sequence::referencePath(dir, int(r));
    if (cachedFileValid(rp, hash, "reference", int(r), channels::referenceLayers(), why)) {
      info.referenceSpp[r] = std::stoi(readExrAttributes(rp).at("arena.spp"));
      ++jobsDone;
      continue;
    }
    if (fs::exists(rp)) say("[" + scene.name + "] re-rendering " + rp.filename().string() + ": " + why);
    auto t0 = std::chrono::steady_clock::now();
    RayCounts counts;
    int spp = 0;
    LayerSet ref = renderer.renderReference(firstFrameOfReference[r], spp, counts);
    double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ExrAttributes attrs = attributes("reference", int(r));
    attrs["arena.spp"] = std::to_string(spp);
    writeExr(rp, ref, channels::referenceLayers(), attrs);
    info.referenceSpp[r] = spp;
    report("reference " + std::to_string(r) + " (" + std::to_string(spp) + " spp)", counts, sec);
  }
  writeTextAtomically(infoPath, info.toJson().dump(1));
  return dir;
}

}  // namespace arena
