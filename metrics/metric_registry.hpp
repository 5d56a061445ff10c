#pragma once
// The metric registry: every metric the arena reports is declared once, in the file that computes
// it, and defined in docs/metrics.md. The catalogue (`arena metrics`), compare, statistics, the
// SQLite schema, the report's columns and the printouts read these declarations; nothing else
// lists metrics or says which direction is better.
//
// A metric family is one computation that yields one or more metrics (linearError gives relMSE,
// its corrected form, MSE and RMSE at once). A family sees one output frame at a time through a
// FrameView (and the frames before it through FrameView::previous) and records values with the
// per-tile sums behind them (metrics/tiles.hpp) into a FrameRecorder. Adding a metric's code is one
// file with its family function plus its declaration and entry in metric_registry.cpp; with its
// definition in docs/metrics.md and its tests, docs/extending.md lists the five places.
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <typeindex>
#include <typeinfo>
#include <vector>

#include "core/exr_io.hpp"
#include "core/image.hpp"
#include "metrics/statistics.hpp"
#include "metrics/tiles.hpp"

namespace arena {

enum class Better { Lower, Higher };
// What a metric reads: linear HDR values, the display image (core/display.hpp: exposure from the
// reference, ACES, sRGB), or facts of the run (time, extra paths) rather than pixels.
enum class MetricInput { Linear, Display, Run };
// A metric's floor: what a perfect method would score against a reference that carries noise.
enum class FloorRule {
  None,            // no floor: a run fact, already corrected for the reference's noise, or no reference
  ReferenceNoise,  // the metric of an image with the reference's own noise and nothing else
};
// Which per-frame chart of the report offers a metric: the error over time, the temporal
// (flicker) over time, or none.
enum class ReportChart { None, Error, Temporal };

struct MetricOptions;

struct MetricDefinition {
  std::string name;
  std::string unit;  // "" for dimensionless
  Better better = Better::Lower;
  bool needsReference = true;
  MetricInput reads = MetricInput::Linear;
  // A frame's scalar derived from the images (effectiveSpp from relMSE), recorded without tile
  // sums: its interval resamples frames only. Every other metric of the images is put with its
  // tile sums (the evaluation refuses one without: its interval would be several times too narrow).
  bool frameScalar = false;
  // Whether its family computes it under these options, where that is narrower than the family's
  // own `enabled` (hdrFlip: only under --flip all); empty: whenever the family runs. A metric of
  // the images its family ran for and never put on any frame is recorded absent, with the reason.
  std::function<bool(const MetricOptions&)> computedUnder;
  FrameTransform transform = FrameTransform::Mean;  // how a frame's tile sums become its value
  FloorRule floor = FloorRule::None;
  // > 0: a summary within this factor of the floor is flagged (the reference's noise, not the
  // method, dominates it), measured as the distance from `perfect`.
  double floorWarningFactor = 0;
  double perfect = 0;  // the value of an output equal to the reference (for the floor warning)
  bool ranked = false;  // statistics ranks every scene on it with paired differences
  bool gatedByDefault = false;  // `arena compare` checks it when no --metric is given
  // statistics scores every method across scenes on it (geometric mean of ratios to a baseline,
  // with an interval): the one overall score the printout and the report's all-scenes chart show.
  bool overall = false;
  // The report: a table column shown before the reader picks any, the per-frame chart that offers
  // it, and its label there (empty: the name).
  bool reportColumn = false;
  ReportChart chart = ReportChart::None;
  std::string title;
  std::string description;  // one line; docs/metrics.md has the definition
  bool lowerIsBetter() const { return better == Better::Lower; }
  const char* betterName() const { return better == Better::Lower ? "lower" : "higher"; }
};

// Facts of one frame's run that are not pixels: the denoiser's time, and the extra paths it read.
struct FrameFacts {
  double milliseconds = 0;
  std::optional<double> wallMilliseconds;   // an external process timed itself; the harness's clock
  // Paths beyond the frame's own 1-spp ones that the denoiser read, per pixel (readers only):
  // reengine's low-resolution disocclusion rays, A-SVGF's re-shaded gradient samples.
  std::optional<double> extraRaysPerPixel;
  double extraPathsPerSecond = 0;  // the render rate of those paths (0: unknown)
};

// What families derive from a scene's own data alone, kept for every output evaluated against it:
// from a reference (FLIP's filtered reference planes) or from a frame's input layers (the
// stability metric's paths back through the motion layers). Made on first use under `key`, then
// shared. An evaluation scene keeps one memo per reference and one per frame for all its pairs;
// each kind's memos share one byte budget: a value that does not fit is made, used and dropped as
// before (a scene of many large references keeps what fits). A value is made outside the lock (it
// may run parallel loops); T says its size with `size_t bytes() const` and must not point into
// anything that moves with the scene.
class SceneMemo {
 public:
  // Bytes left to the memos that share it.
  struct Budget {
    explicit Budget(size_t bytes) : left(bytes) {}
    std::mutex mutex;
    size_t left;
  };
  explicit SceneMemo(std::shared_ptr<Budget> budget) : budget_(std::move(budget)) {}

  template <class T, class Make>
  std::shared_ptr<const T> get(const std::string& key, const Make& make) const {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (auto it = items_.find(key); it != items_.end()) return cast<T>(key, it->second);
    }
    auto value = std::make_shared<const T>(make());
    std::lock_guard<std::mutex> lock(mutex_);
    if (auto it = items_.find(key); it != items_.end())
      return cast<T>(key, it->second);  // made meanwhile
    if (budget_ && take(value->bytes()))
      items_.emplace(key, Item{std::type_index(typeid(T)), value});
    return value;
  }

 private:
  struct Item {
    std::type_index type;
    std::shared_ptr<const void> value;
  };
  template <class T>
  static std::shared_ptr<const T> cast(const std::string& key, const Item& item) {
    if (item.type != std::type_index(typeid(T)))
      throw std::logic_error("SceneMemo: \"" + key + "\" holds another type");
    return std::static_pointer_cast<const T>(item.value);
  }
  bool take(size_t bytes) const {
    std::lock_guard<std::mutex> lock(budget_->mutex);
    if (bytes > budget_->left) return false;
    budget_->left -= bytes;
    return true;
  }
  std::shared_ptr<Budget> budget_;
  mutable std::mutex mutex_;
  mutable std::map<std::string, Item> items_;
};

// What a metric family sees of one output frame. Pointers to reference images are null when the
// sequence has no reference (a capture without one): families that need it are not asked then.
struct FrameView {
  int frame = 0;
  const Image* output = nullptr;         // d_t, linear RGB
  const Image* outputDisplay = nullptr;  // d_t through the frame's display transform
  const LayerSet* guides = nullptr;      // the input's layers at t (noisy colour, normal, depth, motion, meshId)
  const Image* reference = nullptr;      // r_t
  const Image* referenceVariance = nullptr;  // Var(r_t), the variance of the reference's mean
  const Image* referenceDisplay = nullptr;
  const SceneMemo* referenceMemo = nullptr;  // r_t's; null: nothing is kept between outputs
  const SceneMemo* frameMemo = nullptr;      // frame t's input layers'; null: likewise
  const Image* error = nullptr;          // d_t - r_t
  double noisyRelMse = kUndefined;       // relMSE of the 1-spp input against r_t
  double referenceRelMse = kUndefined;   // the reference's own estimated relMSE
  FrameFacts facts;
  // The view of frame t - lag (1 <= lag <= kMaxMetricHistory), or null before the first frame.
  const FrameView* previous(int lag) const;
  // Whether a camera cut falls in frames t - lag + 1 .. t (the view changed within the lag).
  bool cutWithin(int lag) const;

  std::vector<const FrameView*> history;  // history[k - 1] = frame t - k
  std::vector<int> cutFrames;
};
constexpr int kMaxMetricHistory = 3;

// The options every family may read (the run's settings).
struct MetricOptions {
  std::string flip = "all";  // none | ldr | all (LDR + HDR)
};

// Where a family puts its values. Each metric's frame transform comes from its declaration.
class FrameRecorder {
 public:
  virtual ~FrameRecorder() = default;
  // A metric's value at this frame, with its tile sums (empty: a scalar per frame). A metric not
  // put on a frame is undefined there (flicker on frame 0); a non-finite value is counted.
  virtual void put(const std::string& metric, double value, TileSums tiles = {}) = 0;
  // A per-frame figure kept beside the metrics in results.json (not summarised).
  virtual void note(const std::string& key, double value) = 0;
  // A per-pixel map of this frame kept for people (the report's FLIP image).
  virtual void keepMap(const std::string& name, Image map) = 0;
};

struct MetricFamily {
  std::vector<MetricDefinition> metrics;
  // Whether the family runs under these options (e.g. FLIP only when --flip asks for it).
  std::function<bool(const MetricOptions&)> enabled = [](const MetricOptions&) { return true; };
  std::function<void(const FrameView&, const MetricOptions&, FrameRecorder&)> measure;
  // Whether every metric of the family needs a reference (then it does not run without one).
  bool needsReference() const;
};

// Every family, in registration order (metric_registry.cpp), checked once: each metric declared
// once, its name an identifier, its description given (an Error names the first that is not).
const std::vector<MetricFamily>& metricFamilies();
// That check, on any list of families.
void checkFamilies(const std::vector<MetricFamily>& families);
// An Error unless `family` declares `metric`: a family puts only its own metrics (one that put
// another's would silently replace that family's values).
void requireOwnMetric(const MetricFamily& family, const std::string& metric);
// Whether a run records `m` with its tile sums: a metric of the images (not a run fact, not a
// frameScalar), whose interval resamples tiles.
bool recordedWithTiles(const MetricDefinition& m);
// An Error unless a value of `m` comes with its tile sums where recordedWithTiles(m): without
// them its interval would resample frames only.
void requireTilesWhereDeclared(const MetricDefinition& m, double value, const TileSums& tiles);
// Every metric, in registration order.
std::vector<const MetricDefinition*> metricCatalog();
// The declaration of `name`, or null.
const MetricDefinition* findMetric(const std::string& name);
// The declaration of `name`; an Error listing the valid names when there is none (`what` says who asked).
const MetricDefinition& requireMetric(const std::string& name, const std::string& what);
// The catalogue as JSON: one object per metric with every declared field.
nlohmann::json metricCatalogJson();

}  // namespace arena
