#include "harness/run_matrix.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <set>

#include "core/display.hpp"
#include "core/env_info.hpp"
#include "core/error.hpp"
#include "harness/image_files.hpp"
#include "metrics/results.hpp"
#include "metrics/error.hpp"
#include "metrics/flip.hpp"
#include "metrics/ghosting.hpp"
#include "metrics/summary.hpp"
#include "metrics/temporal.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string nowIso() {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

std::string safeName(const std::string& label) {
  std::string s = label;
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || std::string("._=,-[]").find(c) != std::string::npos)) c = '_';
  return s;
}

std::string frameName(const char* prefix, int t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s_%04d.png", prefix, t);
  return buf;
}

// A per-pixel relative-error map for eyes: mean over channels of (d - r)^2 / (r^2 + eps), mapped
// through x / (1 + x) into [0, 1).
Image relativeErrorMap(const Image& d, const Image& r) {
  Image m(d.width(), d.height(), 1);
  for (size_t i = 0; i < d.pixelCount(); ++i) {
    double s = 0;
    for (int c = 0; c < 3; ++c) {
      double diff = double(d.plane(c)[i]) - r.plane(c)[i];
      s += diff * diff / (double(r.plane(c)[i]) * r.plane(c)[i] + kRelMseEpsilon);
    }
    s /= 3;
    m.plane(0)[i] = float(s / (1 + s));
  }
  return m;
}

// Everything about a scene that every pair shares: frames, references, display transform, masks.
struct SceneData {
  Sequence sequence;
  std::vector<LayerSet> frames;       // per frame
  std::vector<LayerSet> references;   // per distinct reference
  std::vector<Image> referenceDisplay;
  DisplayTransform display;
  std::vector<double> referenceRelMse, noisyRelMse;
  struct Event {
    SequenceEvent event;
    int begin = 0, end = 0;
    std::vector<Image> masks;  // per window frame
  };
  std::vector<Event> events;
  std::vector<int> chosenFrames;
  const LayerSet& reference(int t) const { return references[size_t(sequence.info().referenceOfFrame[size_t(t)])]; }
  const Image& referenceDisplayAt(int t) const {
    return referenceDisplay[size_t(sequence.info().referenceOfFrame[size_t(t)])];
  }
};

int meshIdOf(const Scene& scene, const std::string& name) {
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (scene.objects[i].name == name) return int(i);
  for (size_t i = 0; i < scene.lights.size(); ++i)
    if (scene.lights[i].name == name) return int(scene.objects.size() + i);
  return -1;
}

SceneData loadScene(const Scene& scene, const fs::path& dir, int warmup) {
  SceneData s{Sequence::open(dir), {}, {}, {}, {}, {}, {}, {}, {}};
  const SequenceInfo& info = s.sequence.info();
  for (int t = 0; t < info.frames; ++t) s.frames.push_back(s.sequence.frame(t));
  int refs = 0;
  for (int r : info.referenceOfFrame) refs = std::max(refs, r + 1);
  for (int r = 0; r < refs; ++r)
    s.references.push_back(readExr(Sequence::referencePath(dir, r), channels::referenceLayers()).layers);
  s.display = DisplayTransform::fromReference(s.reference(0).get("color"));
  for (const LayerSet& r : s.references) s.referenceDisplay.push_back(s.display.apply(r.get("color")));
  for (int t = 0; t < info.frames; ++t) {
    const LayerSet& ref = s.reference(t);
    s.referenceRelMse.push_back(referenceRelMse(ref.get("color"), ref.get("colorVar")));
    s.noisyRelMse.push_back(linearError(s.frames[size_t(t)].get("color"), ref.get("color"), &ref.get("colorVar")).relMse);
  }
  // Ghosting windows: [t0 - 5, t0 + 60], clipped to the sequence and ended before the next event
  // (ours: a second event would otherwise pollute the first one's steady state).
  GhostingConfig gc;
  std::vector<int> eventFrames;
  for (const SequenceEvent& e : info.events) eventFrames.push_back(e.frame);
  for (const SequenceEvent& e : info.events) {
    if (e.frame < 1 || e.kind == "camera_cut") continue;
    SceneData::Event ev;
    ev.event = e;
    ev.begin = std::max(0, e.frame - gc.before);
    ev.end = std::min(info.frames - 1, e.frame + gc.after);
    for (int f : eventFrames)
      if (f > e.frame) ev.end = std::min(ev.end, f - 1);
    Image base = changedRegion(s.reference(e.frame).get("color"), s.reference(e.frame - 1).get("color"), gc);
    const int objectId = e.kind == "object_moves" ? meshIdOf(scene, e.what) : -1;
    for (int t = ev.begin; t <= ev.end; ++t) {
      Image mask = base;
      if (objectId >= 0) {
        std::vector<const Image*> previous;
        for (int k = 1; k <= gc.trailFrames && t - k >= 0; ++k) previous.push_back(&s.frames[size_t(t - k)].get("meshId"));
        addTrail(mask, objectId, previous, s.frames[size_t(t)].get("meshId"));
      }
      ev.masks.push_back(std::move(mask));
    }
    s.events.push_back(std::move(ev));
  }
  std::set<int> chosen = {std::min(warmup, info.frames - 1), info.frames / 2, info.frames - 1};
  for (const SequenceEvent& e : info.events)
    for (int t : {e.frame, e.frame + 2})
      if (t < info.frames) chosen.insert(t);
  s.chosenFrames.assign(chosen.begin(), chosen.end());
  return s;
}

json timingJson(const std::vector<std::vector<PassStats>>& passesPerFrame, const std::vector<double>& ms, int warmup,
                int width, int height) {
  json passes = json::array();
  if (!passesPerFrame.empty()) {
    const auto& names = passesPerFrame.back();
    for (size_t p = 0; p < names.size(); ++p) {
      std::vector<double> v;
      double taps = names[p].tapsPerPixel;
      for (const auto& f : passesPerFrame)
        if (p < f.size() && f[p].name == names[p].name) v.push_back(f[p].milliseconds);
      Summary s = summarize(v, std::min(warmup, int(v.size()) - 1));
      passes.push_back({{"name", names[p].name}, {"msMedian", s.median}, {"msP95", s.p95}, {"tapsPerPixel", taps}});
    }
  }
  Summary total = summarize(ms, std::min(warmup, int(ms.size()) - 1));
  double taps = 0;
  for (const json& p : passes) taps += p["tapsPerPixel"].get<double>();
  return {{"msMedian", total.median}, {"msP95", total.p95}, {"msMean", total.mean},
          {"msPerMegapixel", total.median / (double(width) * height * 1e-6)}, {"tapsPerPixel", taps},
          {"passes", passes}};
}

json runPair(const RunConfig& cfg, const SceneData& sd, const DenoiserRequest& req, const fs::path& imageDir,
             bool keepAll) {
  const SequenceInfo& info = sd.sequence.info();
  DenoiseRun run(req, sd.sequence);
  const int w = info.width, h = info.height;
  json frames = json::array();
  std::map<std::string, std::vector<double>> series;
  std::vector<std::vector<PassStats>> passes;
  std::vector<std::vector<double>> eventCurves(sd.events.size()), eventBias(sd.events.size());
  Image prevColor, prevDisplay, prevError;
  long sanitized = 0;
  const bool keepImages = cfg.keepFrames != "none";
  run.run([&](int t) -> const LayerSet& { return sd.frames[size_t(t)]; },
          [&](const DenoisedFrame& f) {
            const int t = f.frame;
            const LayerSet& ref = sd.reference(t);
            const Image &r = ref.get("color"), &var = ref.get("colorVar");
            const Image& rDisp = sd.referenceDisplayAt(t);
            json m = {{"frame", t}};
            ErrorStats e = linearError(f.color, r, &var);
            Image disp = sd.display.apply(f.color);
            m["relMse"] = e.relMse;
            m["relMseCorrected"] = e.relMseCorrected;
            m["mse"] = e.mse;
            m["rmse"] = e.rmse;
            m["psnr"] = psnrFromMse(meanSquaredError(disp, rDisp));
            m["ssim"] = ssim(disp, rDisp);
            FlipResult ldr;
            if (cfg.flip != "none") {
              ldr = ldrFlip(rDisp, disp);
              m["ldrFlip"] = ldr.mean;
            }
            if (cfg.flip == "all") m["hdrFlip"] = hdrFlip(r, f.color).mean;
            Image err(w, h, 3);
            for (size_t i = 0; i < err.raw().size(); ++i) err.raw()[i] = f.color.raw()[i] - r.raw()[i];
            if (t > 0) {
              const LayerSet& refPrev = sd.reference(t - 1);
              m["tRmae"] = temporalRelativeMae(f.color, prevColor, r, refPrev.get("color"));
              m["tPsnr"] = temporalPsnr(disp, prevDisplay, rDisp, sd.referenceDisplayAt(t - 1));
              WarpedFlicker wf = warpedFlicker(err, prevError, sd.frames[size_t(t)], sd.frames[size_t(t - 1)]);
              m["warpedFlicker"] = wf.value;
              m["warpedValid"] = wf.validFraction;
            }
            // Effective spp (ours): 1-spp relMSE falls as 1/spp, so spp_eff = relMSE(noisy) / relMSE(method);
            // the reference-corrected values when both are positive.
            double noisyCorr = sd.noisyRelMse[size_t(t)] - sd.referenceRelMse[size_t(t)];
            bool corrected = noisyCorr > 0 && e.relMseCorrected > 0;
            m["effectiveSpp"] = corrected ? noisyCorr / e.relMseCorrected
                                          : sd.noisyRelMse[size_t(t)] / std::max(e.relMse, 1e-12);
            m["ms"] = f.milliseconds;
            m["referenceRelMse"] = sd.referenceRelMse[size_t(t)];
            for (auto it = m.begin(); it != m.end(); ++it) {
              if (it.key() == "frame") continue;
              std::vector<double>& s = series[it.key()];
              s.resize(size_t(info.frames), NAN);
              s[size_t(t)] = it.value().get<double>();
            }
            for (size_t k = 0; k < sd.events.size(); ++k) {
              const auto& ev = sd.events[k];
              if (t < ev.begin || t > ev.end) continue;
              const Image& mask = ev.masks[size_t(t - ev.begin)];
              eventCurves[k].push_back(linearError(f.color, r, &var, &mask).relMse);
              eventBias[k].push_back(signedBias(f.color, r, mask));
            }
            passes.push_back(f.passes);
            sanitized += f.sanitized;
            frames.push_back(m);
            const bool chosen = std::find(sd.chosenFrames.begin(), sd.chosenFrames.end(), t) != sd.chosenFrames.end();
            if (keepImages && (keepAll || chosen)) {
              writePng(imageDir / frameName("frame", t), disp);
              if (cfg.flip != "none") writePng(imageDir / frameName("flip", t), ldr.map);
              writePng(imageDir / frameName("relerr", t), relativeErrorMap(f.color, r));
              if (keepAll) {
                LayerSet out;
                out.set("color", f.color);
                out.set("diffuse", f.diffuse);
                out.set("specular", f.specular);
                char name[64];
                std::snprintf(name, sizeof name, "frame_%04d.exr", t);
                writeExr(imageDir / name, out,
                         {{"color", {"R", "G", "B"}}, {"color", {"R", "G", "B"}, false, true},
                          {"diffuse", {"R", "G", "B"}}, {"specular", {"R", "G", "B"}}},
                         {{"arena.denoiser", req.name}, {"arena.params", run.params().toJson().dump()}});
              }
            }
            prevColor = f.color;
            prevDisplay = std::move(disp);
            prevError = std::move(err);
          });
  json summary = json::object();
  for (auto& [name, v] : series) summary[name] = summarize(v, cfg.warmup).toJson();
  json ghosting = json::array();
  for (size_t k = 0; k < sd.events.size(); ++k) {
    const auto& ev = sd.events[k];
    GhostingResult g = analyseGhosting(ev.event.frame, ev.begin, eventCurves[k], eventBias[k]);
    double maskPixels = 0;
    for (float v : ev.masks[size_t(ev.event.frame - ev.begin)].raw()) maskPixels += v;
    g.maskFraction = maskPixels / double(size_t(w) * h);
    json j = g.toJson();
    j["kind"] = ev.event.kind;
    j["what"] = ev.event.what;
    ghosting.push_back(j);
  }
  json warnings = json::array();
  double refFloor = summarize(sd.referenceRelMse, cfg.warmup).mean;
  if (summary.contains("relMse") && summary["relMse"]["mean"].get<double>() < 10.0 * refFloor)
    warnings.push_back("relMSE is within 10x of the reference's own noise floor (" + std::to_string(refFloor) +
                       "): the ranking on raw relMSE is unreliable; use relMseCorrected or a better reference");
  if (sanitized > 0) warnings.push_back(std::to_string(sanitized) + " NaN/Inf input values were replaced by 0");
  return {{"scene", info.scene}, {"denoiser", req.name}, {"label", req.label}, {"params", run.params().toJson()},
          {"status", "ok"}, {"frames", frames}, {"summary", summary},
          {"timing", timingJson(passes, series["ms"], cfg.warmup, w, h)}, {"ghosting", ghosting},
          {"warnings", warnings}, {"sanitizedInputs", sanitized},
          {"images", {{"dir", fs::relative(imageDir, cfg.out).string()}, {"all", keepAll && keepImages}}}};
}

std::string clock(double s) {
  char buf[32];
  int total = int(std::lround(std::max(0.0, s)));
  std::snprintf(buf, sizeof buf, "%d:%02d", total / 60, total % 60);
  return buf;
}

}  // namespace

std::pair<int, int> parseShard(const std::string& text) {
  int i = -1, n = 0;
  char slash = 0;
  if (std::sscanf(text.c_str(), "%d%c%d", &i, &slash, &n) != 3 || slash != '/' || n < 1 || i < 0 || i >= n)
    throw Error("--shard '" + text + "': expected i/n with 0 <= i < n, e.g. 0/4");
  return {i, n};
}

std::vector<std::string> failedPairs(const json& results) {
  std::vector<std::string> out;
  for (const json& p : results["pairs"])
    if (p["status"] != "ok") out.push_back(p["label"].get<std::string>() + " on " + p["scene"].get<std::string>() + ": " +
                                           p.value("error", ""));
  return out;
}

json runMatrix(const RunConfig& cfg) {
  if (cfg.out.empty()) throw Error("run: --out is required");
  if (cfg.scenes.empty()) throw Error("run: no scenes");
  std::vector<DenoiserRequest> denoisers;
  auto add = [&](DenoiserRequest r) {
    if (r.label.empty()) r.label = defaultLabel(r);
    for (auto& d : denoisers)
      if (d.label == r.label) return;
    DenoiserRegistry::instance().find(r.name);
    denoisers.push_back(std::move(r));
  };
  if (cfg.baselines) {
    add({"passthrough", {}, ""});
    add({"temporal", {}, ""});
  }
  for (const DenoiserRequest& r : cfg.denoisers) add(r);
  // Validate every parameter set before any work: a typo must fail in a second, not after an hour.
  for (const DenoiserRequest& r : denoisers) DenoiserRegistry::instance().find(r.name).schema.resolve(r.params, r.name);

  const bool keepAll = cfg.keepFrames == "all" || (cfg.keepFrames == "auto" && cfg.scenes.size() == 1 &&
                                                   denoisers.size() == (cfg.baselines ? 3u : 1u) && !cfg.denoisers.empty());
  fs::create_directories(cfg.out);
  json results = {{"schema", kResultsSchemaVersion}, {"kind", "arena-run"}, {"name", cfg.name}, {"created", nowIso()},
                  {"environment", environmentInfo()},
                  {"settings", {{"render", cfg.render.pixelSettings(cfg.scenes.front())},
                                {"preset", cfg.render.preset}, {"warmup", cfg.warmup}, {"flip", cfg.flip},
                                {"relMseEpsilon", kRelMseEpsilon},
                                {"display", "exposure from the scene's first reference (mean luminance -> 0.18), "
                                            "ACES filmic (Narkowicz 2015), clamp, sRGB"},
                                {"tRmae", "Noisebase's form without its extra division by 3"},
                                {"flipPixelsPerDegree", 67},
                                {"shard", std::to_string(cfg.shardIndex) + "/" + std::to_string(cfg.shardCount)}}},
                  {"scenes", json::object()}, {"pairs", json::array()}};
  results["settings"]["render"].erase("width");
  results["settings"]["render"].erase("height");
  results["settings"]["render"].erase("frames");

  const size_t totalPairs = cfg.scenes.size() * denoisers.size();
  size_t pairIndex = 0, pairsDone = 0, pairsMine = 0;
  for (size_t k = 0; k < totalPairs; ++k) pairsMine += int(k % size_t(cfg.shardCount)) == cfg.shardIndex;
  const auto start = std::chrono::steady_clock::now();
  auto say = [&](const std::string& s) {
    if (cfg.progress) cfg.progress(s);
  };
  for (const Scene& scene : cfg.scenes) {
    std::vector<const DenoiserRequest*> mine;
    for (const DenoiserRequest& r : denoisers)
      if (int(pairIndex++ % size_t(cfg.shardCount)) == cfg.shardIndex) mine.push_back(&r);
    if (mine.empty()) continue;
    fs::path dir;
    std::unique_ptr<SceneData> sd;
    std::string sceneError;
    try {
      dir = renderSequence(scene, cfg.render, cfg.cache, cfg.progress);
      sd = std::make_unique<SceneData>(loadScene(scene, dir, cfg.warmup));
    } catch (const std::exception& e) {
      sceneError = e.what();
    }
    if (sd) {
      const SequenceInfo& info = sd->sequence.info();
      fs::path sceneImages = cfg.out / "images" / scene.name;
      json events = json::array();
      for (auto& e : info.events) events.push_back({{"frame", e.frame}, {"kind", e.kind}, {"what", e.what}});
      if (cfg.keepFrames != "none")
        for (int t : sd->chosenFrames) {
          writePng(sceneImages / frameName("reference", t), sd->referenceDisplayAt(t));
          writePng(sceneImages / frameName("noisy", t), sd->display.apply(sd->frames[size_t(t)].get("color")));
        }
      results["scenes"][scene.name] = {
          {"purpose", scene.purpose}, {"sequence", dir.string()}, {"hash", info.hash}, {"width", info.width},
          {"height", info.height}, {"frames", info.frames}, {"events", events},
          {"referenceSpp", info.referenceSpp}, {"referenceRelMse", sd->referenceRelMse},
          {"noisyRelMse", sd->noisyRelMse}, {"exposure", sd->display.exposure},
          {"chosenFrames", sd->chosenFrames}, {"images", fs::relative(sceneImages, cfg.out).string()}};
    }
    for (const DenoiserRequest* r : mine) {
      auto t0 = std::chrono::steady_clock::now();
      json pair;
      try {
        if (!sd) throw Error("scene " + scene.name + " could not be prepared: " + sceneError);
        pair = runPair(cfg, *sd, *r, cfg.out / "images" / scene.name / safeName(r->label), keepAll);
      } catch (const std::exception& e) {
        pair = {{"scene", scene.name}, {"denoiser", r->name}, {"label", r->label}, {"params", json::object()},
                {"status", "failed"}, {"error", e.what()}};
      }
      results["pairs"].push_back(pair);
      ++pairsDone;
      double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      char buf[512];
      std::snprintf(buf, sizeof buf, "[%zu/%zu] %s on %s: %s in %.1f s (ETA %s)", pairsDone, pairsMine, r->label.c_str(),
                    scene.name.c_str(), pair["status"] == "ok" ? "done" : "FAILED", took,
                    clock(elapsed / double(pairsDone) * double(pairsMine - pairsDone)).c_str());
      say(buf);
      if (pair["status"] != "ok") say("  error: " + pair["error"].get<std::string>());
    }
  }
  saveResults(cfg.out, results);
  appendToDatabase(cfg.out / "results.db", results);
  return results;
}

json mergeRuns(const std::vector<fs::path>& runs, const fs::path& out) {
  if (runs.empty()) throw Error("merge: no runs given");
  json merged;
  std::set<std::string> seen;
  for (const fs::path& run : runs) {
    json r = loadResults(run);
    if (merged.is_null()) {
      merged = r;
      merged["pairs"] = json::array();
      merged["scenes"] = json::object();
      merged["settings"]["shard"] = "merged";
    } else {
      json a = merged["settings"], b = r["settings"];
      a.erase("shard");
      b.erase("shard");
      if (a != b) throw Error(run.string() + ": settings differ from " + runs.front().string() + "; only shards of one run can be merged");
    }
    for (auto it = r["scenes"].begin(); it != r["scenes"].end(); ++it) merged["scenes"][it.key()] = it.value();
    for (json& p : r["pairs"]) {
      std::string key = p["scene"].get<std::string>() + "\n" + p["label"].get<std::string>();
      if (!seen.insert(key).second)
        throw Error(run.string() + ": pair " + p["label"].get<std::string>() + " on " + p["scene"].get<std::string>() +
                    " appears in two shards");
      merged["pairs"].push_back(p);
    }
    if (fs::exists(run / "images"))
      fs::copy(run / "images", out / "images", fs::copy_options::recursive | fs::copy_options::skip_existing);
  }
  saveResults(out, merged);
  appendToDatabase(out / "results.db", merged);
  return merged;
}

}  // namespace arena
