// `arena bench tracer` and `arena bench denoise`: options in, harness/benchmarks.hpp measures.
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli/commands.hpp"
#include "core/atomic_file.hpp"
#include "harness/benchmarks.hpp"
#include "harness/denoise_run.hpp"
#include "harness/scene_selection.hpp"

namespace arena::cli {

namespace {
void printLine(const std::string& line) { std::cout << line << std::endl; }
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
    const nlohmann::json out = benchTracer({o->scene, o->size, o->frames, o->warmup, o->embree}, printLine);
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
    DenoiseBench b;
    std::tie(b.width, b.height) = parseResolution("--resolution", d->resolution);
    b.sceneFile = d->scene;
    b.frames = d->frames;
    b.warmup = d->warmup;
    b.inputs = d->inputs;
    b.lowresFactor = d->lowresFactor;
    b.lowresSpp = d->lowresSpp;
    b.denoisers = d->denoisers == "all" ? DenoiserRegistry::instance().names() : splitList(d->denoisers);
    for (const std::string& library : d->plugins) b.denoisers.push_back("plugin:" + library);
    for (std::string& n : b.denoisers) n = DenoiserRegistry::resolve(n);  // loads external ones
    b.params = parseParamAssignments(d->params);
    const nlohmann::json out = benchDenoise(b, printLine);
    if (!d->json.empty()) writeTextAtomically(d->json, out.dump(2));
  });
}

}  // namespace arena::cli
