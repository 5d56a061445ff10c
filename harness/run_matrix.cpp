#include "harness/run_matrix.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <set>

#include "core/atomic_file.hpp"
#include "core/capture.hpp"
#include "core/crash_note.hpp"
#include "core/env_info.hpp"
#include "core/error.hpp"
#include "core/stage_clock.hpp"
#include "harness/pair_run.hpp"
#include "harness/reference_quality.hpp"
#include "harness/scene_data.hpp"
#include "metrics/results.hpp"
#include "metrics/run_statistics.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string safeName(const std::string& label) {
  std::string s = label;
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || std::string("._=,-[]").find(c) != std::string::npos)) c = '_';
  return s;
}

// The record of a pair that could not run or be measured.
json failedPair(const std::string& scene, const DenoiserRequest& r, const std::string& error) {
  return {{"scene", scene}, {"denoiser", r.name}, {"label", r.label}, {"params", json::object()},
          {"status", "failed"}, {"error", error}};
}

// A pair's image folder emptied before the pair runs (a reused --out's earlier images are not
// this run's); an error fails the pair.
void removePairImages(const fs::path& dir) {
  std::error_code ec;
  fs::remove_all(dir, ec);
  if (ec) throw Error(dir.string() + ": cannot remove the images there: " + ec.message());
}

// A failed pair's images removed (its frames so far are no measurement); never throws, so a
// folder that cannot be removed fails only that pair, saying so in its error.
void discardPairImages(const fs::path& dir, json& pair) {
  std::error_code ec;
  fs::remove_all(dir, ec);
  if (ec)
    pair["error"] = pair["error"].get<std::string>() + " (its images in " + dir.string() +
                    " could not be removed: " + ec.message() + ")";
}

// A scene's own images (the chosen frames' noisy_ and reference_ PNGs) removed before the scene
// writes them again: a reused --out's other chosen frames are not this run's.
void removeSceneImages(const fs::path& dir, const ProgressFn& say) {
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (it->is_regular_file(ec) &&
        (name.rfind("noisy_", 0) == 0 || name.rfind("reference_", 0) == 0)) {
      std::error_code removed;
      fs::remove(it->path(), removed);
      if (removed && say)
        say("  warning: " + it->path().string() +
            ": cannot remove an earlier run's image: " + removed.message());
    }
  }
}

// A path that a results file recorded under the run directory, if it is one: relative, below
// images/, no "..". Anything else is left alone.
std::optional<fs::path> recordedImagePath(const fs::path& out, const json& recorded) {
  if (!recorded.is_string()) return std::nullopt;
  const fs::path relative = recorded.get<std::string>();
  if (relative.is_absolute() || relative.empty() || *relative.begin() != "images")
    return std::nullopt;
  for (const fs::path& part : relative)
    if (part == "..") return std::nullopt;
  return out / relative;
}

// Image folders under images/ that no results file records: a run stopped before its commit wrote
// them, or someone else did. Those the run's mark names (`named`: this run's plan and a stopped
// run's, metrics/results.hpp unfinishedRunFolders) are removed (a pair's folder whole, a scene's
// own PNGs and then the folder if that emptied it); anything else is said, not removed: nothing
// says whose it is.
void pruneUnrecordedImages(const fs::path& out, const std::set<fs::path>& recorded,
                           const std::set<fs::path>& named, const ProgressFn& say) {
  std::error_code ec;
  std::vector<std::string> unrecorded;
  std::vector<fs::path> strayPairs, strayScenes;
  for (fs::directory_iterator scene(out / "images", ec), end; !ec && scene != end;
       scene.increment(ec))
    if (scene->is_directory(ec)) {
      // A folder beside the scenes' that nothing records or names (a user's): said as a whole.
      if (!recorded.count(scene->path()) && !named.count(scene->path())) {
        unrecorded.push_back(fs::relative(scene->path(), out, ec).string());
        continue;
      }
      for (fs::directory_iterator pair(scene->path(), ec); !ec && pair != end; pair.increment(ec))
        if (pair->is_directory(ec) && !recorded.count(pair->path())) {
          if (named.count(pair->path()))
            strayPairs.push_back(pair->path());
          else
            unrecorded.push_back(fs::relative(pair->path(), out, ec).string());
        }
      if (!recorded.count(scene->path()) && named.count(scene->path()))
        strayScenes.push_back(scene->path());
    }
  for (const fs::path& dir : strayPairs) {
    std::error_code removed;
    fs::remove_all(dir, removed);
    if (removed && say)
      say("  warning: " + dir.string() +
          ": cannot remove a stopped run's images: " + removed.message());
  }
  for (const fs::path& dir : strayScenes) {
    removeSceneImages(dir, say);
    std::error_code removed;
    if (fs::is_empty(dir, removed)) fs::remove(dir, removed);
  }
  if (unrecorded.empty() || !say) return;
  std::sort(unrecorded.begin(), unrecorded.end());
  std::string names;
  for (size_t i = 0; i < std::min<size_t>(unrecorded.size(), 3); ++i)
    names += (i ? ", " : "") + unrecorded[i];
  say("  warning: " + out.string() + " holds " + std::to_string(unrecorded.size()) +
      " image folder(s) no run recorded (" + names + (unrecorded.size() > 3 ? ", ..." : "") +
      "), left by a run stopped before its commit?; the report reads none of them: remove them");
}

// The image folders that the run directory's previous results.json recorded (a reused --out) and
// this run did not write are removed before the new results replace it, so the report copies only
// this run's images. Only what that file names is touched (a --out holding other folders keeps
// them), and nothing here fails a finished run: what cannot be removed is said.
// Returns the folders the earlier run recorded (removed, or said when they could not be).
std::set<fs::path> pruneRecordedImages(const fs::path& out, const std::set<fs::path>& written,
                                       const ProgressFn& say) {
  std::error_code ec;
  std::set<fs::path> stale;
  if (!fs::exists(out / "results.json", ec)) return stale;
  json earlier;
  try {
    earlier = json::parse(readText(out / "results.json"));
  } catch (const std::exception&) {
    return stale;  // not readable as JSON: checkRunOutputs took it as replaceable, it names nothing
  }
  if (!earlier.is_object()) return stale;
  for (const json& p : earlier.value("pairs", json::array()))
    if (p.is_object() && p.contains("images") && p["images"].is_object())
      if (auto dir = recordedImagePath(out, p["images"].value("dir", json()));
          dir && !written.count(*dir))
        stale.insert(*dir);
  for (const fs::path& dir : stale) {
    fs::remove_all(dir, ec);
    if (ec && say)
      say("  warning: " + dir.string() +
          ": cannot remove an earlier run's images: " + ec.message());
  }
  for (const json& scene : earlier.value("scenes", json::object()))
    if (scene.is_object())
      if (auto dir = recordedImagePath(out, scene.value("images", json()));
          dir && !written.count(*dir)) {
        removeSceneImages(*dir, say);
        if (fs::is_empty(*dir, ec)) fs::remove(*dir, ec);
      }
  return stale;
}

// The images of this run, alone under images/: the earlier run's are removed, and so are the
// folders the mark names that no results record (a stopped run's); other strays are said.
void pruneEarlierImages(const fs::path& out, const json& results, const ProgressFn& say) {
  std::set<fs::path> written;
  for (const json& p : results["pairs"])
    if (p.contains("images"))
      if (auto dir = recordedImagePath(out, p["images"].value("dir", json()))) written.insert(*dir);
  for (const json& scene : results["scenes"])
    if (scene.is_object())
      if (auto dir = recordedImagePath(out, scene.value("images", json()))) written.insert(*dir);
  std::set<fs::path> known = pruneRecordedImages(out, written, say);
  known.insert(written.begin(), written.end());
  const std::vector<fs::path> marked = unfinishedRunFolders(out);
  pruneUnrecordedImages(out, known, {marked.begin(), marked.end()}, say);
}

const std::string kIdenticalOutputs = "its output on this scene is bit-identical to ";
const std::string kSkippedPasses = "at this resolution its scaled footprint skipped ";

}  // namespace

void warnOfIdenticalSweepPoints(json& results, const ProgressFn& say) {
  const json labels = results.value("sweep", json::object()).value("labels", json::array());
  for (json& p : results["pairs"])  // a merge recomputes them over every shard's pairs
    if (p.contains("warnings"))
      for (size_t w = p["warnings"].size(); w-- > 0;)
        if (const std::string text = p["warnings"][w].get<std::string>();
            text.rfind(kIdenticalOutputs, 0) == 0 || text.rfind(kSkippedPasses, 0) == 0)
          p["warnings"].erase(w);
  // A grid over iterations where the scaled footprint skips some of them (steps that scale below
  // a pixel): a point named "iterations=5" ran fewer, and the table would compare what it names
  // with what it did not run. Said per point; the identical outputs below say the rest.
  const json grid = results.value("sweep", json::object()).value("grid", json::object());
  // Any other grid: every point ran the same shortened filter, so the comparison stands, but it
  // describes the filter as it runs at this resolution, not a 1080p frame's: said once for the
  // sweep (a researcher ablating sigmaL at 64x36 concluded on a 2-pass svgf unwarned).
  if (results.contains("sweep") && results["sweep"].is_object()) {
    results["sweep"].erase("footprintNote");
    int most = 0;
    for (const json& p : results["pairs"]) {
      if (p.value("status", "") != "ok" ||
          std::find(labels.begin(), labels.end(), p["label"]) == labels.end())
        continue;
      const json predicted =
          p.value("timing", json::object()).value("gpuPredicted", json::object());
      most = std::max(most, predicted.is_object() ? predicted.value("skippedHere", 0) : 0);
    }
    if (most > 0 && !grid.contains("iterations")) {
      const std::string denoiser = results["sweep"].value("denoiser", "");
      const std::string note =
          "at this resolution " + denoiser + "'s scaled footprint skipped up to " +
          std::to_string(most) +
          " pass(es) per frame (à-trous steps or mip levels below half a pixel, which a 1080p "
          "frame runs): every point ran that shortened filter, so the ablation describes " +
          denoiser +
          " as it runs here; for the filter a 1080p frame runs, sweep at a larger "
          "--resolution or with --param " +
          denoiser + ".footprint=native (docs/statistics.md)";
      results["sweep"]["footprintNote"] = note;
      if (say) say("  note: " + note);
    }
  }
  if (grid.is_object() && grid.contains("iterations"))
    for (json& p : results["pairs"]) {
      if (p.value("status", "") != "ok" ||
          std::find(labels.begin(), labels.end(), p["label"]) == labels.end())
        continue;
      const json predicted =
          p.value("timing", json::object()).value("gpuPredicted", json::object());
      const int skipped = predicted.is_object() ? predicted.value("skippedHere", 0) : 0;
      if (skipped <= 0) continue;
      const std::string warning =
          kSkippedPasses + std::to_string(skipped) +
          " à-trous pass(es) (over its signals) whose steps scale below a pixel, which a 1080p "
          "frame "
          "runs: its iterations value names more passes than ran here; for an ablation of "
          "iterations, run at a larger --resolution or with footprint=native (docs/statistics.md)";
      p["warnings"].push_back(warning);
      if (say)
        say("  warning: " + p["label"].get<std::string>() + " on " + p.value("scene", "") + ": " +
            warning);
    }
  std::map<std::pair<std::string, std::string>, std::vector<json*>> groups;  // (scene, checksum)
  for (json& p : results["pairs"])
    if (p.value("status", "") == "ok" && p.contains("outputChecksum") &&
        std::find(labels.begin(), labels.end(), p["label"]) != labels.end())
      groups[{p["scene"], p["outputChecksum"]}].push_back(&p);
  for (auto& [key, group] : groups) {
    if (group.size() < 2) continue;
    for (json* p : group) {
      std::string others;
      for (const json* q : group)
        if (q != p) others += (others.empty() ? "" : ", ") + (*q)["label"].get<std::string>();
      const std::string warning =
          kIdenticalOutputs + others +
          " (every frame): the parameters that differ between them changed nothing here";
      (*p)["warnings"].push_back(warning);
    }
    // Not said here: the run's printout names each scene's identical outputs after its table
    // (once per group; said here too, a large grid printed them twice, hundreds of lines).
  }
}

namespace {

std::string clock(double s) {
  char buf[32];
  int total = int(std::lround(std::max(0.0, s)));
  std::snprintf(buf, sizeof buf, "%d:%02d", total / 60, total % 60);
  return buf;
}

}  // namespace

void resolveAutoLowres(RunConfig& c) {
  if (!c.lowresAuto) return;
  bool reads = false;
  for (const DenoiserRequest& r : c.denoisers) {
    if (!capturedOutputName(r.name).empty()) continue;  // a stored output reads nothing
    const DenoiserInfo& info = DenoiserRegistry::instance().find(r.name);
    if (!info.origin.empty()) continue;  // external denoisers read no low-resolution buffer
    reads = reads || info.create(info.schema.resolve(r.params, r.name), SignalKind::Diffuse)->wantsLowres();
  }
  c.render.lowresFactor = reads ? kAutoLowresFactor : 0;
  c.lowresAuto = false;
}

json runMatrix(const RunConfig& cfg) {
  if (cfg.out.empty()) throw Error("run: --out is required");
  if (cfg.scenes.empty() && cfg.captures.empty()) throw Error("run: no scenes and no captures");
  if (cfg.seeds < 1 || cfg.seeds > 64) throw Error("run: --seeds " + std::to_string(cfg.seeds) + ": expected 1 to 64");
  const ExposureMode exposure = exposureModeFromName(cfg.exposure);
  std::vector<DenoiserRequest> denoisers;
  auto add = [&](DenoiserRequest r) {
    if (r.label.empty()) r.label = defaultLabel(r);
    for (auto& d : denoisers)
      if (d.label == r.label) return;
    // Each pair's images have a folder named after its label: two labels that differ only in
    // characters a file name cannot hold would share one (and delete each other's images).
    for (auto& d : denoisers)
      if (safeName(d.label) == safeName(r.label))
        throw Error("contenders '" + d.label + "' and '" + r.label +
                    "' would share the image folder '" + safeName(r.label) +
                    "'; labels must differ in letters, digits or ._=,-[]");
    if (capturedOutputName(r.name).empty()) DenoiserRegistry::instance().find(r.name);
    else if (cfg.captures.empty()) throw Error(r.name + ": file: contenders need a capture (--capture DIR)");
    denoisers.push_back(std::move(r));
  };
  if (cfg.baselines)
    for (const char* baseline : {"passthrough", "temporal"}) {
      auto params = cfg.baselineParams.find(baseline);
      add({baseline, params == cfg.baselineParams.end() ? std::map<std::string, std::string>{} : params->second, ""});
    }
  for (const DenoiserRequest& r : cfg.denoisers) add(r);
  // Validate every parameter set before any work: a typo must fail in a second, not after an hour.
  for (const DenoiserRequest& r : denoisers)
    if (capturedOutputName(r.name).empty()) {
      const DenoiserInfo& info = DenoiserRegistry::instance().find(r.name);
      const ParamSet params = info.schema.resolve(r.params, r.name);
      // A denoiser that cannot run without the low-resolution buffer, in a run rendering none,
      // would fail each pair after the rendering.
      if (!cfg.lowresAuto && cfg.render.lowresFactor == 0 && info.origin.empty() &&
          info.create(params, SignalKind::Diffuse)->needsLowres())
        throw Error(lowresNeeded(r.label));
    } else if (!r.params.empty()) {
      throw Error(r.name + ": a stored output has no parameters to set");
    }

  // What runs: the scenes (rendered or taken from the cache), then the captures.
  struct Source {
    std::string name, purpose;
    const Scene* scene = nullptr;
    fs::path capture;
    int width = 0, height = 0, frames = 0;  // as the run sees it (a shard's plan records them)
  };
  std::vector<Source> sources;
  for (const Scene& scene : cfg.scenes)
    sources.push_back({scene.name,
                       scene.purpose,
                       &scene,
                       {},
                       cfg.render.resolvedWidth(scene),
                       cfg.render.resolvedHeight(scene),
                       cfg.render.resolvedFrames(scene)});
  for (const fs::path& capture : cfg.captures) {
    const CaptureDescription d = readCaptureDescription(capture);
    for (const Source& other : sources)
      if (other.name == d.info.scene)
        throw Error("capture " + capture.string() + ": its name '" + d.info.scene + "' is also the name of " +
                    (other.scene ? "a scene" : "capture " + other.capture.string()) + " in this run");
    sources.push_back({d.info.scene, d.info.purpose, nullptr, capture, d.info.width, d.info.height,
                       d.info.frames});
  }
  const bool keepAll = cfg.keepFrames == "all" || (cfg.keepFrames == "auto" && sources.size() == 1 &&
                                                   denoisers.size() == (cfg.baselines ? 3u : 1u) && !cfg.denoisers.empty());
  // A run written into the cache mixes its results with sequences (and a later cache clean-up
  // with the run), as does a cache inside the run: the two stay apart. So do a run and a capture
  // it reads (a run into its capture's folder wrote its results and images among the capture's
  // files, which its validation then warned of; a bad-input trial).
  for (const fs::path& capture : cfg.captures) {
    if (liesIn(resolvedPath(cfg.out), resolvedPath(capture)))
      throw Error("--out " + cfg.out.string() + " lies in the capture " + capture.string() +
                  " the run reads; expected a directory outside it");
    // The run replaces what its images/ holds: a capture there had its stored outputs
    // overwritten, then removed (a re-trial).
    if (liesIn(resolvedPath(capture), resolvedPath(cfg.out) / "images"))
      throw Error("the capture " + capture.string() + " lies in " + cfg.out.string() +
                  "/images, which the run replaces; keep captures outside a run's images");
  }
  if (std::error_code ec; fs::exists(cfg.out / "capture.json", ec))
    throw Error("--out " + cfg.out.string() +
                " is a capture (capture.json): a run there would write among its files; expected "
                "a directory of its own");
  if (!cfg.scenes.empty()) {
    if (cfg.cache.empty())
      throw Error("--cache: an empty directory name; expected the sequence cache, e.g. cache");
    const fs::path out = resolvedPath(cfg.out), cache = resolvedPath(cfg.cache);
    if (liesIn(out, cache))
      throw Error("--out " + cfg.out.string() + " lies in the sequence cache " +
                  cfg.cache.string() + "; expected a directory outside it");
    if (liesIn(cache, out))
      throw Error("--cache " + cfg.cache.string() + " lies in the run directory " +
                  cfg.out.string() + "; expected the sequence cache outside it");
  }
  const RunDirectoryLock outLock = checkRunOutputs(cfg.out);
  // The cache, like --out, before any work: a file there would fail every pair one by one.
  if (std::error_code ec;
      !cfg.scenes.empty() && fs::exists(cfg.cache, ec) && !fs::is_directory(cfg.cache, ec))
    throw Error(cfg.cache.string() +
                ": exists and is not a directory; the sequence cache (--cache) needs one");
  // Held while the run reads the cache: a refinement (which rewrites references) waits for it.
  std::optional<DirectoryLock> cacheLock;
  if (!cfg.scenes.empty())
    cacheLock.emplace(cfg.cache, DirectoryLock::Mode::Shared, DirectoryLock::IfHeld::Wait,
                      "a run reading sequences");
  const EvaluationOptions evaluation{cfg.warmup, {cfg.flip}, exposure};
  json settings = {{"render", cfg.scenes.empty() ? json::object() : cfg.render.pixelSettings(cfg.scenes.front())},
                   {"preset", cfg.render.preset},
                   {"seeds", cfg.seeds},
                   {"shard", std::to_string(cfg.shardIndex) + "/" + std::to_string(cfg.shardCount)}};
  settings.update(evaluationSettings(evaluation));
  json results = {{"schema", kResultsSchemaVersion}, {"kind", "arena-run"}, {"name", cfg.name}, {"created", utcTimestamp()},
                  {"environment", environmentInfo()}, {"settings", settings},
                  {"metrics", metricCatalogJson()}, {"scenes", json::object()}, {"pairs", json::array()}};
  results.update(cfg.annotations);
  if (!cfg.revision.empty()) results["environment"]["revision"] = cfg.revision;
  results["settings"]["render"].erase("width");
  results["settings"]["render"].erase("height");
  results["settings"]["render"].erase("frames");

  if (!cfg.captures.empty()) {
    json captures = json::array();
    for (const fs::path& c : cfg.captures) captures.push_back(c.string());
    results["settings"]["captures"] = captures;
  }
  // A shard records the whole run it is a slice of: every sequence with its size and every
  // contender. Shards of runs with other scenes, sizes or denoisers then differ in their settings,
  // and merge refuses them (their slices would not add up to one run).
  if (cfg.shardCount > 1) {
    json plan = {{"sequences", json::array()}, {"labels", json::array()}};
    for (const Source& source : sources)
      plan["sequences"].push_back({{"name", source.name},
                                   {"width", source.width},
                                   {"height", source.height},
                                   {"frames", source.frames}});
    for (const DenoiserRequest& d : denoisers) plan["labels"].push_back(d.label);
    results["settings"]["plan"] = plan;
  }
  // Each source's pairs in this shard's slice (pair k of the scene-major order is shard k % n's).
  std::vector<std::vector<const DenoiserRequest*>> minePerSource(sources.size());
  size_t pairsDone = 0, pairsMine = 0, scenesMine = 0, scenesDone = 0;
  for (size_t k = 0, index = 0; k < sources.size(); ++k) {
    for (const DenoiserRequest& r : denoisers)
      if (int(index++ % size_t(cfg.shardCount)) == cfg.shardIndex) minePerSource[k].push_back(&r);
    pairsMine += minePerSource[k].size();
    scenesMine += !minePerSource[k].empty();
  }
  const auto start = std::chrono::steady_clock::now();
  auto say = [&](const std::string& s) {
    if (cfg.progress) cfg.progress(s);
  };
  // From here an earlier run's images in --out are replaced pair by pair (unfinishedRunNote). The
  // mark names the folders this run may write: a later run removes them if this one stops.
  std::vector<fs::path> plannedFolders;
  for (size_t k = 0; k < sources.size(); ++k) {
    for (const DenoiserRequest* r : minePerSource[k])
      plannedFolders.push_back(fs::path("images") / sources[k].name / safeName(r->label));
    if (!minePerSource[k].empty()) plannedFolders.push_back(fs::path("images") / sources[k].name);
  }
  // Set once the first scene is ready, before its images replace anything: a run stopped while
  // it renders (a long reference, a Ctrl-C) leaves the directory as it was.
  bool marked = false;
  for (size_t sourceIndex = 0; sourceIndex < sources.size(); ++sourceIndex) {
    const Source& source = sources[sourceIndex];
    const std::vector<const DenoiserRequest*>& mine = minePerSource[sourceIndex];
    if (mine.empty()) continue;
    fs::path dir;
    std::unique_ptr<SceneData> sd;
    std::vector<SeedSequence> seedSequences;
    std::string sceneError;
    json validation;
    try {
      dir = source.scene ? renderSequence(*source.scene, cfg.render, cfg.cache, cfg.progress) : source.capture;
      sd = prepareScene(dir, evaluation, source.scene ? nullptr : &validation);
      if (source.scene) seedSequences = renderSeedSequences(*source.scene, cfg);
    } catch (const std::exception& e) {
      sceneError = e.what();
    }
    if (!marked) markRunUnfinished(cfg.out, plannedFolders), marked = true;
    removeSceneImages(cfg.out / "images" / source.name, cfg.progress);
    // A capture's checks are printed and kept, also when they refused it.
    for (const std::string& line : validationLines(validation)) say("  " + source.name + ": " + line);
    if (sd)
      results["scenes"][source.name] = sceneRecord(cfg, *sd, source.purpose, source.scene, dir, validation);
    else if (!validation.is_null())
      results["scenes"][source.name] = {{"purpose", source.purpose}, {"source", "capture"},
                                        {"capture", source.capture.string()}, {"validation", validation}};
    const auto sceneStart = std::chrono::steady_clock::now();
    size_t sceneFailures = 0;
    // With a refinement after the scene, its pairs are first screened (their relMSE, all the
    // decision reads) and their output frames kept, to be measured in full once the references are
    // final: a refined scene is not measured in full twice.
    const bool mayRefine = cfg.refineScene && source.scene;
    std::vector<std::vector<KeptFrame>> kept(mayRefine ? mine.size() : 0);
    const size_t firstPair = results["pairs"].size();  // the scene's pairs follow in the order of `mine`
    for (size_t k = 0; k < mine.size(); ++k) {
      const DenoiserRequest* r = mine[k];
      auto t0 = std::chrono::steady_clock::now();
      json pair;
      const fs::path images = cfg.out / "images" / source.name / safeName(r->label);
      // Under --denoisers all, a built-in (a plugin or process the user named fails instead) that
      // the capture lacks the inputs for is not run there, nor a stored output (file:NAME, which
      // 'all' takes from the captures) on a sequence that does not store it: a scene rendered here
      // or another capture (a run of scenes beside a capture with outputs failed a pair per scene,
      // exit 1). A denoiser that cannot even be created here fails its pair below, with its own
      // error; a file:NAME the user named fails where it is not stored.
      std::string lacking;
      const std::string storedOutput = capturedOutputName(r->name);
      if (cfg.everyDenoiser && sd && !storedOutput.empty()) {
        if (source.scene)
          lacking = "a scene rendered here stores no denoiser outputs (" + r->name +
                    " is an output stored in a capture's outputs/ folder)";
        else if (!sd->sequence.capture().outputs.count(storedOutput))
          lacking = "the capture stores no output '" + storedOutput + "' (another capture does)";
      } else if (cfg.everyDenoiser && sd && !source.scene &&
                 DenoiserRegistry::instance().find(r->name).origin.empty()) {
        try {
          lacking = lackingInputs(*r, sd->sequence);
        } catch (const std::exception&) {
        }
      }
      if (!lacking.empty()) {
        results["scenes"][source.name]["notRun"].push_back(
            {{"label", r->label}, {"reason", lacking}});
        say("  " + r->label + " not run on " + source.name + ": " + lacking);
        --pairsMine;
        continue;
      }
      try {
        removePairImages(images);
        if (!sd) throw Error("scene " + source.name + " could not be prepared: " + sceneError);
        // A fatal signal while the pair runs names it (a plugin's names its call too).
        const CrashNote note("while " + r->label + " ran on " + source.name);
        pair = runPair(cfg, *sd, *r, images, keepAll, mayRefine ? &kept[k] : nullptr,
                       mayRefine ? EvaluationScope::Screening : EvaluationScope::Full);
        if (!seedSequences.empty()) pair["biasVariance"] = biasVarianceOf(cfg, *sd, seedSequences, *r);
      } catch (const std::exception& e) {
        pair = failedPair(source.name, *r, e.what());
        discardPairImages(images, pair);
      }
      results["pairs"].push_back(pair);
      ++pairsDone;
      double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      char buf[512];
      std::snprintf(buf, sizeof buf, "[%zu/%zu] %s on %s: %s in %.1f s (ETA %s)", pairsDone, pairsMine, r->label.c_str(),
                    source.name.c_str(), pair["status"] == "ok" ? "done" : "FAILED", took,
                    clock(elapsed / double(pairsDone) * double(pairsMine - pairsDone)).c_str());
      say(buf);
      if (pair["status"] != "ok") {
        // A scene that could not be prepared fails each of its pairs with one error: said once.
        if (sd || k == 0)
          say("  error: " + pair["error"].get<std::string>());
        else
          say("  error: as above (the scene could not be prepared)");
      } else {
        for (const std::string& warning : runWarnings(pair, sd->sequence.info().frames))
          say("  warning: " + warning);
        // A perfect score from no computation is said where the ranking is read, not only kept.
        for (const json& w : pair.value("warnings", json::array()))
          if (w.is_string() && w.get<std::string>().rfind(kEqualsReferenceWarning, 0) == 0)
            say("  warning: " + w.get<std::string>());
      }
      sceneFailures += pair["status"] != "ok";
    }
    // The scene's pairs measured again from their kept outputs, against the references as they now
    // are; a pair that cannot be is recorded failed with its error.
    bool refined = false;
    auto measureAgain = [&](EvaluationScope scope) {
      for (size_t k = 0; k < mine.size(); ++k) {
        json& pair = results["pairs"][firstPair + k];
        if (pair["status"] != "ok") continue;
        try {
          if (!sd) throw Error("scene " + source.name + ": " + sceneError);
          pair = evaluatePairAgain(cfg, *sd, pair, kept[k], cfg.out / "images" / source.name / safeName(mine[k]->label),
                                   keepAll, scope);
          if (scope == EvaluationScope::Full && refined && !seedSequences.empty())
            pair["biasVariance"] = biasVarianceOf(cfg, *sd, seedSequences, *mine[k]);
        } catch (const std::exception& e) {
          pair = failedPair(source.name, *mine[k], e.what());
          discardPairImages(cfg.out / "images" / source.name / safeName(mine[k]->label), pair);
          say("  error: " + std::string(e.what()));
          ++sceneFailures;
        }
      }
    };
    // The refinement may take rounds: each round's target rests on the best corrected relMSE
    // measured against the references before it, which moves as they get cleaner, so after each
    // the pairs are screened again and the hook decides again (at most kMaxRefineRounds).
    for (int round = 0; mayRefine && sd && round < kMaxRefineRounds && cfg.refineScene(*source.scene, results);
         ++round) {
      refined = true;
      // The references changed: the scene's floors, and every measurement against them.
      try {
        sd = prepareScene(dir, evaluation, nullptr);
        results["scenes"][source.name] = sceneRecord(cfg, *sd, source.purpose, source.scene, dir, validation);
      } catch (const std::exception& e) {
        sd.reset();
        sceneError = std::string("reading it again after refining its references: ") + e.what();
      }
      measureAgain(EvaluationScope::Screening);
    }
    if (mayRefine) {  // the screened pairs measured in full, against the references as they now are
      measureAgain(EvaluationScope::Full);
      if (refined)
        cfg.announce("[refine] " + source.name + ": its " + std::to_string(mine.size()) +
                     " pair(s) measured again against the refined references (their outputs were kept)");
    }
    if (cfg.milestone) {
      ++scenesDone;
      const auto now = std::chrono::steady_clock::now();
      char buf[512];
      std::snprintf(buf, sizeof buf, "[scene %zu/%zu] %s: %zu pair(s) in %.1f s%s (ETA %s)",
                    scenesDone, scenesMine, source.name.c_str(),
                    results["pairs"].size() - firstPair,  // run: not those notRun
                    std::chrono::duration<double>(now - sceneStart).count(),
                    sceneFailures ? (", " + std::to_string(sceneFailures) + " FAILED").c_str() : "",
                    clock(pairsDone == 0 ? 0.0
                                         : std::chrono::duration<double>(now - start).count() /
                                               double(pairsDone) * double(pairsMine - pairsDone))
                        .c_str());
      cfg.milestone(buf);
    }
  }
  if (cfg.finish) finishRun(results, cfg);
  return results;
}

void finishRun(json& results, const RunConfig& cfg) {
  {
    // Every pair of contenders on a scene is compared (paired intervals): with many contenders,
    // after the pairs' ETA has run out, this is where a large sweep's time goes; said.
    std::map<std::string, size_t> perScene;
    for (const json& p : results["pairs"])
      if (p.value("status", "") == "ok") ++perScene[p.value("scene", "")];
    size_t most = 0, comparisons = 0;
    for (const auto& [scene, n] : perScene) {
      most = std::max(most, n);
      comparisons += n * (n - 1) / 2;
    }
    if (most > kManyContenders && cfg.progress)
      cfg.progress("statistics: " + std::to_string(comparisons) + " paired comparisons of up to " +
                   std::to_string(most) + " contenders on " + std::to_string(perScene.size()) +
                   " scene(s), each metric (this can take a while)");
    StageTimer timer(Stage::Statistics);
    results["statistics"] = analyseRun(results).toJson();
    addReferenceQuality(results, cfg.warmup, cfg.referenceNotes, cfg.cache.string());
  }
  warnOfIdenticalSweepPoints(results, cfg.progress);
  pruneEarlierImages(cfg.out, results, cfg.progress);
  commitResults(cfg.out, results);
}

}  // namespace arena
