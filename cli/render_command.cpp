// `arena scenes` and `arena render`.
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli/commands.hpp"
#include "cli/render_options.hpp"
#include "core/display.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/sequence.hpp"
#include "harness/run_matrix.hpp"
#include "harness/scene_selection.hpp"
#include "reports/image_files.hpp"
#include "tracer/sequence_cache.hpp"

namespace arena::cli {

void addScenesCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("scenes", "List the scenes with their purpose");
  auto dir = std::make_shared<std::string>(defaultScenesDir());
  auto json = std::make_shared<bool>(false);
  cmd->add_option("--scenes-dir", *dir, "Directory of scene files")->default_str(*dir);
  cmd->add_flag("--json", *json, "Machine-readable output");
  cmd->callback([dir, json] {
    nlohmann::json out = nlohmann::json::array();
    for (const std::string& file : listSceneFiles(*dir)) {
      Scene s = loadScene(file);
      out.push_back({{"name", s.name}, {"purpose", s.purpose}, {"resolution", {s.width, s.height}},
                     {"frames", s.frames}, {"file", file}});
    }
    if (*json) {
      std::cout << jsonText(out, 2) << "\n";
      return;
    }
    for (auto& s : out)
      std::cout << std::left << std::setw(22) << s["name"].get<std::string>() << s["purpose"].get<std::string>() << "\n";
  });
}

void addRenderCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("render", "Render scenes into the sequence cache (resumes; re-renders stale files)");
  auto opt = std::make_shared<RenderOptions>();
  auto names = std::make_shared<std::string>("all");
  auto previews = std::make_shared<bool>(false);
  auto shardText = std::make_shared<std::string>("0/1");
  cmd->add_flag("--previews", *previews, "Also write preview PNGs (noisy frame and reference, first and last frame)");
  cmd->add_option(
      "--shard", *shardText,
      "Render only the deterministic slice i/n of the work (frames x reference replicates), i from "
      "0 to n-1; a render "
      "without --shard afterwards merges the slices exactly");
  cmd->add_option("scenes", *names, "Scene names or files, comma-separated, or 'all'")->default_val("all");
  addRenderOptions(cmd, *opt);
  cmd->callback([opt, names, previews, shardText] {
    Shard shard;
    std::tie(shard.index, shard.count) = parseShard(*shardText);
    const std::vector<Scene> scenes = selectScenes(*names, opt->scenesDir, "scenes");
    for (const Scene& scene : scenes) requireRenderable(scene, opt->settings(), false);
    for (const Scene& scene : scenes) {
      auto dir = renderSequence(
          scene, opt->settings(), opt->cacheDir, [](const std::string& line) { std::cout << line << std::endl; },
          shard);
      std::cout << scene.name << ": " << dir.string() << std::endl;
      if (!*previews || shard.count > 1) continue;
      Sequence seq = Sequence::open(dir);
      for (int t : {0, seq.info().frames - 1}) {
        LayerSet ref = seq.reference(t);
        DisplayTransform display = DisplayTransform::fromReference(ref.get("color"));
        std::string n = std::to_string(t);
        writePng(dir / ("preview_noisy_" + n + ".png"), display.apply(seq.frame(t).get("color")));
        writePng(dir / ("preview_reference_" + n + ".png"), display.apply(ref.get("color")));
      }
    }
  });
}

void addRefineCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "refine", "Add samples to cached references until their estimated relMSE meets --target (bit-identical to "
                "rendering with that target in one go)");
  auto opt = std::make_shared<RenderOptions>();
  auto names = std::make_shared<std::string>("all");
  auto target = std::make_shared<double>(0);
  auto maxSpp = std::make_shared<int>(4096);
  cmd->add_option("scenes", *names, "Scene names or files, comma-separated, or 'all'")->default_val("all");
  cmd->add_option("--target", *target, "Target relMSE of each reference (e.g. 1e-5)")
      ->required()
      ->default_str("")
      ->check(CLI::Validator(
          [](const std::string& text) {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            return end != text.c_str() && *end == '\0' && v > 0 && std::isfinite(v)
                       ? std::string()
                       : "expected a relMSE > 0, e.g. 1e-5, got " + text;
          },
          "RELMSE>0"));
  cmd->add_option(
         "--max-spp", *maxSpp,
         "Never go past this many samples per pixel, rounded up to a multiple of the reference's "
         "replicates (4: 15 allows 16)")
      ->default_val(4096)
      ->check(CLI::Range(1, 1 << 20));
  addRenderOptions(cmd, *opt);
  cmd->callback([opt, names, target, maxSpp] {
    for (const Scene& scene : selectScenes(*names, opt->scenesDir, "scenes")) {
      auto dir = refineSequence(scene, opt->settings(), opt->cacheDir, *target, *maxSpp,
                                [](const std::string& line) { std::cout << line << std::endl; });
      std::cout << scene.name << ": " << dir.string() << std::endl;
    }
  });
}

}  // namespace arena::cli
