// `arena study`: the main job. Renders the default scene suite (quick preset), runs every
// registered denoiser on every scene, computes every metric, writes the report, and prints where
// it is together with a short ranking table.
#include <chrono>
#include <iomanip>
#include <iostream>
#include <map>

#include "harness/commands.hpp"
#include "harness/run_matrix.hpp"
#include "harness/scene_selection.hpp"
#include "reports/report.hpp"

namespace arena::cli {

namespace {

using nlohmann::json;

// Mean over scenes of each denoiser's per-scene means; ranked by relMSE (lower first).
void printRanking(const json& results) {
  struct Row {
    double relMse = 0, flip = 0, ms = 0;
    int scenes = 0, flipScenes = 0;
  };
  std::map<std::string, Row> rows;
  for (const json& p : results["pairs"]) {
    if (p["status"] != "ok") continue;
    Row& r = rows[p["label"].get<std::string>()];
    r.relMse += p["summary"]["relMse"]["mean"].get<double>();
    r.ms += p["timing"]["msMedian"].get<double>();
    if (p["summary"].contains("ldrFlip")) {
      r.flip += p["summary"]["ldrFlip"]["mean"].get<double>();
      ++r.flipScenes;
    }
    ++r.scenes;
  }
  std::vector<std::pair<std::string, Row>> sorted(rows.begin(), rows.end());
  std::sort(sorted.begin(), sorted.end(),
            [](auto& a, auto& b) { return a.second.relMse / a.second.scenes < b.second.relMse / b.second.scenes; });
  std::cout << "\nranking (mean over scenes, frames after warm-up):\n"
            << std::left << std::setw(6) << "rank" << std::setw(28) << "denoiser" << std::right << std::setw(12)
            << "relMSE" << std::setw(12) << "LDR-FLIP" << std::setw(12) << "ms/frame" << std::setw(8) << "scenes"
            << "\n";
  int rank = 1;
  for (auto& [label, r] : sorted) {
    std::cout << std::left << std::setw(6) << rank++ << std::setw(28) << label << std::right << std::fixed
              << std::setprecision(4) << std::setw(12) << r.relMse / r.scenes << std::setw(12)
              << (r.flipScenes ? r.flip / r.flipScenes : 0.0) << std::setprecision(2) << std::setw(12)
              << r.ms / r.scenes << std::setw(8) << r.scenes << std::defaultfloat << "\n";
  }
}

}  // namespace

void addStudyCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "study", "The default study: render the suite (quick preset), run every denoiser on every scene, report");
  auto opt = std::make_shared<RenderOptions>();
  auto out = std::make_shared<std::string>("runs/study");
  auto report = std::make_shared<std::string>("report");
  auto flip = std::make_shared<std::string>("all");
  auto scenes = std::make_shared<std::string>("all");
  cmd->add_option("--out", *out, "Run directory")->default_val("runs/study");
  cmd->add_option("--report", *report, "Report directory (index.html)")->default_val("report");
  cmd->add_option("--flip", *flip, "FLIP metrics: none, ldr, all")->check(CLI::IsMember({"none", "ldr", "all"}));
  cmd->add_option("--scenes", *scenes, "Scenes, comma-separated, or 'all'")->default_val("all");
  addRenderOptions(cmd, *opt);
  cmd->callback([=] {
    const auto start = std::chrono::steady_clock::now();
    RunConfig c;
    c.name = "study";
    c.out = *out;
    c.cache = opt->cacheDir;
    c.render = opt->settings();
    c.scenes = selectScenes(*scenes, opt->scenesDir);
    for (const std::string& n : DenoiserRegistry::instance().names()) c.denoisers.push_back({n, {}, ""});
    c.flip = *flip;
    c.keepFrames = "chosen";
    c.progress = [](const std::string& line) { std::cout << line << std::endl; };
    json results = runMatrix(c);
    ReportOptions ro;
    ro.run = *out;
    ro.out = *report;
    ReportSummary rs = writeReport(ro);
    printRanking(results);
    double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::cout << "\nstudy finished in " << int(sec / 60) << " min " << int(sec) % 60 << " s\n"
              << "results: " << *out << "/results.json, " << *out << "/results.db\n"
              << "report:  " << rs.index.string() << "\n";
    auto failed = failedPairs(results);
    if (!failed.empty()) {
      std::cerr << failed.size() << " pair(s) failed:\n";
      for (auto& f : failed) std::cerr << "  " << f << "\n";
      throw CLI::RuntimeError(1);
    }
  });
}

}  // namespace arena::cli
