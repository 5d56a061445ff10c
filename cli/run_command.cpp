// `arena run`, `arena sweep`, `arena merge`, `arena compare`, `arena denoisers`, `arena serve`.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "cli/commands.hpp"
#include "cli/printout.hpp"
#include "cli/render_options.hpp"
#include "core/atomic_file.hpp"
#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/text.hpp"
#include "denoisers/external/loader.hpp"
#include "denoisers/external/plugin_denoiser.hpp"
#include "harness/denoiser_server.hpp"
#include "harness/reference_quality.hpp"
#include "harness/run_matrix.hpp"
#include "harness/scene_selection.hpp"
#include "harness/sweep.hpp"
#include "metrics/compare.hpp"
#include "metrics/gate.hpp"
#include "metrics/ghosting_intervals.hpp"
#include "metrics/results.hpp"

namespace arena::cli {

namespace {

// The memory this machine has available to a new process (/proc/meminfo's MemAvailable), in GiB;
// NaN where it cannot be read.
double availableMemoryGiB() {
  std::ifstream in("/proc/meminfo");
  for (std::string line; std::getline(in, line);) {
    double kib = 0;
    if (std::sscanf(line.c_str(), "MemAvailable: %lf kB", &kib) == 1)
      return kib / (1024.0 * 1024.0);
  }
  return std::nan("");
}

using nlohmann::json;

struct MatrixOptions {
  RenderOptions render;
  std::string scenes = "all", out, shard = "0/1", flip = "all", keepFrames = "auto";
  std::string exposure = "per-frame";
  std::vector<std::string> params;
  std::vector<std::string> captures;
  std::string revision;
  CLI::Option* scenesOption = nullptr;
  bool noBaselines = false;
  int warmup = 8;
  int seeds = 1;
};

void addMatrixOptions(CLI::App* cmd, MatrixOptions& o) {
  o.scenesOption = cmd->add_option("--scenes,--scene", o.scenes,
                                   "Scene names, comma-separated, or 'all' (with --capture: none unless given)")
                       ->default_val("all");
  cmd->add_option("--capture", o.captures,
                  "A capture folder (capture.json + EXR frames, docs/captures.md) to validate and score like a "
                  "scene, repeatable")
      ->default_str("none");
  cmd->add_option("--out", o.out, "Run directory, e.g. runs/today")->required();
  cmd->add_option("--revision", o.revision,
                  "The revision of what this run measures (your denoiser's commit, say): recorded "
                  "as environment.revision and shown beside arena's own commit by the report and "
                  "the history")
      ->default_str("none");
  cmd->add_option("--param", o.params, "DENOISER.NAME=VALUE, repeatable (e.g. svgf.sigmaL=8)")
      ->default_str("none: registry defaults");
  cmd->add_option(
         "--shard", o.shard,
         "Run only the deterministic slice i/n of the pairs, i from 0 to n-1 (see `arena merge`)")
      ->default_val("0/1");
  cmd->add_option("--flip", o.flip, "FLIP metrics: none, ldr, or all (LDR and HDR)")
      ->check(CLI::IsMember({"none", "ldr", "all"}))
      ->default_val("all");
  cmd->add_option("--keep-frames", o.keepFrames, "Images kept: auto, all, chosen, none")
      ->check(CLI::IsMember({"auto", "all", "chosen", "none"}))
      ->default_val("auto");
  cmd->add_option("--exposure", o.exposure,
                  "Display exposure (metrics.md): per-frame (each frame's own reference) or first "
                  "(the first reference's)")
      ->check(CLI::IsMember({"per-frame", "first"}))
      ->default_val("per-frame");
  cmd->add_option("--warmup", o.warmup, "Frames excluded from summaries (metrics.md W)")
      ->check(CLI::Range(0, kMaxSceneFrames))
      ->default_val(8);
  cmd->add_flag("--no-baselines", o.noBaselines, "Do not add passthrough and temporal for context");
  cmd->add_option(
         "--seeds", o.seeds,
         "Input seeds per scene: > 1 also renders K-1 more noise realisations and reports each "
         "pair's error split into bias^2 and variance")
      ->check(CLI::Range(1, 64))
      ->default_val(1);
  addRenderOptions(cmd, o.render);
}

// The rendering options given a value of their own: they shape the scenes a run renders, and a
// run of captures alone renders nothing, so there they would be ignored without a word.
std::vector<std::string> renderingOptionsGiven(const MatrixOptions& o) {
  const RenderOptions defaults;
  const RenderOptions& r = o.render;
  std::vector<std::string> given;
  if (r.preset != defaults.preset) given.push_back("--preset " + r.preset);
  if (!r.resolution.empty()) given.push_back("--resolution " + r.resolution);
  if (r.frames != defaults.frames) given.push_back("--frames " + std::to_string(r.frames));
  if (r.referenceSpp != defaults.referenceSpp)
    given.push_back("--ref-spp " + std::to_string(r.referenceSpp));
  if (r.referenceRelError != defaults.referenceRelError) given.push_back("--ref-rel-error");
  if (r.maxBounces != defaults.maxBounces)
    given.push_back("--max-bounces " + std::to_string(r.maxBounces));
  if (r.inputSeed != defaults.inputSeed)
    given.push_back("--input-seed " + std::to_string(r.inputSeed));
  if (r.referenceSampler != defaults.referenceSampler)
    given.push_back("--ref-sampler " + r.referenceSampler);
  if (r.referenceTile != defaults.referenceTile)
    given.push_back("--ref-tile " + std::to_string(r.referenceTile));
  if (r.lowresFactor != defaults.lowresFactor)
    given.push_back("--lowres-factor " + std::to_string(r.lowresFactor));
  if (r.lowresSpp != defaults.lowresSpp)
    given.push_back("--lowres-spp " + std::to_string(r.lowresSpp));
  if (o.seeds != 1) given.push_back("--seeds " + std::to_string(o.seeds));
  return given;
}

// A note on one table row: a failed pair's error may quote a process's stderr over several lines.
std::string oneLine(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  for (size_t at; (at = text.find('\n')) != std::string::npos;) text.replace(at, 1, " / ");
  return text;
}

RunConfig configFrom(const MatrixOptions& o) {
  RunConfig c;
  if (o.out.empty())
    throw Error("--out: an empty directory name; expected the run's directory, e.g. runs/today");
  c.out = o.out;
  c.name = folderName(o.out);  // "runs/today/" too
  if (o.revision.find_first_of("\n\r") != std::string::npos)
    throw Error("--revision: one line expected (a commit or tag), got \"" + o.revision + "\"");
  c.revision = o.revision;
  c.cache = o.render.cacheDir;
  c.render = o.render.settings();
  c.lowresAuto = o.render.lowresAuto();  // resolved once the denoisers are known
  // A run on captures covers only them unless scenes are asked for too.
  if (o.captures.empty() || o.scenesOption->count() > 0) c.scenes = selectScenes(o.scenes, o.render.scenesDir);
  for (const std::string& capture : o.captures) c.captures.push_back(capture);
  if (c.scenes.empty())
    if (const std::vector<std::string> given = renderingOptionsGiven(o); !given.empty()) {
      std::string list;
      for (const std::string& g : given) list += (list.empty() ? "" : ", ") + g;
      throw Error(
          list +
          ": rendering options, for the scenes a run renders; this run scores captures only, "
          "whose frames, resolution and references are what they hold (drop them, or name "
          "scenes too with --scenes)");
    }
  for (const Scene& s : c.scenes) requireRenderable(s, c.render, true);
  c.baselines = !o.noBaselines;
  c.warmup = o.warmup;
  c.seeds = o.seeds;
  c.flip = o.flip;
  c.keepFrames = o.keepFrames;
  c.exposure = o.exposure;
  std::tie(c.shardIndex, c.shardCount) = parseShard(o.shard);
  for (const std::string& w : c.scenes.empty() ? std::vector<std::string>{} : shortSequenceWarnings(c.scenes, c.render, c.warmup))
    std::cerr << "arena: warning: " << w << "\n";
  for (const std::filesystem::path& capture : c.captures)
    if (isCapture(capture))  // else the run names what is wrong with it
      if (const std::string w = shortSequenceWarning(
              capture.string(), readCaptureDescription(capture).info.frames, c.warmup, true);
          !w.empty())
        std::cerr << "arena: warning: " << w << "\n";
  // Progress on stderr, as the study's: stdout holds the results table alone.
  c.progress = [](const std::string& line) { std::cerr << line << std::endl; };
  return c;
}

// `v` with `precision` significant digits, as the table shows numbers.
std::string formatNumber(double v, int precision) {
  std::ostringstream o;
  o << std::setprecision(precision) << v;
  return o.str();
}

// Prints the run as committed to `out` (read back: what the table shows is what results.json holds).
void finish(const std::string& out) {
  const RunResults results = loadResults(out);
  std::cout << "results: " << out << "/results.json (and results.db)\n";
  size_t sceneWidth = 22, labelWidth = 34;  // as wide as the longest entry
  for (const PairResult& p : results.pairs) {
    sceneWidth = std::max(sceneWidth, displayWidth(p.scene) + 2);
    labelWidth = std::max(labelWidth, displayWidth(markedLabel(results, p.label)) + 2);
  }
  // Each pair's rank on its scene, with ties: a mean alone reads as an order the intervals may
  // not support. "3=": two methods resolved better, tied with another (statistics.scenes).
  std::map<std::pair<std::string, std::string>, std::string> ranks;
  if (results.statistics)
    for (const auto& [scene, st] : results.statistics->scenes)
      for (const RankedMethod& m : st.ranking.ranking)
        ranks[{scene, m.label}] = std::to_string(m.rank) + (m.tiedWith.empty() ? "" : "=");
  // The times' clock and size: this machine's CPU at the scenes' resolutions (a reader with a GPU
  // budget must not read them as GPU times).
  const std::string sizeText = sceneSizesText(results);
  std::cout << paddedText("scene", sceneWidth) << paddedText("denoiser", labelWidth) << std::right
            << std::setw(6) << "rank" << std::setw(12) << "relMSE" << std::setw(10) << "ms"
            << "  (rank on relMSE, = tied: not resolved at "
            << (results.statistics ? formatNumber(100 * results.statistics->confidence, 3) : "95")
            << "%; mean relMSE after the warm-up; median ms a frame on this machine's CPU"
            << (sizeText.empty() ? "" : " at " + sizeText) << ", unless marked)\n";
  for (const PairResult& p : results.pairs) {
    std::cout << paddedText(p.scene, sceneWidth)
              << paddedText(markedLabel(results, p.label), labelWidth);
    if (p.ok()) {
      const auto rank = ranks.find({p.scene, p.label});
      std::cout << std::right << std::setw(6) << (rank == ranks.end() ? "-" : rank->second);
      // An ok pair can still have no relMSE summary (a sequence no longer than the warm-up): "-"
      // here and the reason below the table.
      const SummaryMean relMse = p.mean("relMse");
      const json ms = p.timing().value("msMedian", json());
      // A time on another clock than this machine's (a process's own, a capture's device) says so.
      const std::string clock = p.clock();
      const std::string on =
          clock == "process" ? " [reported by the process]"
          : clock == "capture"
              ? " [recorded on " + p.timing().value("device", std::string("the capture's device")) +
                    "]"
              : "";
      std::cout << std::right << std::setw(12)
                << (relMse.present() ? formatNumber(relMse.mean, 4) : "-") << std::setw(10)
                << (ms.is_number() ? formatNumber(ms.get<double>(), 3) : "-") << on << "\n";
    } else {
      std::cout << "  FAILED\n";
    }
  }
  // A scene without a reference has no relMSE ("-" above): what was measured without one, the
  // output's own stability, is printed for it (a capture author saw no number of their run).
  for (const auto& [name, scene] : results.scenes.items()) {
    if (!scene.is_object() || scene.value("hasReference", true)) continue;
    std::cout << name
              << " has no reference: the output's own temporal stability (mean after the "
                 "warm-up with its 95% interval; lower is steadier; docs/metrics.md). Steadier is "
                 "not better on its own: an output that loses detail (blurred, or flat) is the "
                 "steadiest, and without a reference nothing here measures what it lost\n";
    std::cout << "  " << paddedText("", labelWidth) << std::right << std::setw(28)
              << "stabilityFine" << std::setw(28) << "stabilityCoarse"
              << "\n";
    for (const PairResult& p : results.pairs) {
      if (p.scene != name || !p.ok()) continue;
      std::cout << "  " << paddedText(p.label, labelWidth);
      for (const char* metric : {"stabilityFine", "stabilityCoarse"}) {
        const SummaryMean m = p.mean(metric);
        std::string cell = m.present() ? formatNumber(m.mean, 4) : "-";
        if (const auto it = p.summary.find(metric);
            m.present() && it != p.summary.end() && it->second.ci95.valid())
          cell += " [" + formatNumber(it->second.ci95.lo, 3) + ", " +
                  formatNumber(it->second.ci95.hi, 3) + "]";
        std::cout << std::right << std::setw(28) << cell;
      }
      std::cout << "\n";
    }
  }
  // A tie between two methods whose outputs are the same bits measures one output twice.
  for (const auto& item : results.scenes.items()) {
    const std::string& name = item.key();  // read by the lambda below
    const json& scene = item.value();
    if (const std::string same = identicalOutputsText(results, name); !same.empty()) {
      // Under the scaled footprint a small image rounds radii and steps given at footprintHeight
      // lines to the same pixels (radius 1, 2 and 4 all 1 pixel at 36 lines): the likely cause
      // where one denoiser's settings gave one output, not where two denoisers compute alike (eaw
      // and a plugin of it).
      const double height = scene.is_object() ? scene.value("height", 0.0) : 0.0;
      auto shrunk = [&](const PairResult* p) {
        const json reference = p->params.value("footprintHeight", json());
        return p->params.value("footprint", json()) == "scaled" && reference.is_number() &&
               height > 0 && height < reference.get<double>();
      };
      // The parameters that differ within such groups: the footprint is a likely cause only where
      // one of them is a radius or a step, which a parameter's schema does not say, so the hint
      // names them and says both readings (normalPower=[32,128] is no radius, and native keeps
      // it identical).
      std::set<std::string> differing;
      for (const std::vector<const PairResult*>& group : identicalOutputGroups(results, name))
        for (size_t i = 0; i < group.size(); ++i)
          for (size_t j = i + 1; j < group.size(); ++j) {
            if (group[i]->denoiser != group[j]->denoiser || !shrunk(group[i]) || !shrunk(group[j]))
              continue;
            for (auto v = group[i]->params.begin(); v != group[i]->params.end(); ++v)
              if (group[j]->params.value(v.key(), json()) != v.value()) differing.insert(v.key());
          }
      std::string names;
      for (const std::string& n : differing) names += (names.empty() ? "" : ", ") + n;
      std::cout << name << ": identical outputs (bit for bit, every frame): " << same
                << (names.empty()
                        ? ""
                        : " (they differ in " + names +
                              ": where that is a radius or a step, the scaled footprint can round "
                              "it to the same pixels at this size, and footprint=native keeps them "
                              "apart; where not, it changed nothing here)")
                << "\n";
    }
  }
  printSeedSplit(std::cout, results);
  for (const std::string& line : absentSummaryLines(results, {"relMse"})) std::cout << line << "\n";
  for (const std::string& line : otherAbsentSummaryLines(results)) std::cout << line << "\n";
  if (const PairWarningCount w = countPairWarnings(results); w.warnings > 0)
    std::cout << w.warnings << " warning(s) on " << w.pairs
              << " pair(s): results.json pairs[].warnings, and the report beside each pair\n";
  // What concerns a scene rather than a method (events beyond the frames rendered, an unflagged
  // camera jump, references at their cap): in results.json and the report, and said here too.
  for (const auto& [name, scene] : results.scenes.items())
    if (scene.is_object() && scene.contains("warnings") && scene["warnings"].is_array())
      for (const json& w : scene["warnings"])
        if (w.is_string()) std::cout << "warning: " << name << ": " << w.get<std::string>() << "\n";
  printOverallRanking(std::cout, results);
  printOtherOverallScores(std::cout, results);
  // The scripted events' and camera cuts' figures (lag, response, old-view leak) with intervals:
  // an anti-lag ablation's main result, which a run printed nowhere (results.json, the report).
  printEventTables(std::cout, results);
  // The scenes whose reference is too noisy to separate the methods well: said here, not only in
  // results.json and the report (the ranking above is read first).
  std::vector<std::string> missed, unknown;
  for (const auto& [name, scene] : results.scenes.items())
    if (const json q = scene.value("referenceQuality", json::object());
        q.value("meets", true) == false)
      missed.push_back(q.value("verdict", name));
    else if (!q.contains("meets") && q.contains("verdict") && scene.value("hasReference", true))
      unknown.push_back(q.value("verdict", name));
  if (!missed.empty()) {
    std::cout << "\nreference quality: " << missed.size() << " of " << results.scenes.size()
              << " scene(s) miss the goal (noise floor / best corrected relMSE <= "
              << kReferenceQualityGoal
              << "); their rankings hold more ties and the overall score reads nearer 1:\n";
    for (const std::string& line : missed) std::cout << "  " << line << "\n";
  }
  if (const std::vector<std::string> between = segmentQualityLines(results.scenes);
      !between.empty()) {
    std::cout
        << "\nreference quality: " << between.size()
        << " scene(s) meet the goal as a whole but not between their events; the event figures "
           "there carry more of the reference's noise:\n";
    for (const std::string& line : between) std::cout << "  " << line << "\n";
  }
  // A reference whose quality cannot be judged (a capture's without its variance) is said too: a
  // 4-spp reference scored as if converged otherwise passes without a word.
  for (const std::string& line : unknown) std::cout << "reference quality: " << line << "\n";
  auto failed = failedPairs(results);
  if (!failed.empty()) {
    std::cerr << failed.size() << " pair(s) failed:\n";
    for (auto& f : failed) std::cerr << "  " << f << "\n";
    throw CLI::RuntimeError(1);
  }
  // Every summary of every pair absent (no frame after the warm-up, said per metric above): the
  // run measured nothing, which is no result to pass as done (compare fails on it too).
  bool measured = false;
  for (const PairResult& p : results.pairs)
    for (const auto& [metric, summary] : p.summary) measured = measured || p.mean(metric).present();
  if (!results.pairs.empty() && !measured) {
    std::cerr
        << "nothing measured: every summary of every pair is absent (the lines above say why; "
           "a sequence no longer than the warm-up: render more --frames or lower --warmup)\n";
    throw CLI::RuntimeError(1);
  }
  // Every contender left out where it lacked the inputs (a capture without the layers any of them
  // reads): nothing was measured, which a run must not pass as done. (A shard whose slice held no
  // pair left nothing out.)
  bool leftOut = false;
  for (const auto& [name, scene] : results.scenes.items())
    leftOut =
        leftOut || (scene.is_object() && scene.contains("notRun") && !scene["notRun"].empty());
  if (results.pairs.empty() && leftOut) {
    std::cerr << "no pair ran: every contender lacked the inputs it reads on every capture (the "
                 "\"not run\" lines above say which); give those layers, or name a denoiser that "
                 "reads what the capture has\n";
    throw CLI::RuntimeError(1);
  }
}

}  // namespace

void addRunCommands(CLI::App& app) {
  {
    auto* cmd = app.add_subcommand("run", "Run denoisers x scenes, compute every metric, store results");
    auto o = std::make_shared<MatrixOptions>();
    auto names = std::make_shared<std::string>("all");
    auto plugins = std::make_shared<std::vector<std::string>>();
    cmd->add_option("--denoisers,--denoiser", *names,
                    "Registered names, ext:MANIFEST, plugin:LIBRARY.so, file:OUTPUT (a capture's stored output), "
                    "comma-separated, or 'all'")
        ->default_val("all");
    cmd->add_option("--plugin", *plugins, "A C plugin library (include/arena_plugin.h) to run too, repeatable");
    addMatrixOptions(cmd, *o);
    cmd->callback([o, names, plugins] {
      RunConfig c = configFrom(*o);
      // '' or ',' would otherwise run only the baselines, as if the denoisers had been left out.
      std::vector<std::string> list = *names == "all"
                                          ? DenoiserRegistry::instance().names()
                                          : splitList(*names, "--denoisers", kDenoiserListExpected);
      for (const std::string& library : *plugins) list.push_back("plugin:" + library);
      c.everyDenoiser = *names == "all";
      // 'all' on captures includes every denoiser output they store (file:NAME contenders).
      if (*names == "all")
        for (const auto& capture : c.captures)
          for (const auto& [output, stored] : readCaptureDescription(capture).outputs)
            if (std::find(list.begin(), list.end(), "file:" + output) == list.end())
              list.push_back("file:" + output);
      for (std::string& n : list)
        if (capturedOutputName(n).empty()) n = DenoiserRegistry::resolve(n);  // loads external ones
      // A stored output no capture of the run holds (a misspelt file:NAME) is refused before the
      // work, as a misspelt denoiser is; one that some captures lack fails there only.
      for (const std::string& n : list) {
        const std::string output = capturedOutputName(n);
        if (output.empty() || c.captures.empty())
          continue;  // without captures: runMatrix refuses it
        std::set<std::string> outputs;
        bool unreadable = false;  // a capture that cannot be read fails its own pairs, saying why
        for (const auto& capture : c.captures) {
          try {
            for (const auto& [name, unused] : readCaptureDescription(capture).outputs)
              outputs.insert(name);
          } catch (const Error&) {
            unreadable = true;
          }
        }
        if (unreadable) continue;
        std::string stored;
        for (const std::string& name : outputs) stored += (stored.empty() ? "" : ", ") + name;
        if (!outputs.count(output))
          throw Error("--denoisers " + n + ": no capture of this run stores an output '" + output +
                      "' (" +
                      (stored.empty() ? std::string("they store none") : "stored: " + stored) +
                      "; docs/captures.md, \"outputs\")");
      }
      auto params = parseParamAssignments(o->params);
      for (auto& [denoiser, kv] : params) {
        if (std::find(list.begin(), list.end(), denoiser) != list.end()) continue;
        // A baseline that runs (not listed itself) takes its --param too.
        if (c.baselines && (denoiser == "passthrough" || denoiser == "temporal")) {
          c.baselineParams[denoiser] = kv;
          continue;
        }
        std::string running;
        for (const std::string& n : list) running += (running.empty() ? "" : ", ") + n;
        if (c.baselines) running += ", passthrough, temporal (baselines)";
        throw Error("--param " + denoiser + "." + kv.begin()->first + ": " + denoiser +
                    " is not among the denoisers of this run (" + running + ")");
      }
      for (const std::string& n : list) {
        if (capturedOutputName(n).empty()) DenoiserRegistry::instance().find(n);
        c.denoisers.push_back({n, params[n], ""});
      }
      resolveAutoLowres(c);
      runMatrix(c);
      finish(o->out);
    });
  }
  {
    auto* cmd = app.add_subcommand("sweep", "Run a parameter grid of one denoiser (ablations) into one run");
    auto o = std::make_shared<MatrixOptions>();
    auto denoiser = std::make_shared<std::string>();
    auto grids = std::make_shared<std::vector<std::string>>();
    cmd->add_option("--denoiser", *denoiser, "The denoiser to sweep")->required();
    cmd->add_option("--grid", *grids, "NAME=[v1,v2,...], repeatable; the run covers the Cartesian product")->required();
    auto maxPoints = std::make_shared<size_t>(kDefaultMaxSweepPoints);
    cmd->add_option("--max-points", *maxPoints,
                    "Refuse a grid of more points than this (each runs on every scene)")
        ->check(CLI::Range(size_t(1), size_t(1000000)))
        ->capture_default_str();
    addMatrixOptions(cmd, *o);
    cmd->callback([o, denoiser, grids, maxPoints] {
      RunConfig c = configFrom(*o);
      *denoiser = DenoiserRegistry::resolve(*denoiser);  // ext:MANIFEST or plugin:LIBRARY too
      auto assignments = parseParamAssignments(o->params);
      for (auto& [other, kv] : assignments)
        if (other != *denoiser)
          throw Error(
              "--param " + other + "." + kv.begin()->first + ": this sweep runs only " + *denoiser +
              " and the baselines; a sweep's --param sets " + *denoiser +
              "'s fixed parameters (--param " + *denoiser + ".NAME=VALUE)" +
              (other == "passthrough" || other == "temporal"
                   ? "; the baselines run at their defaults, as in every sweep, so that its "
                     "overall score is normalised by the same temporal baseline "
                     "(--no-baselines leaves them out)"
                   : ""));
      c = sweepRun(std::move(c), *denoiser, assignments[*denoiser], *grids, *maxPoints);
      // An axis of one value ablates nothing (the report says "no ablation" afterwards): said now.
      for (const auto& [name, values] : c.annotations["sweep"]["grid"].items())
        if (values.size() == 1)
          std::cerr << "arena: warning: --grid " << name << ": one value ("
                    << values[0].get<std::string>()
                    << "): it fixes the parameter, as --param would, and the ablation compares "
                       "nothing along it (give two values or more to ablate it)\n";
      // What a large grid costs beyond its pairs (a trial's 500 points on one scene at 64x36:
      // 2 minutes, 4 GB of memory, a 372 MB results.json, most of it after the pairs' ETA).
      if (const size_t n = c.denoisers.size() + (c.baselines ? 2 : 0); n > kManyContenders) {
        // Projected from that trial (3.95 GB for 500 contenders on one scene), with the square
        // of the contenders and the number of scenes: an estimate, said as one, and set against
        // what the machine has (the trial's 1000-point grid would have needed about 16 GB).
        const double projected =
            3.95 * std::pow(double(n) / 500.0, 2) * double(std::max<size_t>(1, c.scenes.size()));
        const double available = availableMemoryGiB();
        std::cerr << "arena: warning: " << n << " contenders per scene: the statistics compare "
                  << n * (n - 1) / 2
                  << " pairs of them on each scene and metric and results.json keeps them all, "
                     "so time, memory and the file grow with the square of the grid (shards "
                     "merged are compared whole); for an ablation, sweeps of fewer axes cost "
                     "less. Memory, projected from a measured 4 GB for 500 contenders on one "
                     "scene: about "
                  << shortestText(std::round(projected * 10) / 10) << " GB";
        if (std::isfinite(available) && projected > available)
          std::cerr << ", MORE than the " << shortestText(std::round(available * 10) / 10)
                    << " GB this machine has available: narrow the grid or run fewer scenes";
        std::cerr << "\n";
      }
      resolveAutoLowres(c);
      runMatrix(c);
      finish(o->out);
    });
  }
  {
    auto* cmd = app.add_subcommand("merge", "Combine shard runs (--shard i/n) into one run");
    auto runs = std::make_shared<std::vector<std::string>>();
    auto out = std::make_shared<std::string>();
    cmd->add_option("runs", *runs, "Shard run directories")->required();
    cmd->add_option("--out", *out, "Merged run directory")->required();
    cmd->callback([runs, out] {
      std::vector<std::filesystem::path> paths(runs->begin(), runs->end());
      mergeRuns(paths, *out);
      finish(*out);
    });
  }
  {
    auto* cmd = app.add_subcommand(
        "compare",
        "Compare two runs; exit 1 when a metric regresses beyond its tolerance (or a pair is "
        "missing or failed), 2 when the gate could not judge");
    auto a = std::make_shared<std::string>(), b = std::make_shared<std::string>();
    auto metrics = std::make_shared<std::vector<std::string>>();
    auto tol = std::make_shared<std::string>("2%");
    auto asJson = std::make_shared<bool>(false);
    auto confidence = std::make_shared<std::string>("95%");
    cmd->add_option("baseline", *a, "Baseline run directory")->required();
    cmd->add_option("candidate", *b, "Candidate run directory")->required();
    std::string gated;
    for (const MetricDefinition* m : metricCatalog())
      if (m->gatedByDefault) gated += (gated.empty() ? "" : " ") + m->name;
    // One value per --metric, or a comma-separated list: never the positional runs after it.
    cmd->add_option(
           "--metric", *metrics,
           "Metric(s) to gate on, repeatable or comma-separated (`arena metrics` lists them); "
           "event figures as ghosting.FIGURE or cut.FIGURE (e.g. ghosting.lagEnergy), a row per "
           "event")
        ->default_str(gated)
        ->delimiter(',')
        ->allow_extra_args(false);
    auto only = std::make_shared<std::string>();
    cmd->add_option("--denoisers", *only,
                    "Gate only these contenders (labels or denoiser names, comma-separated): the "
                    "ones a change can move, not the baselines it cannot")
        ->default_str("every pair");
    cmd->add_option("--tolerance", *tol,
                    "Allowed relative change in the worse direction, e.g. 2%; a metric's own as "
                    "METRIC=VALUE, comma-separated (2%,ghosting.lagEnergy=10%)")
        ->default_val("2%");
    cmd->add_option("--confidence", *confidence,
                    "A change regresses only when its paired bootstrap interval at this level excludes zero")
        ->default_val("95%");
    auto correction = std::make_shared<std::string>("holm");
    cmd->add_option(
           "--correction", *correction,
           "holm: a change regresses only when it stays resolved among every row the gate judges "
           "(made so that noise alone fails the gate about 1 - confidence of the time, where the "
           "intervals hold their level); none: each row alone")
        ->check(CLI::IsMember({"holm", "none"}))
        ->default_val("holm");
    cmd->add_flag("--json", *asJson, "Machine-readable output")->default_str("off");
    auto matchLabels = std::make_shared<std::vector<std::string>>();
    cmd->add_option(
           "--match", *matchLabels,
           "BASELINE=CANDIDATE: compare the baseline's pairs of one label with the "
           "candidate's of another on every scene (e.g. 'svgf=svgf[sigmaL=8]': a parameter "
           "changed between the runs), repeatable")
        ->allow_extra_args(false);
    auto allowMismatch = std::make_shared<bool>(false);
    cmd->add_flag("--allow-settings-mismatch", *allowMismatch,
                  "Compare runs whose settings differ (resolution, warm-up, references, ...): warn and go on "
                  "instead of refusing");
    cmd->callback([=] {
      Gate gate;
      gate.tolerances = parseGate(*metrics, *tol);
      gate.bootstrap.confidence = parseConfidence(*confidence);
      gate.correction = parseCorrection(*correction);
      gate.matches = *matchLabels;
      gate.allowSettingsMismatch = *allowMismatch;
      if (cmd->count("--denoisers") > 0)  // given empty: an error, not every pair gated
        gate.contenders = splitList(*only, "--denoisers", "labels or denoiser names");
      const RunResults baseline = loadResults(*a), candidate = loadResults(*b);
      const std::map<std::string, std::string> matches =
          checkLabelMatches(gate.matches, baseline, candidate);
      // The judgement `report --baseline` and `history` make too (metrics/gate.hpp). What it cannot
      // judge (the same run twice, other settings, data compareRuns refuses) exits 2.
      const GateJudgement judged = judgeRuns(baseline, candidate, gate, matches);
      const GateSides sides{"the baseline " + *a, "the candidate " + *b};
      std::vector<std::string> warnings;  // said on stderr, and in the JSON
      const auto warn = [&](const std::string& text) {
        std::cerr << "arena: warning: " << text << "\n";
        warnings.push_back(text);
      };
      // Its numbers are whole (the earlier run's); only its images are mixed: said, and compared.
      for (const std::string* dir : {a.get(), b.get()})
        if (const std::string note = unfinishedRunNote(*dir); !note.empty())
          warn(note + "; compared on the earlier run's numbers, which are whole");
      // What it warns of is said before a refusal too (a run that records no settings beside a
      // resolution that differs).
      for (const std::string& text : gateWarningTexts(judged, sides, /*multiLine=*/true))
        warn(text);
      if (judged.refusal == GateRefusal::Data) throw Error(judged.refusalDetail);
      if (judged.refusal != GateRefusal::None)
        throw Error("compare: " + refusalText(judged, sides, /*multiLine=*/true));
      const Correction corrected = gate.correction;
      const BootstrapConfig& bc = gate.bootstrap;
      const std::vector<Tolerance> tols = gateTolerances(gate.tolerances);
      const std::vector<ComparisonRow>& rows = judged.rows;
      const size_t family = judged.rowsJudgedTogether;  // the rows the correction judges together
      const GateOutcome outcome = judged.outcome;
      if (*asJson) {
        const auto runJson = [](const std::string& path, const RunResults& r) {
          return json{{"path", path},
                      {"name", r.name},
                      {"created", r.created},
                      {"commit", r.environment.value("git_commit", "")},
                      {"revision", r.environment.value("revision", "")}};
        };
        const json out = {
            {"gate", gateOutcomeName(outcome)},  {"exitCode", gateExitCode(outcome)},
            {"baseline", runJson(*a, baseline)}, {"candidate", runJson(*b, candidate)},
            {"confidence", bc.confidence},       {"correction", *correction},
            {"rowsJudgedTogether", family},      {"warnings", warnings},
            {"rows", comparisonJson(rows)}};
        std::cout << jsonText(out, 2) << "\n";
      } else {
        std::cout << "regressed = worse by more than the tolerance AND the paired "
                  << bc.confidence * 100 << "% interval of the change excludes zero"
                  << (corrected == Correction::Holm && family == 0
                          ? std::string(" (no row has an interval to judge together)")
                      : corrected == Correction::Holm
                          ? " AND it stays resolved among the " + std::to_string(family) +
                                " rows judged together (Holm)"
                          : std::string(
                                " (each row alone: no correction for the rows judged together)"))
                  << "\n";
        // The tolerances, where a metric has its own (the table's rows do not show them).
        std::map<double, std::vector<std::string>> byTolerance;
        for (const Tolerance& t : tols) byTolerance[t.relative].push_back(t.metric);
        if (byTolerance.size() > 1) {
          std::cout << "tolerances:";
          for (const auto& [value, names] : byTolerance) {
            std::cout << " " << shortestText(value * 100) << "% (";
            for (size_t k = 0; k < names.size(); ++k) std::cout << (k ? ", " : "") << names[k];
            std::cout << ")";
          }
          std::cout << "\n";
        }
        // Columns as wide as their longest entry (a sweep's labels carry their parameters).
        // A pair matched by what it ran under another label shows both ("svgf = svgf[sigmaL=4]").
        // One matched by --match shows where it went ("svgf -> svgf[sigmaL=8]").
        const auto shownLabel = [](const ComparisonRow& r) {
          return r.candidateLabel.empty()
                     ? r.label
                     : r.label + (r.matchedByRequest ? " -> " : " = ") + r.candidateLabel;
        };
        size_t sceneWidth = 22, labelWidth = 30, metricWidth = 16;
        for (const ComparisonRow& r : rows) {
          sceneWidth = std::max(sceneWidth, displayWidth(r.scene) + 2);
          labelWidth = std::max(labelWidth, displayWidth(shownLabel(r)) + 2);
          metricWidth = std::max(metricWidth, displayWidth(r.metric) + 2);
        }
        std::cout << paddedText("scene", sceneWidth) << paddedText("denoiser", labelWidth)
                  << paddedText("metric", metricWidth) << std::right << std::setw(12) << "baseline"
                  << std::setw(12) << "candidate" << std::setw(9) << "change" << std::setw(22)
                  << "interval"
                  << "  verdict\n";
        const auto pct = [](double v) { return changePercentText(v); };
        auto figure = [](double v) {  // a missing value is "-", not "nan"
          std::ostringstream o;
          o << std::setprecision(4) << v;
          return std::isfinite(v) ? o.str() : std::string("-");
        };
        for (auto& r : rows)
          std::cout << paddedText(r.scene, sceneWidth) << paddedText(shownLabel(r), labelWidth)
                    << paddedText(r.metric, metricWidth) << std::right << std::setw(12)
                    << figure(r.baseline) << std::setw(12) << figure(r.candidate) << std::setw(9)
                    << pct(r.change) << std::setw(22)
                    << (r.changeCi.valid()
                            ? "[" + pct(r.changeCi.lo) + ", " + pct(r.changeCi.hi) + "]"
                            : "-")
                    << "  " << r.verdict << (r.note.empty() ? "" : " (" + oneLine(r.note) + ")")
                    << "\n";
        // The verdict in one line, with what it rests on, for a CI log.
        std::map<std::string, int> verdicts;
        for (const ComparisonRow& r : rows) ++verdicts[r.verdict];
        std::string counts;
        for (const auto& [verdict, n] : verdicts)
          counts += (counts.empty() ? "" : ", ") + std::to_string(n) + " " + verdict;
        std::cout << "gate: "
                  << (outcome == GateOutcome::Regressed       ? "FAIL"
                      : outcome == GateOutcome::CouldNotJudge ? "COULD NOT JUDGE"
                                                              : "pass")
                  << " (" << rows.size() << " row(s): " << counts << ")\n";
      }
      if (gateExitCode(outcome) != 0) throw CLI::RuntimeError(gateExitCode(outcome));
    });
  }
  {
    auto* cmd = app.add_subcommand("denoisers",
                                   "List the registered denoisers (and the manifests on ARENA_DENOISER_PATH) "
                                   "and their parameters");
    auto asJson = std::make_shared<bool>(false);
    cmd->add_flag("--json", *asJson, "Machine-readable output");
    cmd->callback([asJson] {
      // One bad or shadowed file on the path is said and left out; it does not hide the rest.
      for (const auto& manifest : manifestsOnSearchPath()) try {
          DenoiserRegistry::resolve("ext:" + manifest.string());
        } catch (const Error& e) {
          std::cerr << "arena: warning: " << e.what() << " (not listed)\n";
        }
      json out = json::array();
      for (const std::string& n : DenoiserRegistry::instance().names()) {
        const DenoiserInfo& info = DenoiserRegistry::instance().find(n);
        json params = json::array();
        for (const ParamSpec& p : info.schema.specs()) params.push_back(p.describe());
        out.push_back({{"name", n}, {"description", info.description}, {"parameters", params}});
        if (!info.origin.empty()) out.back()["origin"] = info.origin;
      }
      if (*asJson) {
        std::cout << jsonText(out, 2) << "\n";
        return;
      }
      for (auto& d : out) {
        // An external's line says where it came from (the manifest or library the name resolves
        // to: a search path may hold several of that name).
        const std::string description = d["description"].get<std::string>();
        std::cout << d["name"].get<std::string>() << (description.empty() ? "" : ": " + description)
                  << (d.contains("origin") ? " [" + d["origin"].get<std::string>() + "]" : "")
                  << "\n";
        for (auto& p : d["parameters"]) std::cout << "    " << p.get<std::string>() << "\n";
      }
    });
  }
  {
    auto* cmd = app.add_subcommand(
        "serve",
        "Run one denoiser (plugin:LIBRARY or a built-in) as a frame-protocol process on stdin and "
        "stdout: what an isolated plugin runs in (docs/external-denoisers.md)");
    auto entry = std::make_shared<std::string>();
    cmd->add_option("denoiser", *entry,
                    "plugin:LIBRARY, or a built-in that reads neither gradient samples nor the "
                    "low-resolution buffer")
        ->required();
    auto describe = std::make_shared<bool>(false);
    cmd->add_flag("--describe", *describe,
                  "Print what the denoiser is, as a manifest would (name, signals, channels, "
                  "parameters), one JSON line, and exit");
    cmd->footer(
        "It reads one setup line and answers ready, then answers each frame with its result, as "
        "any process speaking the frame protocol; its stdout carries only the protocol (what the "
        "denoiser prints there goes to stderr). Exit status 0 when its input ends after whole "
        "frames, 1 after a fault (answered with an error message), 2 when the denoiser cannot be "
        "loaded.");
    cmd->callback([entry, describe] {
      // The protocol keeps the real stdin and stdout on descriptors of its own (closed on exec:
      // a child the plugin starts does not inherit them); the denoiser's prints go to stderr, and
      // a read of stdin or a close of it reaches /dev/null, not the protocol.
      std::cout.flush();
      const int protocolIn = ::fcntl(STDIN_FILENO, F_DUPFD_CLOEXEC, 3);
      const int protocolOut = ::fcntl(STDOUT_FILENO, F_DUPFD_CLOEXEC, 3);
      const int devNull = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
      if (protocolIn < 0 || protocolOut < 0 || devNull < 0 || ::dup2(devNull, STDIN_FILENO) < 0 ||
          ::dup2(STDERR_FILENO, STDOUT_FILENO) < 0)
        throw Error(std::string("arena serve: cannot set up its input and output: ") +
                    std::strerror(errno));
      ::close(devNull);
      // Line by line: what the plugin prints before a crash reaches the pair's error.
      std::setvbuf(stdout, nullptr, _IOLBF, 0);
      setPluginCrashConsequence(
          *describe
              ? "this process (arena serve --describe, the plugin's isolated host) ends here, "
                "and arena refuses the manifest before anything runs"
              : "this process (arena serve, the plugin's isolated host) ends here; the "
                "harness fails this pair alone, unless every frame was answered before (a "
                "crash in destroy)");
      const int status = *describe ? describeDenoiser(*entry, protocolOut)
                                   : serveDenoiser(*entry, protocolIn, protocolOut);
      ::close(protocolIn);
      ::close(protocolOut);
      if (status != 0) throw CLI::RuntimeError(status);
    });
  }
  {
    auto* cmd = app.add_subcommand("metrics", "List the registered metrics: unit, better direction, reference, "
                                              "what they read, how tiles become a frame value, floor");
    auto asJson = std::make_shared<bool>(false);
    cmd->add_flag("--json", *asJson, "Machine-readable output");
    cmd->callback([asJson] {
      const json catalog = metricCatalogJson();
      if (*asJson) {
        std::cout << jsonText(catalog, 2) << "\n";
        return;
      }
      for (const json& m : catalog) {
        const std::string unit = m["unit"].get<std::string>();
        std::cout << std::left << std::setw(22) << m["name"].get<std::string>() << std::setw(8)
                  << (m["better"].get<std::string>() == "lower" ? "lower" : "higher")
                  << std::setw(14) << (m["needsReference"].get<bool>() ? "reference" : "no reference")
                  << m["meaning"].get<std::string>() << (unit.empty() ? "" : " [" + unit + "]") << "\n";
        // What the help promises: what it reads, how its tiles become a frame value, its floor, and
        // whether it is ranked, gated by default and has an overall score.
        std::string roles;
        for (const auto& [key, role] : {std::pair<const char*, const char*>{"ranked", "ranked"},
                                        {"gatedByDefault", "gated by default"},
                                        {"overall", "overall score"}})
          if (m.value(key, false)) roles += std::string(roles.empty() ? "" : ", ") + role;
        // A counter of the run (a time, rays) is one number per frame: it has no tiles.
        const std::string reads = m.value("reads", std::string("?"));
        std::cout << std::string(22, ' ') << "reads " << reads << "; frame value: "
                  << (reads == "run" ? "one per frame (no image, no tiles)"
                                     : m.value("transform", std::string("?")) + " of its tiles")
                  << "; floor: " << m.value("floor", std::string("none"))
                  << (roles.empty() ? "" : "; " + roles) << "\n";
      }
      // The event-window figures are not summaries of a pair but one figure per event: `compare`
      // gates them where named.
      std::string figures;
      for (const std::string& f : gatedEventFigureNames())
        figures += (figures.empty() ? "" : ", ") + f;
      std::cout << "\nevent figures, one per scripted event or camera cut (lower is better; ranked "
                   "per event; gated by `arena compare --metric` only where named):\n  "
                << figures << "\n(definitions: docs/metrics.md)\n";
    });
  }
}

}  // namespace arena::cli
