#include "harness/benchmarks.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <random>
#include <sstream>

#include "core/env_info.hpp"
#include "core/error.hpp"
#include "core/non_finite.hpp"
#include "core/printed.hpp"
#include "harness/denoise_run.hpp"
#include "metrics/error.hpp"
#include "metrics/rank_agreement.hpp"
#include "metrics/results.hpp"
#include "tracer/scene_state.hpp"

namespace arena {

namespace {

using nlohmann::json;

// One run of Embree's `pathtracer` tutorial benchmark (embree-tools) on its Cornell box: its
// average Mrays/s and frames/s (rays per frame = their quotient); zeros where it did not run.
struct TutorialRun {
  double mrays = 0, fps = 0;
};
constexpr const char* kTutorialModelDir = "/usr/share/doc/embree3/models";

TutorialRun runTutorial(const std::string& sceneArgs, int size) {
  const std::string cmd = std::string("cd ") + kTutorialModelDir + " && /usr/bin/pathtracer " +
                          sceneArgs + " --size " + std::to_string(size) + " " +
                          std::to_string(size) + " --benchmark 10 50 2>/dev/null";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return {};
  std::array<char, 512> line{};
  TutorialRun run;
  while (fgets(line.data(), int(line.size()), p)) {
    double v;
    if (std::sscanf(line.data(), "BENCHMARK_RENDER_MRAYPS_AVG %lf", &v) == 1) run.mrays = v;
    if (std::sscanf(line.data(), "BENCHMARK_RENDER_AVG %lf", &v) == 1) run.fps = v;
  }
  pclose(p);
  return run;
}

// The tutorial's model file (cornell_box.ecs) holds its command line: the mesh, one point light
// and the camera. Without the -pointlight option and its six numbers the tutorial traces paths of
// the same distribution (its path weights and directions do not depend on the light; only their
// random numbers shift, as the light no longer draws any) without their shadow rays.
std::string withoutPointLight(const std::string& ecs) {
  std::istringstream in(ecs);
  std::string word, out;
  while (in >> word) {
    if (word == "-pointlight") {
      for (int i = 0; i < 6 && in >> word; ++i) {
      }
      continue;
    }
    out += (out.empty() ? "" : " ") + word;
  }
  return out;
}

// Embree's tutorial beside our tracer (`out` holds our rays per path and occlusion rays per path).
// Its headline rate is the tutorial's Mrays/s; a second run without its light gives its ray mix,
// the cost of each kind of ray and its rate at our mix (tutorialMix).
void compareWithTutorial(int size, json& out, const ProgressFn& progress) {
  const std::string model = std::string(kTutorialModelDir) + "/cornell_box.ecs";
  if (!std::filesystem::exists("/usr/bin/pathtracer") || !std::filesystem::exists(model)) {
    progress(
        "embree pathtracer: not measured (embree-tools not installed: apt-get install "
        "embree-tools)");
    return;
  }
  const TutorialRun lit = runTutorial("-c " + model, size);
  if (lit.mrays <= 0 || lit.fps <= 0) {
    progress("embree pathtracer: not measured (could not parse its output)");
    return;
  }
  const double ours = out["mrays_per_s"].get<double>();
  out["embree_pathtracer_mrays_per_s"] = lit.mrays;
  out["ratio_to_embree"] = ours / lit.mrays;
  progress(printed("embree pathtracer: %.2f Mrays/s  -> ratio %.2fx", lit.mrays, ours / lit.mrays));

  std::ifstream ecs(model);
  const std::string args = withoutPointLight(std::string(std::istreambuf_iterator<char>(ecs), {}));
  const TutorialRun dark = runTutorial(args, size);
  const double ourShare =
      out["occlusion_rays_per_path"].get<double>() / out["rays_per_path"].get<double>();
  const TutorialMix mix = tutorialMix(lit.mrays, lit.fps, dark.mrays, dark.fps, ourShare);
  if (!mix.counted) {
    progress(
        "embree pathtracer without its light: not measured (its output, or its rays, did not add "
        "up)");
    return;
  }
  out["embree_pathtracer_occlusion_share"] = mix.occlusionShare;
  progress(printed("embree pathtracer: %.0f%% of its rays are occlusion rays (ours %.0f%%)",
                   100 * mix.occlusionShare, 100 * ourShare));
  if (!mix.timed) {
    progress(
        printed("embree pathtracer: its frames took %.2f ms without its light against %.2f ms "
                "with it (a machine busy with something else?): no rate at our mix",
                1e3 / dark.fps, 1e3 / lit.fps));
    return;
  }
  out["embree_pathtracer_shadow_to_closest_cost"] = mix.shadowToClosestCost;
  out["embree_pathtracer_mrays_per_s_at_our_mix"] = mix.mraysAtMix;
  out["ratio_to_embree_at_our_mix"] = ours / mix.mraysAtMix;
  progress(
      printed("embree pathtracer: an occlusion ray costs it %.2f of a closest-hit ray; at our mix "
              "it would report %.2f Mrays/s  -> ratio %.2fx",
              mix.shadowToClosestCost, mix.mraysAtMix, ours / mix.mraysAtMix));
}

}  // namespace

TutorialMix tutorialMix(double litMrays, double litFps, double darkMrays, double darkFps,
                        double share) {
  TutorialMix mix;
  if (!(litMrays > 0 && litFps > 0 && darkMrays > 0 && darkFps > 0)) return mix;
  const double raysLit = litMrays * 1e6 / litFps, closest = darkMrays * 1e6 / darkFps;
  const double shadow = raysLit - closest;
  if (!(shadow > 0)) return mix;
  mix.counted = true;
  mix.occlusionShare = shadow / raysLit;
  const double addedSeconds = 1 / litFps - 1 / darkFps;
  if (!(addedSeconds > 0)) return mix;
  mix.timed = true;
  const double closestCost = 1 / darkFps / closest, shadowCost = addedSeconds / shadow;
  mix.shadowToClosestCost = shadowCost / closestCost;
  mix.mraysAtMix = 1e-6 / ((1 - share) * closestCost + share * shadowCost);
  return mix;
}

namespace {

// The input frame timed at step f of n distinct ones, forward and back: 0 1 .. n-1 n-2 .. 1 0 1 ..
size_t pingPong(int f, size_t n) {
  if (n < 2) return 0;
  const size_t k = size_t(f) % (2 * (n - 1));
  return k < n ? k : 2 * (n - 1) - k;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}
double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[std::min(v.size() - 1, size_t(std::ceil(0.95 * double(v.size()))) - 1)];
}

}  // namespace

PairedRatio pairedRatio(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> r;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    if (b[i] > 0) r.push_back(a[i] / b[i]);
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  if (r.empty()) return {kNone, kNone, kNone, 0};
  std::sort(r.begin(), r.end());
  const double n = double(r.size());
  if (r.size() < 6) return {median(r), kNone, kNone, r.size()};
  const double half = 1.96 * std::sqrt(n) / 2;
  const size_t lo = size_t(std::max(0.0, std::floor(n / 2 - half)));
  const size_t hi = std::min(r.size() - 1, size_t(std::ceil(n / 2 + half)) - 1);
  return {median(r), r[lo], r[hi], r.size()};
}

std::string PairedRatio::ciText(const char* format) const {
  if (!std::isfinite(lo) || !std::isfinite(hi))
    return "no 95% CI from " + std::to_string(pairs) + " pair(s); 6 are needed";
  return "95% CI " + printed(format, lo) + ", " + printed(format, hi);
}

double bilateralUnitMs(int width, int height, int repetitions) {
  cv::Mat src(height, width, CV_32FC3), dst;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) src.at<cv::Vec3f>(y, x) = cv::Vec3f(u(rng), u(rng), u(rng));
  cv::bilateralFilter(src, dst, 5, 0.1, 2.0);  // warm-up
  std::vector<double> ms;
  for (int i = 0; i < repetitions; ++i) {
    auto t0 = std::chrono::steady_clock::now();
    cv::bilateralFilter(src, dst, 5, 0.1, 2.0);
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  return median(ms);
}

json benchTracer(const TracerBench& b, const ProgressFn& progress) {
  Scene scene = loadScene(b.sceneFile);
  RenderSettings settings;
  settings.width = settings.height = b.size;
  settings.frames = 1;
  // The machine as the bench found it: read after the timed loop, the load average counted the
  // bench's own two busy threads.
  const json environment = environmentInfo();
  SequenceRenderer renderer(scene, settings);
  for (int i = 0; i < b.warmup; ++i) renderer.renderFrame(0);
  RayCounts total;
  auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < b.frames; ++i) {
    auto r = renderer.renderFrame(0);
    total += r.counts;
  }
  double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  json out = {{"scene", scene.name},
              {"size", b.size},
              {"frames", b.frames},
              {"seconds", sec},
              {"mrays_per_s", double(total.rays) / sec * 1e-6},
              {"mpaths_per_s", double(total.paths) / sec * 1e-6},
              {"rays_per_path", double(total.rays) / double(total.paths)},
              {"occlusion_rays_per_path", double(total.occlusionRays) / double(total.paths)},
              {"ms_per_frame", sec * 1e3 / b.frames},
              {"environment", environment}};
  progress(
      printed("arena tracer: %.2f Mrays/s, %.2f Mpaths/s, %.1f ms/frame at %dx%d (%.2f rays/path, "
              "%.2f of them occlusion rays)",
              out["mrays_per_s"].get<double>(), out["mpaths_per_s"].get<double>(),
              out["ms_per_frame"].get<double>(), b.size, b.size, out["rays_per_path"].get<double>(),
              out["occlusion_rays_per_path"].get<double>()));
  if (b.embree) compareWithTutorial(b.size, out, progress);
  return out;
}

json benchDenoise(const DenoiseBench& b, const ProgressFn& progress) {
  const int w = b.width, h = b.height;
  const json environment = environmentInfo();  // before the inputs' rendering loads the machine
  // What would time nothing, a contender against itself, or less than it does is refused before
  // anything renders.
  if (b.denoisers.empty()) throw Error("bench denoise: --denoisers names no denoiser");
  bool lowres = false;  // a contender reads the low-resolution buffer
  for (size_t i = 0; i < b.denoisers.size(); ++i) {
    const std::string& name = b.denoisers[i];
    if (std::find(b.denoisers.begin(), b.denoisers.begin() + long(i), name) !=
        b.denoisers.begin() + long(i))
      throw Error("bench denoise: --denoisers names " + name + " twice");
    const DenoiserInfo& info = DenoiserRegistry::instance().find(name);
    const auto params = b.params.find(name);
    const ParamSet resolved = info.schema.resolve(
        params == b.params.end() ? std::map<std::string, std::string>{} : params->second, name);
    const std::unique_ptr<Denoiser> probe = info.create(resolved, SignalKind::Diffuse);
    lowres = lowres || probe->wantsLowres();
    if (b.lowresFactor == 0 && probe->needsLowres())
      throw Error("bench denoise: " + lowresNeeded(name));
    if (b.inputs < 2 && info.origin.empty() && probe->needsGradients())
      throw Error("bench denoise: " + name +
                  " reads gradient samples, which need a frame before them: expected --inputs >= 2 "
                  "(with 1 its gradient passes would not run and its time would be low)");
  }
  for (const auto& [name, values] : b.params)
    if (std::find(b.denoisers.begin(), b.denoisers.end(), name) == b.denoisers.end())
      throw Error("bench denoise: --param " + name + "." +
                  (values.empty() ? "" : values.begin()->first) + ": " + name +
                  " is not among the denoisers timed");
  Scene scene = loadScene(b.sceneFile);
  // Frames past the scene's end would render its last pose again (keys hold), so more inputs
  // than the scene has would not be distinct frames as the option promises.
  if (b.inputs > scene.frames)
    throw Error(
        printed("bench denoise: --inputs %d: %s has %d frames; expected at most %d distinct inputs",
                b.inputs, b.sceneFile.c_str(), scene.frames, scene.frames));
  RenderSettings settings;
  settings.width = w;
  settings.height = h;
  settings.frames = std::max(1, b.inputs);
  settings.lowresFactor = b.lowresFactor;
  settings.lowresSpp = b.lowresSpp;
  SequenceRenderer renderer(scene, settings);
  std::vector<LayerSet> inputs, inputGradients, inputLowres;
  std::vector<CameraState> cameras;  // per input frame: reprojection needs them (hit points, depth)
  progress(printed("rendering %d input frame(s) of %s at %dx%d...", settings.frames, scene.name.c_str(), w, h));
  for (int t = 0; t < settings.frames; ++t) {
    auto r = renderer.renderFrame(t);
    inputs.push_back(std::move(r.frame));
    inputGradients.push_back(std::move(r.gradients));  // empty for frame 0
    cameras.push_back(evaluateState(scene, t, w, h).camera);
  }
  const double bu = bilateralUnitMs(1280, 720, 15);
  progress(printed("1 BU = cv::bilateralFilter(5, 0.1, 2.0) on 1280x720 CV_32FC3 = %.2f ms", bu));
  auto params = b.params;
  if (lowres && b.lowresFactor > 0) {
    progress(printed("rendering the low-resolution buffer (1/%d, %d spp)...", b.lowresFactor, b.lowresSpp));
    for (int t = 0; t < settings.frames; ++t) {
      RayCounts counts;
      inputLowres.push_back(renderer.renderLowres(t, counts));
    }
  }
  json out = {{"resolution", {w, h}}, {"bilateralUnitMs", bu},      {"frames", b.frames},
              {"warmup", b.warmup},   {"environment", environment}, {"denoisers", json::array()}};
  // Every contender runs on every frame, in an order rotated frame by frame, so that a change
  // of machine load (another process, thermal state) falls on all of them alike and the
  // per-frame ratios to the first contender are paired measurements.
  struct Contender {
    std::string name;
    ParamSet params;
    std::vector<SignalKind> kinds;
    std::vector<std::unique_ptr<Denoiser>> instances;
    std::vector<LayerSet> staged;  // per instance: its inputs, copied in before each timed call
    // ...and the low-resolution buffer and gradient samples it reads, staged the same way.
    std::vector<LayerSet> stagedLowres, stagedGradients;
    std::vector<double> total;
    std::vector<double>
        wall;               // the harness's clock around the calls, where a process reports its own
    bool reported = false;  // total holds a process's own reported compute time
    // Timed frames whose own report of their time outlasts the call (implausibleTime), the first
    // said in words; and the error that ended the contender's part (the others go on).
    int implausibleFrames = 0;
    std::string firstImplausible, error;
    std::string origin;  // DenoiserInfo::origin, which a fault of its output names
    std::map<std::string, std::vector<double>> passMs;
    std::map<std::string, double> passTaps;
    std::vector<std::string> passOrder;
  };
  std::vector<Contender> contenders;
  for (const std::string& name : b.denoisers) {
    const DenoiserInfo& info = DenoiserRegistry::instance().find(name);
    Contender c{name, info.schema.resolve(params[name], name)};
    c.origin = info.origin;
    c.kinds = info.signals == SignalMode::Color ? std::vector<SignalKind>{SignalKind::Color}
                                                : std::vector<SignalKind>{SignalKind::Diffuse, SignalKind::Specular};
    // Failing to start (a process that crashes before it is ready) ends this contender's part
    // too, as it fails its pair in a run: it is reported failed, the others are timed.
    try {
      for (SignalKind kind : c.kinds) c.instances.push_back(info.create(c.params, kind));
      for (auto& inst : c.instances) inst->setup(w, h);
    } catch (const std::exception& e) {
      c.error = std::string("setup: ") + e.what();
      progress(printed("%s failed in setup; the others go on: %s", name.c_str(), e.what()));
    }
    c.staged.resize(c.instances.size());
    c.stagedLowres.resize(c.instances.size());
    c.stagedGradients.resize(c.instances.size());
    contenders.push_back(std::move(c));
  }
  Image outImage(w, h, 3), signal;
  for (int f = 0; f < b.warmup + b.frames; ++f) {
    const size_t input = pingPong(f, inputs.size());
    const LayerSet& frame = inputs[input];
    const LayerSet& gradients = inputGradients[std::max<size_t>(1, input) % inputs.size()];
    FrameContext ctx;
    ctx.frameIndex = f;
    ctx.width = w;
    ctx.height = h;
    // The input frames run forward and back (0 1 2 1 0 1 ...): every frame follows a neighbour
    // with its camera, and no wrap cuts the history (a cut every few frames would time another mix
    // of work than a denoiser's steady state). A backward step keeps the frame's own motion
    // vectors, which point the other way: on a moving camera part of the history is rejected
    // there (the default scene's camera is still).
    ctx.reset = f == 0;
    ctx.camera = cameras[input];
    ctx.previousCamera = cameras[f > 0 ? pingPong(f - 1, inputs.size()) : input];
    for (size_t turn = 0; turn < contenders.size(); ++turn) {
      Contender& c = contenders[(turn + size_t(f)) % contenders.size()];
      if (!c.error.empty()) continue;
      const bool grads = c.instances[0]->needsGradients() && f > 0 && inputs.size() > 1;
      double frameMs = 0, frameWall = 0;
      std::string implausible;
      // A contender that fails (an error, a process that crashed, an output it did not write) ends
      // its own part, as a run fails only its pair; the others are timed on.
      try {
        for (size_t k = 0; k < c.instances.size(); ++k) {
          const SignalKind kind = c.kinds[k];
          // Every contender starts from the same cache state: what it reads (the signal and its
          // declared layers) has just been written, as by the passes that produce them in an
          // engine. Without this the layers came cold from the cycled input pool, while a plugin
          // that copied its inputs first read them warm -- and measured faster than its own code.
          // The output is marked first (as a run does, so a call that writes nothing is not timed
          // as fast), then the inputs copied: they are what the call finds in the cache.
          markUnwritten(outImage);
          signal = frame.get(signalName(kind));
          LayerSet& staged = c.staged[k];  // the instance's own: only what it declared
          for (const std::string& name : c.instances[k]->requiredChannels())
            staged.copyIn(name, frame.get(name));
          // The low-resolution buffer and the gradient samples too: a run reads them just
          // decoded (warm), and a contender reading them cold here was timed against one whose
          // inputs were all staged.
          const auto stage = [](LayerSet& into, const LayerSet& from) {
            for (const auto& [name, image] : from.all()) into.copyIn(name, image);
          };
          const bool low = c.instances[k]->wantsLowres() && !inputLowres.empty();
          if (low) stage(c.stagedLowres[k], inputLowres[input]);
          if (grads) stage(c.stagedGradients[k], gradients);
          const LowresInputs lowInputs{low ? c.stagedLowres[k] : frame, b.lowresFactor,
                                       b.lowresSpp};
          DenoiserInputs in{signal, staged, grads ? &c.stagedGradients[k] : nullptr,
                            low ? &lowInputs : nullptr};
          c.instances[k]->clearPassStats();
          auto t0 = std::chrono::steady_clock::now();
          c.instances[k]->denoise(ctx, in, outImage);
          const double wall =
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                  .count();
          if (const std::string fault =
                  outputFault(outImage, signal, c.name, kind, int(input), c.origin);
              !fault.empty())
            throw Error(fault);
          // An external process's own compute time; the wall clock (transfer included) otherwise.
          const std::optional<double> reported = c.instances[k]->reportedMilliseconds();
          // A time or count no measurement gives fails the contender, as it fails a run's pair.
          if (const std::string fault =
                  reportedFault(c.origin.empty() ? c.name : c.name + " (" + c.origin + ")",
                                std::string("the ") + signalName(kind) + " signal of input " +
                                    std::to_string(input),
                                reported, c.instances[k]->lastPasses(), wall);
              !fault.empty())
            throw Error(fault);
          c.reported = c.reported || reported.has_value();
          frameMs += reported.value_or(wall);
          frameWall += wall;
          if (f < b.warmup) continue;
          if (const std::string wrong =
                  implausibleTime(reported, c.instances[k]->lastPasses(), wall);
              !wrong.empty() && implausible.empty())
            implausible = std::string(signalName(kind)) + ": " + wrong;
          for (const PassStats& p : c.instances[k]->lastPasses()) {
            std::string pn = std::string(signalName(kind)) + "/" + p.name;
            if (!c.passMs.count(pn)) c.passOrder.push_back(pn);
            c.passMs[pn].push_back(p.milliseconds);
            c.passTaps[pn] = p.tapsPerPixel;
          }
        }
      } catch (const std::exception& e) {
        c.error = e.what();
        progress(printed("%s failed at frame %d; the others go on: %s", c.name.c_str(), f,
                         c.error.c_str()));
        continue;
      }
      if (f < b.warmup) continue;
      c.total.push_back(frameMs), c.wall.push_back(frameWall);
      if (!implausible.empty() && c.implausibleFrames++ == 0)
        c.firstImplausible = "frame " + std::to_string(f) + ", " + implausible;
    }
  }
  // The ratios' denominator: the first contender that did not fail.
  const Contender* baseline = nullptr;
  for (const Contender& c : contenders)
    if (c.error.empty() && !baseline) baseline = &c;
  if (!baseline) {
    std::string errors;
    for (const Contender& c : contenders) errors += (errors.empty() ? "" : "; ") + c.error;
    throw Error("bench denoise: every contender failed, nothing was timed: " + errors);
  }
  for (const Contender& c : contenders) {
    if (!c.error.empty()) {
      progress(printed("%-14s failed: %s", c.name.c_str(), c.error.c_str()));
      out["denoisers"].push_back({{"name", c.name},
                                  {"params", c.params.toJson()},
                                  {"status", "failed"},
                                  {"error", c.error}});
      continue;
    }
    // Bilateral units are this CPU's: a process's own report of its time (a GPU's, perhaps) is on
    // another clock and has none, its passes neither.
    json passes = json::array();
    for (const std::string& pn : c.passOrder) {
      json pass = {{"name", pn}, {"msMedian", median(c.passMs.at(pn))}};
      if (!c.reported) pass["bu"] = median(c.passMs.at(pn)) / bu;
      if (std::isfinite(c.passTaps.at(pn))) pass["tapsPerPixel"] = c.passTaps.at(pn);
      passes.push_back(pass);
    }
    // Which clock measured it, as `arena run` says (timing.msSource): a process's own report of its
    // compute time is not the harness's wall clock, and the two sit side by side here.
    json row = {{"name", c.name},
                {"params", c.params.toJson()},
                {"status", "ok"},
                {"msMedian", median(c.total)},
                {"msP95", p95(c.total)},
                {"passes", passes},
                {"msSource", c.reported ? "reported by the process" : "harness wall clock"}};
    std::string line =
        printed("%-14s %8.2f ms/frame (p95 %.2f)", c.name.c_str(), median(c.total), p95(c.total));
    if (c.reported) {
      row["msWallMedian"] = median(c.wall);
      line += printed("  [reported by the process, no BU; wall clock %.2f ms]", median(c.wall));
    } else {
      row["bu"] = median(c.total) / bu;
      line += printed("  %5.2f BU", median(c.total) / bu);
    }
    if (c.implausibleFrames > 0) {
      row["implausibleFrames"] = c.implausibleFrames;
      row["implausibleFirst"] = c.firstImplausible;
    }
    if (&c != baseline) {
      // A ratio of two times read on one clock: where either contender reported its own time (a
      // process's, perhaps a GPU's), both are taken on the harness's wall clock around the calls.
      const Contender& first = *baseline;
      const bool wall = c.reported || first.reported;
      const PairedRatio r =
          wall ? pairedRatio(c.wall, first.wall) : pairedRatio(c.total, first.total);
      row["ratioTo"] = {{"name", first.name},
                        {"median", r.median},
                        {"ci95", {r.lo, r.hi}},
                        {"clock", wall ? "harness wall clock, both" : "as msMedian"}};
      line += printed("  x%.3f of %s%s [%s]", r.median, first.name.c_str(),
                      wall ? " on the wall clock" : "", r.ciText().c_str());
    }
    progress(line);
    if (c.implausibleFrames > 0)
      progress(
          printed("    warning: reported times longer than the call that carried them on %d of %d "
                  "frames (%s); no work in a call outlasts the call, so these ms are not credible",
                  c.implausibleFrames, int(c.total.size()), c.firstImplausible.c_str()));
    for (const auto& p : passes)
      progress(printed(
          "    %-34s %8.2f ms  %s  %s taps/px", p["name"].get<std::string>().c_str(),
          p["msMedian"].get<double>(),
          p.contains("bu") ? printed("%5.2f BU", p["bu"].get<double>()).c_str() : "   no BU",
          p.contains("tapsPerPixel") ? printed("%5.1f", p["tapsPerPixel"].get<double>()).c_str()
                                     : "    ?"));
    out["denoisers"].push_back(row);
  }
  return out;
}

namespace {

struct Measured {
  double seconds = 0, relMse = 0, estimatedRelMse = 0, spp = 0;
};

// One sampler's reference of `frame` at about `spp` samples, timed, and its true error against
// the gold (the gold's own noise term subtracted).
Measured measure(const Scene& scene, RenderSettings settings, const std::string& sampler, bool adaptive, int frame,
                 int spp, const LayerSet& gold) {
  settings.referenceSampler = sampler;
  SequenceRenderer renderer(scene, settings);
  RayCounts counts;
  const int perReplicate = std::max(1, spp / renderer.referenceReplicates());
  renderer.frameScene(frame);  // the Embree build is not part of a sampler's time
  const auto t0 = std::chrono::steady_clock::now();
  ReferenceSums sums = renderer.emptyReferenceSums(0, renderer.referenceReplicates());
  if (adaptive) {
    renderer.extendReference(frame, sums, std::max(1, perReplicate / 4), counts);  // the pilot
    // A tile may get up to 8x the mean count.
    for (;;) {  // the references' rounds; the last one is cut to the count (rounding may miss it)
      const bool last = kReferenceRoundGrowth * sums.meanSpp() >= 0.99 * perReplicate * sums.replicates;
      const std::vector<int> next =
          nextReferenceAllocation(sums, 8 * perReplicate, kReferenceRoundGrowth, perReplicate);
      if (next == sums.tileSamples) break;
      renderer.extendReference(frame, sums, next, counts);
      if (last) break;
    }
  } else {
    renderer.extendReference(frame, sums, perReplicate, counts);
  }
  Measured m;
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  m.spp = sums.meanSpp();
  const LayerSet ref = referenceLayersFromSums(sums);
  m.relMse = linearError(ref.get("color"), gold.get("color"), &gold.get("colorVar")).relMseCorrected;
  m.estimatedRelMse = estimatedReferenceRelMse(sums);
  return m;
}

}  // namespace

json benchReference(const ReferenceBench& b, const ProgressFn& progress) {
  RenderSettings settings = b.settings;
  json out = {{"resolution", std::to_string(settings.width) + "x" + std::to_string(settings.height)},
              {"spp", b.spp},
              {"goldFactor", b.goldFactor},
              {"maxBounces", settings.maxBounces > 0 ? json(settings.maxBounces) : json("scene")},
              {"referenceTile", settings.referenceTile},
              {"scenes", json::array()},
              {"environment", environmentInfo()}};
  for (const Scene& scene : b.scenes) {
    if (b.frame >= scene.frames)
      throw Error("--frame " + std::to_string(b.frame) + ": scene " + scene.name + " has " +
                  std::to_string(scene.frames) + " frames");
    RenderSettings goldSettings = settings;
    goldSettings.referenceSampler = "sobol";
    SequenceRenderer goldRenderer(withIndependentSeed(scene), goldSettings);
    ReferenceSums goldSums;
    RayCounts counts;
    const auto g0 = std::chrono::steady_clock::now();
    goldRenderer.extendReference(b.frame, goldSums, std::max(1, b.spp * b.goldFactor / goldRenderer.referenceReplicates()),
                                 counts);
    const double goldSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - g0).count();
    const LayerSet gold = referenceLayersFromSums(goldSums);
    const double goldNoise = estimatedReferenceRelMse(goldSums);
    settings.referenceReplicates = b.replicates;
    // Each repeat renders the three estimators under its own seed (repeat 0: the scene's), so the
    // repeats are independent draws of each estimator's error and time; the gold is shared.
    std::vector<Measured> ind, sob, ada;
    std::vector<double> indCost, sobCost, adaCost;  // relMSE x seconds: lower is more efficient
    for (int r = 0; r < b.repeats; ++r) {
      Scene repeat = scene;
      if (r > 0) repeat.seed = uint32_t(mix64(uint64_t(scene.seed) ^ (0x7265706561740000ull + uint64_t(r))) >> 32);
      // The baseline is the plain path tracer under the independent sampler, whichever estimator
      // the scene's references use (the Sobol rows and the gold use the scene's).
      Scene baseline = repeat;
      baseline.referenceEstimator = ReferenceEstimator::Path;
      ind.push_back(measure(baseline, settings, "independent", false, b.frame, b.spp, gold));
      sob.push_back(measure(repeat, settings, "sobol", false, b.frame, b.spp, gold));
      ada.push_back(measure(repeat, settings, "sobol", true, b.frame, b.spp, gold));
      indCost.push_back(ind.back().relMse * ind.back().seconds);
      sobCost.push_back(sob.back().relMse * sob.back().seconds);
      adaCost.push_back(ada.back().relMse * ada.back().seconds);
    }
    // The equal-time gain over the independent sampler: the median over repeats of the cost ratio,
    // with the distribution-free 95% interval of that median (none under 6 repeats).
    const PairedRatio sobolGain = pairedRatio(indCost, sobCost), gain = pairedRatio(indCost, adaCost);
    auto medianOf = [](const std::vector<Measured>& ms, double Measured::*field) {
      std::vector<double> v;
      for (const Measured& m : ms) v.push_back(m.*field);
      return median(v);
    };
    auto summary = [&](const std::vector<Measured>& ms) {
      json j = {{"relMse", medianOf(ms, &Measured::relMse)},
                {"seconds", medianOf(ms, &Measured::seconds)},
                {"estimatedRelMse", medianOf(ms, &Measured::estimatedRelMse)},
                {"spp", medianOf(ms, &Measured::spp)},
                {"repeats", json::array()}};
      for (const Measured& m : ms)
        j["repeats"].push_back({{"relMse", m.relMse}, {"seconds", m.seconds}, {"estimatedRelMse", m.estimatedRelMse}});
      return j;
    };
    const json indJ = summary(ind), sobJ = summary(sob), adaJ = summary(ada);
    const char* estimator =
        scene.referenceEstimator == ReferenceEstimator::Bidirectional ? "bidirectional" : "path";
    progress(printed(
        "%-22s %d spp, %d repeats (medians): independent path relMSE %.3e in %.2f s | %s "
        "sobol %.3e in %.2f s "
        "(gain %.2fx [%s]) | adaptive %.0f spp %.3e in %.2f s (est. %.3e) "
        "| gold %d spp "
        "in %.1f s, own noise %.1e | gain %.2fx [%s]",
        scene.name.c_str(), int(std::lround(indJ["spp"].get<double>())), b.repeats,
        indJ["relMse"].get<double>(), indJ["seconds"].get<double>(), estimator,
        sobJ["relMse"].get<double>(), sobJ["seconds"].get<double>(), sobolGain.median,
        sobolGain.ciText("%.2f").c_str(), adaJ["spp"].get<double>(), adaJ["relMse"].get<double>(),
        adaJ["seconds"].get<double>(), adaJ["estimatedRelMse"].get<double>(), goldSums.spp(),
        goldSeconds, goldNoise, gain.median, gain.ciText("%.2f").c_str()));
    out["scenes"].push_back({{"scene", scene.name},
                             {"repeats", b.repeats},
                             {"independent", indJ},
                             {"sobol", sobJ},
                             {"adaptive", adaJ},
                             {"sobolGain", sobolGain.median},
                             {"sobolGainCi95", {sobolGain.lo, sobolGain.hi}},
                             {"goldSpp", goldSums.spp()},
                             {"goldSeconds", goldSeconds},
                             {"goldRelMse", goldNoise},
                             {"gain", gain.median},
                             {"gainCi95", {gain.lo, gain.hi}},
                             {"estimator", estimator},
                             {"gainEstimator", std::string("adaptive sobol, ") + estimator +
                                                   " (the study's references)"}});
  }
  return out;
}

nlohmann::json benchRankAgreement(const std::string& runA, const std::string& runB, const ProgressFn& progress) {
  const RunResults a = loadResults(runA), b = loadResults(runB);
  // The first common scene's size in each run: what the comparison is about.
  auto size = [](const RunResults& r, const std::string& scene) {
    const nlohmann::json& s = r.scenes.value(scene, nlohmann::json::object());
    return std::to_string(s.value("width", 0)) + "x" + std::to_string(s.value("height", 0));
  };
  if (!a.statistics || !b.statistics)
    throw Error((a.statistics ? runB : runA) + ": the run has no statistics (expected a finished run)");
  const std::vector<SceneRankAgreement> scenes = compareRankings(*a.statistics, *b.statistics);
  if (scenes.empty())
    throw Error(runA + " and " + runB + ": no scene is ranked in both runs (expected runs of the same scenes)");
  progress("rank agreement: " + runA + " (A, " + size(a, scenes.front().scene) + ") against " + runB + " (B, " +
           size(b, scenes.front().scene) + "), ranked on " + scenes.front().metric);
  char line[256];
  std::snprintf(line, sizeof line, "%-22s %7s %10s %10s %14s %6s", "scene", "methods", "tau ranks",
                "tau values", "resolved", "flips");
  progress(line);
  nlohmann::json out = {{"runA", runA}, {"runB", runB}, {"scenes", nlohmann::json::array()}};
  double tauSum = 0;
  int tauCount = 0, flips = 0;
  for (const SceneRankAgreement& s : scenes) {
    std::snprintf(line, sizeof line, "%-22s %7zu %10.2f %10.2f %14s %6zu", s.scene.c_str(),
                  s.methods.size(), s.tauRanks, s.tauValues, s.resolvedText().c_str(),
                  s.flips.size());
    progress(line);
    for (const RankFlip& f : s.flips)
      progress("    flip: " + f.better + " better than " + f.worse + " in A (" + std::to_string(f.diffA) +
               "), worse in B (" + std::to_string(f.diffB) + ")");
    if (std::isfinite(s.tauRanks)) {
      tauSum += s.tauRanks;
      ++tauCount;
    }
    flips += int(s.flips.size());
    out["scenes"].push_back(s.toJson());
  }
  out["meanTauRanks"] = tauCount > 0 ? nlohmann::json(tauSum / tauCount) : nlohmann::json();
  out["flips"] = flips;
  progress("resolved: pairs resolved in A / in B / in both; a flip is resolved in both in opposite orders");
  std::snprintf(line, sizeof line, "mean tau (ranks) over %d scene(s): %.2f; %d flip(s)", tauCount,
                tauCount > 0 ? tauSum / tauCount : std::nan(""), flips);
  progress(line);
  return out;
}

}  // namespace arena
