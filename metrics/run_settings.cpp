#include "metrics/run_settings.hpp"

#include <cstdint>

#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "metrics/summary.hpp"

namespace arena {

using nlohmann::json;

namespace {

// Each field is optional (a run records what applied to it: no "captures" without captures, no
// "lowresFactor" without the buffer); where present it must have its type.
void text(JsonReader& r, const char* key) {
  if (r.has(key)) r.string(key);
}
void count(JsonReader& r, const char* key, long long lo) {
  if (r.has(key)) r.integerIn(key, lo, JsonReader::kIntMax);
}
void number(JsonReader& r, const char* key) {
  if (r.has(key)) r.number(key);
}

}  // namespace

RunSettings RunSettings::fromJson(const json& j, const std::string& file, const std::string& path) {
  if (!j.is_object()) throw Error(file + ": " + path + ": expected an object, got " + jsonTypeName(j));
  JsonReader r(j, file, path);
  // The run's own (harness/run_matrix.cpp).
  count(r, "warmup", 0);
  count(r, "seeds", 1);
  text(r, "preset");
  text(r, "shard");
  if (r.has("captures")) r.strings("captures");
  // A shard's plan: the whole run's sequences and contenders (merge compares them).
  if (auto plan = r.optionalChild("plan")) {
    const json& sequences = plan->value("sequences");
    if (!sequences.is_array())
      plan->fail("sequences", "expected an array of {name, width, height, frames}");
    for (size_t i = 0; i < sequences.size(); ++i) {
      JsonReader s(sequences[i], file, path + ".plan.sequences[" + std::to_string(i) + "]");
      s.string("name");
      for (const char* k : {"width", "height", "frames"}) s.integerIn(k, 1, JsonReader::kIntMax);
      s.rejectUnread();
    }
    plan->strings("labels");
    plan->rejectUnread();
  }
  // The evaluation's (metrics/evaluator.cpp evaluationSettings, metrics/ghosting.cpp GhostingConfig).
  for (const char* k : {"flip", "exposure", "display", "oldViewLeak", "tRmae"}) text(r, k);
  number(r, "relMseEpsilon");
  number(r, "flipPixelsPerDegree");
  if (auto g = r.optionalChild("ghosting")) {
    for (const char* k : {"tau", "chromaTau", "eps", "biasThreshold"}) number(*g, k);
    for (const char* k : {"windowBefore", "windowAfter", "steadyFrames", "minFramesFromEvent",
                          "trailFrames", "cutRecoveryFrames"})
      count(*g, k, 0);
    for (const char* k : {"chroma", "intervals"}) text(*g, k);
    if (g->has("lagAfterUnsettled")) text(*g, "lagAfterUnsettled");  // absent in older runs
    g->rejectUnread();
  }
  // The sequences' (tracer/render.cpp RenderSettings::pixelSettings, less width, height, frames).
  if (auto render = r.optionalChild("render")) {
    for (const char* k : {"referenceSpp", "referenceMinSpp", "maxBounces", "tracerVersion", "referenceReplicates",
                          "referenceTile", "lowresFactor", "lowresSpp"})
      count(*render, k, 0);
    number(*render, "referenceRelError");
    for (const char* k : {"referenceSampler", "preset"}) text(*render, k);
    if (render->has("inputSeed")) {
      const json& seed = render->value("inputSeed");
      if (!seed.is_number_unsigned() || seed.get<uint64_t>() > UINT32_MAX)
        render->fail("inputSeed", "expected an integer in [0, 4294967295], got " + seed.dump());
    }
    render->rejectUnread();
  }
  r.rejectUnread();
  RunSettings s;
  s.record_ = j;
  return s;
}

int RunSettings::warmup() const {
  return record_.contains("warmup") ? record_.at("warmup").get<int>() : kDefaultWarmup;
}

int RunSettings::seeds() const { return record_.contains("seeds") ? record_.at("seeds").get<int>() : 1; }

std::string RunSettings::shard() const {
  return record_.contains("shard") ? record_.at("shard").get<std::string>() : "";
}

void RunSettings::setShard(const std::string& shard) { record_["shard"] = shard; }

const json& RunSettings::render() const {
  static const json none = json::object();
  return record_.contains("render") ? record_.at("render") : none;
}

json RunSettings::measurement() const {
  json m = record_;
  m.erase("shard");  // which slice of the pairs a run holds, not how they were measured
  return m;
}

}  // namespace arena
