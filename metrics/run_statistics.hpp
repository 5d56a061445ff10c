#pragma once
// The statistics of a run as a typed model (results.json "statistics", docs/usage.md): per scene
// the ranking with ties and every paired difference on the run's ranked metric (relMSE), on the
// other ranked metrics, and on every figure of every scripted event and camera cut; the overall
// score across scenes; and the extra paths each method read. analyseRun builds it, RunResults
// carries it, and every reader (printouts, report, SQLite, rank agreement) takes it from here.
//
// fromJson checks the block's shape once, naming the JSON path of anything out of place (a missing
// or misspelt field, a count that disagrees with its list, a "resolved" flag its interval
// contradicts); toJson writes the same block back, byte for byte once dumped.
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "metrics/statistics.hpp"

namespace arena {

// statistics.scenes.<scene>.events[] / .cuts[]: one scripted event or camera cut (matched by its
// frame across the scene's pairs), ranked on each of its figures (metrics/ghosting_intervals.hpp).
struct EventStatistics {
  int eventFrame = -1;
  std::string kind;                               // the event's kind; cuts: "camera_cut"
  std::string what;                               // the object an event concerns (cuts: none)
  std::map<std::string, SceneRanking> byFigure;   // figure -> ranking with ties
};

// statistics.scenes.<scene>: the ranking on the run's ranked metric (written at the scene's top
// level), the other ranked metrics' rankings, and the event figures'.
struct SceneStatistics {
  SceneRanking ranking;                           // on RunStatistics::rankedOn
  std::map<std::string, SceneRanking> byMetric;   // metric -> ranking
  std::vector<EventStatistics> events, cuts;

  // f(event, isCut) for the scripted events, then the camera cuts.
  template <class F>
  void forEachEvent(F&& f) const {
    for (const EventStatistics& e : events) f(e, false);
    for (const EventStatistics& e : cuts) f(e, true);
  }
  template <class F>
  void forEachEvent(F&& f) {
    for (EventStatistics& e : events) f(e, false);
    for (EventStatistics& e : cuts) f(e, true);
  }
};

struct RunStatistics {
  std::string method;          // how the intervals were drawn, in words
  double confidence = 0.95;
  int replicates = 0;
  TileGrid tileGrid;
  std::string rankedOn = "relMse";
  std::map<std::string, SceneStatistics> scenes;
  // The overall score on rankedOn across scenes (absent: no scene ranked), and on the other
  // metrics that declare one (metric_registry: MetricDefinition::overall).
  std::optional<OverallRanking> overall;
  std::map<std::string, OverallRanking> overallByMetric;
  // Paths per pixel per frame each label read beyond the frame's own 1-spp paths (mean over its
  // scenes; only labels that read any), and what that means. Every ranking entry of such a label
  // carries its figure too (RankedMethod::extraPathsPerPixel).
  std::map<std::string, double> extraPathsPerPixel;
  std::string extraPathsMeaning;
  // The oracle layers each label read on any scene (pairs[].oracleLayers; only labels that read
  // any), and what that means. Every ranking entry of such a label names them too
  // (RankedMethod::oracleLayers).
  std::map<std::string, std::vector<std::string>> oracleLayers;
  std::string oracleMeaning;

  // `file`: the name errors give; the block's JSON path is `path`.
  static RunStatistics fromJson(const nlohmann::json& j, const std::string& file,
                                const std::string& path = "$.statistics");
  nlohmann::json toJson() const;

  // The ranking of `scene` on `metric` (rankedOn or one of byMetric), or null.
  const SceneRanking* ranking(const std::string& scene, const std::string& metric) const;
};

// Builds the statistics of a results document (its "pairs": each ok pair's "tiles", its event and
// cut figures with their tiles, its extraRaysPerPixel summary); a pair without tiles is excluded
// and named.
RunStatistics analyseRun(const nlohmann::json& results, const BootstrapConfig& cfg = {});

}  // namespace arena
