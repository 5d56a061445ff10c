#include "harness/study.hpp"

#include <algorithm>
#include <filesystem>
#include <map>

#include "core/error.hpp"
#include "harness/reference_quality.hpp"

namespace arena {

using nlohmann::json;

namespace {

// The study's refinement (issue 13), after each rendered scene's pairs: when the scene misses the
// reference-quality goal and the paths predicted to meet it are within its budget
// (planReferenceRefinement), its references are refined; each decision is said and noted on the
// scene's verdict. Returns whether the references changed.
// What the study's refinement did to a scene, round by round (run_matrix.hpp calls it again while it
// refines): the verdict's note, and whether a round failed (then it does not try again).
struct SceneRefinement {
  std::string note;
  bool failed = false;
  void add(const std::string& sentence) { note = note.empty() ? sentence : note + "; then " + sentence; }
};

bool refineAfterScene(const RunConfig& c, const Scene& scene, const json& results, double budget, int maxSpp,
                      std::map<std::string, SceneRefinement>& done) {
  SceneRefinement& state = done[scene.name];
  if (state.failed) return false;
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
  const std::vector<ReferenceRefinement> plans = planReferenceRefinement(one, sequences, firstFrame, maxSpp, budget);
  if (plans.empty()) return false;  // the goal is met (or unknown)
  const ReferenceRefinement& plan = plans.front();
  const std::string note = refinementNote(plan, budget);
  c.announce("[refine] " + scene.name + ": " + note);
  if (!plan.withinBudget) {
    state.add(note);
    return false;
  }
  try {
    refineSequence(scene, c.render, c.cache, plan.targetRelMse, maxSpp, c.progress, firstFrame);
    state.add(note);
    return true;
  } catch (const std::exception& e) {  // e.g. a reference without its sums
    const std::string failed = std::string("the study could not refine it: ") + e.what();
    state.add(failed);
    state.failed = true;
    c.announce("[refine] " + scene.name + ": " + failed);
    // References refined before the failure are on disk (and in sequence.json): the pairs are
    // measured again against them; if none was, the first verdict stands.
    try {
      return Sequence::open(dir).info().referenceSpp != sequences.at(scene.name).referenceSpp;
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
  c.keepFrames = "chosen";
  return c;
}

json runStudy(StudyConfig config) {
  RunConfig& c = config.run;
  if (!(config.refineBudget > 0)) return runMatrix(c);
  if (!config.referenceRelErrorGiven && c.render.referenceRelError > 0)
    c.render.referenceRelError = std::max(c.render.referenceRelError, kStudyFirstReferenceRelError);
  // Each scene is refined right after its pairs, whose outputs are then measured again; the run is
  // analysed and committed once, with the refinement's notes on the verdicts.
  std::map<std::string, SceneRefinement> refinements;
  c.finish = false;
  c.refineScene = [&](const Scene& scene, const json& results) {
    return refineAfterScene(c, scene, results, config.refineBudget, config.refineMaxSpp, refinements);
  };
  json results = runMatrix(c);
  for (const auto& [scene, refinement] : refinements)
    if (!refinement.note.empty()) c.referenceNotes[scene] = refinement.note;
  finishRun(results, c);
  return results;
}

}  // namespace arena
