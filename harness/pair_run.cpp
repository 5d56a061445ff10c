#include "harness/pair_run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>

#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/json_reader.hpp"
#include "core/stage_clock.hpp"
#include "harness/gpu_cost.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/error_maps.hpp"
#include "metrics/results.hpp"
#include "reports/image_files.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// An output's mean luminance against the references' (or, without them, the noisy inputs'), said.
std::string brightnessText(double ratio, bool againstReference) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", ratio);
  return "its output's mean luminance is " + std::string(text) + "x the " +
         (againstReference ? "references'" : "noisy inputs' (there are no references)") +
         " over the sequence: outputs are linear radiance at the input's exposure, and another "
         "exposure, a tone map or display encoding (sRGB, gamma) is scored as the denoiser's "
         "error" +
         (ratio < 1
              ? std::string("; a denoiser that clamps fireflies loses light too (hybrid keeps "
                            "0.3x on hard_light), so darker may be its bias, which is scored")
              : std::string());
}

}  // namespace

std::vector<std::string> runWarnings(const json& pair, int frames) {
  std::vector<std::string> first;
  if (const json timing = pair.value("timing", json::object());
      timing.contains("implausibleFrames"))
    first.push_back("reported times longer than the call that carried them on " +
                    timing["implausibleFrames"].dump() + " of " + std::to_string(frames) +
                    " frames (" + timing.value("implausibleFirst", "") +
                    "); no work in a call outlasts the call, so its reported ms are not credible");
  if (const json timing = pair.value("timing", json::object());
      timing.value("reportedZeroEveryFrame", false)) {
    char wall[48] = "not known";
    if (const json w = timing.value("msWallMedian", json()); w.is_number())
      std::snprintf(wall, sizeof wall, "median %.3g ms", w.get<double>());
    first.push_back("reported a time of 0 ms on all " + std::to_string(frames) +
                    " frames (the harness's wall clock around its calls: " + wall +
                    "): no filter takes no time, so its timer is likely not read; its ms, and its "
                    "place on the speed axes, are not credible");
  }
  if (pair.contains("oracleLayers")) {
    std::string named;
    for (const json& layer : pair["oracleLayers"]) {
      const std::string name = layer.get<std::string>();
      named += (named.empty() ? "" : ", ") + name + " (" + channels::oracleLayers().at(name) + ")";
    }
    first.push_back("reads oracle data a real-time engine would not have: " + named +
                    "; its results are not on equal terms with the others'");
  }
  if (const json inputs = pair.value("sanitizedInputs", json::object());
      inputs.value("total", 0L) > 0)
    first.push_back(sanitizedWarning(inputs["channels"].get<NonFiniteCounts>()));
  if (pair.value("equalsInputEveryFrame", false))
    first.push_back(
        "the output is its input value for value on all " + std::to_string(frames) + " frames" +
        (pair.value("signals", "") != "color" ? " (the diffuse and specular signals it was given)"
                                              : std::string()) +
        ": scored as a denoiser's, it filtered nothing (is the input wired in as the output?)");
  for (const bool againstReference : {true, false})
    if (const json ratio =
            pair.value(againstReference ? "brightnessVsReference" : "brightnessVsInput", json());
        ratio.is_number())
      first.push_back(brightnessText(ratio.get<double>(), againstReference));
  for (const json& ended : pair.value("processEnds", json::array()))
    if (ended.is_string())
      first.push_back(ended.get<std::string>() + " (every frame was answered: its results stand)");
  return first;
}

namespace {

// Whether frame t's images are kept: every frame's with keepAll, else the report's chosen frames.
bool keepsImagesOf(const RunConfig& cfg, const SceneData& sd, bool keepAll, int t) {
  if (cfg.keepFrames == "none") return false;
  return keepAll || std::find(sd.chosenFrames.begin(), sd.chosenFrames.end(), t) != sd.chosenFrames.end();
}

// runWarnings, put before the evaluation's (a pair measured again keeps them).
void prependRunWarnings(json& pair, int frames) {
  json all = runWarnings(pair, frames);
  for (const json& w : pair.value("warnings", json::array())) all.push_back(w);
  pair["warnings"] = std::move(all);
}

void writeFrameImages(const fs::path& imageDir, int t, const FrameImages& images) {
  writePng(imageDir / frameName("frame", t), images.display);
  if (!images.flip.empty()) writePng(imageDir / frameName("flip", t), images.flip);
  // No reference (a capture without one): no error map to keep. Beside the map, its values
  // unclamped (the map's 8 bits stop at 10, where a firefly's error begins) as block means: a
  // region's relMSE in the report.
  if (!images.relativeError.empty()) {
    writePng(imageDir / frameName("relerr", t), images.relativeError);
    LayerSet values;
    values.set("Y", blockMeans(images.relativeSquaredError, kRelErrorBlock));
    writeExr(fs::path(imageDir / frameName("relerr", t)).replace_extension(".exr"), values,
             {{"Y", {}}},
             ExrAttributes{{"arena.values",
                            "relative squared error (d - r)^2 / (r^2 + 0.01), mean of R, G, B, "
                            "mean over each block of " +
                                std::to_string(kRelErrorBlock) + "x" +
                                std::to_string(kRelErrorBlock) + " pixels"}});
  }
}

// Every output frame as an EXR (colour, and the two signals a split denoiser filtered).
void writeOutputExr(const fs::path& imageDir, const DenoisedFrame& f, const DenoiserRequest& req,
                    const ParamSet& params, const std::string& scene) {
  LayerSet out;
  out.set("color", f.color);
  std::vector<LayerSpec> specs = {{"color", {"R", "G", "B"}}, {"color", {"R", "G", "B"}, false, true}};
  for (const char* signal : {"diffuse", "specular"}) {
    const Image& image = std::string(signal) == "diffuse" ? f.diffuse : f.specular;
    if (image.empty()) continue;  // a colour denoiser has no separate signals
    out.set(signal, image);
    specs.push_back({signal, {"R", "G", "B"}});
  }
  // The scene says whose frames these denoise (`arena export --output` refuses another scene's).
  writeExr(Sequence::framePath(imageDir, f.frame), out, specs,
           {{"arena.denoiser", req.name},
            {"arena.params", jsonText(params.toJson())},
            {"arena.scene", scene}});
}

// Reads the stored outputs of a denoiser that ran elsewhere (a capture's outputs/NAME) as the
// stream of frames a built-in would hand over; their time is the one the capture recorded.
void runCapturedOutput(const Sequence& sequence, const std::string& name,
                       const std::function<void(const DenoisedFrame&)>& onFrame) {
  const CaptureDescription& capture = sequence.capture();
  const CaptureOutput& output = capture.output(name);
  if (!output.timingProblem.empty()) throw Error(output.timingProblem);  // this pair's fault
  DenoisedFrame f;
  for (int t = 0; t < sequence.info().frames; ++t) {
    f.frame = t;
    f.color = readCaptureOutput(capture, name, t);  // refuses non-finite values, naming the file
    f.selfTimed = !output.milliseconds.empty();
    f.milliseconds = f.selfTimed ? output.milliseconds[size_t(t)] : std::numeric_limits<double>::quiet_NaN();
    onFrame(f);
  }
}

}  // namespace

json runPair(const RunConfig& cfg, const SceneData& sd, const DenoiserRequest& req, const fs::path& imageDir,
             bool keepAll, std::vector<KeptFrame>* kept, EvaluationScope scope) {
  const SequenceInfo& info = sd.sequence.info();
  const bool screening = scope == EvaluationScope::Screening;
  if (screening && !kept) throw Error("runPair: a screening keeps the output frames to measure them in full");
  const std::string captured = capturedOutputName(req.name);
  if (!captured.empty() && !sd.sequence.isCapture())
    throw Error(req.name + ": scene " + info.scene + " is not a capture; file: contenders are outputs stored in a "
                "capture's outputs/ folder (docs/captures.md)");
  std::unique_ptr<DenoiseRun> run = captured.empty() ? std::make_unique<DenoiseRun>(req, sd.sequence) : nullptr;
  const ParamSet params = run ? run->params() : ParamSet{};
  PairEvaluation evaluation(sd.evaluation, scope);
  bool selfTimed = false;
  NonFiniteCounts sanitized;  // over every frame, warm-up included: each one shaped the history
  uint64_t outputChecksum = 1469598103934665603ull;  // of every output frame, in order
  int implausibleFrames = 0;  // frames whose reported time exceeds the call that carried it
  int zeroTimedFrames = 0;    // frames whose reported time is 0 (a timer not read?)
  std::string firstImplausible;
  std::vector<std::vector<PassTime>> passes;
  std::vector<double> ms;
  GpuFrameCost gpuCost(info.width, info.height);  // the speed axis's predicted GPU ms (issue 31)
  // Frames whose output is the input value for value: on every frame, a contender wired to pass
  // its input through (a stored output copied from the noisy frames), said, never scored silently
  // as a denoiser. (On some frames it is no fault: a temporal filter's first frame is its input.)
  // Not for an identity by design (passthrough).
  const bool identity = run && run->info().identity;
  std::vector<int> equalsInput;
  // An output made outside (a stored output, a process, a plugin) at another exposure, tone
  // mapped or display-encoded scores as a poor denoiser, which it may not be: its mean luminance
  // against the references' (without references, the noisy inputs', which average to them), over
  // every frame, is warned of beyond 1.25x either way. It is still scored: a denoiser that clamps
  // fireflies loses light (hybrid keeps 0.31x of hard_light's at 48x27), which is its bias and its
  // measurement, and a short noisy input's mean is itself uncertain.
  const bool madeOutside = !run || !run->info().origin.empty();
  const bool againstReference = sd.evaluation.hasReference();
  double outputLight = 0, referenceLight = 0;
  auto onFrame = [&](const DenoisedFrame& f) {
    if (madeOutside && f.color.channels() >= 3) {
      outputLight += finiteLuminanceSum(f.color);
      referenceLight +=
          finiteLuminanceSum(againstReference ? sd.evaluation.reference(f.frame).get("color")
                                              : sd.evaluation.frame(f.frame).get("color"));
    }
    if (!identity) {
      const Image& in = sd.evaluation.frame(f.frame).get("color");
      if (f.outputIsInput || (in.sameShape(f.color) &&
                              std::equal(in.raw().begin(), in.raw().end(), f.color.raw().begin())))
        equalsInput.push_back(f.frame);
    }
    FrameFacts facts;
    facts.milliseconds = f.milliseconds;
    if (f.selfTimed && run) facts.wallMilliseconds = f.wallMilliseconds;
    // Extra paths: the low-resolution buffer's (reengine) or the gradient samples'
    // (asvgf), each at the rate it rendered at.
    if (run && (run->readsLowres() || run->readsGradients()))
      facts.extraRaysPerPixel = f.extraRaysPerPixel;
    facts.extraPathsPerSecond = run && run->readsLowres() ? info.lowresPathsPerSecond : info.inputPathsPerSecond;
    StageTimer metrics(Stage::Metrics);  // inside the denoiser's run: its time is taken out of it
    evaluation.add(f.frame, f.color, facts);
    if (kept) kept->push_back({f.frame, f.color, facts});
    selfTimed |= f.selfTimed;
    for (int c = 0; c < f.color.channels(); ++c)
      outputChecksum = (outputChecksum ^ wordChecksum(f.color.plane(c), f.color.pixelCount())) *
                       1099511628211ull;
    for (const auto& [channel, n] : f.sanitized) sanitized[channel] += n;
    zeroTimedFrames += f.selfTimed && f.milliseconds == 0;
    if (!f.implausibleTime.empty() && implausibleFrames++ == 0)
      firstImplausible = "frame " + std::to_string(f.frame) + ", " + f.implausibleTime;
    ms.push_back(f.milliseconds);
    std::vector<PassTime>& frame = passes.emplace_back();
    for (const PassStats& p : f.passes) frame.push_back({p.name, p.milliseconds, p.tapsPerPixel});
    if (run) gpuCost.add(f.passes);
    if (keepsImagesOf(cfg, sd, keepAll, f.frame)) {
      StageTimer images(Stage::Report);
      if (!screening) writeFrameImages(imageDir, f.frame, evaluation.lastImages());
      if (keepAll) writeOutputExr(imageDir, f, req, params, info.scene);
    }
  };
  std::vector<std::string> processEnds;  // an external process that ended badly after its frames
  {
    StageTimer denoisers(Stage::Denoisers);
    if (run) {
      run->run([&](int t) -> const LayerSet& { return sd.evaluation.frame(t); }, onFrame);
      processEnds = run->finish();
    } else
      runCapturedOutput(sd.sequence, captured, onFrame);
  }
  json pair = {{"scene", info.scene}, {"denoiser", req.name}, {"label", req.label}, {"params", params.toJson()},
               {"status", "ok"}};
  {
    StageTimer metrics(Stage::Metrics);
    pair.update(evaluation.finish());
  }
  // Oracle data (a layer no real-time engine has), named in the results and in a warning: the
  // method is then not ranked on equal terms.
  if (run) {
    json oracles = json::array();
    for (const std::string& layer : run->readLayers())
      if (channels::oracleLayers().count(layer)) oracles.push_back(layer);
    if (!oracles.empty()) pair["oracleLayers"] = oracles;
  }
  json timing;
  if (run) {
    timing = timingSummary(passes, ms, cfg.warmup, info.width, info.height);
    // External processes time themselves: "ms" is what they reported, "msWall" the harness's clock
    // around the exchange (transfer included). Built-ins and plugins: the harness's clock. A
    // process's own clock may be a GPU's: its time is charted on an axis of its own ("process").
    timing["msSource"] = selfTimed ? "reported by the process" : "harness wall clock";
    timing["clock"] = selfTimed ? "process" : "cpu";
    if (const Summary wall = summarize(evaluation.values("msWall"), cfg.warmup);
        selfTimed && !wall.empty())
      timing["msWallMedian"] = wall.median;
    const json gpu = gpuCost.summary(cfg.warmup);
    if (!gpu.is_null()) timing["gpuPredicted"] = gpu;
    // A process or plugin that reports no passes says nothing of its taps: unknown, not the 0 of a
    // built-in that has none (passthrough).
    if (!run->info().origin.empty() && timing["passes"].empty()) timing.erase("tapsPerPixel");
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
      // Its frames carry no time (none is put): the summary says why, and a warning repeats it,
      // as for any absent summary.
      if (pair.contains("summary")) {
        const std::string why = "not recorded in the capture (capture.json's outputs." + captured +
                                " gives no milliseconds)";
        pair["summary"]["ms"] = {{"frames", 0}, {"absent", why}};
        pair["warnings"].push_back("ms has no summary: " + why);
      }
    }
  }
  // A time the denoiser reported for work longer than the call that carried it cannot be: counted
  // and warned of (runWarnings), never charted silently.
  if (run && zeroTimedFrames == info.frames) timing["reportedZeroEveryFrame"] = true;
  if (implausibleFrames > 0) {
    timing["implausibleFrames"] = implausibleFrames;
    timing["implausibleFirst"] = firstImplausible;
  }
  pair["timing"] = timing;
  pair["outputChecksum"] = checksumHex(outputChecksum);
  if (run) pair["readsLowres"] = run->readsLowres();  // compare judges the buffer's settings by it
  // A denoiser that carries nothing between frames: its event and cut figures are by construction.
  if (run && !run->info().keepsHistory) pair["keepsHistory"] = false;
  pair["sanitizedInputs"] = {{"total", totalNonFinite(sanitized)}, {"channels", sanitized}};
  if (!processEnds.empty()) pair["processEnds"] = processEnds;
  if (!equalsInput.empty() && int(equalsInput.size()) == info.frames)
    pair["equalsInputEveryFrame"] = true;
  if (referenceLight > 0) {  // a black output is the extreme case: a ratio of 0
    const double ratio = std::max(outputLight, 0.0) / referenceLight;
    const double factor =
        ratio > 0 ? std::max(ratio, 1 / ratio) : std::numeric_limits<double>::infinity();
    if (factor > 1.25)
      pair[againstReference ? "brightnessVsReference" : "brightnessVsInput"] = ratio;
  }
  if (!run || run->signals() == SignalMode::Color) pair["signals"] = "color";
  prependRunWarnings(pair, info.frames);
  // With --keep-frames none no image was written: none is recorded (a folder named in results.json
  // that does not exist read as images lost).
  if (cfg.keepFrames != "none")
    pair["images"] = {{"dir", fs::relative(imageDir, cfg.out).string()}, {"all", keepAll}};
  if (run && !run->info().origin.empty()) pair["origin"] = run->info().origin;
  if (!run) pair["origin"] = (sd.sequence.dir() / "outputs" / captured).string();
  return pair;
}

json evaluatePairAgain(const RunConfig& cfg, const SceneData& sd, const json& first, const std::vector<KeptFrame>& kept,
                       const fs::path& imageDir, bool keepAll, EvaluationScope scope) {
  StageTimer metrics(Stage::Metrics);
  PairEvaluation evaluation(sd.evaluation, scope);
  for (const KeptFrame& f : kept) {
    evaluation.add(f.frame, f.color, f.facts);
    if (scope == EvaluationScope::Full && keepsImagesOf(cfg, sd, keepAll, f.frame)) {
      StageTimer images(Stage::Report);
      writeFrameImages(imageDir, f.frame, evaluation.lastImages());
    }
  }
  json pair = first;
  pair.update(evaluation.finish());
  prependRunWarnings(pair, sd.sequence.info().frames);  // the evaluation's warnings were replaced
  return pair;
}

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

}  // namespace arena
