// `arena study`: the main job. Renders the default scene suite (quick preset), runs every
// registered denoiser on every scene, computes every metric, writes the report, and prints a
// summary that fits on one screen (cli/printout.hpp); --verbose prints every step and table.
#include <sys/ioctl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iostream>

#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/stage_clock.hpp"
#include "cli/commands.hpp"
#include "cli/printout.hpp"
#include "cli/render_options.hpp"
#include "harness/run_matrix.hpp"
#include "harness/scene_selection.hpp"
#include "harness/study.hpp"
#include "metrics/results.hpp"
#include "reports/report.hpp"

namespace arena::cli {

namespace {

using nlohmann::json;

// The study's progress. --verbose: every line on stdout, as `arena run` prints them. Otherwise, on
// a terminal, one status line on stderr rewritten in place (every step, with its ETA) and cleared
// when the study is done, so the summary is what stays on the screen; when stderr is not a
// terminal (a log), one line per finished scene and per refinement decision.
class StudyProgress {
 public:
  explicit StudyProgress(bool verbose) : verbose_(verbose), terminal_(isatty(fileno(stderr)) == 1) {}
  ~StudyProgress() { clear(); }
  StudyProgress(const StudyProgress&) = delete;
  StudyProgress& operator=(const StudyProgress&) = delete;

  void step(const std::string& line) {
    if (verbose_)
      std::cout << line << std::endl;
    else if (terminal_)
      show(line);
  }
  void milestone(const std::string& line) {
    if (verbose_)
      std::cout << line << std::endl;
    else if (terminal_)
      show(line);
    else
      std::cerr << line << std::endl;
  }
  void clear() {
    if (shown_) std::cerr << "\r\033[K" << std::flush;
    shown_ = false;
  }

 private:
  void show(const std::string& line) {
    winsize size{};
    const size_t columns = ioctl(fileno(stderr), TIOCGWINSZ, &size) == 0 && size.ws_col > 1 ? size.ws_col : 80;
    std::cerr << "\r\033[K" << line.substr(0, columns - 1) << std::flush;
    shown_ = true;
  }
  bool verbose_, terminal_, shown_ = false;
};

}  // namespace

void addStudyCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "study", "The default study: render the suite (quick preset), run every denoiser on every scene, report");
  auto opt = std::make_shared<RenderOptions>();
  auto out = std::make_shared<std::string>("runs/study");
  auto report = std::make_shared<std::string>("report");
  auto flip = std::make_shared<std::string>("all");
  auto scenes = std::make_shared<std::string>("all");
  auto exposure = std::make_shared<std::string>("per-frame");
  auto refineBudget = std::make_shared<double>(4);
  auto refineMaxSpp = std::make_shared<int>(8192);
  auto verbose = std::make_shared<bool>(false);
  cmd->add_option("--out", *out, "Run directory")->default_val("runs/study");
  cmd->add_option("--report", *report, "Report directory (index.html)")->default_val("report");
  cmd->add_option("--flip", *flip, "FLIP metrics: none, ldr, all")
      ->check(CLI::IsMember({"none", "ldr", "all"}))
      ->default_val("all");
  cmd->add_option("--scenes", *scenes, "Scenes, comma-separated, or 'all'")->default_val("all");
  auto captures = std::make_shared<std::vector<std::string>>();
  cmd->add_option("--capture", *captures,
                  "A capture folder (docs/captures.md) to validate and score beside the scenes, repeatable; its "
                  "stored outputs run as file:NAME contenders")
      ->default_str("none");
  cmd->add_option("--exposure", *exposure, "Display exposure (metrics.md): per-frame or first")
      ->check(CLI::IsMember({"per-frame", "first"}))
      ->default_val("per-frame");
  cmd->add_option("--refine-budget", *refineBudget,
                  "After a scene's pairs, refine its references when it misses the reference-quality goal "
                  "and its predicted extra paths are at most this many times the paths of its frames at the "
                  "preset's (or the given) reference sample cap (width x height x frames x --ref-spp), then "
                  "measure its pairs again (0: off). With a budget, the quick preset's first references stop "
                  "at relative error 0.02 or 128 spp when neither --ref-rel-error nor --ref-spp is given (at "
                  "0.02 and the given cap with --ref-spp alone)")
      ->check(finiteRange(0.0, 1000.0))
      ->default_val(4);
  cmd->add_option("--refine-max-spp", *refineMaxSpp, "The refinement's cap on a reference's samples per pixel")
      ->check(CLI::Range(1, 1 << 20))
      ->default_val(8192);
  cmd->add_flag("--verbose", *verbose,
                "Print every progress line and the full tables (every scene's ranking, every event and cut with "
                "its intervals, every reference verdict) before the summary");
  // The study, like every run, renders the low-resolution buffer (1/8, 16 paths per texel, the
  // CAPCOM 2023 setting, denoisers/FIDELITY.md `reengine`) because reengine reads it
  // (resolveAutoLowres), so reengine runs its disocclusion rays and is charged for them (a quarter
  // of the 1-spp input's paths per frame); --lowres-factor 0 leaves it out.
  addRenderOptions(cmd, *opt);
  cmd->callback([=] {
    const auto start = std::chrono::steady_clock::now();
    StudyConfig study{studyRun(selectScenes(*scenes, opt->scenesDir), opt->settings()),
                      *refineBudget, *refineMaxSpp, opt->referenceRelError >= 0,
                      opt->referenceSpp > 0};
    RunConfig& c = study.run;
    for (const std::string& capture : *captures) {
      c.captures.push_back(capture);
      for (const auto& [output, stored] : readCaptureDescription(capture).outputs)
        c.denoisers.push_back({"file:" + output, {}, ""});
    }
    c.lowresAuto = opt->lowresAuto();
    resolveAutoLowres(c);
    c.out = *out;
    c.cache = opt->cacheDir;
    c.flip = *flip;
    c.exposure = *exposure;
    auto progress = std::make_shared<StudyProgress>(*verbose);
    c.progress = [progress](const std::string& line) { progress->step(line); };
    c.milestone = [progress](const std::string& line) { progress->milestone(line); };
    for (const Scene& s : c.scenes) requireRenderable(s, c.render, true);
    for (const std::string& w : shortSequenceWarnings(c.scenes, c.render, c.warmup))
      std::cerr << "arena: warning: " << w << "\n";
    runStudy(study);
    const RunResults results = loadResults(*out);  // as committed
    ReportOptions ro;
    ro.run = *out;
    ro.out = *report;
    progress->step("writing the report");
    ReportSummary rs = [&] {
      StageTimer timer(Stage::Report);
      return writeReport(ro);
    }();
    progress->clear();
    if (*verbose) printStudyTables(std::cout, results);
    const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    printStudySummary(std::cout, results,
                      {*out + "/results.json", *out + "/results.db", rs.index.string(), sec});
    // Where the time went (rendering, references, denoisers, metrics, ...): what a study's cost is
    // made of on this machine (docs/performance.md).
    std::cout << "Time by stage: " << stageBreakdownLine(sec) << "\n";
    auto failed = failedPairs(results);
    if (!failed.empty()) {
      std::cerr << failed.size() << " pair(s) failed:\n";
      for (auto& f : failed) std::cerr << "  " << f << "\n";
      throw CLI::RuntimeError(1);
    }
  });
}

}  // namespace arena::cli
