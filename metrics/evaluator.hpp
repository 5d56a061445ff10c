#pragma once
// The evaluation stage: guide layers, an optional reference and a stream of output frames in;
// per-frame values, tile sums, event and cut curves, floors and warnings out. It does not know who
// made the frames -- a built-in denoiser, a plugin, or a capture of an engine's output -- so any
// frames can be scored the same way. Every metric comes from the registry (metric_registry.hpp);
// docs/metrics.md defines each.
//
//   EvaluationScene scene(readSequenceForEvaluation(sequence), options);   // once per sequence
//   PairEvaluation pair(scene);                                            // once per output stream
//   for each frame t in order: pair.add(t, output, facts);
//   nlohmann::json result = pair.finish();   // frames, summary, ghosting, cuts, tiles, warnings
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/display.hpp"
#include "core/image.hpp"
#include "core/sequence.hpp"
#include "metrics/ghosting.hpp"
#include "metrics/metric_registry.hpp"
#include "metrics/summary.hpp"

namespace arena {

// A metric of the images (not a run fact, not a frame scalar) whose family ran on the pair and
// never put it on any frame, given these options and a reference or none: recorded in `summary`
// absent, with the reason (it vanished from the results, the printout and the report's columns
// without a word).
void markUnrecorded(nlohmann::json& summary, const std::vector<const MetricFamily*>& families,
                    const MetricOptions& options, bool hasReference);

// How a pair's warning that its output equals the reference (a perfect score no denoiser computes
// from its input) begins: the run also prints it, not only results.json.
inline constexpr const char* kEqualsReferenceWarning =
    "the output equals its reference value for value on ";

struct EvaluationOptions {
  int warmup = kDefaultWarmup;  // summaries over frames t >= warmup
  MetricOptions metrics;
  ExposureMode exposure = ExposureMode::PerFrame;
};

// What the results record of the evaluation's settings and definitions (results.json "settings").
nlohmann::json evaluationSettings(const EvaluationOptions& options);

// A sequence as the evaluation sees it.
struct EvaluationInput {
  std::string name;  // the scene's: seeds the bootstrap plans and the floors' noise
  std::vector<LayerSet> frames;       // per frame: the input's layers (colour, normal, depth, motion, meshId...)
  std::vector<LayerSet> references;   // per distinct reference (color, colorVar, colorHalf?); empty: none
  std::vector<int> referenceOfFrame;  // frame -> reference index (ignored without references)
  std::vector<bool> referenceCapped;  // per reference: stopped at its sample cap above its target
  // false: the references carry no variance and no independent half (a capture's may not), so
  // their noise floor is unknown: referenceRelMse is NaN (null), no metric floors, and
  // relMseCorrected subtracts nothing.
  bool referenceNoiseKnown = true;
  std::vector<SequenceEvent> events;
  // Non-finite values in the inputs, per "file kind: layer.channel" (reported, never silent).
  std::map<std::string, long> nonFinite;
};
// Reads a cached sequence's frames and references, counting non-finite inputs (gradient samples
// too). A reference with non-finite values is an Error naming the file and channels: it cannot rank.
EvaluationInput readSequenceForEvaluation(const Sequence& sequence);

// What a scene's reference memos may keep in all. FLIP's filtered reference is 5 float planes per
// exposure plus 5 for LDR-FLIP: 0.7 MB per exposure at 256x144, 18 MB at 1280x720, so the study's
// scenes keep every reference's, and a paper-size or capture-size scene of many references the
// first few (the others are filtered for each output, as before).
constexpr size_t kReferenceMemoBytes = size_t(1) << 30;
// What a scene's frame memos may keep in all. The stability metric's paths back through the
// motion layers are 9 bytes per pixel and lag, three lags a frame: 1 MB a frame at 256x144, 25 MB
// at 1280x720, so the study's scenes keep every frame's.
constexpr size_t kFrameMemoBytes = size_t(512) << 20;

// Everything about a sequence that every output's evaluation shares: display transforms, the
// reference's and the input's own relMSE, event masks, camera-cut segments and metric floors.
class EvaluationScene {
 public:
  EvaluationScene(EvaluationInput input, EvaluationOptions options);

  const std::string& name() const { return input_.name; }
  int frames() const { return int(input_.frames.size()); }
  const LayerSet& frame(int t) const { return input_.frames[size_t(t)]; }
  bool hasReference() const { return !input_.references.empty(); }
  const LayerSet& reference(int t) const { return input_.references[referenceIndex(t)]; }
  const EvaluationOptions& options() const { return options_; }
  // The display image of a linear frame t (the transform every method of the scene is shown with).
  Image display(int t, const Image& linear) const { return displays_[displayIndex(t)].apply(linear); }
  const Image& referenceDisplay(int t) const { return referenceDisplay_[referenceIndex(t)]; }
  // The results' description of the sequence: referenceRelMse and noisyRelMse per frame,
  // exposures, floors, non-finite inputs and the warnings below.
  nlohmann::json describe() const;
  // Warnings that concern the sequence, not a method (capped references, non-finite inputs):
  // results.scenes.<scene>.warnings, once per scene rather than on each pair.
  std::vector<std::string> warnings() const;
  const nlohmann::json& floors() const { return floors_; }

 private:
  friend class PairEvaluation;
  struct EventWindow {
    SequenceEvent event;
    int begin = 0, end = 0;
    std::vector<Image> masks;  // per window frame
    size_t chromaOnlyPixels = 0;
  };
  struct CutSegment {
    int frame = 0, segmentEnd = 0;  // the new view lasts [frame, segmentEnd]
  };
  size_t referenceIndex(int t) const { return size_t(input_.referenceOfFrame[size_t(t)]); }
  size_t displayIndex(int t) const { return hasReference() ? referenceIndex(t) : size_t(t); }
  void buildEventWindows();
  void computeFloors();

  EvaluationInput input_;
  EvaluationOptions options_;
  std::vector<DisplayTransform> displays_;  // per reference (per frame without one)
  std::vector<Image> referenceDisplay_;     // per reference
  std::vector<std::unique_ptr<SceneMemo>> referenceMemos_;  // per reference
  std::vector<std::unique_ptr<SceneMemo>> frameMemos_;      // per frame
  std::vector<double> referenceRelMse_, noisyRelMse_;  // per frame (empty without a reference)
  std::vector<EventWindow> events_;
  std::vector<CutSegment> cuts_;
  std::vector<int> cutFrames_;
  nlohmann::json floors_ = nlohmann::json::object();
};

// The images of the last added frame that a person looks at.
struct FrameImages {
  Image display;    // the output through the scene's display transform
  Image flip;       // the LDR-FLIP map, colour-mapped (empty when FLIP is off or no reference)
  Image relativeError;  // the relative error map (empty without a reference)
  // What that map shows, unclamped: the per-pixel relative squared error, one channel, whose mean
  // is the frame's relMSE (a region's relMSE in the report is read from it, not from the map).
  Image relativeSquaredError;
};

// What a PairEvaluation measures. Screening: only the linear error family (relMse,
// relMseCorrected and their kin) and the run's facts (its times), the same values as a full
// evaluation gives, without display images, FLIP maps, temporal metrics, event or cut curves --
// for a decision that needs no more (the study's reference-quality check before it refines,
// harness/run_matrix.hpp), after which the outputs are evaluated in full.
enum class EvaluationScope { Full, Screening };

// One stream of output frames evaluated against one EvaluationScene.
class PairEvaluation {
 public:
  explicit PairEvaluation(const EvaluationScene& scene, EvaluationScope scope = EvaluationScope::Full);
  ~PairEvaluation();
  // Frame t's linear RGB output; frames arrive in order 0, 1, ... (a skipped frame is an Error).
  void add(int t, const Image& output, const FrameFacts& facts = {});
  // Not in a screening (it keeps no images).
  FrameImages lastImages() const;
  // Per frame, NaN where undefined.
  std::vector<double> values(const std::string& metric) const;
  // After the last frame: {frames, summary, ghosting, cuts, tiles, warnings}; a screening's has no
  // ghosting and no cuts.
  nlohmann::json finish();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// The per-frame timing of a run summarised after the warm-up: total and per pass (median, p95),
// taps per pixel, ms per megapixel.
struct PassTime {
  std::string name;
  double milliseconds = 0, tapsPerPixel = 0;
};
nlohmann::json timingSummary(const std::vector<std::vector<PassTime>>& passesPerFrame, const std::vector<double>& ms,
                             int warmup, int width, int height);

// The bias^2 / variance split of a method's error over K input seeds (metrics/error.hpp):
// outputs[t] holds frame t's K outputs. Summarised like every metric.
nlohmann::json evaluateBiasVariance(const EvaluationScene& scene, const std::vector<std::vector<Image>>& outputs,
                                    const nlohmann::json& inputSeeds);

}  // namespace arena
