// `arena study`: the main job. Renders the default scene suite (quick preset) into the cache.
// (Denoising, metrics and the report join this command as those stages land.)
#include <chrono>
#include <iostream>

#include "harness/commands.hpp"
#include "harness/scene_selection.hpp"

namespace arena::cli {

void addStudyCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("study", "The default study: render every scene of the suite (quick preset)");
  auto opt = std::make_shared<RenderOptions>();
  addRenderOptions(cmd, *opt);
  cmd->callback([opt] {
    auto start = std::chrono::steady_clock::now();
    for (const Scene& scene : selectScenes("all", opt->scenesDir)) {
      auto dir = renderSequence(scene, opt->settings(), opt->cacheDir,
                                [](const std::string& line) { std::cout << line << std::endl; });
      std::cout << scene.name << ": " << dir.string() << std::endl;
    }
    double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "study: rendered the suite in " << int(sec) << " s; sequences in " << opt->cacheDir << "/\n";
  });
}

}  // namespace arena::cli
