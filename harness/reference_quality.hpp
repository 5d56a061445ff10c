#pragma once
// Reference quality (../shared/docs/metrics.md, "Reference quality"; issue 13's goal): per scene,
// the reference's own noise floor (its estimated relMSE, mean over the summarised frames) over the
// best real denoiser's reference-corrected relMSE. A ratio above kReferenceQualityGoal means the
// reference's noise is not far enough below the errors it ranks; the verdict says why (capped
// references, or a target that was met but is too loose for this scene) and what would fix it.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace arena {

inline constexpr double kReferenceQualityGoal = 0.1;

// results.scenes.<scene>.referenceQuality = {floor, bestCorrectedRelMse, bestLabel, ratio, goal,
// meets, cappedReferences, references, verdict}; scenes without a floor or a real denoiser's
// corrected relMSE get {verdict} only. Baselines (passthrough, temporal) are not "real" denoisers.
void addReferenceQuality(nlohmann::json& results, int warmup);
// One line per scene for a printed summary (the verdicts above, aligned).
std::vector<std::string> referenceQualityLines(const nlohmann::json& results);

}  // namespace arena
