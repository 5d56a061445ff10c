// `arena bench tracer` and `arena bench denoise`: options in, harness/benchmarks.hpp measures.
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli/commands.hpp"
#include "cli/render_options.hpp"
#include "core/atomic_file.hpp"
#include "harness/benchmarks.hpp"
#include "harness/denoise_run.hpp"
#include "harness/gpu_cost.hpp"
#include "harness/scene_selection.hpp"

namespace arena::cli {

namespace {
void printLine(const std::string& line) { std::cout << line << std::endl; }
}  // namespace

void addBenchCommand(CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "Benchmarks (tracer; denoise; reference; gpu-model; gpu-measured; rank-agreement)");
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
  tracer->add_option("--json", o->json, "Write results to this JSON file")
      ->check(writableFile("bench tracer"))
      ->default_str("(none)");
  tracer->callback([o] {
    const nlohmann::json out = benchTracer({o->scene, o->size, o->frames, o->warmup, o->embree}, printLine);
    if (!o->json.empty()) writeMarkedJson(o->json, "bench tracer", out);
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
  denoise
      ->add_option("--inputs", d->inputs, "Distinct rendered input frames, played forward and back")
      ->check(CLI::Range(1, 1000))
      ->default_val(3);
  denoise->add_option("--json", d->json, "Write results to this JSON file")
      ->check(writableFile("bench denoise"))
      ->default_str("(none)");
  denoise
      ->add_option("--lowres-factor", d->lowresFactor,
                   "Low-resolution buffer for denoisers that read one (0: none)")
      ->check(lowresFactorCheck(64))
      ->default_val(8);
  denoise->add_option("--lowres-spp", d->lowresSpp, "Paths per low-resolution texel")
      ->check(CLI::Range(1, 4096))
      ->default_val(16);
  denoise->callback([d] {
    DenoiseBench b;
    std::tie(b.width, b.height) = parseResolution("--resolution", d->resolution);
    b.sceneFile = d->scene;
    b.frames = d->frames;
    b.warmup = d->warmup;
    b.inputs = d->inputs;
    b.lowresFactor = d->lowresFactor;
    b.lowresSpp = d->lowresSpp;
    b.denoisers = d->denoisers == "all"
                      ? DenoiserRegistry::instance().names()
                      : splitList(d->denoisers, "--denoisers", kDenoiserListExpected);
    for (const std::string& library : d->plugins) b.denoisers.push_back("plugin:" + library);
    for (std::string& n : b.denoisers) n = DenoiserRegistry::resolve(n);  // loads external ones
    b.params = parseParamAssignments(d->params);
    const nlohmann::json out = benchDenoise(b, printLine);
    if (!d->json.empty()) writeMarkedJson(d->json, "bench denoise", out);
    // A contender that failed was reported with its error and the others timed; the exit status
    // says the bench is not whole (1, as a run with a failed pair).
    int failed = 0;
    for (const nlohmann::json& row : out["denoisers"])
      failed += row.value("status", "") == "failed";
    if (failed > 0) {
      std::cerr << "bench denoise: " << failed << " of " << out["denoisers"].size()
                << " contender(s) failed (their errors above)\n";
      throw CLI::RuntimeError(1);
    }
  });

  auto* gpuModel = bench->add_subcommand(
      "gpu-model",
      "Predicted GPU ms per pass from counted traffic, validated against published timings "
      "(docs/gpu-cost.md); memory per denoiser");
  struct GpuModelOptions {
    std::string denoisers = "all", scene = defaultScenesDir() + "/cornell_static.json", json,
                resolution = "1920x1080", device = "TITAN RTX";
    int frames = 5;
    std::vector<std::string> params;
  };
  auto g = std::make_shared<GpuModelOptions>();
  gpuModel->add_option("--denoisers", g->denoisers, "Comma-separated built-ins for the per-denoiser and memory tables, or 'all'")
      ->default_val("all");
  gpuModel->add_option("--scene", g->scene, "Scene file whose frames feed the denoisers");
  gpuModel
      ->add_option("--param", g->params,
                   "DENOISER.NAME=VALUE for the per-denoiser and memory tables, repeatable (a "
                   "variant: reengine.disocclusionRays=off)")
      ->default_str("none: registry defaults");
  gpuModel->add_option("--resolution", g->resolution, "WIDTHxHEIGHT of the per-denoiser and memory tables")
      ->default_val("1920x1080");
  gpuModel
      ->add_option("--device", g->device,
                   "Device of the per-denoiser table: TITAN RTX, RTX 4080, PS5, H200")
      ->default_val("TITAN RTX");
  gpuModel->add_option("--frames", g->frames,
                       "Frames per run; the last is counted (5: SVGF-family histories reach h >= 4)")
      ->check(CLI::Range(2, 100))
      ->default_val(5);
  gpuModel->add_option("--json", g->json, "Write results to this JSON file")
      ->check(writableFile("bench gpu-model"))
      ->default_str("(none)");
  gpuModel->callback([g] {
    GpuModelBench b;
    std::tie(b.width, b.height) = parseResolution("--resolution", g->resolution);
    b.sceneFile = g->scene;
    b.device = g->device;
    b.frames = g->frames;
    b.denoisers = g->denoisers == "all"
                      ? DenoiserRegistry::instance().names()
                      : splitList(g->denoisers, "--denoisers",
                                  "built-in names (`arena denoisers`), comma-separated, or 'all'");
    b.params = parseParamAssignments(g->params);
    const nlohmann::json out = benchGpuModel(b, printLine);
    if (!g->json.empty()) writeMarkedJson(g->json, "bench gpu-model", out);
  });

  auto* gpuMeasured = bench->add_subcommand(
      "gpu-measured",
      "The cost model judged on kernels timed on a real GPU (bench/gpu/pass_timing.cu's JSON; "
      "docs/gpu-cost.md)");
  struct GpuMeasuredOptions {
    std::string file, device, json;
  };
  auto gm = std::make_shared<GpuMeasuredOptions>();
  gpuMeasured->add_option("file", gm->file, "JSON printed by bench/gpu/pass_timing.cu")->required();
  gpuMeasured->add_option("--device", gm->device,
                          "Specification to price with (TITAN RTX, RTX 4080, PS5, H200); default: the one "
                          "the file's device names");
  gpuMeasured->add_option("--json", gm->json, "Write results to this JSON file")
      ->check(writableFile("bench gpu-measured"))
      ->default_str("(none)");
  gpuMeasured->callback([gm] {
    const nlohmann::json out = benchGpuMeasured(gm->file, gm->device, printLine);
    if (!gm->json.empty()) writeMarkedJson(gm->json, "bench gpu-measured", out);
  });

  auto* rank = bench->add_subcommand(
      "rank-agreement",
      "Do two runs of the same scenes (e.g. the quick preset and 2.5x its resolution: "
      "scripts/bench_rank_agreement.sh) rank the methods alike? Kendall tau and flipped resolved pairs");
  struct RankOptions {
    std::string runA, runB, json;
  };
  auto ro = std::make_shared<RankOptions>();
  rank->add_option("runA", ro->runA, "Run directory A (its results.json)")->required();
  rank->add_option("runB", ro->runB, "Run directory B, the same scenes")->required();
  rank->add_option("--json", ro->json, "Write results to this JSON file")
      ->check(writableFile("bench rank-agreement"))
      ->default_str("(none)");
  rank->callback([ro] {
    const nlohmann::json out = benchRankAgreement(ro->runA, ro->runB, printLine);
    if (!ro->json.empty()) writeMarkedJson(ro->json, "bench rank-agreement", out);
  });
}

}  // namespace arena::cli
