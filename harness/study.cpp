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
bool refineAfterScene(const RunConfig& c, const Scene& scene, const json& results, double budget, int maxSpp,
                      std::map<std::string, std::string>& notes) {
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
  notes[scene.name] = refinementNote(plan, budget);
  c.announce("[refine] " + scene.name + ": " + notes[scene.name]);
  if (!plan.withinBudget) return false;
  try {
    refineSequence(scene, c.render, c.cache, plan.targetRelMse, maxSpp, c.progress, firstFrame);
    return true;
  } catch (const std::exception& e) {  // e.g. a reference without its sums
    notes[scene.name] = std::string("the study could not refine it: ") + e.what();
    c.announce("[refine] " + scene.name + ": " + notes[scene.name]);
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
  std::map<std::string, std::string> notes;
  c.finish = false;
  c.refineScene = [&](const Scene& scene, const json& results) {
    return refineAfterScene(c, scene, results, config.refineBudget, config.refineMaxSpp, notes);
  };
  json results = runMatrix(c);
  for (const auto& [scene, note] : notes) c.referenceNotes[scene] = note;
  finishRun(results, c);
  return results;
}

}  // namespace arena
