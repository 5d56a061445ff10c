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

#include "core/env_info.hpp"
#include "core/error.hpp"
#include "harness/commands.hpp"
#include "tracer/render.hpp"

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

}  // namespace

void addBenchCommand(CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "Benchmarks (tracer; denoise)");
  bench->require_subcommand(1);
  auto* tracer = bench->add_subcommand("tracer", "Tracer throughput: Mrays/s and Mpaths/s, Cornell box, 1 spp");
  struct Options {
    int size = 512, frames = 20, warmup = 3;
    bool embree = false;
    std::string scene = defaultScenesDir() + "/cornell_static.json";
    std::string json;
  };
  auto o = std::make_shared<Options>();
  tracer->add_option("--size", o->size, "Square resolution")->default_val(512);
  tracer->add_option("--frames", o->frames, "Timed frames")->default_val(20);
  tracer->add_option("--warmup", o->warmup, "Untimed warm-up frames")->default_val(3);
  tracer->add_option("--scene", o->scene, "Scene file");
  tracer->add_flag("--embree", o->embree, "Also run Embree's pathtracer tutorial (embree-tools) for comparison");
  tracer->add_option("--json", o->json, "Write results to this JSON file");
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
    if (!o->json.empty()) {
      FILE* f = std::fopen(o->json.c_str(), "w");
      if (!f) throw Error(o->json + ": cannot write");
      std::fputs(out.dump(2).c_str(), f);
      std::fclose(f);
    }
  });
}

}  // namespace arena::cli
