#include "harness/study.hpp"

#include <algorithm>
#include <filesystem>
#include <map>

#include "core/error.hpp"
#include "harness/reference_quality.hpp"

namespace arena {

using nlohmann::json;

namespace {

// The study's second pass (issue 13): refines the references of the scenes that missed the
// reference-quality goal, each within its budget (planReferenceRefinement), and notes on
// each verdict what was done or what it would take. Returns the scenes whose references it refined.
std::vector<Scene> refineReferences(RunConfig& c, const json& results, double budget, int maxSpp) {
  std::map<std::string, SequenceInfo> sequences;
  for (const Scene& s : c.scenes) {
    const std::filesystem::path dir = sequenceDir(s, c.render, c.cache);
    if (std::filesystem::exists(dir / "sequence.json")) sequences.emplace(s.name, Sequence::open(dir).info());
  }
  auto say = [&](const std::string& line) {  // the study's decisions: milestones where they are kept apart
    if (c.milestone) c.milestone(line);
    else if (c.progress) c.progress(line);
  };
  std::vector<Scene> refined;
  for (const ReferenceRefinement& plan : planReferenceRefinement(results, sequences, c.warmup, maxSpp, budget)) {
    c.referenceNotes[plan.scene] = refinementNote(plan, budget);
    say("[refine] " + plan.scene + ": " + c.referenceNotes[plan.scene]);
    const auto found = std::find_if(c.scenes.begin(), c.scenes.end(), [&](const Scene& s) { return s.name == plan.scene; });
    if (found == c.scenes.end()) {  // a capture: its references are what it brought
      c.referenceNotes[plan.scene] = "a capture's references cannot be refined by the study";
      continue;
    }
    if (!plan.withinBudget) continue;
    const Scene& scene = *found;
    try {
      refineSequence(scene, c.render, c.cache, plan.targetRelMse, maxSpp, c.progress, c.warmup);
      refined.push_back(scene);
    } catch (const Error& e) {  // e.g. a reference without its sums: the first pass's verdict stands
      c.referenceNotes[plan.scene] = std::string("the study could not refine it: ") + e.what();
      say("[refine] " + plan.scene + ": " + c.referenceNotes[plan.scene]);
    }
  }
  return refined;
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
  // With a refinement budget the first pass is finished (analysed and committed) only after the
  // refinement, once, so the run directory and results.db hold one run: the final one.
  c.finish = !(config.refineBudget > 0);
  json results = runMatrix(c);
  if (c.finish) return results;
  addReferenceQuality(results, c.warmup);  // the plan reads the first pass's verdicts
  RunConfig again = c;
  again.captures.clear();  // only rendered scenes are refined and run again
  again.scenes = refineReferences(c, results, config.refineBudget, config.refineMaxSpp);
  if (!again.scenes.empty()) {
    const std::string line =
        "[refine] running the refined scenes again (" + std::to_string(again.scenes.size()) + " of " +
        std::to_string(c.scenes.size()) + ")";
    if (c.milestone)
      c.milestone(line);
    else if (c.progress)
      c.progress(line);
    results = replaceScenes(std::move(results), runMatrix(again));
  }
  finishRun(results, c);
  return results;
}

}  // namespace arena
