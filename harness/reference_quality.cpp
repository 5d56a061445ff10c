#include "harness/reference_quality.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <set>

#include "core/text.hpp"
#include "metrics/evaluator.hpp"
#include "metrics/ghosting.hpp"
#include "metrics/metric_registry.hpp"
#include "tracer/render.hpp"

namespace arena {

namespace fs = std::filesystem;

using nlohmann::json;

namespace {

std::string sci(double v, int digits = 2) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

// `v` with as many digits as tell it from `other` (at least two, at most six): a ratio of 0.1018
// against the goal of 0.1 reads "0.102 > 0.1", not "0.1 > 0.1".
std::string sciApart(double v, double other) {
  int digits = 2;
  while (digits < 6 && v != other && sci(v, digits) == sci(other, digits)) ++digits;
  return sci(v, digits);
}

bool isBaseline(const std::string& denoiser) {
  return denoiser == "passthrough" || denoiser == "temporal";
}

}  // namespace

std::string renderOptionsOf(const json& render) {
  if (!render.is_object()) return "";
  const std::string preset = render.value("preset", "quick");
  const RenderSettings defaults = RenderSettings::fromPreset(preset == "paper" ? "paper" : "quick");
  std::string o;
  auto add = [&o](const std::string& flag, const std::string& value) { o += " " + flag + " " + value; };
  if (preset != defaults.preset) return "";  // not a preset this build knows: no command could find it
  if (preset != "quick") add("--preset", preset);
  if (render.value("referenceSpp", defaults.referenceSpp) != defaults.referenceSpp)
    add("--ref-spp", std::to_string(render.value("referenceSpp", 0)));
  const double relError = render.value("referenceRelError", defaults.referenceRelError);
  if (relError != defaults.referenceRelError) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", relError);
    add("--ref-rel-error", buf);
  }
  if (render.value("referenceSampler", defaults.referenceSampler) != defaults.referenceSampler)
    add("--ref-sampler", render.value("referenceSampler", ""));
  if (render.value("referenceTile", defaults.referenceTile) != defaults.referenceTile)
    add("--ref-tile", std::to_string(render.value("referenceTile", 0)));
  if (render.value("inputSeed", 0u) != 0u) add("--input-seed", std::to_string(render.value("inputSeed", 0u)));
  if (render.value("lowresFactor", 0) > 0) {
    add("--lowres-factor", std::to_string(render.value("lowresFactor", 0)));
    if (render.value("lowresSpp", defaults.lowresSpp) != defaults.lowresSpp)
      add("--lowres-spp", std::to_string(render.value("lowresSpp", 0)));
  }
  return o;
}

void addReferenceQuality(json& results, int warmup, const std::map<std::string, std::string>& notes,
                         const std::string& cache) {
  if (!results.contains("scenes")) return;
  for (auto it = results["scenes"].begin(); it != results["scenes"].end(); ++it) {
    const std::string& name = it.key();
    json& scene = it.value();
    // The floor as the report draws it: the reference's relMSE, mean over frames t >= warmup.
    // Unknown (NaN) where the reference has no variance (a capture without colorVar): then there
    // is no floor, rather than a mean over some frames.
    double floorSum = 0;
    int floorFrames = 0, frame = 0;
    bool floorKnown = true;
    for (const json& v : scene.value("referenceRelMse", json::array()))
      if (frame++ >= warmup) {
        if (!v.is_number() || !std::isfinite(v.get<double>())) {
          floorKnown = false;
          break;
        }
        floorSum += v.get<double>();
        ++floorFrames;
      }
    const bool noFrameAfterWarmup = floorKnown && floorFrames == 0 && frame > 0;
    if (!floorKnown) floorFrames = 0;
    double best = std::numeric_limits<double>::infinity();
    std::string bestLabel;
    for (const json& p : results.value("pairs", json::array())) {
      if (p.value("scene", "") != name || p.value("status", "") != "ok" || isBaseline(p.value("denoiser", "")))
        continue;
      // An output that is the reference (a stored output wired to it) is no denoiser's best: its
      // corrected relMSE of 0 or less would leave the verdict unknown for every real one.
      const json warnings = p.value("warnings", json::array());
      if (std::any_of(warnings.begin(), warnings.end(), [](const json& w) {
            return w.is_string() && w.get<std::string>().rfind(kEqualsReferenceWarning, 0) == 0;
          }))
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
      const bool hasReference = scene.value("hasReference", true);
      q["verdict"] =
          name + ": reference quality unknown (" +
          (!hasReference ? std::string("no reference")
           // Nothing measured at all (a capture refused before any pair ran): not a
           // missing noise floor, which it said of a capture holding colorHalf.
           : frame == 0 && scene.contains("validation") && scene["validation"].is_object() &&
                   scene["validation"].value("status", "") == "fail"
               ? "the capture was refused: its validation failed, and nothing was measured"
           : frame == 0 ? "nothing was measured on it"
           : noFrameAfterWarmup
               ? "no frame after the warm-up of " + std::to_string(warmup) + " to measure it on"
           : floorFrames == 0 && scene.value("source", "") == "capture"
               ? "no reference noise floor: the capture's references give no colorVar "
                 "or colorHalf, so how "
                 "noisy they are, and how much of each error is theirs, is not known"
           : floorFrames == 0 ? "no reference noise floor"
                              : "no real denoiser's corrected relMSE") +
          ")";
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
    std::string verdict =
        name + ": reference noise floor " + sci(floor) + " / best corrected relMSE " + sci(best) +
        " (" + bestLabel + ") = " + sciApart(ratio, kReferenceQualityGoal) +
        (meets ? " <= " : " > ") + sci(kReferenceQualityGoal) + (meets ? ": met" : ": NOT MET, ");
    if (!meets) {
      const double needed = kReferenceQualityGoal * best;
      // The command must find the run's sequences: the same settings hash (the render settings,
      // the size and length the scene ran at) in the same cache.
      std::string options;
      if (scene.value("width", 0) > 0 && scene.value("height", 0) > 0)
        options += " --resolution " + std::to_string(scene.value("width", 0)) + "x" +
                   std::to_string(scene.value("height", 0));
      if (scene.value("frames", 0) > 0)
        options += " --frames " + std::to_string(scene.value("frames", 0));
      options += renderOptionsOf(results.value("settings", json::object()).value("render", json()));
      // A run's --max-bounces is part of every sequence's settings; without it refine would look
      // for (and render) the scene's own path length.
      if (scene.value("maxBounces", 0) > 0)
        options += " --max-bounces " + std::to_string(scene.value("maxBounces", 0));
      // The cache the scene's sequence was read from (a merge of shards has no --cache of its own).
      std::string cacheDir = cache;
      if (scene.contains("sequence") && scene["sequence"].is_string())
        cacheDir = fs::path(scene["sequence"].get<std::string>()).parent_path().string();
      if (!cacheDir.empty() && cacheDir != "cache") options += " --cache " + shellWord(cacheDir);
      verdict += "the reference's noise must fall " + sciApart(ratio / kReferenceQualityGoal, 1) +
                 "x (to " + sci(needed) + "); ";
      if (scene.value("source", "") ==
          "capture")  // references rendered elsewhere: ours to judge, not to refine
        verdict +=
            "a capture's references come from the renderer that made them (`arena refine` renders "
            "scenes only): render them there with about " +
            sciApart(ratio / kReferenceQualityGoal, 1) + "x the samples";
      else if (capped > 0)
        verdict += std::to_string(capped) + " of " + std::to_string(references) +
                   " references stopped at their sample cap (raise --ref-spp, or `arena refine " + name + options +
                   " --target " + sci(needed) + " --max-spp N`)";
      else
        verdict += "its references met their target, which is too loose for this scene (`arena refine " + name +
                   options + " --target " + sci(needed) + "`)";
      // A scene's ranks come from paired differences, the same for raw and corrected relMSE (the
      // reference's term is every method's), which its noise leaves unbiased but widens; the
      // overall score's ratios of raw relMSE it pulls towards 1.
      verdict +=
          ", then run again (everything else is reused); until then the reference's noise widens "
          "the relMSE ranking's intervals (more ties) and pulls the overall score's ratios towards "
          "1, and FLIP/SSIM partly measure the reference";
    }
    // The same ratio between the scene's events (a light switched off has a reference of its own,
    // and the event's figures are measured there): a segment above the goal is said, though the
    // scene's ratio of means meets it (the verdict and the refinement stay the scene's).
    json segments = json::array();
    std::string segmentNote;
    {
      const json refs = scene.value("referenceRelMse", json::array());
      std::vector<int> bounds = {warmup, int(refs.size())};
      std::set<int> eventFrames;
      for (const json& e : scene.value("events", json::array()))  // those within the frames
        if (const int at = e.value("frame", -1); at > warmup && at < int(refs.size())) {
          bounds.push_back(at);
          eventFrames.insert(at);
        }
      std::sort(bounds.begin(), bounds.end());
      bounds.erase(std::unique(bounds.begin(), bounds.end()), bounds.end());
      json bestFrames = json::array();
      for (const json& p : results.value("pairs", json::array()))
        if (p.value("scene", "") == name && p.value("label", "") == bestLabel)
          bestFrames = p.value("frames", json::array());
      for (size_t k = 0; bounds.size() > 2 && k + 1 < bounds.size(); ++k) {
        double f = 0, b = 0;
        int n = 0;
        for (int t = bounds[k]; t < bounds[k + 1]; ++t) {
          const json& r = refs[size_t(t)];
          const json v = size_t(t) < bestFrames.size()
                             ? bestFrames[size_t(t)].value("relMseCorrected", json())
                             : json();
          if (!r.is_number() || !v.is_number()) continue;
          f += r.get<double>();
          b += v.get<double>();
          ++n;
        }
        if (n == 0 || !(b > 0)) continue;
        const double segmentRatio = f / b;
        segments.push_back(
            {{"from", bounds[k]}, {"to", bounds[k + 1] - 1}, {"ratio", segmentRatio}});
        // Said from an event on, over as many frames as an event's figures need (the frames
        // before the first event measure no event figure, and one frame's ratio is noise).
        if (meets && segmentRatio > kReferenceQualityGoal && eventFrames.count(bounds[k]) &&
            n >= GhostingConfig{}.minFramesFromEvent)
          segmentNote += std::string(segmentNote.empty() ? "" : "; ") + "frames " +
                         std::to_string(bounds[k]) + "-" + std::to_string(bounds[k + 1] - 1) + " " +
                         sciApart(segmentRatio, kReferenceQualityGoal) + " > " +
                         sci(kReferenceQualityGoal);
      }
    }
    if (!segmentNote.empty())
      verdict += " for the scene's mean, not between its events (" + segmentNote +
                 ": the figures measured there, an event's lag and ghosting, carry more of the "
                 "reference's noise)";
    if (auto note = notes.find(name); note != notes.end()) verdict += " (" + note->second + ")";
    q = {{"floor", floor},
         {"bestCorrectedRelMse", best},
         {"bestLabel", bestLabel},
         {"ratio", ratio},
         {"goal", kReferenceQualityGoal},
         {"meets", meets},
         {"cappedReferences", capped},
         {"references", references},
         {"verdict", verdict}};
    if (!segments.empty()) {
      q["segments"] = segments;
      // False where the verdict names a segment above the goal (a scene that meets it as a whole):
      // the readers say that verdict too, not only a missed goal's.
      q["segmentsMeet"] = segmentNote.empty();
    }
    scene["referenceQuality"] = q;
  }
}

// A scene's budget unit: the paths of its frames at the references' sample cap (unitSpp: the
// preset's or the given --ref-spp; 0: the cap the sequence was rendered under), as if each frame
// had a reference of its own: W x H x frames x cap, a function of the settings alone. Per frame,
// not per reference: a static scene's one reference serves every frame and is as much work to a
// study as a moving scene's many. (Until 2026-11-27 the unit was the paths all references held,
// cache history included, and the budget was shared cheapest first: a rerun on a cache whose
// references had been refined had a larger unit and fewer scenes to pay for, so it refined scenes
// the first run had not.)
double budgetUnitPaths(const SequenceInfo& info, int unitSpp) {
  const int cap = unitSpp > 0                 ? unitSpp
                  : info.settings.is_object() ? info.settings.value("referenceSpp", 0)
                                              : 0;
  double unit = 0;
  for (int r : info.referenceOfFrame) {
    const int held = r >= 0 && r < int(info.referenceSpp.size()) ? info.referenceSpp[size_t(r)] : 0;
    unit += double(info.width) * info.height * (cap > 0 ? cap : held);
  }
  return unit;
}

int firstFrameSummariesRead(int warmup) { return std::max(0, warmup - kMaxMetricHistory); }

double refinementPaths(const SequenceInfo& info, int firstFrame, double targetRelMse, int maxSpp) {
  double paths = 0;
  for (int r = 0; r < int(info.referenceSpp.size()); ++r) {
    if (!info.referenceUsedFrom(r, firstFrame)) continue;
    const double e = r < int(info.referenceEstimatedRelMse.size())
                         ? info.referenceEstimatedRelMse[size_t(r)]
                         : 0;
    const double s = info.referenceSpp[size_t(r)];
    if (!(e > targetRelMse) || s >= maxSpp) continue;
    const double grown = std::min(s * (e / targetRelMse), double(maxSpp));
    paths += double(info.width) * info.height * (grown - s);
  }
  return paths;
}

std::vector<ReferenceRefinement> planReferenceRefinement(
    const json& results, const std::map<std::string, SequenceInfo>& sequences, int firstFrame,
    int maxSpp, double budget, int unitSpp, bool mayStopShort) {
  std::vector<ReferenceRefinement> plans;
  const json scenes = results.value("scenes", json::object());
  for (const auto& [name, scene] : scenes.items()) {
    const json q = scene.value("referenceQuality", json::object());
    const auto seq = sequences.find(name);
    if (q.value("meets", true) || !q.contains("bestCorrectedRelMse") || seq == sequences.end()) continue;
    const SequenceInfo& info = seq->second;
    ReferenceRefinement plan;
    plan.scene = name;
    const double best = q["bestCorrectedRelMse"].get<double>();
    plan.targetRelMse = kRefineMargin * kReferenceQualityGoal * best;
    plan.predictedPaths = refinementPaths(info, firstFrame, plan.targetRelMse, maxSpp);
    plan.roundTargetRelMse = plan.targetRelMse;
    plan.roundPaths = plan.predictedPaths;
    const double stop = kRefineStageRatio * best;
    if (mayStopShort && q.value("floor", 0.0) > kRefineStageTrigger * best &&
        stop > plan.targetRelMse) {
      plan.roundTargetRelMse = stop;
      plan.roundPaths = refinementPaths(info, firstFrame, stop, maxSpp);
    }
    const double unit = budgetUnitPaths(info, unitSpp);
    plan.budgetNeeded = unit > 0 ? plan.predictedPaths / unit : 0;
    plan.roundBudgetNeeded = unit > 0 ? plan.roundPaths / unit : 0;
    plan.withinBudget = plan.predictedPaths > 0 && plan.budgetNeeded <= budget;
    plans.push_back(plan);
  }
  std::stable_sort(plans.begin(), plans.end(), [](const ReferenceRefinement& a, const ReferenceRefinement& b) {
    return a.predictedPaths < b.predictedPaths;
  });
  return plans;
}

std::string refinementNote(const ReferenceRefinement& plan, double budget) {
  const std::string paths = sci(plan.predictedPaths / 1e6) + " Mpaths";
  if (plan.predictedPaths <= 0)
    return "the study could not refine it: the references its summaries read are at the refinement cap";
  if (plan.withinBudget && plan.stopsShort())
    return "the study refined its references toward " + sci(plan.roundTargetRelMse) +
           " (predicted " + sci(plan.roundPaths / 1e6) + " of the " + paths + " its target " +
           sci(plan.targetRelMse) +
           " needs), where their floor is its best corrected relMSE, to measure that best again "
           "before the target";
  if (plan.withinBudget)
    return "the study refined its references toward " + sci(plan.targetRelMse) + " (predicted " + paths + ")";
  char need[32];
  std::snprintf(need, sizeof need, "%g", std::ceil(plan.budgetNeeded * 10) / 10);
  return "not refined by the study: about " + paths + " more, over its refinement budget of " + sci(budget) +
         "x the paths of its frames at the preset's reference sample cap (or the given --ref-spp); "
         "`arena study --refine-budget " + need + "` covers it";
}

std::vector<std::string> referenceQualityLines(const json& scenes) {
  std::vector<std::string> lines;
  if (!scenes.is_object()) return lines;
  for (const auto& [name, scene] : scenes.items())
    if (scene.contains("referenceQuality")) lines.push_back(scene["referenceQuality"].value("verdict", ""));
  return lines;
}

std::vector<std::string> segmentQualityLines(const json& scenes) {
  std::vector<std::string> lines;
  if (!scenes.is_object()) return lines;
  for (const auto& [name, scene] : scenes.items())
    if (const json q = scene.value("referenceQuality", json::object());
        q.value("meets", false) && !q.value("segmentsMeet", true))
      lines.push_back(q.value("verdict", name));
  return lines;
}

}  // namespace arena
