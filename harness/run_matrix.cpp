#include "harness/run_matrix.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <set>

#include "core/capture.hpp"
#include "core/display.hpp"
#include "core/env_info.hpp"
#include "core/error.hpp"
#include "core/stage_clock.hpp"
#include "harness/gpu_cost.hpp"
#include "harness/image_files.hpp"
#include "harness/reference_quality.hpp"
#include "metrics/capture_checks.hpp"
#include "metrics/error.hpp"
#include "metrics/evaluator.hpp"
#include "metrics/ghosting.hpp"
#include "metrics/results.hpp"
#include "metrics/run_statistics.hpp"

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

// A capture is validated before anything runs on it (metrics/capture_checks.hpp): `validation`
// receives the checks, and a hard failure refuses the scene with the checks' names and numbers.
std::unique_ptr<SceneData> loadScene(const fs::path& dir, const EvaluationOptions& options, json* validation = nullptr) {
  StageTimer timer(Stage::Loading);
  Sequence sequence = Sequence::open(dir);
  EvaluationInput input = readSequenceForEvaluation(sequence);
  if (sequence.isCapture()) {
    const CaptureValidation checks = validateCapture(sequence, input);
    if (validation) *validation = checks.toJson();
    if (checks.status() == CheckStatus::Fail)
      throw Error("capture " + dir.string() + " refused by its validation: " + checks.failures());
  }
  EvaluationScene evaluation(std::move(input), options);
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

// Reads the stored outputs of a denoiser that ran elsewhere (a capture's outputs/NAME) as the
// stream of frames a built-in would hand over; their time is the one the capture recorded.
void runCapturedOutput(const Sequence& sequence, const std::string& name,
                       const std::function<void(const DenoisedFrame&)>& onFrame) {
  const CaptureDescription& capture = sequence.capture();
  const CaptureOutput& output = capture.output(name);
  DenoisedFrame f;
  for (int t = 0; t < sequence.info().frames; ++t) {
    f.frame = t;
    f.color = readCaptureOutput(capture, name, t);
    long bad = 0;
    for (float v : f.color.raw()) bad += !std::isfinite(v);
    if (bad)
      throw Error(captureOutputPath(output, t).string() + ": " + std::to_string(bad) +
                  " non-finite colour values in the output of '" + name + "' (an output is scored as given, never repaired)");
    f.selfTimed = !output.milliseconds.empty();
    f.milliseconds = f.selfTimed ? output.milliseconds[size_t(t)] : std::numeric_limits<double>::quiet_NaN();
    onFrame(f);
  }
}

// Runs one denoiser over a scene (or reads a file: contender's stored outputs) and hands each
// output frame to the evaluation.
json runPair(const RunConfig& cfg, const SceneData& sd, const DenoiserRequest& req, const fs::path& imageDir,
             bool keepAll) {
  const SequenceInfo& info = sd.sequence.info();
  const std::string captured = capturedOutputName(req.name);
  if (!captured.empty() && !sd.sequence.isCapture())
    throw Error(req.name + ": scene " + info.scene + " is not a capture; file: contenders are outputs stored in a "
                "capture's outputs/ folder (docs/captures.md)");
  std::unique_ptr<DenoiseRun> run = captured.empty() ? std::make_unique<DenoiseRun>(req, sd.sequence) : nullptr;
  const ParamSet params = run ? run->params() : ParamSet{};
  PairEvaluation evaluation(sd.evaluation);
  bool selfTimed = false;
  NonFiniteCounts sanitized;  // over every frame, warm-up included: each one shaped the history
  std::vector<std::vector<PassTime>> passes;
  std::vector<double> ms;
  GpuFrameCost gpuCost(info.width, info.height);  // the speed axis's predicted GPU ms (issue 31)
  const bool keepImages = cfg.keepFrames != "none";
  auto onFrame = [&](const DenoisedFrame& f) {
            FrameFacts facts;
            facts.milliseconds = f.milliseconds;
            if (f.selfTimed && run) facts.wallMilliseconds = f.wallMilliseconds;
            // Extra paths: the low-resolution buffer's (reengine) or the gradient samples'
            // (asvgf), each at the rate it rendered at.
            if (run && (run->readsLowres() || run->readsGradients())) facts.extraRaysPerPixel = f.extraRaysPerPixel;
            facts.extraPathsPerSecond = run && run->readsLowres() ? info.lowresPathsPerSecond : info.inputPathsPerSecond;
            StageTimer metrics(Stage::Metrics);  // inside the denoiser's run: its time is taken out of it
            evaluation.add(f.frame, f.color, facts);
            selfTimed |= f.selfTimed;
            for (const auto& [channel, n] : f.sanitized) sanitized[channel] += n;
            ms.push_back(f.milliseconds);
            std::vector<PassTime>& frame = passes.emplace_back();
            for (const PassStats& p : f.passes) frame.push_back({p.name, p.milliseconds, p.tapsPerPixel});
            if (run) gpuCost.add(f.passes);
            const bool chosen = std::find(sd.chosenFrames.begin(), sd.chosenFrames.end(), f.frame) != sd.chosenFrames.end();
            if (keepImages && (keepAll || chosen)) {
              StageTimer images(Stage::Report);
              writeFrameImages(imageDir, f.frame, evaluation.lastImages());
              if (keepAll) writeOutputExr(imageDir, f, req, params);
            }
          };
  {
    StageTimer denoisers(Stage::Denoisers);
    if (run)
      run->run([&](int t) -> const LayerSet& { return sd.evaluation.frame(t); }, onFrame);
    else
      runCapturedOutput(sd.sequence, captured, onFrame);
  }
  json pair = {{"scene", info.scene}, {"denoiser", req.name}, {"label", req.label}, {"params", params.toJson()},
               {"status", "ok"}};
  {
    StageTimer metrics(Stage::Metrics);
    pair.update(evaluation.finish());
  }
  // First: what the inputs were matters before what the outputs measured.
  if (!sanitized.empty()) pair["warnings"].insert(pair["warnings"].begin(), sanitizedWarning(sanitized));
  json timing;
  if (run) {
    timing = timingSummary(passes, ms, cfg.warmup, info.width, info.height);
    // External processes time themselves: "ms" is what they reported, "msWall" the harness's clock
    // around the exchange (transfer included). Built-ins and plugins: the harness's clock.
    timing["msSource"] = selfTimed ? "reported by the process" : "harness wall clock";
    timing["clock"] = "cpu";
    if (selfTimed) timing["msWallMedian"] = summarize(evaluation.values("msWall"), cfg.warmup).median;
    const json gpu = gpuCost.summary(cfg.warmup);
    if (!gpu.is_null()) timing["gpuPredicted"] = gpu;
  } else {
    // A capture's recorded time is another device's: labelled, never mixed with the CPU times.
    const CaptureOutput& output = sd.sequence.capture().output(captured);
    if (selfTimed) {
      timing = timingSummary({}, ms, cfg.warmup, info.width, info.height);
      timing["msSource"] = "recorded in the capture (" + output.device + ")";
      timing["clock"] = "capture";
      timing["device"] = output.device;
    } else {
      timing = {{"msSource", "not recorded in the capture"}, {"clock", "none"}, {"passes", json::array()}};
    }
  }
  pair["timing"] = timing;
  pair["sanitizedInputs"] = {{"total", totalNonFinite(sanitized)}, {"channels", sanitized}};
  pair["images"] = {{"dir", fs::relative(imageDir, cfg.out).string()}, {"all", keepAll && keepImages}};
  if (run && !run->info().origin.empty()) pair["origin"] = run->info().origin;
  if (!run) pair["origin"] = (sd.sequence.dir() / "outputs" / captured).string();
  if (!run || run->info().signals == SignalMode::Color) pair["signals"] = "color";
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

void resolveAutoLowres(RunConfig& c) {
  if (!c.lowresAuto) return;
  bool reads = false;
  for (const DenoiserRequest& r : c.denoisers) {
    if (!capturedOutputName(r.name).empty()) continue;  // a stored output reads nothing
    const DenoiserInfo& info = DenoiserRegistry::instance().find(r.name);
    if (!info.origin.empty()) continue;  // external denoisers read no low-resolution buffer
    reads = reads || info.create(info.schema.resolve(r.params, r.name), SignalKind::Diffuse)->wantsLowres();
  }
  c.render.lowresFactor = reads ? kAutoLowresFactor : 0;
  c.lowresAuto = false;
}

json runMatrix(const RunConfig& cfg) {
  if (cfg.out.empty()) throw Error("run: --out is required");
  if (cfg.scenes.empty() && cfg.captures.empty()) throw Error("run: no scenes and no captures");
  if (cfg.seeds < 1 || cfg.seeds > 64) throw Error("run: --seeds " + std::to_string(cfg.seeds) + ": expected 1 to 64");
  const ExposureMode exposure = exposureModeFromName(cfg.exposure);
  std::vector<DenoiserRequest> denoisers;
  auto add = [&](DenoiserRequest r) {
    if (r.label.empty()) r.label = defaultLabel(r);
    for (auto& d : denoisers)
      if (d.label == r.label) return;
    if (capturedOutputName(r.name).empty()) DenoiserRegistry::instance().find(r.name);
    else if (cfg.captures.empty()) throw Error(r.name + ": file: contenders need a capture (--capture DIR)");
    denoisers.push_back(std::move(r));
  };
  if (cfg.baselines)
    for (const char* baseline : {"passthrough", "temporal"}) {
      auto params = cfg.baselineParams.find(baseline);
      add({baseline, params == cfg.baselineParams.end() ? std::map<std::string, std::string>{} : params->second, ""});
    }
  for (const DenoiserRequest& r : cfg.denoisers) add(r);
  // Validate every parameter set before any work: a typo must fail in a second, not after an hour.
  for (const DenoiserRequest& r : denoisers)
    if (capturedOutputName(r.name).empty()) DenoiserRegistry::instance().find(r.name).schema.resolve(r.params, r.name);
    else if (!r.params.empty()) throw Error(r.name + ": a stored output has no parameters to set");

  // What runs: the scenes (rendered or taken from the cache), then the captures.
  struct Source {
    std::string name, purpose;
    const Scene* scene = nullptr;
    fs::path capture;
  };
  std::vector<Source> sources;
  for (const Scene& scene : cfg.scenes) sources.push_back({scene.name, scene.purpose, &scene, {}});
  for (const fs::path& capture : cfg.captures) {
    const CaptureDescription d = readCaptureDescription(capture);
    for (const Source& other : sources)
      if (other.name == d.info.scene)
        throw Error("capture " + capture.string() + ": its name '" + d.info.scene + "' is also the name of " +
                    (other.scene ? "a scene" : "capture " + other.capture.string()) + " in this run");
    sources.push_back({d.info.scene, d.info.purpose, nullptr, capture});
  }
  const bool keepAll = cfg.keepFrames == "all" || (cfg.keepFrames == "auto" && sources.size() == 1 &&
                                                   denoisers.size() == (cfg.baselines ? 3u : 1u) && !cfg.denoisers.empty());
  checkRunOutputs(cfg.out);
  const EvaluationOptions evaluation{cfg.warmup, {cfg.flip}, exposure};
  json settings = {{"render", cfg.scenes.empty() ? json::object() : cfg.render.pixelSettings(cfg.scenes.front())},
                   {"preset", cfg.render.preset},
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

  if (!cfg.captures.empty()) {
    json captures = json::array();
    for (const fs::path& c : cfg.captures) captures.push_back(c.string());
    results["settings"]["captures"] = captures;
  }
  const size_t totalPairs = sources.size() * denoisers.size();
  size_t pairIndex = 0, pairsDone = 0, pairsMine = 0;
  for (size_t k = 0; k < totalPairs; ++k) pairsMine += int(k % size_t(cfg.shardCount)) == cfg.shardIndex;
  size_t scenesMine = 0, scenesDone = 0;
  for (size_t k = 0; k < sources.size(); ++k) {
    bool any = false;
    for (size_t d = 0; d < denoisers.size(); ++d)
      any = any || int((k * denoisers.size() + d) % size_t(cfg.shardCount)) == cfg.shardIndex;
    scenesMine += any;
  }
  const auto start = std::chrono::steady_clock::now();
  auto say = [&](const std::string& s) {
    if (cfg.progress) cfg.progress(s);
  };
  for (const Source& source : sources) {
    std::vector<const DenoiserRequest*> mine;
    for (const DenoiserRequest& r : denoisers)
      if (int(pairIndex++ % size_t(cfg.shardCount)) == cfg.shardIndex) mine.push_back(&r);
    if (mine.empty()) continue;
    fs::path dir;
    std::unique_ptr<SceneData> sd;
    std::vector<SeedSequence> seedSequences;
    std::string sceneError;
    json validation;
    try {
      if (!source.scene) {
        dir = source.capture;
        sd = loadScene(dir, evaluation, &validation);
      } else {
        dir = renderSequence(*source.scene, cfg.render, cfg.cache, cfg.progress);
        sd = loadScene(dir, evaluation);
      }
      for (int k = 1; k < cfg.seeds && source.scene; ++k) {
        const Scene& scene = *source.scene;
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
    if (!validation.is_null()) {
      // The capture's checks, printed and kept (also when they refused it).
      for (const json& c : validation["checks"])
        if (c["status"] != "pass")
          say("  " + source.name + ": " + c["status"].get<std::string>() + ": " + c["name"].get<std::string>() + " " +
              (c["value"].is_number() ? std::to_string(c["value"].get<double>()) : std::string("-")) + " (" +
              c["detail"].get<std::string>() + ")");
      results["scenes"][source.name] = {{"purpose", source.purpose}, {"source", "capture"},
                                        {"capture", source.capture.string()}, {"validation", validation}};
    }
    if (sd) {
      const SequenceInfo& info = sd->sequence.info();
      const EvaluationScene& ev = sd->evaluation;
      fs::path sceneImages = cfg.out / "images" / source.name;
      json events = json::array();
      for (auto& e : info.events) events.push_back({{"frame", e.frame}, {"kind", eventKindName(e.kind)}, {"what", e.what}});
      if (cfg.keepFrames != "none")
        for (int t : sd->chosenFrames) {
          if (ev.hasReference()) writePng(sceneImages / frameName("reference", t), ev.referenceDisplay(t));
          writePng(sceneImages / frameName("noisy", t), ev.display(t, ev.frame(t).get("color")));
        }
      json entry = {{"purpose", source.purpose}, {"sequence", dir.string()}, {"hash", info.hash}, {"width", info.width},
                    {"height", info.height}, {"frames", info.frames}, {"events", events},
                    {"referenceSpp", info.referenceSpp}, {"referenceCapped", info.referenceCapped},
                    {"referenceEstimatedRelMse", info.referenceEstimatedRelMse}, {"chosenFrames", sd->chosenFrames},
                    {"images", fs::relative(sceneImages, cfg.out).string()}};
      entry.update(ev.describe());
      if (!ev.hasReference()) entry["hasReference"] = false;
      if (!source.scene) {
        entry["source"] = "capture";
        entry["capture"] = source.capture.string();
        entry["validation"] = validation;
        entry["derivedLayers"] = sd->sequence.capture().derived;
        entry["layers"] = info.availableLayers();
      }
      results["scenes"][source.name] = entry;
      // Asset scenes (issue 18): the models' credits and the loader's counted fallbacks.
      if (source.scene && (!source.scene->credits.empty() || !source.scene->warnings.empty())) {
        const Scene& scene = *source.scene;
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
        if (!sd) throw Error("scene " + source.name + " could not be prepared: " + sceneError);
        pair = runPair(cfg, *sd, *r, cfg.out / "images" / source.name / safeName(r->label), keepAll);
        if (!seedSequences.empty()) pair["biasVariance"] = biasVarianceOf(cfg, *sd, seedSequences, *r);
      } catch (const std::exception& e) {
        pair = {{"scene", source.name}, {"denoiser", r->name}, {"label", r->label}, {"params", json::object()},
                {"status", "failed"}, {"error", e.what()}};
      }
      results["pairs"].push_back(pair);
      ++pairsDone;
      double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      char buf[512];
      std::snprintf(buf, sizeof buf, "[%zu/%zu] %s on %s: %s in %.1f s (ETA %s)", pairsDone, pairsMine, r->label.c_str(),
                    source.name.c_str(), pair["status"] == "ok" ? "done" : "FAILED", took,
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
                    source.name.c_str(), mine.size(), std::chrono::duration<double>(now - sceneStart).count(),
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
  {
    StageTimer timer(Stage::Statistics);
    results["statistics"] = analyseRun(results).toJson();
    addReferenceQuality(results, cfg.warmup, cfg.referenceNotes);
  }
  commitResults(cfg.out, results);
}

}  // namespace arena
