// `arena study`: the main job. Renders the default scene suite (quick preset), runs every
// registered denoiser on every scene, computes every metric, writes the report, and prints where
// it is together with a short ranking table.
#include <algorithm>
#include <chrono>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "core/capture.hpp"
#include "core/error.hpp"
#include "cli/commands.hpp"
#include "cli/printout.hpp"
#include "cli/render_options.hpp"
#include "harness/reference_quality.hpp"
#include "harness/run_matrix.hpp"
#include "harness/study.hpp"
#include "harness/scene_selection.hpp"
#include "metrics/summary_value.hpp"
#include "reports/report.hpp"

namespace arena::cli {

namespace {

using nlohmann::json;

// The study's ranking with ties (metrics/statistics.hpp): per scene on relMSE, then overall on the
// per-scene normalised score. Methods whose difference is not resolved at 95% share "tied with".
void printRanking(const json& results) {
  if (!results.contains("statistics")) return;
  const json& st = results["statistics"];
  std::cout << "\nranking on relMSE with 95% intervals (" << st.value("method", "") << ")\n";
  for (auto it = st["scenes"].begin(); it != st["scenes"].end(); ++it) {
    const json& s = it.value();
    std::cout << "\n" << it.key() << ": " << s["resolvedPairs"] << " of " << s["totalPairs"]
              << " pairwise differences resolved\n";
    for (const json& m : s["ranking"])
      std::cout << "  " << std::left << std::setw(4) << m["rank"].get<int>() << std::setw(26)
                << m["label"].get<std::string>() << std::right << std::setw(11) << figureText(m.value("mean", json()))
                << "  " << std::left << std::setw(24) << intervalText(m.value("ci95", json())) << tiedText(m) << "\n";
    if (s.contains("excluded") && s["excluded"].is_string())
      std::cout << "  not ranked: " << s["excluded"].get<std::string>() << "\n";
  }
  printOverallRanking(std::cout, results);
}

// A figure with its interval: "0.123 [0.1, 0.15]", "-" when absent; a null bound of the response
// is "never settled" (metrics/ghosting_intervals.hpp).
std::string figure(const json& e, const char* name) {
  const bool never = std::string(name) == "responseFrames" && e.contains("response");
  if (!never && (!e.contains(name) || !e[name].is_number())) return "-";
  std::ostringstream o;
  if (never)
    o << "never";
  else
    o << std::setprecision(3) << e[name].get<double>();
  const json ci = e.value("ci95", json::object()).value(name, json());
  if (ci.is_array()) {
    auto bound = [](const json& b) {
      std::ostringstream t;
      t << std::setprecision(3);
      if (b.is_number()) t << b.get<double>();
      else t << "never";
      return t.str();
    };
    o << " [" << bound(ci[0]) << ", " << bound(ci[1]) << "]";
  } else {
    o << " (no interval)";
  }
  return o.str();
}

// The event-window figures with their 95% intervals, per scripted event and camera cut, methods in
// the order of their rank (lag energy, old-view leak) with ties (metrics/ghosting_intervals.hpp).
void printEvents(const json& results) {
  if (!results.contains("statistics")) return;
  for (auto it = results["statistics"]["scenes"].begin(); it != results["statistics"]["scenes"].end(); ++it)
    for (const char* kind : {"events", "cuts"})
      for (const json& ev : it.value().value(kind, json::array())) {
        const bool cut = std::string(kind) == "cuts";
        const int frame = ev["eventFrame"];
        const char* rankedOn = cut ? "oldViewLeak" : "lagEnergy";
        const json ranking = ev["byFigure"].value(rankedOn, json::object());
        const std::string what = ev.value("what", "");
        std::cout << "\n" << it.key() << ": " << ev.value("kind", "") << (what.empty() ? "" : " " + what) << " at frame "
                  << frame << ": ranked on " << rankedOn << " (" << ranking.value("resolvedPairs", 0) << " of "
                  << ranking.value("totalPairs", 0) << " pairs resolved)\n";
        for (const json& m : ranking.value("ranking", json::array())) {
          const json* e = nullptr;
          for (const json& p : results["pairs"])
            if (p["scene"] == it.key() && p["label"] == m["label"] && p.contains(cut ? "cuts" : "ghosting"))
              for (const json& x : p.at(cut ? "cuts" : "ghosting"))
                if (x.value("eventFrame", -1) == frame) e = &x;
          if (!e) continue;
          std::cout << "  " << std::left << std::setw(4) << m["rank"].get<int>() << std::setw(22)
                    << m["label"].get<std::string>();
          for (const char* f : cut ? std::vector<const char*>{"oldViewLeak", "atCut"}
                                   : std::vector<const char*>{"lagEnergy", "responseFrames", "peakExcess", "chromaLagEnergy"})
            std::cout << f << " " << std::setw(26) << figure(*e, f) << " ";
          std::cout << tiedText(m) << "\n";
        }
        if (ranking.contains("excluded")) std::cout << "  not ranked: " << ranking["excluded"].get<std::string>() << "\n";
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
  auto exposure = std::make_shared<std::string>("per-frame");
  auto refineBudget = std::make_shared<double>(0.5);
  auto refineMaxSpp = std::make_shared<int>(8192);
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
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--exposure", *exposure, "Display exposure (metrics.md): per-frame or first")
      ->check(CLI::IsMember({"per-frame", "first"}))
      ->default_val("per-frame");
  cmd->add_option("--refine-budget", *refineBudget,
                  "After the first pass, refine the references of scenes that miss the reference-quality goal "
                  "(cheapest first) while the predicted extra paths stay within this many times the paths the "
                  "references hold, then run again (0: off)")
      ->check(finiteRange(0.0, 1000.0))
      ->default_val(0.5);
  cmd->add_option("--refine-max-spp", *refineMaxSpp, "The refinement's cap on a reference's samples per pixel")
      ->check(CLI::Range(1, 1 << 20))
      ->default_val(8192);
  // The study, like every run, renders the low-resolution buffer (1/8, 16 paths per texel, the
  // CAPCOM 2023 setting in algorithms.md) because reengine reads it (resolveAutoLowres), so
  // reengine runs its disocclusion rays and is charged for them (a quarter of the 1-spp input's
  // paths per frame); --lowres-factor 0 leaves it out.
  addRenderOptions(cmd, *opt);
  cmd->callback([=] {
    const auto start = std::chrono::steady_clock::now();
    StudyConfig study{studyRun(selectScenes(*scenes, opt->scenesDir), opt->settings()), *refineBudget,
                      *refineMaxSpp};
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
    c.progress = [](const std::string& line) { std::cout << line << std::endl; };
    for (const Scene& s : c.scenes) requireFitsInMemory(s, c.render, true);
    for (const std::string& w : shortSequenceWarnings(c.scenes, c.render, c.warmup))
      std::cerr << "arena: warning: " << w << "\n";
    const json results = runStudy(study);
    ReportOptions ro;
    ro.run = *out;
    ro.out = *report;
    ReportSummary rs = writeReport(ro);
    printRanking(results);
    printEvents(results);
    // What the ranking could not use, and why (a sequence no longer than the warm-up, ...).
    const std::vector<std::string> absent = absentSummaryLines(results, {"relMse"});
    if (!absent.empty()) std::cout << "\nabsent summaries\n";
    for (const std::string& line : absent) std::cout << "  " << line << "\n";
    // metrics.md "Reference quality": said plainly where the references are too noisy to rank.
    std::cout << "\nreference quality (noise floor / best real denoiser's corrected relMSE, goal <= "
              << kReferenceQualityGoal << ")\n";
    for (const std::string& line : referenceQualityLines(results)) std::cout << "  " << line << "\n";
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
