#include "metrics/run_statistics.hpp"

#include <cmath>

#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "metrics/ghosting_intervals.hpp"
#include "metrics/metric_registry.hpp"

namespace arena {

using nlohmann::json;

namespace {

// ---- Reading: every field named by its JSON path, unknown fields refused -------------------------

Interval readInterval(JsonReader& r, const std::string& key) {
  const json& v = r.value(key);
  const std::optional<Interval> interval = Interval::fromJson(v);
  if (!interval) r.fail(key, "expected [low, high] (or null), got " + v.dump());
  return *interval;
}

// A ranking list: entries {label, rank, <valueName>, ci95, tiedWith, extraPathsPerPixel?,
// oracleLayers?}.
std::vector<RankedMethod> readRanking(JsonReader& r, const char* valueName) {
  std::vector<RankedMethod> out;
  for (JsonReader& e : r.requiredArray("ranking")) {
    RankedMethod m;
    m.label = e.string("label");
    m.rank = e.integerIn("rank", 1, JsonReader::kIntMax);
    m.value = e.numberOrNull(valueName);
    m.ci = readInterval(e, "ci95");
    m.tiedWith = e.strings("tiedWith");
    if (e.has("extraPathsPerPixel")) m.extraPathsPerPixel = e.number("extraPathsPerPixel");
    if (e.has("oracleLayers")) m.oracleLayers = e.strings("oracleLayers");
    e.rejectUnread();
    out.push_back(std::move(m));
  }
  return out;
}

// One paired difference {a, b, <diffKey>, ci95, resolved}; `resolved` must agree with the interval.
SceneRanking::Pair readPair(JsonReader& p, const char* diffKey) {
  SceneRanking::Pair x;
  x.a = p.string("a");
  x.b = p.string("b");
  x.d.diff = p.numberOrNull(diffKey);
  x.d.ci = readInterval(p, "ci95");
  const json& resolved = p.value("resolved");
  if (!resolved.is_boolean() || resolved.get<bool>() != x.d.resolved())
    p.fail("resolved", "expected " + std::string(x.d.resolved() ? "true" : "false") +
                           " (whether the interval excludes zero), got " + resolved.dump());
  p.rejectUnread();
  return x;
}

// "excluded" and "leftOut" (absent in results written before it was stored: the text alone). The
// text must be the list joined: one edited without the other would give two reasons.
void readLeftOut(JsonReader& r, LeftOutMethods& out) {
  const std::string text = r.has("excluded") ? r.string("excluded") : "";
  for (JsonReader& l : r.optionalArray("leftOut")) {
    out.leaveOut(l.string("label"), l.string("why"));
    l.rejectUnread();
  }
  if (out.leftOut.empty())
    out.excluded = text;
  else if (out.excluded != text)
    r.fail("excluded",
           "expected \"" + out.excluded + "\" (the leftOut entries joined), got \"" + text + "\"");
}

// The members of a ranking block; the caller rejects what is left unread (a scene's block holds
// byMetric, events and cuts beside them).
SceneRanking readSceneRankingMembers(JsonReader& r) {
  SceneRanking s;
  s.metric = r.string("metric");
  s.ranking = readRanking(r, "mean");
  for (JsonReader& p : r.requiredArray("pairs")) {
    s.pairs.push_back(readPair(p, "diff"));
    s.resolvedPairs += s.pairs.back().d.resolved();
  }
  if (r.integer("resolvedPairs") != s.resolvedPairs)
    r.fail("resolvedPairs", "expected " + std::to_string(s.resolvedPairs) +
                                " (the pairs marked resolved), got " + r.node().at("resolvedPairs").dump());
  if (r.integer("totalPairs") != int(s.pairs.size()))
    r.fail("totalPairs", "expected " + std::to_string(s.pairs.size()) +
                             " (the pairs listed), got " + r.node().at("totalPairs").dump());
  readLeftOut(r, s);
  return s;
}

SceneRanking readSceneRanking(JsonReader r) {
  SceneRanking s = readSceneRankingMembers(r);
  r.rejectUnread();
  return s;
}

OverallRanking readOverall(JsonReader r) {
  OverallRanking o;
  o.normalisation = r.string("normalisation");
  o.baseline = r.string("baseline");
  o.ranking = readRanking(r, "score");
  readLeftOut(r, o);
  // Absent in results written before they were stored.
  for (JsonReader& p : r.optionalArray("pairs")) o.pairs.push_back(readPair(p, "logRatio"));
  r.rejectUnread();
  return o;
}

std::vector<EventStatistics> readEvents(JsonReader& scene, const char* key, bool cut) {
  std::vector<EventStatistics> out;
  for (JsonReader& e : scene.optionalArray(key)) {
    EventStatistics ev;
    ev.eventFrame = e.integer("eventFrame");
    ev.kind = e.string("kind");
    if (!cut) ev.what = e.string("what");
    JsonReader figures = e.child("byFigure");
    for (const std::string& f : figures.memberNames()) ev.byFigure.emplace(f, readSceneRanking(figures.child(f)));
    e.rejectUnread();
    out.push_back(std::move(ev));
  }
  return out;
}

// ---- Writing ----------------------------------------------------------------------------------------

json eventsJson(const std::vector<EventStatistics>& events, bool cut) {
  json out = json::array();
  for (const EventStatistics& e : events) {
    json figures = json::object();
    for (const auto& [f, r] : e.byFigure) figures[f] = r.toJson();
    json j = {{"eventFrame", e.eventFrame}, {"kind", e.kind}, {"byFigure", figures}};
    if (!cut) j["what"] = e.what;
    out.push_back(std::move(j));
  }
  return out;
}

}  // namespace

RunStatistics RunStatistics::fromJson(const json& j, const std::string& file, const std::string& path) {
  if (!j.is_object()) throw Error(file + ": " + path + ": expected an object, got " + jsonTypeName(j));
  JsonReader r(j, file, path);
  RunStatistics s;
  s.method = r.string("method");
  s.confidence = r.number("confidence");
  if (!(s.confidence > 0 && s.confidence < 1)) r.fail("confidence", "expected a level in (0, 1)");
  s.replicates = r.integerIn("replicates", 0, JsonReader::kIntMax);
  const json& grid = r.value("tileGrid");
  if (!grid.is_array() || grid.size() != 2 || !grid[0].is_number_integer() || !grid[1].is_number_integer() ||
      grid[0].get<int64_t>() < 1 || grid[1].get<int64_t>() < 1 || grid[0].get<int64_t>() > 4096 ||
      grid[1].get<int64_t>() > 4096)
    r.fail("tileGrid", "expected [columns, rows], two positive integers, got " + grid.dump());
  s.tileGrid = {grid[0].get<int>(), grid[1].get<int>()};
  s.rankedOn = r.string("rankedOn");
  JsonReader scenes = r.child("scenes");
  for (const std::string& name : scenes.memberNames()) {
    JsonReader scene = scenes.child(name);
    SceneStatistics st;
    st.ranking = readSceneRankingMembers(scene);
    JsonReader byMetric = scene.child("byMetric");
    for (const std::string& m : byMetric.memberNames()) st.byMetric.emplace(m, readSceneRanking(byMetric.child(m)));
    st.events = readEvents(scene, "events", false);
    st.cuts = readEvents(scene, "cuts", true);
    scene.rejectUnread();
    s.scenes.emplace(name, std::move(st));
  }
  if (r.has("overall")) s.overall = readOverall(r.child("overall"));
  if (auto byMetric = r.optionalChild("overallByMetric"))
    for (const std::string& m : byMetric->memberNames()) s.overallByMetric.emplace(m, readOverall(byMetric->child(m)));
  if (auto extra = r.optionalChild("extraPaths")) {
    s.extraPathsMeaning = extra->string("meaning");
    JsonReader perPixel = extra->child("perPixel");
    for (const std::string& label : perPixel.memberNames()) s.extraPathsPerPixel[label] = perPixel.number(label);
    perPixel.rejectUnread();
    extra->rejectUnread();
  }
  if (auto oracle = r.optionalChild("oracle")) {
    s.oracleMeaning = oracle->string("meaning");
    JsonReader layers = oracle->child("layers");
    for (const std::string& label : layers.memberNames())
      s.oracleLayers[label] = layers.strings(label);
    layers.rejectUnread();
    oracle->rejectUnread();
  }
  r.rejectUnread();
  return s;
}

json RunStatistics::toJson() const {
  json sceneJson = json::object();
  for (const auto& [name, st] : scenes) {
    json j = st.ranking.toJson();
    j["byMetric"] = json::object();
    for (const auto& [m, r] : st.byMetric) j["byMetric"][m] = r.toJson();
    if (!st.events.empty()) j["events"] = eventsJson(st.events, false);
    if (!st.cuts.empty()) j["cuts"] = eventsJson(st.cuts, true);
    sceneJson[name] = std::move(j);
  }
  json out = {{"method", method},
              {"confidence", confidence},
              {"replicates", replicates},
              {"tileGrid", {tileGrid.cols, tileGrid.rows}},
              {"rankedOn", rankedOn},
              {"scenes", sceneJson}};
  if (overall) out["overall"] = overall->toJson();
  for (const auto& [m, o] : overallByMetric) out["overallByMetric"][m] = o.toJson();
  if (!extraPathsPerPixel.empty())
    out["extraPaths"] = {{"meaning", extraPathsMeaning}, {"perPixel", extraPathsPerPixel}};
  if (!oracleLayers.empty()) out["oracle"] = {{"meaning", oracleMeaning}, {"layers", oracleLayers}};
  return out;
}

const SceneRanking* RunStatistics::ranking(const std::string& scene, const std::string& metric) const {
  auto s = scenes.find(scene);
  if (s == scenes.end()) return nullptr;
  if (metric == s->second.ranking.metric) return &s->second.ranking;
  auto m = s->second.byMetric.find(metric);
  return m == s->second.byMetric.end() ? nullptr : &m->second;
}

// ---- Building ---------------------------------------------------------------------------------------

namespace {

// Issue 34, section 2: every ranking entry of a method that read paths beyond the frame's own
// 1-spp ones (reengine's disocclusion rays, asvgf's gradient samples) says so, with the paths;
// and one that read an oracle layer (data no real-time engine has) names it.
void markReadsBeyond(std::vector<RankedMethod>& ranking, const RunStatistics& s) {
  for (RankedMethod& m : ranking) {
    if (auto it = s.extraPathsPerPixel.find(m.label); it != s.extraPathsPerPixel.end())
      m.extraPathsPerPixel = it->second;
    if (auto it = s.oracleLayers.find(m.label); it != s.oracleLayers.end())
      m.oracleLayers = it->second;
  }
}

void markReadsBeyond(RunStatistics& s) {
  for (auto& [name, scene] : s.scenes) {
    markReadsBeyond(scene.ranking.ranking, s);
    for (auto& [m, r] : scene.byMetric) markReadsBeyond(r.ranking, s);
    scene.forEachEvent([&](EventStatistics& e, bool) {
      for (auto& [f, r] : e.byFigure) markReadsBeyond(r.ranking, s);
    });
  }
  if (s.overall) markReadsBeyond(s.overall->ranking, s);
  for (auto& [m, o] : s.overallByMetric) markReadsBeyond(o.ranking, s);
}

}  // namespace

RunStatistics analyseRun(const json& results, const BootstrapConfig& cfg) {
  // The registry's ranked metrics. relMSE ranks (paired differences of raw and corrected relMSE
  // are the same: the correction subtracts the same reference term from every method); the others
  // are reported beside it.
  // Metrics with an overall score are ranked per scene too (the overall score combines the scenes'
  // rankings), even when their scene rankings are not reported.
  std::vector<const MetricDefinition*> rankedMetrics;
  for (const MetricDefinition* m : metricCatalog())
    if (m->ranked || m->overall) rankedMetrics.push_back(m);
  std::map<std::string, std::vector<std::pair<std::string, std::map<std::string, MetricTiles>>>>
      byScene;
  std::map<std::string, std::vector<std::pair<std::string, const json*>>> pairsOfScene;
  if (!results.contains("pairs") || !results["pairs"].is_array())
    throw Error("statistics: results have no pairs array");
  for (const json& p : results["pairs"]) {
    if (p.value("status", "") != "ok") continue;
    std::map<std::string, MetricTiles> tiles;
    if (p.contains("tiles"))
      for (auto it = p["tiles"].begin(); it != p["tiles"].end(); ++it)
        tiles[it.key()] = MetricTiles::fromJson(it.value());
    byScene[p.value("scene", "")].push_back({p.value("label", ""), std::move(tiles)});
    pairsOfScene[p.value("scene", "")].push_back({p.value("label", ""), &p});
  }
  RunStatistics out;
  out.method = "crossed bootstrap: circular blocks of round(n^(1/3)) frames x " +
               std::to_string(cfg.grid.cols) + "x" + std::to_string(cfg.grid.rows) +
               " image tiles, " + std::to_string(cfg.replicates) +
               " replicates, percentile intervals; one plan per scene, so differences are paired";
  out.confidence = cfg.confidence;
  out.replicates = cfg.replicates;
  out.tileGrid = cfg.grid;
  out.rankedOn = "relMse";
  std::map<std::string, std::vector<SceneRanking>> overallInputs;  // metric -> its scene rankings
  for (const auto& [scene, pairs] : byScene) {
    std::optional<SceneStatistics> st;
    const auto& documents = pairsOfScene[scene];  // in the order of pairs
    for (const MetricDefinition* m : rankedMetrics) {
      std::vector<std::pair<std::string, const MetricTiles*>> methods;
      std::vector<std::pair<std::string, std::string>> notFinite;  // label, why
      bool any = false;
      for (size_t k = 0; k < pairs.size(); ++k) {
        const auto& [label, tiles] = pairs[k];
        auto it = tiles.find(m->name);
        any |= it != tiles.end();
        // A method with a non-finite value on some frame has no mean (its summary says so); its
        // tiles hold only its finite frames, and ranked on the frames all methods share, that
        // frame would vanish from everyone's comparison unnoticed. It is left out, named.
        const json& summary =
            documents[k].second->value("summary", json::object()).value(m->name, json::object());
        if (summary.value("nonFinite", 0) > 0) {
          const std::string why = summary.value("absent", std::string("not finite"));
          notFinite.push_back({label, why});
          continue;
        }
        methods.push_back({label, it == tiles.end() ? nullptr : &it->second});
      }
      if (!any) continue;
      SceneRanking r = rankScene(m->name, m->lowerIsBetter(), methods, scene, cfg);
      for (const auto& [label, why] : notFinite) r.leaveOut(label, why);
      if (m->name == out.rankedOn) {
        st.emplace();
        st->ranking = r;
      } else if (st && m->ranked) {
        st->byMetric[m->name] = r;
      }
      if (m->overall) overallInputs[m->name].push_back(std::move(r));
    }
    if (st) {
      // The event-window figures: paired tile bootstrap per event (metrics/ghosting_intervals).
      SceneEvents events = rankSceneEvents(pairsOfScene[scene], scene, cfg);
      st->events = std::move(events.events);
      st->cuts = std::move(events.cuts);
      out.scenes[scene] = std::move(*st);
    }
  }
  // The overall scores: relMSE's is the run's ("overall"); the other metrics that declare one
  // ("overallByMetric") are what the report's all-scenes chart shows on their axes.
  // Scores are relative to `temporal` where it ran (the baselines); without it, to a sweep's
  // first grid point, else to the run's first contender (not the first label in sorted order).
  std::vector<std::string> preferred = {"temporal"};
  if (const json labels = results.value("sweep", json::object()).value("labels", json::array());
      !labels.empty() && labels.front().is_string())
    preferred.push_back(labels.front());
  // The contenders in the order the run was asked for: a merge's pairs are in the order its
  // shards were given, so a sharded run reads its plan's order.
  const json plan = results.value("settings", json::object()).value("plan", json::object());
  for (const json& label : plan.value("labels", json::array()))
    if (label.is_string()) preferred.push_back(label);
  for (const json& p : results["pairs"])
    if (p.value("status", "") == "ok" && p.contains("label") && p["label"].is_string())
      preferred.push_back(p["label"]);
  for (const MetricDefinition* m : rankedMetrics) {
    if (!m->overall) continue;
    std::vector<const SceneRanking*> ranked;
    for (const SceneRanking& r : overallInputs[m->name])
      if (!r.ranking.empty()) ranked.push_back(&r);
    if (ranked.empty()) continue;
    OverallRanking overall = rankOverall(ranked, preferred, m->lowerIsBetter(), cfg.confidence);
    if (m->name == out.rankedOn) out.overall = std::move(overall);
    else out.overallByMetric[m->name] = std::move(overall);
  }
  // The extra paths each label read, mean over its scenes (paths per pixel per frame).
  std::map<std::string, std::pair<double, int>> sums;
  for (const json& p : results["pairs"]) {
    if (p.value("status", "") != "ok" || !p.contains("summary")) continue;
    const json& s = p["summary"];
    if (!s.contains("extraRaysPerPixel") || !s["extraRaysPerPixel"].contains("mean") ||
        !s["extraRaysPerPixel"]["mean"].is_number())
      continue;
    auto& [sum, n] = sums[p.value("label", "")];
    sum += s["extraRaysPerPixel"]["mean"].get<double>();
    ++n;
  }
  for (const auto& [label, sn] : sums)
    if (sn.first > 0) out.extraPathsPerPixel[label] = sn.first / sn.second;
  // The oracle layers each label read, on any of its scenes.
  for (const json& p : results["pairs"]) {
    if (p.value("status", "") != "ok" || !p.contains("oracleLayers") ||
        !p["oracleLayers"].is_array() || p["oracleLayers"].empty())
      continue;
    std::vector<std::string>& layers = out.oracleLayers[p.value("label", "")];
    for (const json& l : p["oracleLayers"])
      if (std::find(layers.begin(), layers.end(), l.get<std::string>()) == layers.end())
        layers.push_back(l.get<std::string>());
  }
  if (!out.oracleLayers.empty())
    out.oracleMeaning =
        "layers no real-time engine has (e.g. the noise-free mirror ray's hit distance) that "
        "these labels read: not ranked on equal terms with the others";
  if (!out.extraPathsPerPixel.empty() || !out.oracleLayers.empty()) markReadsBeyond(out);
  if (!out.extraPathsPerPixel.empty()) {
    out.extraPathsMeaning =
        "paths per pixel per frame read beyond the frame's own 1-spp paths (reengine: "
        "low-resolution disocclusion rays; asvgf: re-shaded gradient samples); their equivalent "
        "tracing time is each pair's tracingMs";
  }
  return out;
}

}  // namespace arena
