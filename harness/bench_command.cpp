// `arena bench tracer`: Mrays/s and Mpaths/s of the 1-spp frame pass (G-buffer, mirror ray, path
// with NEE, gradient samples) on the Cornell box at 512x512, warm-up excluded; optionally beside
// Embree's own `pathtracer` tutorial measured in the same sitting.
#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/atomic_file.hpp"
#include "core/env_info.hpp"
#include <cmath>
#include <map>
#include "core/error.hpp"
#include "harness/commands.hpp"
#include "harness/denoise_run.hpp"
#include "harness/scene_selection.hpp"
#include "tracer/render.hpp"

#include <opencv2/imgproc.hpp>
#include <algorithm>
#include <random>

namespace arena::cli {

namespace {

// Runs Embree's tutorial benchmark and returns its average Mrays/s (0 if unavailable).
double embreePathtracerMrays(int size, std::string& note) {
  const char* model = "/usr/share/doc/embree3/models/cornell_box.ecs";
  if (!std::filesystem::exists("/usr/bin/pathtracer") || !std::filesystem::exists(model)) {
    note = "embree-tools not installed (apt-get install embree-tools)";
    return 0;
  }
  std::string cmd = std::string("/usr/bin/pathtracer -c ") + model + " --size " + std::to_string(size) + " " +
                    std::to_string(size) + " --benchmark 10 50 2>/dev/null";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return 0;
  std::array<char, 512> line{};
  double mrays = 0;
  while (fgets(line.data(), int(line.size()), p)) {
    double v;
    if (std::sscanf(line.data(), "BENCHMARK_RENDER_MRAYPS_AVG %lf", &v) == 1) mrays = v;
  }
  pclose(p);
  if (mrays == 0) note = "could not parse pathtracer output";
  return mrays;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}
double p95(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[std::min(v.size() - 1, size_t(std::ceil(0.95 * double(v.size()))) - 1)];
}

// The median of the per-frame ratios a[i] / b[i] of two contenders timed on the same frames, and a
// distribution-free 95% interval for it: the order statistics of the sorted ratios whose ranks
// bracket the median at the binomial(n, 1/2) 2.5% and 97.5% points (normal approximation, n >= 6;
// fewer frames give the whole range).
struct PairedRatio {
  double median = 0, lo = 0, hi = 0;
};
PairedRatio pairedRatio(const std::vector<double>& a, const std::vector<double>& b) {
  std::vector<double> r;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    if (b[i] > 0) r.push_back(a[i] / b[i]);
  if (r.empty()) return {};
  std::sort(r.begin(), r.end());
  const double n = double(r.size());
  const double half = 1.96 * std::sqrt(n) / 2;
  const size_t lo = n < 6 ? 0 : size_t(std::max(0.0, std::floor(n / 2 - half)));
  const size_t hi = n < 6 ? r.size() - 1 : std::min(r.size() - 1, size_t(std::ceil(n / 2 + half)) - 1);
  return {median(r), r[lo], r[hi]};
}

// One "bilateral unit" (BU): the median time of cv::bilateralFilter(src, dst, 5, 0.1, 2.0) on a
// 1280x720 CV_32FC3 image, measured in the same process and sitting as the denoisers, so ratios
// stay comparable across noisy machines.
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

}  // namespace

void addBenchCommand(CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "Benchmarks (tracer; denoise; reference)");
  bench->require_subcommand(1);
  addBenchReferenceCommand(bench);
  auto* tracer = bench->add_subcommand("tracer", "Tracer throughput: Mrays/s and Mpaths/s, Cornell box, 1 spp");
  struct Options {
    int size = 512, frames = 20, warmup = 3;
    bool embree = false;
    std::string scene = defaultScenesDir() + "/cornell_static.json";
    std::string json;
  };
  auto o = std::make_shared<Options>();
  tracer->add_option("--size", o->size, "Square resolution")->check(CLI::Range(1, kMaxSceneResolution))->default_val(512);
  tracer->add_option("--frames", o->frames, "Timed frames")->check(CLI::Range(1, 100000))->default_val(20);
  tracer->add_option("--warmup", o->warmup, "Untimed warm-up frames")->check(CLI::Range(0, 100000))->default_val(3);
  tracer->add_option("--scene", o->scene, "Scene file");
  tracer->add_flag("--embree", o->embree, "Also run Embree's pathtracer tutorial (embree-tools) for comparison");
  tracer->add_option("--json", o->json, "Write results to this JSON file")->default_str("none");
  tracer->callback([o] {
    Scene scene = loadScene(o->scene);
    RenderSettings settings;
    settings.width = settings.height = o->size;
    settings.frames = 1;
    SequenceRenderer renderer(scene, settings);
    for (int i = 0; i < o->warmup; ++i) renderer.renderFrame(0);
    RayCounts total;
    auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < o->frames; ++i) {
      auto r = renderer.renderFrame(0);
      total.rays += r.counts.rays;
      total.paths += r.counts.paths;
    }
    double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    nlohmann::json out = {{"scene", scene.name}, {"size", o->size}, {"frames", o->frames},
                          {"seconds", sec}, {"mrays_per_s", double(total.rays) / sec * 1e-6},
                          {"mpaths_per_s", double(total.paths) / sec * 1e-6},
                          {"rays_per_path", double(total.rays) / double(total.paths)},
                          {"ms_per_frame", sec * 1e3 / o->frames}, {"environment", environmentInfo()}};
    std::printf("arena tracer: %.2f Mrays/s, %.2f Mpaths/s, %.1f ms/frame at %dx%d (%.2f rays/path)\n",
                out["mrays_per_s"].get<double>(), out["mpaths_per_s"].get<double>(), out["ms_per_frame"].get<double>(),
                o->size, o->size, out["rays_per_path"].get<double>());
    if (o->embree) {
      std::string note;
      double e = embreePathtracerMrays(o->size, note);
      out["embree_pathtracer_mrays_per_s"] = e;
      if (e > 0) {
        out["ratio_to_embree"] = out["mrays_per_s"].get<double>() / e;
        std::printf("embree pathtracer: %.2f Mrays/s  -> ratio %.2fx\n", e, out["ratio_to_embree"].get<double>());
      } else {
        std::printf("embree pathtracer: not measured (%s)\n", note.c_str());
      }
    }
    if (!o->json.empty()) writeTextAtomically(o->json, out.dump(2));
  });

  auto* denoise = bench->add_subcommand("denoise", "Denoiser cost at 1280x720: ms/frame and bilateral units (BU)");
  struct DenoiseOptions {
    std::string denoisers = "all", scene = defaultScenesDir() + "/cornell_static.json", json, resolution = "1280x720";
    int frames = 20, warmup = 5, inputs = 3, lowresFactor = 8, lowresSpp = 16;
    std::vector<std::string> params, plugins;
  };
  auto d = std::make_shared<DenoiseOptions>();
  denoise->add_option("--denoisers", d->denoisers, "Comma-separated names (ext:MANIFEST, plugin:LIBRARY too) or 'all'")
      ->default_val("all");
  denoise->add_option("--plugin", d->plugins, "A C plugin library (include/arena_plugin.h) to time too, repeatable")->default_str("none");
  denoise->add_option("--param", d->params, "DENOISER.NAME=VALUE, repeatable")->default_str("none: registry defaults");
  denoise->add_option("--scene", d->scene, "Scene file whose frames feed the denoisers");
  denoise->add_option("--resolution", d->resolution, "WIDTHxHEIGHT")->default_val("1280x720");
  denoise->add_option("--frames", d->frames, "Timed frames per denoiser")->check(CLI::Range(1, 100000))->default_val(20);
  denoise->add_option("--warmup", d->warmup, "Untimed frames first")->check(CLI::Range(0, 100000))->default_val(5);
  denoise->add_option("--inputs", d->inputs, "Distinct rendered input frames, cycled")
      ->check(CLI::Range(1, 1000))
      ->default_val(3);
  denoise->add_option("--json", d->json, "Write results to this JSON file")->default_str("none");
  denoise->add_option("--lowres-factor", d->lowresFactor,
                      "Low-resolution buffer for denoisers that read one (0: none)")
      ->check(CLI::Range(0, 64))
      ->default_val(8);
  denoise->add_option("--lowres-spp", d->lowresSpp, "Paths per low-resolution texel")
      ->check(CLI::Range(1, 4096))
      ->default_val(16);
  denoise->callback([d] {
    auto [w, h] = parseResolution("--resolution", d->resolution);
    Scene scene = loadScene(d->scene);
    RenderSettings settings;
    settings.width = w;
    settings.height = h;
    settings.frames = std::max(1, d->inputs);
    settings.lowresFactor = d->lowresFactor;
    settings.lowresSpp = d->lowresSpp;
    SequenceRenderer renderer(scene, settings);
    std::vector<LayerSet> inputs, inputGradients, inputLowres;
    std::printf("rendering %d input frame(s) of %s at %dx%d...\n", settings.frames, scene.name.c_str(), w, h);
    for (int t = 0; t < settings.frames; ++t) {
      auto r = renderer.renderFrame(t);
      inputs.push_back(std::move(r.frame));
      inputGradients.push_back(std::move(r.gradients));  // empty for frame 0
    }
    const double bu = bilateralUnitMs(1280, 720, 15);
    std::printf("1 BU = cv::bilateralFilter(5, 0.1, 2.0) on 1280x720 CV_32FC3 = %.2f ms\n", bu);
    std::vector<std::string> names;
    if (d->denoisers == "all") names = DenoiserRegistry::instance().names();
    else
      for (size_t a = 0, b; a <= d->denoisers.size(); a = b + 1) {
        b = d->denoisers.find(',', a);
        if (b == std::string::npos) b = d->denoisers.size();
        if (b > a) names.push_back(d->denoisers.substr(a, b - a));
      }
    for (const std::string& library : d->plugins) names.push_back("plugin:" + library);
    for (std::string& n : names) n = DenoiserRegistry::resolve(n);  // loads external ones
    auto params = parseParamAssignments(d->params);
    bool lowres = false;
    for (const std::string& name : names) {
      const DenoiserInfo& info = DenoiserRegistry::instance().find(name);
      lowres = lowres || info.create(info.schema.resolve(params[name], name), SignalKind::Diffuse)->wantsLowres();
    }
    if (lowres && d->lowresFactor > 0) {
      std::printf("rendering the low-resolution buffer (1/%d, %d spp)...\n", d->lowresFactor, d->lowresSpp);
      for (int t = 0; t < settings.frames; ++t) {
        RayCounts counts;
        inputLowres.push_back(renderer.renderLowres(t, counts));
      }
    }
    nlohmann::json out = {{"resolution", {w, h}}, {"bilateralUnitMs", bu}, {"frames", d->frames},
                          {"warmup", d->warmup}, {"environment", environmentInfo()}, {"denoisers", nlohmann::json::array()}};
    // Every contender runs on every frame, in an order rotated frame by frame, so that a change
    // of machine load (another process, thermal state) falls on all of them alike and the
    // per-frame ratios to the first contender are paired measurements.
    struct Contender {
      std::string name;
      ParamSet params;
      std::vector<SignalKind> kinds;
      std::vector<std::unique_ptr<Denoiser>> instances;
      std::vector<LayerSet> staged;  // per instance: its inputs, copied in before each timed call
      std::vector<double> total;
      std::map<std::string, std::vector<double>> passMs;
      std::map<std::string, double> passTaps;
      std::vector<std::string> passOrder;
    };
    std::vector<Contender> contenders;
    for (const std::string& name : names) {
      const DenoiserInfo& info = DenoiserRegistry::instance().find(name);
      Contender c{name, info.schema.resolve(params[name], name), {}, {}, {}, {}, {}, {}, {}};
      c.kinds = info.signals == SignalMode::Color ? std::vector<SignalKind>{SignalKind::Color}
                                                  : std::vector<SignalKind>{SignalKind::Diffuse, SignalKind::Specular};
      for (SignalKind kind : c.kinds) c.instances.push_back(info.create(c.params, kind));
      for (auto& inst : c.instances) inst->setup(w, h);
      c.staged.resize(c.instances.size());
      contenders.push_back(std::move(c));
    }
    Image outImage(w, h, 3), signal;
    for (int f = 0; f < d->warmup + d->frames; ++f) {
      const LayerSet& frame = inputs[size_t(f) % inputs.size()];
      const LayerSet& gradients = inputGradients[std::max<size_t>(1, size_t(f) % inputs.size()) % inputs.size()];
      FrameContext ctx;
      ctx.frameIndex = f;
      ctx.width = w;
      ctx.height = h;
      ctx.reset = f == 0;
      for (size_t turn = 0; turn < contenders.size(); ++turn) {
        Contender& c = contenders[(turn + size_t(f)) % contenders.size()];
        const bool grads = c.instances[0]->needsGradients() && f > 0 && inputs.size() > 1;
        double frameMs = 0;
        for (size_t k = 0; k < c.instances.size(); ++k) {
          const SignalKind kind = c.kinds[k];
          // Every contender starts from the same cache state: what it reads (the signal and its
          // declared layers) has just been written, as by the passes that produce them in an
          // engine. Without this the layers came cold from the cycled input pool, while a plugin
          // that copied its inputs first read them warm -- and measured faster than its own code.
          signal = frame.get(signalName(kind));
          LayerSet& staged = c.staged[k];  // the instance's own: only what it declared
          for (const std::string& name : c.instances[k]->requiredChannels()) {
            if (!staged.has(name)) staged.set(name, frame.get(name));
            else staged.get(name) = frame.get(name);
          }
          const bool low = c.instances[k]->wantsLowres() && !inputLowres.empty();
          const LowresInputs lowInputs{low ? inputLowres[size_t(f) % inputs.size()] : frame, d->lowresFactor,
                                       d->lowresSpp};
          DenoiserInputs in{signal, staged, grads ? &gradients : nullptr, low ? &lowInputs : nullptr};
          c.instances[k]->clearPassStats();
          auto t0 = std::chrono::steady_clock::now();
          c.instances[k]->denoise(ctx, in, outImage);
          const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
          // An external process's own compute time; the wall clock (transfer included) otherwise.
          frameMs += c.instances[k]->reportedMilliseconds().value_or(wall);
          if (f < d->warmup) continue;
          for (const PassStats& p : c.instances[k]->lastPasses()) {
            std::string pn = std::string(signalName(kind)) + "/" + p.name;
            if (!c.passMs.count(pn)) c.passOrder.push_back(pn);
            c.passMs[pn].push_back(p.milliseconds);
            c.passTaps[pn] = p.tapsPerPixel;
          }
        }
        if (f >= d->warmup) c.total.push_back(frameMs);
      }
    }
    for (const Contender& c : contenders) {
      nlohmann::json passes = nlohmann::json::array();
      for (const std::string& pn : c.passOrder)
        passes.push_back({{"name", pn}, {"msMedian", median(c.passMs.at(pn))}, {"bu", median(c.passMs.at(pn)) / bu},
                          {"tapsPerPixel", c.passTaps.at(pn)}});
      nlohmann::json row = {{"name", c.name}, {"params", c.params.toJson()}, {"msMedian", median(c.total)},
                            {"msP95", p95(c.total)}, {"bu", median(c.total) / bu}, {"passes", passes}};
      std::printf("%-14s %8.2f ms/frame (p95 %.2f)  %5.2f BU", c.name.c_str(), median(c.total), p95(c.total),
                  median(c.total) / bu);
      if (&c != &contenders.front()) {
        const PairedRatio r = pairedRatio(c.total, contenders.front().total);
        row["ratioTo"] = {{"name", contenders.front().name}, {"median", r.median}, {"ci95", {r.lo, r.hi}}};
        std::printf("  x%.3f of %s [95%% CI %.3f, %.3f]", r.median, contenders.front().name.c_str(), r.lo, r.hi);
      }
      std::printf("\n");
      for (const auto& p : passes)
        std::printf("    %-34s %8.2f ms  %5.2f BU  %5.1f taps/px\n", p["name"].get<std::string>().c_str(),
                    p["msMedian"].get<double>(), p["bu"].get<double>(), p["tapsPerPixel"].get<double>());
      out["denoisers"].push_back(row);
    }
    if (!d->json.empty()) writeTextAtomically(d->json, out.dump(2));
  });
}

}  // namespace arena::cli
