#include "harness/reference_quality.hpp"

#include <cstdio>
#include <limits>

namespace arena {

using nlohmann::json;

namespace {

std::string sci(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2g", v);
  return buf;
}

bool isBaseline(const std::string& denoiser) {
  return denoiser == "passthrough" || denoiser == "temporal";
}

}  // namespace

void addReferenceQuality(json& results, int warmup) {
  if (!results.contains("scenes")) return;
  for (auto it = results["scenes"].begin(); it != results["scenes"].end(); ++it) {
    const std::string& name = it.key();
    json& scene = it.value();
    // The floor as the report draws it: the reference's relMSE, mean over frames t >= warmup.
    double floorSum = 0;
    int floorFrames = 0, frame = 0;
    for (const json& v : scene.value("referenceRelMse", json::array()))
      if (frame++ >= warmup && v.is_number()) {
        floorSum += v.get<double>();
        ++floorFrames;
      }
    double best = std::numeric_limits<double>::infinity();
    std::string bestLabel;
    for (const json& p : results.value("pairs", json::array())) {
      if (p.value("scene", "") != name || p.value("status", "") != "ok" || isBaseline(p.value("denoiser", "")))
        continue;
      const json s = p.value("summary", json::object()).value("relMseCorrected", json::object());
      if (!s.contains("mean") || !s["mean"].is_number()) continue;
      if (s["mean"].get<double>() < best) {
        best = s["mean"].get<double>();
        bestLabel = p.value("label", "");
      }
    }
    json q;
    if (floorFrames == 0 || bestLabel.empty() || !(best > 0)) {
      q["verdict"] = name + ": reference quality unknown (no reference floor or no real denoiser's corrected relMSE)";
      scene["referenceQuality"] = q;
      continue;
    }
    const double floor = floorSum / floorFrames, ratio = floor / best;
    int capped = 0, references = 0;
    for (const json& c : scene.value("referenceCapped", json::array())) {
      ++references;
      capped += c.is_boolean() && c.get<bool>();
    }
    const bool meets = ratio <= kReferenceQualityGoal;
    std::string verdict = name + ": reference noise floor " + sci(floor) + " / best corrected relMSE " + sci(best) +
                          " (" + bestLabel + ") = " + sci(ratio) + (meets ? " <= " : " > ") +
                          sci(kReferenceQualityGoal) + (meets ? ": met" : ": NOT MET, ");
    if (!meets) {
      const double needed = kReferenceQualityGoal * best;
      verdict +=
          "the reference's noise must fall " + sci(ratio / kReferenceQualityGoal) + "x (to " + sci(needed) + "); ";
      if (capped > 0)
        verdict += std::to_string(capped) + " of " + std::to_string(references) +
                   " references stopped at their sample cap (raise --ref-spp, or `arena refine " + name + " --target " +
                   sci(needed) + " --max-spp N`)";
      else
        verdict += "its references met their target, which is too loose for this scene (`arena refine " + name +
                   " --target " + sci(needed) + "`)";
      verdict += "; rankings here rest on the corrected relMSE, and FLIP/SSIM partly measure the reference";
    }
    q = {{"floor", floor},
         {"bestCorrectedRelMse", best},
         {"bestLabel", bestLabel},
         {"ratio", ratio},
         {"goal", kReferenceQualityGoal},
         {"meets", meets},
         {"cappedReferences", capped},
         {"references", references},
         {"verdict", verdict}};
    scene["referenceQuality"] = q;
  }
}

std::vector<std::string> referenceQualityLines(const json& results) {
  std::vector<std::string> lines;
  const json scenes = results.value("scenes", json::object());
  for (const auto& [name, scene] : scenes.items())
    if (scene.contains("referenceQuality")) lines.push_back(scene["referenceQuality"].value("verdict", ""));
  return lines;
}

}  // namespace arena
