// `arena bench reference`: options in, harness/benchmarks.hpp's benchReference measures (how fast
// each reference sampler converges against an independent gold render, at equal time).
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli/commands.hpp"
#include "cli/render_options.hpp"
#include "core/atomic_file.hpp"
#include "harness/benchmarks.hpp"
#include "harness/scene_selection.hpp"

namespace arena::cli {

void addBenchReferenceCommand(CLI::App* bench) {
  auto* cmd = bench->add_subcommand("reference",
                                    "Reference samplers: true relMSE against a long gold render at "
                                    "equal time, independent vs sobol");
  struct Options {
    std::string scenes = "cornell_static,camera_pan_occluder", resolution = "128x72", json;
    std::string scenesDir = defaultScenesDir();
    int spp = 128, goldFactor = 32, frame = 0, replicates = RenderSettings().referenceReplicates, maxBounces = 0;
    int repeats = ReferenceBench().repeats;
    int referenceTile = RenderSettings().referenceTile;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("--scenes", o->scenes, "Scenes, comma-separated, or 'all'");
  cmd->add_option("--resolution", o->resolution, "Resolution, WIDTHxHEIGHT");
  cmd->add_option("--spp", o->spp, "Samples per pixel of the compared references")->check(CLI::Range(8, 1 << 16));
  cmd->add_option("--gold-factor", o->goldFactor, "The gold reference has this many times the samples")
      ->check(CLI::Range(4, 1024));
  cmd->add_option("--replicates", o->replicates,
                  "Independent randomisations of the compared references (the gold keeps the default)")
      ->check(CLI::Range(2, 64));
  cmd->add_option("--max-bounces", o->maxBounces,
                  "Override the scenes' maximum path length (gold included): comparing two lengths "
                  "shows which "
                  "part of the error the longer paths carry")
      ->check(CLI::Range(1, 64))
      ->default_str("(each scene's own)");
  cmd->add_option("--repeats", o->repeats,
                  "Independent repeats of each compared reference (own seed each): the gains are "
                  "medians over "
                  "them with a 95% interval (none under 6)")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->add_option("--ref-tile", o->referenceTile,
                  "The adaptive reference's allocation tile, pixels square (0: one tile): comparing sizes shows "
                  "what finer allocation buys and whether its estimate stays honest")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  cmd->add_option("--frame", o->frame, "Frame whose state is rendered")
      ->check(CLI::Range(0, 100000));
  cmd->add_option("--scenes-dir", o->scenesDir, "Directory of scene files");
  cmd->add_option("--json", o->json, "Write results to this JSON file")
      ->check(writableFile("bench reference"))
      ->default_str("(none)");
  cmd->callback([o] {
    RenderOptions ro;
    ro.resolution = o->resolution;
    ro.maxBounces = o->maxBounces;
    ro.referenceTile = o->referenceTile;
    ReferenceBench b;
    b.settings = ro.settings();
    b.scenes = selectScenes(o->scenes, o->scenesDir);
    b.spp = o->spp;
    b.goldFactor = o->goldFactor;
    b.frame = o->frame;
    b.replicates = o->replicates;
    b.repeats = o->repeats;
    const nlohmann::json out = benchReference(b, [](const std::string& line) { std::cout << line << std::endl; });
    if (!o->json.empty()) writeMarkedJson(o->json, "bench reference", out);
  });
}

}  // namespace arena::cli
