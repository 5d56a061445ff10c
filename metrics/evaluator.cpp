#include "metrics/evaluator.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <exception>
#include <functional>
#include <limits>
#include <random>
#include <set>

#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/exr_io.hpp"
#include "core/hash.hpp"
#include "core/non_finite.hpp"
#include "core/sequence.hpp"
#include "metrics/error.hpp"
#include "metrics/error_maps.hpp"
#include "metrics/ghosting_intervals.hpp"

namespace arena {

using nlohmann::json;

namespace {

// An image with the reference's own noise and nothing else: an independent half-sample estimate
// when the cache has one (colorHalf: r_hat - half = (other half - half) / 2 has exactly Var(r_hat)),
// else r_hat plus Gaussian noise of the stored variance of the mean (the CLT's approximation,
// deterministic per scene). A perfect method would score this against the reference.
Image referenceNoiseImage(const LayerSet& ref, const std::string& seedName) {
  if (ref.has("colorHalf")) return ref.get("colorHalf");
  const Image &r = ref.get("color"), &var = ref.get("colorVar");
  Image out = r;
  std::mt19937_64 rng(Hasher().add("arena-floor").add(seedName).value());
  auto uniform = [&] { return (double(rng() >> 11) + 0.5) * 0x1.0p-53; };
  for (size_t i = 0; i < out.raw().size(); ++i) {
    const double z = std::sqrt(-2 * std::log(uniform())) * std::cos(2 * M_PI * uniform());  // Box-Muller
    out.raw()[i] = float(r.raw()[i] + std::sqrt(std::max(0.0f, var.raw()[i])) * z);
  }
  return out;
}

// The families that run on this scene: enabled under the options, and with a reference when they
// need one.
std::vector<const MetricFamily*> activeFamilies(const MetricOptions& options, bool hasReference) {
  std::vector<const MetricFamily*> out;
  for (const MetricFamily& f : metricFamilies())
    if (f.enabled(options) && (hasReference || !f.needsReference())) out.push_back(&f);
  return out;
}

// The families a scope measures: a screening keeps the one that measures relMseCorrected and the
// run's facts (its times, which read no pixels and which the pair's timing summary reads back).
std::vector<const MetricFamily*> familiesIn(EvaluationScope scope, std::vector<const MetricFamily*> families) {
  if (scope == EvaluationScope::Full) return families;
  std::erase_if(families, [](const MetricFamily* f) {
    return std::none_of(f->metrics.begin(), f->metrics.end(), [](const MetricDefinition& m) {
      return m.name == "relMseCorrected" || m.reads == MetricInput::Run;
    });
  });
  return families;
}

// Keeps one frame's values, notes and maps (what the families hand the evaluation). Each family
// puts only the metrics it declares: one that put another's would silently replace its values.
class FrameValues : public FrameRecorder {
 public:
  struct Value {
    double value;
    TileSums tiles;
  };
  // Runs `family` on the frame, its puts checked against its own declarations.
  void measure(const MetricFamily& f, const FrameView& v, const MetricOptions& options) {
    family_ = &f;
    f.measure(v, options, *this);
    family_ = nullptr;
  }
  void put(const std::string& metric, double value, TileSums tiles) override {
    // Its own first: a misspelt name is then said with the family's names, not only as unknown.
    if (family_) requireOwnMetric(*family_, metric);
    // Registered, so its transform and direction are known.
    const MetricDefinition& m = requireMetric(metric, "a metric family");
    requireTilesWhereDeclared(m, value, tiles);
    values[metric] = {value, std::move(tiles)};
  }
  void note(const std::string& key, double value) override { notes[key] = value; }
  void keepMap(const std::string& name, Image map) override { maps[name] = std::move(map); }
  std::map<std::string, Value> values;
  std::map<std::string, double> notes;
  std::map<std::string, Image> maps;

 private:
  const MetricFamily* family_ = nullptr;  // the family measuring now
};

// The metrics with a reference-noise floor, measured on an image that carries only the reference's
// noise (single-frame families only: a floor has no history).
std::map<std::string, double> floorsOf(const FrameView& noiseView, const MetricOptions& options) {
  std::map<std::string, double> out;
  for (const MetricFamily* f : activeFamilies(options, true)) {
    if (std::none_of(f->metrics.begin(), f->metrics.end(),
                     [](const MetricDefinition& m) { return m.floor == FloorRule::ReferenceNoise; }))
      continue;
    FrameValues values;
    values.measure(*f, noiseView, options);
    for (const MetricDefinition& m : f->metrics)
      if (m.floor == FloorRule::ReferenceNoise && values.values.count(m.name))
        out[m.name] = values.values.at(m.name).value;
  }
  return out;
}

}  // namespace

json evaluationSettings(const EvaluationOptions& options) {
  const ExposureMode exposure = options.exposure;
  return {{"warmup", options.warmup},
          {"flip", options.metrics.flip},
          {"relMseEpsilon", kRelMseEpsilon},
          {"exposure", exposureModeName(exposure)},
          {"display", std::string(exposure == ExposureMode::PerFrame
                                      ? "exposure from each frame's own reference"
                                      : "exposure from the scene's first reference") +
                          " (mean luminance -> 0.18), ACES filmic (Narkowicz 2016), clamp, sRGB"},
          {"ghosting", GhostingConfig{}.toJson()},
          {"oldViewLeak",
           "least-squares coefficient of d - r onto r(cut - 1) - r over pixels and "
           "channels (linear RGB), per frame cut..cut+5; 0 = nothing of the old "
           "view, 1 = all of it"},
          {"tRmae", "Noisebase's form without its extra division by 3"},
          {"flipPixelsPerDegree", 67}};
}

namespace {
// f(0) .. f(n - 1) on the task pool, any order; an error is the lowest index's, as a loop in order
// would have thrown it (the others' work is dropped).
void forEachIndexInParallel(int n, const std::function<void(int)>& f) {
  std::vector<std::exception_ptr> errors(size_t(std::max(n, 0)));
  tbb::parallel_for(0, n, [&](int i) {
    try {
      f(i);
    } catch (...) {
      errors[size_t(i)] = std::current_exception();
    }
  });
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}
}  // namespace

EvaluationInput readSequenceForEvaluation(const Sequence& sequence) {
  const SequenceInfo& info = sequence.info();
  EvaluationInput in;
  in.name = info.scene;
  in.referenceOfFrame = info.referenceOfFrame;
  in.referenceCapped = info.referenceCapped;
  in.events = info.events;
  if (sequence.isCapture())
    in.referenceNoiseKnown = sequence.capture().referenceHasVariance || sequence.capture().referenceHasHalf;
  // The files are read two or more at a time (reading is most of a scene's loading); counts and
  // errors are taken in frame order, as one at a time would give them.
  std::vector<NonFiniteCounts> frameCounts(size_t(info.frames));
  in.frames.resize(size_t(info.frames));
  forEachIndexInParallel(info.frames, [&](int t) {
    in.frames[size_t(t)] = sequence.frame(t);
    countNonFinite(in.frames[size_t(t)], channels::frameLayers(),
                   "frame " + std::to_string(t) + ": ", frameCounts[size_t(t)]);
    if (t > 0 && info.hasGradients)
      countNonFinite(sequence.gradients(t), channels::gradientLayers(),
                     "gradients " + std::to_string(t) + ": ", frameCounts[size_t(t)]);
  });
  for (const NonFiniteCounts& counts : frameCounts)
    for (const auto& [where, n] : counts) in.nonFinite[where] += n;
  int refs = 0;
  if (info.hasReference)
    for (int r : info.referenceOfFrame) refs = std::max(refs, r + 1);
  in.references.resize(size_t(refs));
  forEachIndexInParallel(refs,
                         [&](int r) { in.references[size_t(r)] = sequence.referenceByIndex(r); });
  for (int r = 0; r < refs; ++r) {
    const std::filesystem::path file = sequence.isCapture()
                                           ? captureReferencePath(sequence.dir(), r)
                                           : Sequence::referencePath(sequence.dir(), r);
    NonFiniteCounts bad;
    // The layers the file holds: a capture's colorVar derived from its half carries the colour's
    // NaN, which the colour already names.
    std::vector<std::string> held;
    for (const LayerSpec& spec : channels::referenceLayers())
      if (in.references[size_t(r)].has(spec.name) &&
          !(spec.name == "colorVar" && sequence.isCapture() &&
            !sequence.capture().referenceHasVariance))
        held.push_back(spec.name);
    countNonFinite(in.references[size_t(r)], channels::referenceLayers(), file.string() + ": ", bad,
                   held);
    // A non-finite reference cannot rank anything: every metric against it would be NaN or a
    // fake perfect score. The scene fails, naming the file and the channels.
    if (!bad.empty())
      throw Error(
          (sequence.isCapture() ? "capture " : "scene ") + info.scene +
          ": the reference has non-finite values (" + describeNonFinite(bad) + "); " +
          (sequence.isCapture()
               ? "a reference is scored as given, never repaired: write it again without them"
               : "check the scene's emitters and materials (a value beyond float range becomes "
                 "Inf)"));
  }
  return in;
}

EvaluationScene::EvaluationScene(EvaluationInput input, EvaluationOptions options)
    : input_(std::move(input)), options_(std::move(options)) {
  if (input_.frames.empty()) throw Error("evaluation of " + input_.name + ": the sequence has no frames");
  if (hasReference()) {
    if (input_.referenceOfFrame.size() != input_.frames.size())
      throw Error("evaluation of " + input_.name + ": " + std::to_string(input_.referenceOfFrame.size()) +
                  " frame -> reference entries for " + std::to_string(input_.frames.size()) + " frames");
    for (int r : input_.referenceOfFrame)
      if (r < 0 || size_t(r) >= input_.references.size())
        throw Error("evaluation of " + input_.name + ": frame refers to reference " + std::to_string(r) + " of " +
                    std::to_string(input_.references.size()));
    std::vector<const Image*> referenceColors;
    for (const LayerSet& r : input_.references) referenceColors.push_back(&r.get("color"));
    displays_ = displayTransforms(referenceColors, options_.exposure);
    auto budget = std::make_shared<SceneMemo::Budget>(kReferenceMemoBytes);
    for (size_t r = 0; r < input_.references.size(); ++r) {
      referenceDisplay_.push_back(displays_[r].apply(*referenceColors[r]));
      referenceMemos_.push_back(std::make_unique<SceneMemo>(budget));
    }
    for (int t = 0; t < frames(); ++t) {
      const LayerSet& ref = reference(t);
      referenceRelMse_.push_back(input_.referenceNoiseKnown ? arena::referenceRelMse(ref.get("color"), ref.get("colorVar"))
                                                            : std::numeric_limits<double>::quiet_NaN());
      Image scratch;  // the input as the denoisers read it (a NaN pixel becomes 0)
      noisyRelMse_.push_back(linearError(finiteInput(frame(t).get("color"), scratch),
                                         ref.get("color"), &ref.get("colorVar"))
                                 .relMse);
    }
  } else {
    // No reference: each frame is shown through the exposure of its own noisy input.
    std::vector<const Image*> inputs;
    for (const LayerSet& f : input_.frames) inputs.push_back(&f.get("color"));
    displays_ = displayTransforms(inputs, options_.exposure);
  }
  auto frameBudget = std::make_shared<SceneMemo::Budget>(kFrameMemoBytes);
  for (int t = 0; t < frames(); ++t)
    frameMemos_.push_back(std::make_unique<SceneMemo>(frameBudget));
  for (const SequenceEvent& e : input_.events)
    if (e.kind == EventKind::CameraCut && e.frame >= 1) cutFrames_.push_back(e.frame);
  buildEventWindows();
  if (hasReference() && input_.referenceNoiseKnown) computeFloors();
}

void EvaluationScene::buildEventWindows() {
  // Ghosting windows: [t0 - 5, t0 + 60], clipped to the sequence and ended before the next event
  // (ours: a second event would otherwise pollute the first one's steady state). A camera cut's
  // segment runs from the cut to the frame before the next event.
  const GhostingConfig gc;
  const int last = frames() - 1;
  auto endBeforeNextEvent = [&](int from, int end) {
    for (const SequenceEvent& e : input_.events)
      if (e.frame > from) end = std::min(end, e.frame - 1);
    return end;
  };
  for (const SequenceEvent& e : input_.events) {
    if (e.frame < 1) continue;
    if (e.kind == EventKind::CameraCut) {
      cuts_.push_back({e.frame, endBeforeNextEvent(e.frame, last)});
      continue;
    }
    if (!hasReference()) continue;  // the changed region is where the reference changed
    EventWindow ev;
    ev.event = e;
    ev.begin = std::max(0, e.frame - gc.before);
    ev.end = endBeforeNextEvent(e.frame, std::min(last, e.frame + gc.after));
    Image base = changedRegion(reference(e.frame).get("color"), reference(e.frame - 1).get("color"), gc,
                               &ev.chromaOnlyPixels);
    const int objectId = e.kind == EventKind::ObjectMoves ? e.meshId : -1;
    for (int t = ev.begin; t <= ev.end; ++t) {
      Image mask = base;
      if (objectId >= 0) {
        std::vector<const Image*> previous;
        for (int k = 1; k <= gc.trailFrames && t - k >= 0; ++k) previous.push_back(&frame(t - k).get("meshId"));
        addTrail(mask, objectId, previous, frame(t).get("meshId"));
      }
      ev.masks.push_back(std::move(mask));
    }
    events_.push_back(std::move(ev));
  }
}

void EvaluationScene::computeFloors() {
  // Each metric's own floor: the metric between a reference-noise-only image and the reference,
  // per distinct reference used after the warm-up, then averaged over those frames.
  std::map<std::string, std::vector<double>> floorFrames;
  std::map<size_t, std::map<std::string, double>> perReference;
  for (int t = std::max(options_.warmup, 0); t < frames(); ++t) {
    const size_t r = referenceIndex(t);
    if (!perReference.count(r)) {
      const LayerSet& ref = input_.references[r];
      const Image noise = referenceNoiseImage(ref, input_.name + "#" + std::to_string(r));
      const Image noiseDisplay = displays_[r].apply(noise);
      FrameView v;
      v.frame = t;
      v.output = &noise;
      v.outputDisplay = &noiseDisplay;
      v.guides = &frame(t);
      v.reference = &ref.get("color");
      v.referenceDisplay = &referenceDisplay_[r];
      v.referenceMemo = referenceMemos_[r].get();
      // The floor is the raw metric: no variance to correct with (the noise *is* the variance).
      perReference[r] = floorsOf(v, options_.metrics);
    }
    for (const auto& [name, v] : perReference[r]) floorFrames[name].push_back(v);
  }
  for (const auto& [name, v] : floorFrames) {
    double sum = 0;
    for (double x : v) sum += x;
    floors_[name] = sum / double(v.size());
  }
  floors_["source"] = input_.references.front().has("colorHalf") ? "independent half-sample reference"
                                                                 : "reference plus Gaussian noise of its variance";
}

json EvaluationScene::describe() const {
  std::vector<double> exposures;
  for (int t = 0; t < frames(); ++t) exposures.push_back(displays_[displayIndex(t)].exposure);
  return {{"referenceRelMse", referenceRelMse_}, {"noisyRelMse", noisyRelMse_},
          {"exposure", exposures.front()},       {"exposurePerFrame", exposures},
          {"floors", floors_},                   {"nonFiniteInputs", input_.nonFinite},
          {"warnings", warnings()}};
}

namespace {

// "frame 3", "frames 0-4, 7" (ascending frames, runs as ranges): the study's capped references are
// often the warm-up frames' alone, which no summary reads.
std::string frameRanges(const std::vector<int>& frames) {
  std::string text;
  for (size_t i = 0; i < frames.size(); ++i) {
    size_t end = i;
    while (end + 1 < frames.size() && frames[end + 1] == frames[end] + 1) ++end;
    // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on one concatenated string.
    if (!text.empty()) text += ", ";
    text += std::to_string(frames[i]);
    if (end > i) text.append("-").append(std::to_string(frames[end]));
    i = end;
  }
  return (frames.size() == 1 ? "frame " : "frames ") + text;
}

}  // namespace

std::vector<std::string> EvaluationScene::warnings() const {
  // What concerns the scene's sequence rather than one method: said once per scene, not on each
  // of its pairs (the printout and the report list it once).
  std::vector<std::string> out;
  int capped = 0;
  for (bool c : input_.referenceCapped) capped += c;
  // The first frame whose reference a figure reads: the summaries' frames from the warm-up on, the
  // temporal metrics' lags before them, an event's window before it, a cut's last old view.
  int firstRead = options_.warmup - kMaxMetricHistory;
  for (const SequenceEvent& e : input_.events)
    firstRead = std::min(firstRead,
                         e.frame - (e.kind == EventKind::CameraCut ? 1 : GhostingConfig{}.before));
  std::vector<int> frames;  // the frames the capped references serve
  bool read = false;        // ... some of them read by a figure
  for (int t = 0; capped > 0 && t < int(input_.referenceOfFrame.size()); ++t) {
    const int r = input_.referenceOfFrame[size_t(t)];
    if (r >= 0 && r < int(input_.referenceCapped.size()) && input_.referenceCapped[size_t(r)]) {
      frames.push_back(t);
      read = read || t >= firstRead;
    }
  }
  // Capped references that only warm-up frames no figure reads use (the study's refinement leaves
  // those) change no number: not said (sequence.json and scenes.<s>.referenceCapped keep them).
  if (capped > 0 && (read || frames.empty())) {
    out.push_back(
        std::to_string(capped) + " of " + std::to_string(input_.referenceCapped.size()) +
        " reference(s) stopped at the sample cap above their target relMSE (" +
        (frames.empty() ? std::string("no frame reads them") : frameRanges(frames)) +
        "; see sequence.json referenceEstimatedRelMse). Whether that matters is the "
        "scene's reference-quality verdict (results.json scenes.<scene>.referenceQuality, "
        "the report; printed when the goal is missed): met, their noise is small enough "
        "beside the methods' error to rank the scene; NOT MET, the verdict gives the "
        "`arena refine` command that extends them");
  }
  long nonFinite = 0;
  for (const auto& [where, count] : input_.nonFinite) nonFinite += count;
  if (nonFinite > 0)
    out.push_back(std::to_string(nonFinite) + " non-finite value(s) in the cached inputs (scenes." + input_.name +
                  ".nonFiniteInputs); each denoiser's reads of them were replaced by 0 (pairs[].sanitizedInputs)");
  return out;
}

// One stream's state: the frames before the current one (for temporal metrics), the series of
// every metric, and the event and cut curves with their tile sums.
struct PairEvaluation::State {
  const EvaluationScene& scene;
  EvaluationScope scope;
  std::vector<const MetricFamily*> families;
  struct Kept {  // what a later frame's metrics read of an earlier one
    Image output, display, error;
    FrameView view;
  };
  std::deque<std::unique_ptr<Kept>> history;  // front = the newest
  PairSeries series;
  json frames = json::array();
  int nextFrame = 0;
  std::vector<std::vector<double>> eventCurves, eventBias, eventChroma, cutLeak;
  // The per-tile sums behind the event and cut curves: their intervals' spatial blocks
  // (metrics/ghosting_intervals.hpp).
  std::vector<EventTiles> eventTiles;
  std::vector<CutTiles> cutTiles;
  std::map<std::string, Image> lastMaps;
  // Frames whose output equals the reference value for value while the input does not: a perfect
  // score no denoiser computes from its input (a stored output wired to the reference).
  std::vector<int> equalsReference;
  // Frames after the warm-up with a signal whose input differs from the reference (where an output
  // equal to the reference is no denoiser's), and how many of them the output equals.
  int comparableScored = 0, equalScored = 0;
  State(const EvaluationScene& s, EvaluationScope sc)
      : scene(s),
        scope(sc),
        families(familiesIn(sc, activeFamilies(s.options().metrics, s.hasReference()))),
        series(s.frames(), s.options().warmup),
        eventCurves(s.events_.size()),
        eventBias(s.events_.size()),
        eventChroma(s.events_.size()),
        cutLeak(s.cuts_.size()),
        eventTiles(s.events_.size()),
        cutTiles(s.cuts_.size()) {}
};

PairEvaluation::PairEvaluation(const EvaluationScene& scene, EvaluationScope scope)
    : state_(std::make_unique<State>(scene, scope)) {}
PairEvaluation::~PairEvaluation() = default;

void PairEvaluation::add(int t, const Image& output, const FrameFacts& facts) {
  State& s = *state_;
  const EvaluationScene& scene = s.scene;
  if (t != s.nextFrame)
    throw Error("evaluation of " + scene.name() + ": frame " + std::to_string(t) + " arrived, expected frame " +
                std::to_string(s.nextFrame) + " (frames must arrive in order)");
  if (t >= scene.frames())
    throw Error("evaluation of " + scene.name() + ": frame " + std::to_string(t) + " beyond the sequence's " +
                std::to_string(scene.frames()) + " frames");
  const Image& input = scene.frame(t).get("color");
  if (!output.sameShape(input))
    throw Error("evaluation of " + scene.name() + ", frame " + std::to_string(t) + ": the output is " +
                std::to_string(output.width()) + "x" + std::to_string(output.height()) + "x" +
                std::to_string(output.channels()) + ", the sequence's colour is " + std::to_string(input.width()) +
                "x" + std::to_string(input.height()) + "x" + std::to_string(input.channels()));
  ++s.nextFrame;
  const bool full = s.scope == EvaluationScope::Full;
  auto kept = std::make_unique<State::Kept>();
  kept->output = output;
  if (full) kept->display = scene.display(t, output);
  FrameView& v = kept->view;
  v.frame = t;
  v.output = &kept->output;
  v.outputDisplay = full ? &kept->display : nullptr;
  v.guides = &scene.frame(t);
  v.frameMemo = scene.frameMemos_[size_t(t)].get();
  v.facts = facts;
  v.cutFrames = scene.cutFrames_;
  for (const auto& h : s.history) v.history.push_back(&h->view);
  const Image* r = nullptr;
  if (scene.hasReference()) {
    const LayerSet& ref = scene.reference(t);
    r = &ref.get("color");
    v.reference = r;
    v.referenceVariance = &ref.get("colorVar");
    v.referenceDisplay = &scene.referenceDisplay(t);
    v.referenceMemo = scene.referenceMemos_[scene.referenceIndex(t)].get();
    kept->error = Image(output.width(), output.height(), 3);
    bool same = true,
         signal = false;  // a black reference equals any black output: no verdict there
    for (size_t i = 0; i < kept->error.raw().size(); ++i) {
      kept->error.raw()[i] = output.raw()[i] - r->raw()[i];
      same = same && kept->error.raw()[i] == 0.0f;
      signal = signal || r->raw()[i] != 0.0f;
    }
    if (same && signal && scene.noisyRelMse_[size_t(t)] != 0) s.equalsReference.push_back(t);
    if (signal && scene.noisyRelMse_[size_t(t)] != 0 && t >= scene.options().warmup) {
      ++s.comparableScored;
      s.equalScored += same;
    }
    v.error = &kept->error;
    v.noisyRelMse = scene.noisyRelMse_[size_t(t)];
    v.referenceRelMse = scene.referenceRelMse_[size_t(t)];
  }

  FrameValues values;
  for (const MetricFamily* f : s.families) values.measure(*f, v, scene.options().metrics);
  json m = {{"frame", t}};
  for (auto& [name, value] : values.values) {
    m[name] = std::isfinite(value.value) ? json(value.value) : json(nullptr);
    if (name == "relMse")
      for (size_t k = 0; k < scene.cuts_.size(); ++k)
        if (t >= scene.cuts_[k].frame && t <= scene.cuts_[k].segmentEnd) s.cutTiles[k].relMse.add(t, value.tiles);
    s.series.record(name, t, value.value, std::move(value.tiles), findMetric(name)->transform);
  }
  for (const auto& [key, value] : values.notes) m[key] = value;
  s.frames.push_back(m);
  s.lastMaps = std::move(values.maps);
  if (!full) return;  // a screening's one family reads the frame alone: no history, events or cuts

  // The event windows: relMSE, signed bias and chromaticity error inside each event's mask.
  const GhostingConfig gc;
  for (size_t k = 0; k < scene.events_.size(); ++k) {
    const auto& ev = scene.events_[k];
    if (t < ev.begin || t > ev.end) continue;
    const Image& mask = ev.masks[size_t(t - ev.begin)];
    ErrorTiles inMask;
    TileSums biasTiles;
    s.eventCurves[k].push_back(linearError(output, *r, v.referenceVariance, &mask, kRelMseEpsilon, &inMask).relMse);
    s.eventBias[k].push_back(signedBias(output, *r, mask, gc.eps, &biasTiles));
    s.eventTiles[k].curve.add(t, std::move(inMask.relMse));
    s.eventTiles[k].bias.add(t, std::move(biasTiles));
    ColourTileSums colourTiles;
    s.eventChroma[k].push_back(chromaticityError(output, *r, mask, &colourTiles));
    s.eventTiles[k].addColour(t, std::move(colourTiles));
  }
  // Camera cuts: how much of the old view survives in the frames after the cut.
  if (r)
    for (size_t k = 0; k < scene.cuts_.size(); ++k) {
      const auto& cut = scene.cuts_[k];
      if (t >= cut.frame && t <= std::min(cut.frame + gc.recoveryFrames, cut.segmentEnd)) {
        TileSums leakTiles;
        s.cutLeak[k].push_back(oldViewLeak(output, *r, scene.reference(cut.frame - 1).get("color"), &leakTiles));
        s.cutTiles[k].leak.add(t, std::move(leakTiles));
      }
    }

  s.history.push_front(std::move(kept));
  if (s.history.size() > size_t(kMaxMetricHistory)) s.history.pop_back();
  // The views still kept point at frames still kept; refresh each one's own history list.
  for (size_t i = 0; i < s.history.size(); ++i) {
    FrameView& hv = s.history[i]->view;
    hv.history.clear();
    for (size_t j = i + 1; j < s.history.size(); ++j) hv.history.push_back(&s.history[j]->view);
  }
}

FrameImages PairEvaluation::lastImages() const {
  const State& s = *state_;
  if (s.scope != EvaluationScope::Full)
    throw Error("evaluation of " + s.scene.name() + ": a screening keeps no images (evaluate in full)");
  if (s.history.empty()) throw Error("evaluation of " + s.scene.name() + ": no frame added yet");
  const State::Kept& k = *s.history.front();
  FrameImages out;
  out.display = k.display;
  if (auto it = s.lastMaps.find("ldrFlip"); it != s.lastMaps.end()) out.flip = applyColorMap(it->second, magmaColorMap());
  if (k.view.reference) {
    out.relativeSquaredError = relativeSquaredError(k.output, *k.view.reference);
    out.relativeError = relativeErrorMap(out.relativeSquaredError);
  }
  return out;
}

std::vector<double> PairEvaluation::values(const std::string& metric) const { return state_->series.values(metric); }

void markUnrecorded(json& summary, const std::vector<const MetricFamily*>& families,
                    const MetricOptions& options, bool hasReference) {
  for (const MetricFamily* f : families)
    for (const MetricDefinition& m : f->metrics)
      if (m.reads != MetricInput::Run && !m.frameScalar && !summary.contains(m.name) &&
          (hasReference || !m.needsReference) && (!m.computedUnder || m.computedUnder(options)))
        summary[m.name] = {{"frames", 0},
                           {"absent",
                            "no frame recorded a value of it: its family ran and never "
                            "put it (undefined on every frame, or a family that does "
                            "not record what it declares)"}};
}

json PairEvaluation::finish() {
  State& s = *state_;
  const EvaluationScene& scene = s.scene;
  const int warmup = scene.options().warmup;
  if (s.nextFrame != scene.frames())
    throw Error("evaluation of " + scene.name() + ": " + std::to_string(s.nextFrame) + " of " +
                std::to_string(scene.frames()) + " frames arrived");
  const size_t pixels = size_t(scene.frame(0).get("color").width()) * size_t(scene.frame(0).get("color").height());
  json summary = s.series.summaries(scene.name());
  markUnrecorded(summary, s.families, scene.options().metrics, scene.hasReference());
  const GhostingConfig gc;
  const bool full = s.scope == EvaluationScope::Full;
  json ghosting = json::array();
  std::vector<std::string> emptyEvents;
  int unsettledEvent = -1;  // the previous event, when this method never settled after it
  double unsettledBiasPre = 0;  // |b_M| before that event: the method's own offset then
  for (size_t k = 0; full && k < scene.events_.size(); ++k) {
    const auto& ev = scene.events_[k];
    GhostingResult g =
        analyseGhosting(ev.event.frame, ev.begin, s.eventCurves[k], s.eventBias[k], s.eventChroma[k], gc);
    double maskPixels = 0;
    for (float v : ev.masks[size_t(ev.event.frame - ev.begin)].raw()) maskPixels += v;
    g.maskFraction = maskPixels / double(pixels);
    g.maskChromaFraction = double(ev.chromaOnlyPixels) / double(pixels);
    json j = g.toJson();
    j["kind"] = eventKindName(ev.event.kind);
    j["what"] = ev.event.what;
    // No pixel changed: the curve and every figure over the region would read 0, a flawless
    // response measured on nothing. Too few frames from the event on: a response of 0 frames and
    // no ghost energy, measured on the event frame alone. The figures are null, with the reason
    // (the ranking has no data either: the intervals say the same).
    const std::string absent =
        maskPixels == 0
            ? "the changed region is empty at frame " + std::to_string(ev.event.frame) +
                  ": the reference does not change there, so there is no response to measure"
            : ghostingWindowProblem(ev.event.frame, ev.end, gc);
    if (!absent.empty()) {
      for (const char* figure :
           {"steadyState", "steadyBegin", "peakExcess", "ghostEnergy", "signedBias", "biasPre",
            "lagEnergy", "settled", "responseFrames", "chromaPre", "chromaLagEnergy"})
        if (j.contains(figure)) j[figure] = nullptr;
      if (maskPixels == 0)  // curves over an empty region are no measurement either
        for (const char* curve : {"curve", "bias", "chromaError"})
          if (j.contains(curve)) j[curve] = nullptr;
      j.erase("response");
      j.erase("steadyAbsent");  // `absent` covers every figure
      j["absent"] = absent;
      emptyEvents.push_back("event at frame " + std::to_string(ev.event.frame) + ": " + absent);
    }
    const BootstrapConfig bc;
    FigureReplicates replicates = ghostingReplicates(
        ev.event.frame, s.eventTiles[k], eventSeedName(scene.name(), ev.event.frame), bc, gc);
    // Still lagging from the previous event when this one comes (it never settled, and b_pre
    // here exceeds its b_pre before that event by more than the settle threshold): the lag
    // figures would be measured against that offset, and an error that never rises above it reads
    // as lag energy 0, the best score. Undefined instead, with the reason. A steady offset (a
    // spatial filter's bias, the same before both events, which "never settles" under the
    // absolute threshold) is what b_pre subtracts, and stays.
    if (absent.empty() && unsettledEvent >= 0 && g.biasPre > unsettledBiasPre + gc.biasThreshold) {
      char text[360];
      std::snprintf(text, sizeof text,
                    "the method never settled after the event at frame %d, and |b_M| before this "
                    "one was %.3g, %.3g before that one (more than the settle threshold %.3g "
                    "apart): its lag here is measured against that earlier lag, and an error that "
                    "stays under it would read as lag energy 0",
                    unsettledEvent, g.biasPre, unsettledBiasPre, gc.biasThreshold);
      j["lagAbsent"] = text;
      for (const char* figure : {"lagEnergy", "chromaLagEnergy"})
        if (j.contains(figure)) {
          j[figure] = nullptr;
          replicates.absent[figure] = text;
        }
    }
    unsettledEvent = absent.empty() && !g.settled ? ev.event.frame : -1;
    unsettledBiasPre = g.biasPre;
    addFigureIntervals(j, replicates, ghostingFigures(g), bc.confidence);
    j["tiles"] = s.eventTiles[k].toJson();
    ghosting.push_back(j);
  }
  json cuts = json::array();
  if (full && scene.hasReference())
    for (size_t k = 0; k < scene.cuts_.size(); ++k) {
      const auto& cut = scene.cuts_[k];
      const CutResult c = analyseCut(cut.frame, cut.segmentEnd, s.series.values("relMse"), s.cutLeak[k], gc);
      json j = c.toJson();
      const BootstrapConfig bc;
      addFigureIntervals(j,
                         cutReplicates(cut.frame, cut.segmentEnd, s.cutTiles[k], cutSeedName(scene.name(), cut.frame),
                                       bc, gc),
                         cutFigures(c, gc), bc.confidence);
      j["tiles"] = s.cutTiles[k].toJson();
      cuts.push_back(j);
    }
  // An output that is its reference on every frame scored is no measurement of a denoiser: its
  // perfect score would rank first (a stored output wired to the reference). The pair fails.
  if (s.comparableScored > 0 && s.equalScored == s.comparableScored)
    throw Error("the output equals its reference value for value on every frame scored (" +
                frameRanges(std::vector<int>(
                    std::lower_bound(s.equalsReference.begin(), s.equalsReference.end(), warmup),
                    s.equalsReference.end())) +
                ") while the input does not: a perfect score no denoiser computes from its input; "
                "is the reference wired in as the output?");
  json warnings = json::array();
  if (!s.equalsReference.empty())
    warnings.push_back(
        kEqualsReferenceWarning + frameRanges(s.equalsReference) +
        " while the input does not: a perfect score there that no denoiser computes from its "
        "input (is the reference wired in as the output?)");
  for (const std::string& e : emptyEvents) warnings.push_back(e);
  for (auto it = summary.begin(); it != summary.end(); ++it)
    if (it.value().contains("absent"))
      warnings.push_back(it.key() + " has no summary: " + it.value()["absent"].get<std::string>());
  if (scene.hasReference()) {
    const double refFloor = summarize(scene.referenceRelMse_, warmup).mean;
    if (summary.contains("relMse") && summary["relMse"].contains("mean") &&
        summary["relMse"]["mean"].get<double>() < 10.0 * refFloor)
      warnings.push_back(
          "relMSE is within 10x of the reference's own noise floor (" + std::to_string(refFloor) +
          "): much of it is the reference's noise, which widens the ranking's intervals and pulls "
          "ratios between methods (the overall score) towards 1; relMseCorrected removes it on "
          "average, a better reference removes it");
  }
  // Metrics that cannot be corrected for the reference's noise (the perceptual ones): warn within
  // their declared factor of their own floor.
  for (const MetricDefinition* m : metricCatalog()) {
    if (m->floorWarningFactor <= 0 || !scene.floors_.contains(m->name) || !summary.contains(m->name) ||
        !summary[m->name].contains("mean"))
      continue;
    const double floor = scene.floors_[m->name], value = summary[m->name]["mean"];
    // Distances from the perfect score (1 for SSIM: "0.59 within 2x of 0.79" read as nonsense).
    const auto fromPerfect = [&](double v) {
      const auto g4 = [](double x) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%.4g", x);
        return std::string(buf);
      };
      return m->perfect == 0 ? g4(v)
                             : g4(v) + ", " + g4(std::abs(v - m->perfect)) + " from a perfect " +
                                   g4(m->perfect);
    };
    if (std::abs(value - m->perfect) < m->floorWarningFactor * std::abs(floor - m->perfect))
      warnings.push_back(m->name + " (" + fromPerfect(value) + ") is within " +
                         std::to_string(int(m->floorWarningFactor)) +
                         "x of the reference's own floor (" + fromPerfect(floor) +
                         "): the reference's noise, not the method, dominates it");
  }
  json out = {{"frames", s.frames}, {"summary", summary}, {"tiles", s.series.tilesJson()}, {"warnings", warnings}};
  if (full) {
    out["ghosting"] = ghosting;
    out["cuts"] = cuts;
  }
  return out;
}

json timingSummary(const std::vector<std::vector<PassTime>>& passesPerFrame, const std::vector<double>& ms, int warmup,
                   int width, int height) {
  json passes = json::array();
  // Times are summarised over t >= W like every metric: with no frame left there is no time (the
  // warm-up's first frames, allocation and cold caches included, would pass for one).
  if (int(ms.size()) <= warmup)
    return {{"absent", "no frame after the warm-up: the sequence has " + std::to_string(ms.size()) +
                           " frames, the warm-up is " + std::to_string(warmup)},
            {"passes", passes}};
  if (!passesPerFrame.empty()) {
    const auto& names = passesPerFrame.back();
    for (size_t p = 0; p < names.size(); ++p) {
      std::vector<double> v;
      double taps = names[p].tapsPerPixel;
      for (const auto& f : passesPerFrame)
        if (p < f.size() && f[p].name == names[p].name) v.push_back(f[p].milliseconds);
      Summary s = summarize(v, warmup);
      if (s.empty()) continue;  // a pass not run after the warm-up
      json pass = {{"name", names[p].name}, {"msMedian", s.median}, {"msP95", s.p95}};
      if (std::isfinite(taps)) pass["tapsPerPixel"] = taps;  // NaN: not reported (a process's)
      passes.push_back(pass);
    }
  }
  Summary total = summarize(ms, warmup);
  double taps = 0;
  bool tapsKnown = true;  // a pass of unknown taps leaves the total unknown, never a low count
  for (const json& p : passes)
    if (p.contains("tapsPerPixel"))
      taps += p["tapsPerPixel"].get<double>();
    else
      tapsKnown = false;
  json out = {{"msMedian", total.median},
              {"msP5", total.p5},
              {"msP95", total.p95},
              {"msMean", total.mean},
              {"msPerMegapixel", total.median / (double(width) * height * 1e-6)},
              {"passes", passes}};
  if (tapsKnown) out["tapsPerPixel"] = taps;
  return out;
}

json evaluateBiasVariance(const EvaluationScene& scene, const std::vector<std::vector<Image>>& outputs,
                          const json& inputSeeds) {
  if (!scene.hasReference()) throw Error("bias/variance of " + scene.name() + ": needs a reference");
  if (int(outputs.size()) != scene.frames())
    throw Error("bias/variance of " + scene.name() + ": outputs for " + std::to_string(outputs.size()) + " of " +
                std::to_string(scene.frames()) + " frames");
  PairSeries series(scene.frames(), scene.options().warmup);
  json frames = json::array();
  for (int t = 0; t < scene.frames(); ++t) {
    std::vector<const Image*> out;
    for (const Image& i : outputs[size_t(t)]) out.push_back(&i);
    const LayerSet& ref = scene.reference(t);
    BiasVarianceTiles tiles;
    const BiasVariance bv = biasVariance(out, ref.get("color"), &ref.get("colorVar"), kRelMseEpsilon, &tiles);
    series.record("bias2", t, bv.bias2, std::move(tiles.bias2), FrameTransform::Mean);
    series.record("bias2Corrected", t, bv.bias2Corrected, std::move(tiles.bias2Corrected), FrameTransform::Mean);
    series.record("variance", t, bv.variance, std::move(tiles.variance), FrameTransform::Mean);
    frames.push_back({{"frame", t}, {"bias2", bv.bias2}, {"bias2Corrected", bv.bias2Corrected}, {"variance", bv.variance}});
  }
  return {{"seeds", outputs.empty() ? 0 : int(outputs.front().size())}, {"inputSeeds", inputSeeds},
          {"definition", "relMSE units: bias2 + variance = mean relMSE over the seeds; bias2Corrected subtracts "
                         "the reference's own noise term"},
          {"frames", frames}, {"summary", series.summaries(scene.name())}};
}

}  // namespace arena
