#include "harness/scene_data.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/stage_clock.hpp"
#include "harness/run_matrix.hpp"
#include "harness/scene_selection.hpp"
#include "metrics/capture_checks.hpp"
#include "reports/image_files.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// The frames whose images the report shows: after the warm-up, the middle, the last, and each
// event's frame and two after it.
std::vector<int> chooseFrames(const SequenceInfo& info, int warmup) {
  std::set<int> chosen = {std::min(warmup, info.frames - 1), info.frames / 2, info.frames - 1};
  for (const SequenceEvent& e : info.events)
    for (int t : {e.frame, e.frame + 2})
      if (t < info.frames) chosen.insert(t);
  return {chosen.begin(), chosen.end()};
}

}  // namespace

std::unique_ptr<SceneData> prepareScene(const fs::path& dir, const EvaluationOptions& options, json* validation) {
  StageTimer timer(Stage::Loading);
  Sequence sequence = Sequence::open(dir);
  EvaluationInput input = readSequenceForEvaluation(sequence);
  // The frames the run scores (after the warm-up): those whose reference is black, and those whose
  // input equals its reference on every finite value (inputEqualsReference).
  int scored = 0, equal = 0, black = 0;
  if (!input.references.empty())
    for (int t = std::max(options.warmup, 0); t < int(input.frames.size()); ++t) {
      const Image& color = input.frames[size_t(t)].get("color");
      const Image& reference =
          input.references[size_t(input.referenceOfFrame[size_t(t)])].get("color");
      if (!hasSignal(reference)) {  // validate's predicate: no nonzero finite value
        ++black;
        continue;
      }
      ++scored;
      equal += inputEqualsReference(color, reference);
    }
  const std::string fromFrame =
      "(from frame " + std::to_string(std::max(options.warmup, 0)) + ", after the warm-up)";
  if (sequence.isCapture()) {
    const CaptureValidation checks = validateCapture(sequence, input);
    if (validation) *validation = checks.toJson();
    if (checks.status() == CheckStatus::Fail)
      throw Error("capture " + dir.string() + " refused by its validation: " + checks.failures());
    // The validation fails references black in every frame and only warns of some: black in
    // every frame the run scores, the relative errors would rank the outputs by their own
    // brightness alone (the darkest first), with nothing to measure against.
    if (scored == 0 && black > 0)
      throw Error("capture " + dir.string() + ": the reference of every frame the run scores " +
                  fromFrame +
                  " is black, holding no nonzero finite value: nothing to measure the outputs "
                  "against, and relative errors would rank them by their brightness alone "
                  "(reference.blackFrames; a shorter --warmup, or references rendered for the "
                  "frames after it)");
    // The validation fails an input equal to its reference on every frame; on every frame the
    // run scores the input would score a perfect 0 and every method be measured against its own
    // input: nothing to rank.
    if (scored > 0 && equal == scored)
      throw Error("capture " + dir.string() + ": every frame the run scores " + fromFrame +
                  " equals its reference value for value: the input itself would score a perfect "
                  "0 and every method be measured against its own input (a reference must be "
                  "rendered apart from the input; reference.equalsInput)");
  } else if (!input.references.empty() &&
             std::all_of(input.references.begin(), input.references.end(), [](const LayerSet& r) {
               const Image& c = r.get("color");
               for (int k = 0; k < c.channels(); ++k)
                 for (const float v : c.planeSpan(k))
                   if (v != 0) return false;
               return true;
             })) {
    // Against a black reference every method, and the noisy input, scores relMSE 0: a tie of
    // perfect scores measured on nothing (the captures' reference.blackFrames check, for scenes).
    throw Error("scene " + sequence.info().scene + " (" + dir.string() +
                "): its reference is black in every frame, so no light reaches the camera (a light "
                "facing away, or hidden?); every method would score a perfect 0 on nothing");
  } else if (scored > 0 && equal == scored) {
    // A rendered input with no noise (a scene of nothing but emitters and the sky in view): the
    // input scored a perfect 0 beside every method, ranked first with them (a bad-input trial).
    throw Error("scene " + sequence.info().scene + " (" + dir.string() +
                "): every frame the run scores " + fromFrame +
                " equals its reference value for value, so the 1-spp input holds no noise "
                "(nothing in view but light sources or the sky?): the input would score a perfect "
                "0 beside every method, and nothing would be measured");
  }
  EvaluationScene evaluation(std::move(input), options);
  std::vector<int> chosen = chooseFrames(sequence.info(), options.warmup);
  return std::make_unique<SceneData>(SceneData{std::move(sequence), std::move(evaluation), std::move(chosen)});
}

std::vector<SeedSequence> renderSeedSequences(const Scene& scene, const RunConfig& config) {
  std::vector<SeedSequence> seeds;
  for (int k = 1; k < config.seeds; ++k) {
    RenderSettings seeded = config.render;
    seeded.inputSeed = config.render.inputSeed + uint32_t(k);
    const fs::path dir = renderSequence(scene, seeded, config.cache, config.progress);
    SeedSequence s{seeded.inputSeed, Sequence::open(dir), {}};
    for (int t = 0; t < s.sequence.info().frames; ++t) s.frames.push_back(s.sequence.frame(t));
    seeds.push_back(std::move(s));
  }
  return seeds;
}

std::vector<std::string> validationLines(const json& validation) {
  std::vector<std::string> lines;
  if (validation.is_null()) return lines;
  for (const json& c : validation["checks"])
    if (c["status"] != "pass")
      lines.push_back(c["status"].get<std::string>() + ": " + c["name"].get<std::string>() + " " +
                      (c["value"].is_number() ? std::to_string(c["value"].get<double>()) : std::string("-")) + " (" +
                      c["detail"].get<std::string>() + ")");
  return lines;
}

json sceneRecord(const RunConfig& config, const SceneData& data, const std::string& purpose, const Scene* scene,
                 const fs::path& dir, const json& validation) {
  const SequenceInfo& info = data.sequence.info();
  const EvaluationScene& ev = data.evaluation;
  const fs::path images = config.out / "images" / info.scene;
  json events = json::array();
  for (auto& e : info.events) events.push_back({{"frame", e.frame}, {"kind", eventKindName(e.kind)}, {"what", e.what}});
  if (config.keepFrames != "none")
    for (int t : data.chosenFrames) {
      if (ev.hasReference()) writePng(images / frameName("reference", t), ev.referenceDisplay(t));
      writePng(images / frameName("noisy", t), ev.display(t, ev.frame(t).get("color")));
    }
  json entry = {{"purpose", purpose},
                {"sequence", dir.string()},
                {"hash", info.hash},
                {"width", info.width},
                {"height", info.height},
                {"frames", info.frames},
                {"events", events},
                {"referenceSpp", info.referenceSpp},
                {"referenceCapped", info.referenceCapped},
                {"referenceEstimatedRelMse", info.referenceEstimatedRelMse}};
  if (config.keepFrames != "none") {  // none: no image written, none recorded
    entry["chosenFrames"] = data.chosenFrames;
    entry["images"] = fs::relative(images, config.out).string();
  }
  entry.update(ev.describe());
  if (!ev.hasReference()) entry["hasReference"] = false;
  // A run's --max-bounces, which the scene's sequence was rendered under (absent: the scene's own
  // path length): a command that must find the sequence again (`arena refine`) repeats it.
  if (scene && config.render.maxBounces > 0) entry["maxBounces"] = config.render.maxBounces;
  auto warn = [&](const std::string& warning) {
    if (!entry.contains("warnings") || !entry["warnings"].is_array())
      entry["warnings"] = json::array();
    entry["warnings"].push_back(warning);
  };
  // Few frames (or none) after the warm-up: said before the work, and kept with the results (the
  // report of a 1-frame run showed confident ranks without a word).
  if (const std::string few = shortSequenceText(info.frames, config.warmup, scene == nullptr);
      !few.empty())
    warn(few);
  // Events the scene has on frames a shorter sequence (--frames) does not reach: not measured,
  // said.
  if (scene) {
    std::string dropped;
    for (const SceneEvent& e : scene->events)
      if (e.frame >= info.frames)
        dropped += std::string(dropped.empty() ? "" : ", ") + eventKindName(e.kind) +
                   (e.what.empty() ? "" : " ") + e.what + " at frame " + std::to_string(e.frame);
    if (!dropped.empty())
      warn("events beyond the sequence's " + std::to_string(info.frames) +
           " frames are not measured (" + dropped + "); render more frames to measure them");
    // A camera that jumps without a camera_cut event: the denoisers are not told (no reset, as an
    // engine that forgets to flag a teleport) and no cut figures are measured there. A test may
    // mean exactly that; the results say it.
    std::string unflagged;
    for (const auto& key : scene->camera.keys) {
      const bool cut =
          std::any_of(scene->events.begin(), scene->events.end(), [&](const SceneEvent& e) {
            return e.kind == EventKind::CameraCut && e.frame == key.frame;
          });
      if (scene->camera.stepsAt(key.frame) && key.frame < info.frames && !cut)
        unflagged += (unflagged.empty() ? "" : ", ") + std::to_string(key.frame);
    }
    if (!unflagged.empty())
      warn("the camera jumps (a key with \"step\": true) at frame(s) " + unflagged +
           " without a camera_cut event: the denoisers keep their histories there and no "
           "cut figures are measured; add {\"frame\": N, \"kind\": \"camera_cut\"} "
           "if an engine would flag the jump");
  }
  // What the sequence's pixels are made of (metrics/compare.cpp compares it): a scene's file and
  // assets (its references follow from them and referenceSpp), a capture's files.
  if (scene) {
    entry["content"] = {{"inputs", scene->contentHash.substr(0, 12)}};
  } else {
    const CaptureContent content = captureContent(data.sequence.capture());
    entry["content"] = {{"inputs", content.inputs}};
    if (!content.references.empty()) entry["content"]["references"] = content.references;
  }
  if (!scene) {
    entry["source"] = "capture";
    entry["capture"] = dir.string();
    entry["validation"] = validation;
    entry["derivedLayers"] = data.sequence.capture().derived;
    // The layers the capture gives: what derivedLayers lists was made from them.
    json given = json::array();
    for (const std::string& layer : info.availableLayers())
      if (std::find(data.sequence.capture().derived.begin(), data.sequence.capture().derived.end(),
                    layer) == data.sequence.capture().derived.end())
        given.push_back(layer);
    entry["layers"] = given;
  }
  // Asset scenes (issue 18): the models' credits and the loader's counted fallbacks.
  if (scene && (!scene->credits.empty() || !scene->warnings.empty())) {
    json credits = json::array();
    for (const Credit& c : scene->credits)
      credits.push_back({{"asset", c.asset}, {"author", c.author}, {"license", c.license}, {"source", c.source}});
    entry["assets"] = {{"credits", credits}, {"warnings", scene->warnings}};
  }
  return entry;
}

}  // namespace arena
