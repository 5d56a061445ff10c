#pragma once
// How a run measured (results.json "settings"): the sequence settings that identify its renders
// (tracer/render.hpp RenderSettings::pixelSettings, less each scene's size), the evaluation's
// settings (metrics/evaluator.hpp evaluationSettings: warm-up, FLIP, exposure, the ghosting
// thresholds and what each figure means), the preset, the input seeds, the shard and the captured
// sequences it ranked.
//
// Kept as the record the run wrote -- `arena compare` lists every difference between two records
// and the report shows it as it is -- and checked once when read: every field this version writes
// must have its type (an integer where frames are counted, an object where one belongs), and a
// field it does not write is an error naming its JSON path. Readers take the accessors, never a
// field of the record, so a misshapen record fails when read and not later with a JSON type error.
#include <nlohmann/json.hpp>
#include <string>

namespace arena {

class RunSettings {
 public:
  RunSettings() = default;
  // `file`: the name errors give; the record's JSON path is `path`.
  static RunSettings fromJson(const nlohmann::json& j, const std::string& file,
                              const std::string& path = "$.settings");
  const nlohmann::json& toJson() const { return record_; }

  int warmup() const;          // frames before the summaries start (8 where the record has none)
  int seeds() const;           // input seeds per scene (1 where none)
  std::string shard() const;   // "i/n", or "merged"; empty where none
  void setShard(const std::string& shard);
  // The sequence settings (an object; empty where the run rendered nothing, e.g. captures only).
  const nlohmann::json& render() const;
  // The record less the shard: what the shards of one run share, and what compare compares.
  nlohmann::json measurement() const;

 private:
  nlohmann::json record_ = nlohmann::json::object();
};

}  // namespace arena
