#include "harness/study.hpp"

#include <algorithm>
#include <filesystem>
#include <map>

#include "core/error.hpp"
#include "harness/reference_quality.hpp"
#include "metrics/results.hpp"

namespace arena {

using nlohmann::json;

namespace {

// What the study's refinement did to a scene, round by round (run_matrix.hpp calls it again while it
// refines): the verdict's note, the budget its rounds' predictions used (the budget is the scene's,
// whatever the rounds), and whether it stopped (a round failed or could add nothing: no more rounds).
struct SceneRefinement {
  std::string note;
  double budgetUsed = 0;
  bool stopped = false;
  bool stoppedShort = false;  // a round stopped short of the target (kRefineStageRatio): once
  void add(const std::string& sentence) { note = note.empty() ? sentence : note + "; then " + sentence; }
};

// The study's refinement (issue 13), after each rendered scene's pairs: when the scene misses the
// reference-quality goal and the paths predicted to meet it, with those its earlier rounds were
// predicted, are within its budget (planReferenceRefinement), its references are refined; each
// decision is said and noted on the scene's verdict. Returns whether the references changed.
bool refineAfterScene(const RunConfig& c, const Scene& scene, const json& results, double budget,
                      int budgetSpp, int maxSpp, std::map<std::string, SceneRefinement>& done) {
  SceneRefinement& state = done[scene.name];
  if (state.stopped) return false;
  json one = {{"scenes", {{scene.name, results["scenes"][scene.name]}}}, {"pairs", json::array()}};
  for (const json& p : results["pairs"])
    if (p.value("scene", "") == scene.name) one["pairs"].push_back(p);
  addReferenceQuality(one, c.warmup);
  const std::filesystem::path dir = sequenceDir(scene, c.render, c.cache);
  if (!std::filesystem::exists(dir / "sequence.json")) return false;
  const std::map<std::string, SequenceInfo> sequences = {{scene.name, Sequence::open(dir).info()}};
  // The references every summary reads: the summarised frames' and the few before them that their
  // temporal metrics compare with.
  const int firstFrame = firstFrameSummariesRead(c.warmup);
  const std::vector<ReferenceRefinement> plans = planReferenceRefinement(
      one, sequences, firstFrame, maxSpp, budget, budgetSpp, !state.stoppedShort);
  if (plans.empty()) return false;  // the goal is met (or unknown)
  ReferenceRefinement plan = plans.front();
  plan.budgetNeeded += state.budgetUsed;
  plan.withinBudget = plan.withinBudget && plan.budgetNeeded <= budget;
  const std::string note = refinementNote(plan, budget);
  c.announce("[refine] " + scene.name + ": " + note);
  if (!plan.withinBudget) {
    state.add(note);
    return false;
  }
  // The budget counts what the round is predicted to add (a stop short of the target adds less).
  state.budgetUsed += plan.roundBudgetNeeded;
  state.stoppedShort = state.stoppedShort || plan.stopsShort();
  // Whether the references on disk differ from those the decision read (a reference's mean spp is
  // rounded; its estimated relMSE moves with any sample added).
  auto changed = [&] {
    const SequenceInfo now = Sequence::open(dir).info(), &then = sequences.at(scene.name);
    return now.referenceSpp != then.referenceSpp || now.referenceEstimatedRelMse != then.referenceEstimatedRelMse;
  };
  try {
    refineSequence(scene, c.render, c.cache, plan.roundTargetRelMse, maxSpp, c.progress,
                   firstFrame);
    if (changed()) {
      state.add(note);
      return true;
    }
    const std::string none = "its references could take no more samples (their tiles are at the cap)";
    state.add(none);
    state.stopped = true;
    c.announce("[refine] " + scene.name + ": " + none);
    return false;
  } catch (const std::exception& e) {  // e.g. a reference without its sums
    const std::string failed = std::string("the study could not refine it: ") + e.what();
    state.add(failed);
    state.stopped = true;
    c.announce("[refine] " + scene.name + ": " + failed);
    // References refined before the failure are on disk (and in sequence.json): the pairs are
    // measured again against them; if none was, the first verdict stands.
    try {
      return changed();
    } catch (const std::exception&) {
      return true;  // reading the scene again says what is wrong with it
    }
  }
}

}  // namespace

RunConfig studyRun(std::vector<Scene> scenes, const RenderSettings& render) {
  RunConfig c;
  c.name = "study";
  c.render = render;
  c.scenes = std::move(scenes);
  for (const std::string& n : DenoiserRegistry::instance().names()) c.denoisers.push_back({n, {}, ""});
  // Control rows (issue 34, section 2): each method that reads paths beyond the frame's own, run
  // without them. reengine without its disocclusion rays; asvgf's gradient samples cannot come
  // from the frame's own paths here (the 1-spp input is every method's), and asvgf without them
  // is svgf exactly (lambda = 0 everywhere), which the study already runs.
  c.denoisers.push_back({"reengine", {{"disocclusionRays", "off"}}, ""});
  c.everyDenoiser = true;  // a capture the study scores is not failed for what it lacks
  c.keepFrames = "chosen";
  return c;
}

json runStudy(StudyConfig config) {
  RunConfig& c = config.run;
  if (!(config.refineBudget > 0)) return runMatrix(c);
  // The study holds its run directory from the first pass to the commit after the refinement,
  // and the cache alone: its refinement rewrites references that another run or study would
  // otherwise read half old, half new (a second study waits, then finds them refined).
  const RunDirectoryLock outLock = checkRunOutputs(c.out);
  const DirectoryLock cacheLock(c.cache, DirectoryLock::Mode::Exclusive,
                                DirectoryLock::IfHeld::Wait, "a study refining references");
  // The budget is counted at the preset's (or the given) sample cap, whatever cap the first
  // references are rendered under.
  const int budgetSpp = c.render.referenceSpp;
  if (!config.referenceRelErrorGiven && c.render.referenceRelError > 0) {
    c.render.referenceRelError = std::max(c.render.referenceRelError, kStudyFirstReferenceRelError);
    if (!config.referenceSppGiven) {
      c.render.referenceSpp = std::min(c.render.referenceSpp, kStudyFirstReferenceSpp);
      c.render.referenceMinSpp = std::min(c.render.referenceMinSpp, c.render.referenceSpp);
    }
  }
  // Each scene is refined right after its pairs, whose outputs are then measured again; the run is
  // analysed and committed once, with the refinement's notes on the verdicts.
  std::map<std::string, SceneRefinement> refinements;
  c.finish = false;
  c.refineScene = [&](const Scene& scene, const json& results) {
    return refineAfterScene(c, scene, results, config.refineBudget, budgetSpp, config.refineMaxSpp,
                            refinements);
  };
  json results = runMatrix(c);
  for (const auto& [scene, refinement] : refinements)
    if (!refinement.note.empty()) c.referenceNotes[scene] = refinement.note;
  finishRun(results, c);
  return results;
}

}  // namespace arena
