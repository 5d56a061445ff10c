#include "harness/run_matrix.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>

#include "core/display.hpp"
#include "core/env_info.hpp"
#include "core/error.hpp"
#include "harness/image_files.hpp"
#include "harness/reference_quality.hpp"
#include "metrics/error.hpp"
#include "metrics/evaluator.hpp"
#include "metrics/ghosting.hpp"
#include "metrics/results.hpp"
#include "metrics/statistics.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

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

// A scene as every pair of it sees it: the cached sequence and its evaluation (metrics/evaluator).
struct SceneData {
  Sequence sequence;
  EvaluationScene evaluation;
  std::vector<int> chosenFrames;  // frames whose images are kept for the report
};

// The frames whose images the report shows: after the warm-up, the middle, the last, and each
// event's frame and two after it.
std::vector<int> chooseFrames(const SequenceInfo& info, int warmup) {
  std::set<int> chosen = {std::min(warmup, info.frames - 1), info.frames / 2, info.frames - 1};
  for (const SequenceEvent& e : info.events)
    for (int t : {e.frame, e.frame + 2})
      if (t < info.frames) chosen.insert(t);
  return {chosen.begin(), chosen.end()};
}

std::unique_ptr<SceneData> loadScene(const fs::path& dir, const EvaluationOptions& options) {
  Sequence sequence = Sequence::open(dir);
  EvaluationScene evaluation(readSequenceForEvaluation(sequence), options);
  std::vector<int> chosen = chooseFrames(sequence.info(), options.warmup);
  return std::make_unique<SceneData>(SceneData{std::move(sequence), std::move(evaluation), std::move(chosen)});
}

void writeFrameImages(const fs::path& imageDir, int t, const FrameImages& images) {
  writePng(imageDir / frameName("frame", t), images.display);
  if (!images.flip.empty()) writePng(imageDir / frameName("flip", t), images.flip);
  writePng(imageDir / frameName("relerr", t), images.relativeError);
}

// Every output frame as an EXR (colour, and the two signals a split denoiser filtered).
void writeOutputExr(const fs::path& imageDir, const DenoisedFrame& f, const DenoiserRequest& req, const ParamSet& params) {
  LayerSet out;
  out.set("color", f.color);
  std::vector<LayerSpec> specs = {{"color", {"R", "G", "B"}}, {"color", {"R", "G", "B"}, false, true}};
  for (const char* signal : {"diffuse", "specular"}) {
    const Image& image = std::string(signal) == "diffuse" ? f.diffuse : f.specular;
    if (image.empty()) continue;  // a colour denoiser has no separate signals
    out.set(signal, image);
    specs.push_back({signal, {"R", "G", "B"}});
  }
  char name[64];
  std::snprintf(name, sizeof name, "frame_%04d.exr", f.frame);
  writeExr(imageDir / name, out, specs, {{"arena.denoiser", req.name}, {"arena.params", params.toJson().dump()}});
}

// Runs one denoiser over a scene and hands each output frame to the evaluation.
json runPair(const RunConfig& cfg, const SceneData& sd, const DenoiserRequest& req, const fs::path& imageDir,
             bool keepAll) {
  const SequenceInfo& info = sd.sequence.info();
  DenoiseRun run(req, sd.sequence);
  PairEvaluation evaluation(sd.evaluation);
  bool selfTimed = false;
  NonFiniteCounts sanitized;  // over every frame, warm-up included: each one shaped the history
  std::vector<std::vector<PassTime>> passes;
  std::vector<double> ms;
  const bool keepImages = cfg.keepFrames != "none";
  run.run([&](int t) -> const LayerSet& { return sd.evaluation.frame(t); },
          [&](const DenoisedFrame& f) {
            FrameFacts facts;
            facts.milliseconds = f.milliseconds;
            if (f.selfTimed) facts.wallMilliseconds = f.wallMilliseconds;
            if (run.readsLowres()) facts.extraRaysPerPixel = f.extraRaysPerPixel;
            facts.lowresPathsPerSecond = info.lowresPathsPerSecond;
            evaluation.add(f.frame, f.color, facts);
            selfTimed |= f.selfTimed;
            for (const auto& [channel, n] : f.sanitized) sanitized[channel] += n;
            ms.push_back(f.milliseconds);
            std::vector<PassTime>& frame = passes.emplace_back();
            for (const PassStats& p : f.passes) frame.push_back({p.name, p.milliseconds, p.tapsPerPixel});
            const bool chosen = std::find(sd.chosenFrames.begin(), sd.chosenFrames.end(), f.frame) != sd.chosenFrames.end();
            if (keepImages && (keepAll || chosen)) {
              writeFrameImages(imageDir, f.frame, evaluation.lastImages());
              if (keepAll) writeOutputExr(imageDir, f, req, run.params());
            }
          });
  json pair = {{"scene", info.scene}, {"denoiser", req.name}, {"label", req.label}, {"params", run.params().toJson()},
               {"status", "ok"}};
  pair.update(evaluation.finish());
  // First: what the inputs were matters before what the outputs measured.
  if (!sanitized.empty()) pair["warnings"].insert(pair["warnings"].begin(), sanitizedWarning(sanitized));
  json timing = timingSummary(passes, ms, cfg.warmup, info.width, info.height);
  // External processes time themselves: "ms" is what they reported, "msWall" the harness's clock
  // around the exchange (transfer included). Built-ins and plugins: the harness's clock.
  timing["msSource"] = selfTimed ? "reported by the process" : "harness wall clock";
  if (selfTimed) timing["msWallMedian"] = summarize(evaluation.values("msWall"), cfg.warmup).median;
  pair["timing"] = timing;
  pair["sanitizedInputs"] = {{"total", totalNonFinite(sanitized)}, {"channels", sanitized}};
  pair["images"] = {{"dir", fs::relative(imageDir, cfg.out).string()}, {"all", keepAll && keepImages}};
  if (!run.info().origin.empty()) pair["origin"] = run.info().origin;
  if (run.info().signals == SignalMode::Color) pair["signals"] = "color";
  return pair;
}

// Another noise realisation of a scene's input, with its frames in memory.
struct SeedSequence {
  uint32_t inputSeed = 0;
  Sequence sequence;
  std::vector<LayerSet> frames;
};

// The bias^2 / variance split of a pair's error over the scene's input seeds: the denoiser runs on
// every seed's sequence from a reset history; the evaluation splits the K outputs per frame.
json biasVarianceOf(const RunConfig& cfg, const SceneData& sd, const std::vector<SeedSequence>& seeds,
                    const DenoiserRequest& req) {
  const SequenceInfo& info = sd.sequence.info();
  std::vector<std::vector<Image>> outputs(size_t(info.frames));
  auto collect = [&](const Sequence& sequence, const std::function<const LayerSet&(int)>& frame) {
    DenoiseRun run(req, sequence);
    run.run(frame, [&](const DenoisedFrame& f) { outputs[size_t(f.frame)].push_back(f.color); });
  };
  collect(sd.sequence, [&](int t) -> const LayerSet& { return sd.evaluation.frame(t); });
  json inputSeeds = json::array({cfg.render.inputSeed});
  for (const SeedSequence& s : seeds) {
    if (s.sequence.info().frames != info.frames) throw Error("bias/variance: seed sequences differ in frame count");
    collect(s.sequence, [&](int t) -> const LayerSet& { return s.frames[size_t(t)]; });
    inputSeeds.push_back(s.inputSeed);
  }
  return evaluateBiasVariance(sd.evaluation, outputs, inputSeeds);
}

std::string clock(double s) {
  char buf[32];
  int total = int(std::lround(std::max(0.0, s)));
  std::snprintf(buf, sizeof buf, "%d:%02d", total / 60, total % 60);
  return buf;
}

}  // namespace

json runMatrix(const RunConfig& cfg) {
  if (cfg.out.empty()) throw Error("run: --out is required");
  if (cfg.scenes.empty()) throw Error("run: no scenes");
  if (cfg.seeds < 1 || cfg.seeds > 64) throw Error("run: --seeds " + std::to_string(cfg.seeds) + ": expected 1 to 64");
  const ExposureMode exposure = exposureModeFromName(cfg.exposure);
  std::vector<DenoiserRequest> denoisers;
  auto add = [&](DenoiserRequest r) {
    if (r.label.empty()) r.label = defaultLabel(r);
    for (auto& d : denoisers)
      if (d.label == r.label) return;
    DenoiserRegistry::instance().find(r.name);
    denoisers.push_back(std::move(r));
  };
  if (cfg.baselines)
    for (const char* baseline : {"passthrough", "temporal"}) {
      auto params = cfg.baselineParams.find(baseline);
      add({baseline, params == cfg.baselineParams.end() ? std::map<std::string, std::string>{} : params->second, ""});
    }
  for (const DenoiserRequest& r : cfg.denoisers) add(r);
  // Validate every parameter set before any work: a typo must fail in a second, not after an hour.
  for (const DenoiserRequest& r : denoisers) DenoiserRegistry::instance().find(r.name).schema.resolve(r.params, r.name);

  const bool keepAll = cfg.keepFrames == "all" || (cfg.keepFrames == "auto" && cfg.scenes.size() == 1 &&
                                                   denoisers.size() == (cfg.baselines ? 3u : 1u) && !cfg.denoisers.empty());
  checkRunOutputs(cfg.out);
  const EvaluationOptions evaluation{cfg.warmup, {cfg.flip}, exposure};
  json settings = {{"render", cfg.render.pixelSettings(cfg.scenes.front())}, {"preset", cfg.render.preset},
                   {"seeds", cfg.seeds},
                   {"shard", std::to_string(cfg.shardIndex) + "/" + std::to_string(cfg.shardCount)}};
  settings.update(evaluationSettings(evaluation));
  json results = {{"schema", kResultsSchemaVersion}, {"kind", "arena-run"}, {"name", cfg.name}, {"created", utcTimestamp()},
                  {"environment", environmentInfo()}, {"settings", settings},
                  {"metrics", metricCatalogJson()}, {"scenes", json::object()}, {"pairs", json::array()}};
  results.update(cfg.annotations);
  results["settings"]["render"].erase("width");
  results["settings"]["render"].erase("height");
  results["settings"]["render"].erase("frames");

  const size_t totalPairs = cfg.scenes.size() * denoisers.size();
  size_t pairIndex = 0, pairsDone = 0, pairsMine = 0;
  for (size_t k = 0; k < totalPairs; ++k) pairsMine += int(k % size_t(cfg.shardCount)) == cfg.shardIndex;
  size_t scenesMine = 0, scenesDone = 0;
  for (size_t k = 0; k < cfg.scenes.size(); ++k) {
    bool any = false;
    for (size_t d = 0; d < denoisers.size(); ++d)
      any = any || int((k * denoisers.size() + d) % size_t(cfg.shardCount)) == cfg.shardIndex;
    scenesMine += any;
  }
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
    std::vector<SeedSequence> seedSequences;
    std::string sceneError;
    try {
      dir = renderSequence(scene, cfg.render, cfg.cache, cfg.progress);
      sd = loadScene(dir, evaluation);
      for (int k = 1; k < cfg.seeds; ++k) {
        RenderSettings seeded = cfg.render;
        seeded.inputSeed = cfg.render.inputSeed + uint32_t(k);
        const fs::path seedDir = renderSequence(scene, seeded, cfg.cache, cfg.progress);
        SeedSequence s{seeded.inputSeed, Sequence::open(seedDir), {}};
        for (int t = 0; t < s.sequence.info().frames; ++t) s.frames.push_back(s.sequence.frame(t));
        seedSequences.push_back(std::move(s));
      }
    } catch (const std::exception& e) {
      sceneError = e.what();
    }
    if (sd) {
      const SequenceInfo& info = sd->sequence.info();
      const EvaluationScene& ev = sd->evaluation;
      fs::path sceneImages = cfg.out / "images" / scene.name;
      json events = json::array();
      for (auto& e : info.events) events.push_back({{"frame", e.frame}, {"kind", eventKindName(e.kind)}, {"what", e.what}});
      if (cfg.keepFrames != "none")
        for (int t : sd->chosenFrames) {
          writePng(sceneImages / frameName("reference", t), ev.referenceDisplay(t));
          writePng(sceneImages / frameName("noisy", t), ev.display(t, ev.frame(t).get("color")));
        }
      json entry = {{"purpose", scene.purpose}, {"sequence", dir.string()}, {"hash", info.hash}, {"width", info.width},
                    {"height", info.height}, {"frames", info.frames}, {"events", events},
                    {"referenceSpp", info.referenceSpp}, {"referenceCapped", info.referenceCapped},
                    {"referenceEstimatedRelMse", info.referenceEstimatedRelMse}, {"chosenFrames", sd->chosenFrames},
                    {"images", fs::relative(sceneImages, cfg.out).string()}};
      entry.update(ev.describe());
      results["scenes"][scene.name] = entry;
      // Asset scenes (issue 18): the models' credits and the loader's counted fallbacks.
      if (!scene.credits.empty() || !scene.warnings.empty()) {
        json credits = json::array();
        for (const Credit& c : scene.credits)
          credits.push_back({{"asset", c.asset}, {"author", c.author}, {"license", c.license}, {"source", c.source}});
        results["scenes"][scene.name]["assets"] = {{"credits", credits}, {"warnings", scene.warnings}};
      }
    }
    const auto sceneStart = std::chrono::steady_clock::now();
    size_t sceneFailures = 0;
    for (const DenoiserRequest* r : mine) {
      auto t0 = std::chrono::steady_clock::now();
      json pair;
      try {
        if (!sd) throw Error("scene " + scene.name + " could not be prepared: " + sceneError);
        pair = runPair(cfg, *sd, *r, cfg.out / "images" / scene.name / safeName(r->label), keepAll);
        if (!seedSequences.empty()) pair["biasVariance"] = biasVarianceOf(cfg, *sd, seedSequences, *r);
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
      else if (pair["sanitizedInputs"]["total"].get<long>() > 0)
        say("  warning: " + pair["warnings"][0].get<std::string>());
      sceneFailures += pair["status"] != "ok";
    }
    if (cfg.milestone) {
      ++scenesDone;
      const auto now = std::chrono::steady_clock::now();
      char buf[512];
      std::snprintf(buf, sizeof buf, "[scene %zu/%zu] %s: %zu pair(s) in %.1f s%s (ETA %s)", scenesDone, scenesMine,
                    scene.name.c_str(), mine.size(), std::chrono::duration<double>(now - sceneStart).count(),
                    sceneFailures ? (", " + std::to_string(sceneFailures) + " FAILED").c_str() : "",
                    clock(std::chrono::duration<double>(now - start).count() / double(pairsDone) *
                          double(pairsMine - pairsDone))
                        .c_str());
      cfg.milestone(buf);
    }
  }
  if (cfg.finish) finishRun(results, cfg);
  return results;
}

void finishRun(json& results, const RunConfig& cfg) {
  results["statistics"] = analyseRun(results);
  addReferenceQuality(results, cfg.warmup, cfg.referenceNotes);
  commitResults(cfg.out, results);
}

}  // namespace arena
