#pragma once
// Reference quality (docs/metrics.md, "Reference quality"; issue 13's goal): per scene,
// the reference's own noise floor (its estimated relMSE, mean over the summarised frames) over the
// best real denoiser's reference-corrected relMSE. A ratio above kReferenceQualityGoal means the
// reference's noise is not far enough below the errors it ranks; the verdict says why (capped
// references, or a target that was met but is too loose for this scene) and what would fix it.
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/sequence.hpp"

namespace arena {

inline constexpr double kReferenceQualityGoal = 0.1;

// results.scenes.<scene>.referenceQuality = {floor, bestCorrectedRelMse, bestLabel, ratio, goal,
// meets, cappedReferences, references, verdict}; scenes without a floor or a real denoiser's
// corrected relMSE get {verdict} only. Baselines (passthrough, temporal) are not "real" denoisers.
// notes: per scene, a sentence appended to its verdict (the study's refinement, below). The
// suggested `arena refine` command carries the scene's resolution and frame count as run, and
// `cache` when it is not the default "cache" (the sequence cache the run read).
void addReferenceQuality(nlohmann::json& results, int warmup,
                         const std::map<std::string, std::string>& notes = {},
                         const std::string& cache = "cache");
// The options that make `arena render`/`refine` find a run's sequences (the same settings hash),
// from its results.settings.render: each setting that differs from its preset's default, e.g.
// " --lowres-factor 8" for the study; "" when nothing differs.
std::string renderOptionsOf(const nlohmann::json& render);
// The first frame whose reference a summary reads: the summaries cover frames t >= warmup, and a
// temporal metric at frame t also reads the references of up to kMaxMetricHistory frames before it
// (tRmae the frame difference r_t - r_{t-1}, the stability metrics up to three frames back).
int firstFrameSummariesRead(int warmup);
// The paths that refining the references the summaries read (frames t >= firstFrame) to a target
// relMSE would add: a reference of P pixels, mean s spp and estimated relMSE e > target needs
// s e / target spp (relMSE ~ 1/spp), i.e. P (min(s e / target, maxSpp) - s).
double refinementPaths(const SequenceInfo& info, int firstFrame, double targetRelMse, int maxSpp);

// The study's refinement of references to the goal (issue 13). A scene that misses it gets the
// target kRefineMargin x goal x its best corrected relMSE (the margin absorbs the noise of that
// estimate), and a prediction of the paths that refining the references the summaries read (frames
// t >= firstFrame, firstFrameSummariesRead) would add (refinementPaths; relMSE ~ 1/spp is the
// independent sampler's rate, conservative for Sobol, and the schedule stops at the tile that meets
// the target). A scene is refined when its prediction is at most `budget`
// x the paths of its frames at the references' sample cap (W x H x frames x --ref-spp, 512 per
// pixel for the quick preset; unitSpp, when > 0, is that cap, else the one the sequence was
// rendered under: the study renders its first references under a lower cap,
// kStudyFirstReferenceSpp, and counts its budget in the preset's): a budget per scene, in work, not
// seconds, and a function of the settings, so which scenes are refined depends neither on the
// machine nor on the cache's history.
inline constexpr double kRefineMargin = 0.9;
// A round's stop short of that target. The best corrected relMSE is the measured one less the
// floor, a difference of noisy numbers; where the floor is more than kRefineStageTrigger x the
// best, the floor's own error can move it far (hard_light's first best, its floor 3.3x it, came
// out 1.6x low against fireflies, and its references were aimed 1.6x too far). Such a scene's
// round stops where its floor is kRefineStageRatio x the best it measured (when that is above the
// target); the pairs are screened again against the cleaner references and the next round plans
// the target from their best (a scene stops short once: mayStopShort false after).
// camera_pan_occluder, floor 1.55x its first best (which was right within 3%), gained nothing from
// a stop: docs/performance.md, 2026-11-27, tenth entry.
inline constexpr double kRefineStageTrigger = 2.0;
inline constexpr double kRefineStageRatio = 1.0;
struct ReferenceRefinement {
  std::string scene;
  double targetRelMse = 0;
  double predictedPaths = 0;  // the paths refining to the target would add
  double budgetNeeded = 0;    // the smallest budget that covers it
  bool withinBudget = false;
  // This round's target: targetRelMse, or the stop short of it (kRefineStageRatio), the paths
  // predicted to reach it, and the part of the budget they take.
  double roundTargetRelMse = 0;
  double roundPaths = 0;
  double roundBudgetNeeded = 0;
  bool stopsShort() const { return roundTargetRelMse > targetRelMse; }
};
std::vector<ReferenceRefinement> planReferenceRefinement(
    const nlohmann::json& results, const std::map<std::string, SequenceInfo>& sequences,
    int firstFrame, int maxSpp, double budget, int unitSpp = 0, bool mayStopShort = true);
// The sentence the verdict carries for a planned scene.
std::string refinementNote(const ReferenceRefinement& plan, double budget);
// One line per scene for a printed summary (the verdicts above, aligned), from results.scenes.
std::vector<std::string> referenceQualityLines(const nlohmann::json& scenes);
// The verdicts of the scenes that meet the goal as a whole but not between their events
// (referenceQuality.segmentsMeet false): the lag and ghosting figures measured there carry more of
// the reference's noise than the scene's verdict says.
std::vector<std::string> segmentQualityLines(const nlohmann::json& scenes);

}  // namespace arena
