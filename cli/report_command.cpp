// `arena report`: the static HTML dashboard of a run (reports/report.hpp does the work).
#include <iostream>

#include "cli/commands.hpp"
#include "core/error.hpp"
#include "harness/scene_selection.hpp"
#include "metrics/compare.hpp"
#include "metrics/metric_registry.hpp"
#include "reports/history.hpp"
#include "reports/report.hpp"

namespace arena::cli {

void addReportCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("report", "Build a static HTML dashboard (index.html) from a run");
  auto o = std::make_shared<ReportOptions>();
  auto run = std::make_shared<std::string>(), baseline = std::make_shared<std::string>(),
       out = std::make_shared<std::string>();
  cmd->add_option("run", *run, "Run directory (written by `arena run` or `arena sweep`)")
      ->required();
  cmd->add_option("--baseline", *baseline, "A run to compare against: adds the regression view")
      ->default_str("none");
  cmd->add_option("--out", *out, "Output directory for index.html and its files")->required();
  // The regression view judges as the gate does, with the gate's options.
  auto gateMetrics = std::make_shared<std::vector<std::string>>();
  auto gateTolerance = std::make_shared<std::string>("2%");
  auto gateConfidence = std::make_shared<std::string>("95%");
  auto gateCorrection = std::make_shared<std::string>("holm");
  cmd->add_option(
         "--metric", *gateMetrics,
         "With --baseline: the metric(s) the regression view gates, as for `arena compare`")
      ->default_str("compare's defaults")
      ->delimiter(',')
      ->allow_extra_args(false);
  auto gateOnly = std::make_shared<std::string>();
  cmd->add_option("--denoisers", *gateOnly,
                  "With --baseline: gate only these contenders (labels or denoiser names, "
                  "comma-separated), as for `arena compare`")
      ->default_str("all");
  auto gateMatches = std::make_shared<std::vector<std::string>>();
  cmd->add_option("--match", *gateMatches,
                  "With --baseline: BASELINE=CANDIDATE, a contender relabelled between the runs, "
                  "as for `arena compare` (repeatable)")
      ->allow_extra_args(false);
  cmd->add_option("--tolerance", *gateTolerance, "With --baseline: as for `arena compare`")
      ->default_val("2%");
  cmd->add_option("--confidence", *gateConfidence, "With --baseline: as for `arena compare`")
      ->default_val("95%");
  cmd->add_option("--correction", *gateCorrection, "With --baseline: as for `arena compare`")
      ->check(CLI::IsMember({"holm", "none"}))
      ->default_val("holm");
  auto gateAllowMismatch = std::make_shared<bool>(false);
  cmd->add_flag("--allow-settings-mismatch", *gateAllowMismatch,
                "With --baseline: judge runs whose settings differ, warning of them, as for `arena "
                "compare`");
  cmd->callback([=] {
    // The gate's options judge the regression view, which only a baseline makes.
    if (baseline->empty())
      for (const char* option : {"--metric", "--tolerance", "--confidence", "--correction",
                                 "--denoisers", "--match", "--allow-settings-mismatch"})
        if (cmd->count(option) > 0)
          throw Error(std::string("report: ") + option +
                      " judges the regression view against a baseline: give --baseline RUN too");
    o->run = *run;
    o->baseline = *baseline;
    o->out = *out;
    o->gate.tolerances = parseGate(*gateMetrics, *gateTolerance);
    o->gate.bootstrap.confidence = parseConfidence(*gateConfidence);
    o->gate.correction = parseCorrection(*gateCorrection);
    o->gate.matches = *gateMatches;
    o->gate.allowSettingsMismatch = *gateAllowMismatch;
    // Given, even empty (an unset variable in a CI script): a list that names no contender is an
    // error, not every pair gated.
    if (cmd->count("--denoisers") > 0)
      o->gate.contenders = splitList(*gateOnly, "--denoisers", "labels or denoiser names");
    ReportSummary s = writeReport(*o);
    std::cout << "report: " << s.index.string() << " (" << s.pairs << " pairs";
    if (s.failedPairs) std::cout << ", " << s.failedPairs << " failed: shown in the report";
    std::cout << ", " << s.images << " images" << (s.imagesInPlace ? ", in place" : "") << ")\n";
    if (!s.ablation.empty()) std::cout << "ablation: " << s.ablation.string() << "\n";
    if (!s.noAblation.empty()) std::cout << "no ablation: " << s.noAblation << "\n";
    if (!s.points.empty()) std::cout << "points: " << s.points.string() << "\n";
    for (const std::string& line : s.absentSummaries) std::cout << "absent: " << line << "\n";
    // The regression view's verdict, for a CI log: compare's, which this command does not exit
    // with (`arena compare` is the gate).
    if (s.judged) {
      for (const std::string& w : s.gateWarnings) std::cerr << "arena: warning: " << w << "\n";
      // In compare's own words: its last line where it judges, an error where it refuses.
      std::cout << "regression view against " << *baseline << " (as `arena compare " << *baseline
                << " " << *run << "` with these options): ";
      if (!s.refused.empty())
        std::cout << "refused (exit 2): " << s.refused;
      else
        std::cout << "gate: "
                  << (s.gateExitCode == 0   ? "pass"
                      : s.gateExitCode == 1 ? "FAIL"
                                            : "COULD NOT JUDGE")
                  << " (exit " << s.gateExitCode << "; "
                  << (s.verdicts.empty() ? "no rows" : s.verdicts) << ")";
      std::cout << "\n";
    }
  });

  auto* hist = app.add_subcommand(
      "history",
      "Build a regression dashboard (index.html) from many runs: results.db files or "
      "run directories, ordered by creation time");
  auto inputs = std::make_shared<std::vector<std::string>>();
  auto histOut = std::make_shared<std::string>();
  auto metrics = std::make_shared<std::vector<std::string>>();
  auto tol = std::make_shared<std::string>("2%");
  hist->add_option("inputs", *inputs, "results.db files and/or run directories")->required();
  hist->add_option("--out", *histOut, "Output directory for index.html and its files")->required();
  hist->add_option(
          "--metric", *metrics,
          "Metric(s) the gate checks, as for `arena compare`, repeatable or comma-separated "
          "(default: its defaults)")
      ->delimiter(',')
      ->allow_extra_args(false);
  auto histMatches = std::make_shared<std::vector<std::string>>();
  hist->add_option("--match", *histMatches,
                   "BASELINE=CANDIDATE: a contender relabelled between runs (a parameter added to "
                   "the command, e.g. 'svgf=svgf[sigmaL=8]') stays one series, and a run with the "
                   "first label is compared with the next run's second, as `arena compare --match` "
                   "(repeatable)")
      ->allow_extra_args(false);
  hist->add_option("--tolerance", *tol, "Allowed relative change, as for `arena compare`")
      ->default_val("2%");
  auto confidence = std::make_shared<std::string>("95%");
  hist->add_option("--confidence", *confidence,
                   "Confidence of the paired intervals, as for `arena compare`")
      ->default_val("95%");
  auto only = std::make_shared<std::string>();
  hist->add_option("--denoisers", *only,
                   "Gate only these contenders (labels or denoiser names, comma-separated), as for "
                   "`arena compare`")
      ->default_str("all");
  auto correction = std::make_shared<std::string>("holm");
  hist->add_option("--correction", *correction,
                   "How each comparison's rows are counted together, as for `arena compare`")
      ->check(CLI::IsMember({"holm", "none"}))
      ->default_val("holm");
  auto histAllowMismatch = std::make_shared<bool>(false);
  hist->add_flag("--allow-settings-mismatch", *histAllowMismatch,
                 "Compare consecutive runs whose settings differ (a warm-up changed in the command "
                 "CI runs), warning of them, instead of marking them not comparable, as for `arena "
                 "compare`");
  hist->callback([=] {
    HistoryOptions h;
    h.inputs.assign(inputs->begin(), inputs->end());
    h.out = *histOut;
    h.gate.tolerances = parseGate(*metrics, *tol);
    h.gate.bootstrap.confidence = parseConfidence(*confidence);
    h.gate.correction = parseCorrection(*correction);
    if (hist->count("--denoisers") > 0)  // given empty: an error, not every pair gated
      h.gate.contenders = splitList(*only, "--denoisers", "labels or denoiser names");
    h.gate.matches = *histMatches;
    h.gate.allowSettingsMismatch = *histAllowMismatch;
    const HistorySummary s = writeHistory(h);
    if (s.runs == 1) {  // "0 of 0 comparison(s) failing" read as a pass
      std::cout << "history: " << s.index.string()
                << " (one run: nothing to compare it with yet; a history judges each run against "
                   "the one before)\n";
    } else {
      std::cout << "history: " << s.index.string() << " (" << s.runs << " runs, "
                << s.failingComparisons << " of " << s.comparisons
                << " comparison(s) failing `arena compare`'s gate (" << s.failing << " row(s))";
      if (s.notComparable > 0)
        std::cout << ", " << s.notComparable
                  << " of them not comparable (other settings or data compare refuses: it exits 2 "
                     "there, could not judge, not 1 for a regression; the page says why)";
      // Changes beyond the tolerance that the gate did not resolve are not passes: said, and
      // those it could not judge at all (a database's runs keep no tiles) apart from those within
      // noise.
      if (s.unresolved > 0)
        std::cout << "; " << s.unresolved
                  << " change(s) beyond the tolerance within noise (orange on the page)";
      // Not silently fewer: the runs before the contenders named existed are not compared.
      if (s.notMadeBeforeContenders > 0)
        std::cout << "; " << s.notMadeBeforeContenders
                  << " comparison(s) not made: the earlier run has none of the --denoisers "
                     "contenders";
      std::cout << ")\n";
    }
    if (s.notJudged > 0)
      std::cerr << "arena: warning: " << s.notJudged
                << " change(s) in the worse direction beyond the tolerance (or of a size not "
                   "known) were NOT JUDGED: the gate cannot tell them from noise ("
                << (s.notJudgedFromDatabase > 0
                        ? std::to_string(s.notJudgedFromDatabase) +
                              " against runs read from results.db, which keep no per-tile data: "
                              "give `arena history` the run directories, their results.json, to "
                              "judge them"
                        : std::string())
                << (s.notJudgedFromDatabase > 0 && s.notJudgedFewFrames > 0 ? "; " : "")
                << (s.notJudgedFewFrames > 0
                        ? std::to_string(s.notJudgedFewFrames) + " resolved on " +
                              std::to_string(kFewSummarisedFrames) +
                              " or fewer frames after the warm-up, too few for "
                              "their intervals to hold their level"
                        : std::string())
                << (s.notJudgedFromDatabase + s.notJudgedFewFrames > 0 &&
                            s.notJudgedFromDatabase + s.notJudgedFewFrames < s.notJudged
                        ? "; "
                        : "")
                << (s.notJudgedFromDatabase + s.notJudgedFewFrames < s.notJudged
                        ? std::to_string(s.notJudged - s.notJudgedFromDatabase -
                                         s.notJudgedFewFrames) +
                              " on events no interval can judge, their changed region within "
                              "fewer than 4 effective tiles"
                        : std::string())
                << "; each row's note on the page says why)\n";
    for (const auto& [assignment, at] : s.matches) {
      std::string runs;
      for (const size_t i : at) runs += (runs.empty() ? "" : ", ") + std::to_string(i);
      std::cout << "match: " << assignment << ": compared at run" << (at.size() > 1 ? "s " : " ")
                << runs << " (against the run before; 0 the oldest), one series on the page\n";
    }
    for (const std::string& line : s.absentSummaries) std::cout << "absent: " << line << "\n";
    for (const std::string& line : s.warnings) std::cerr << "arena: warning: " << line << "\n";
  });
}

}  // namespace arena::cli
