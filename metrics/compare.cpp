#include "metrics/compare.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <tuple>

#include "core/error.hpp"
#include "core/text.hpp"
#include "metrics/ghosting_intervals.hpp"
#include "metrics/results.hpp"

namespace arena {

using nlohmann::json;

namespace {

double parseFraction(const std::string& text, const char* option, const char* expected) {
  double v = kUndefined;
  // Decimal only: std::stod reads "0x10" as 16 and "inf" as infinity.
  if (text.find_first_not_of("0123456789.eE+-%") == std::string::npos) try {
      size_t used = 0;
      v = std::stod(text, &used);
      if (used == text.size() - 1 && text.back() == '%')
        v /= 100.0;
      else if (used != text.size())
        v = kUndefined;
    } catch (...) {
    }
  if (!std::isfinite(v) || v < 0)
    throw Error(std::string(option) + " '" + text + "': expected " + expected);
  return v;
}

std::string key(const PairResult& p) { return p.scene + "\n" + p.label; }

// Two recorded parameter sets as what ran: numbers equal as the float a built-in reads (an older
// run recorded alpha 0.30000001 where a newer one records the float it ran, 0.3).
bool sameParameters(const json& a, const json& b) {
  if (!a.is_object() || !b.is_object() || a.size() != b.size()) return a == b;
  for (auto it = a.begin(); it != a.end(); ++it) {
    if (!b.contains(it.key())) return false;
    const json &x = it.value(), &y = b[it.key()];
    if (x.is_number() && y.is_number() ? float(x.get<double>()) != float(y.get<double>()) : x != y)
      return false;
  }
  return true;
}

// Whether `baseline` and `candidate` ran one configuration (the same scene, denoiser and resolved
// parameters) whatever their labels: how compareRuns matches a pair without its label in the
// candidate (a baseline pair that records no parameters is matched by label alone).
bool ranTheSame(const PairResult& baseline, const PairResult& candidate) {
  return baseline.scene == candidate.scene && baseline.denoiser == candidate.denoiser &&
         !baseline.params.empty() && sameParameters(candidate.params, baseline.params);
}

// A row about a whole pair (metric "*"): missing, failed or new; no numbers to compare.
ComparisonRow pairRow(const PairResult& p, const std::string& verdict, const std::string& note) {
  ComparisonRow row;
  row.scene = p.scene;
  row.label = p.label;
  row.metric = "*";
  row.verdict = verdict;
  row.note = note;
  return row;
}

// Appends "path: a vs b" for every leaf where a and b differ (a missing side reads "absent"; arrays
// of one length are compared element by element, others whole).
void collectDifferences(const json& a, const json& b, const std::string& path, std::vector<std::string>& out) {
  if (a.is_object() && b.is_object()) {
    std::set<std::string> keys;
    for (auto it = a.begin(); it != a.end(); ++it) keys.insert(it.key());
    for (auto it = b.begin(); it != b.end(); ++it) keys.insert(it.key());
    static const json absent = "absent";
    for (const std::string& k : keys)
      collectDifferences(a.contains(k) ? a[k] : absent, b.contains(k) ? b[k] : absent, path + "." + k, out);
    return;
  }
  if (a.is_array() && b.is_array() && a.size() == b.size()) {  // element by element: "[2].frames"
    for (size_t i = 0; i < a.size(); ++i)
      collectDifferences(a[i], b[i], path + "[" + std::to_string(i) + "]", out);
    return;
  }
  if (a != b) out.push_back(path + ": " + a.dump() + " vs " + b.dump());
}

// A name the gate can judge: a registered metric or an event figure; an Error listing both.
void requireGateMetric(const std::string& name, const std::string& what) {
  if (isGatedEventFigure(name)) return;
  try {
    requireMetric(name, what);
  } catch (const Error& e) {
    std::string figures;
    for (const std::string& f : gatedEventFigureNames())
      figures += (figures.empty() ? "" : ", ") + f;
    throw Error(std::string(e.what()) + "; the event figures: " + figures);
  }
}

// What a row's change and interval say against its tolerance (the rule the summaries' and the
// event figures' rows share). `worse`: the change in the worse direction; `unjudgeable`: no
// interval where one was due (fails the gate when worse beyond tolerance); `noTilesKept`: a run
// read from results.db (not judged).
void judge(ComparisonRow& row, double worse, bool resolvedWorse, bool resolvedBetter,
           bool unjudgeable, bool noTilesKept, bool noteEvenWithNote,
           const std::string& notJudgedNote =
               ": the gate cannot tell this change from noise without them (judge the run "
               "directories, which keep them)") {
  if (worse > row.tolerance && resolvedWorse) {
    row.verdict = "regressed";
  } else if (worse > row.tolerance && unjudgeable) {
    row.verdict = "unverified";
    row.note +=
        ": the gate cannot tell this change from noise (rerun both with their tiles and "
        "frames)";
  } else if (std::abs(worse) > row.tolerance && noTilesKept) {
    row.verdict = "not judged";
    row.note += notJudgedNote;
  } else if (worse > row.tolerance) {
    row.verdict = "unresolved";
  } else if (-worse > row.tolerance) {
    row.verdict = resolvedBetter ? "improved" : "unresolved";
  }
  if (row.verdict == "unresolved" && (row.note.empty() || noteEvenWithNote))
    row.note += (row.note.empty() ? "" : "; ") +
                std::string(worse > 0 ? "worse beyond tolerance but within noise"
                                      : "better beyond tolerance but within noise");
}

// Whether a row's p-value must be drawn more finely under Holm: the rows resolved alone, and every
// row whose replicates all lie on one side (its p-value at the plan's floor): Holm's thresholds
// rise as rows are rejected, so a row left at the floor would stop the procedure before a later
// one.
bool needsSharperP(const ComparisonRow& row, int replicates) {
  return row.verdict == "regressed" || row.verdict == "improved" ||
         row.pValue <= 2.0 / double(replicates + 1) * (1 + 1e-9);
}

// "12 frames" for a response figure, "never settled (counted as 40 frames)" for one that did not.
std::string responseText(double frames, bool never) {
  return never ? "never settled (counted as " + shortestText(frames) + " frames, its window)"
               : shortestText(frames) + " frames";
}

}  // namespace

std::vector<std::string> jsonDifferences(const json& a, const json& b, const std::string& path) {
  std::vector<std::string> out;
  collectDifferences(a, b, path, out);
  return out;
}

std::vector<std::string> referenceDifferences(const RunResults& baseline,
                                              const RunResults& candidate) {
  std::vector<std::string> out;
  if (!baseline.scenes.is_object() || !candidate.scenes.is_object()) return out;
  for (auto it = baseline.scenes.begin(); it != baseline.scenes.end(); ++it) {
    if (!candidate.scenes.contains(it.key())) continue;
    const json &a = it.value(), &b = candidate.scenes[it.key()];
    if (!a.is_object() || !b.is_object()) continue;
    if (a.contains("referenceSpp") && b.contains("referenceSpp") &&
        a["referenceSpp"] != b["referenceSpp"])
      out.push_back("scenes." + it.key() + ".referenceSpp: " + a["referenceSpp"].dump() + " vs " +
                    b["referenceSpp"].dump());
    // A capture's reference files, checksummed (runs written before 2026-12-06 lack them).
    const json ra = a.value("content", json::object()).value("references", json()),
               rb = b.value("content", json::object()).value("references", json());
    if (ra.is_string() && rb.is_string() && ra != rb)
      out.push_back("scenes." + it.key() + ".content.references: " + ra.dump() + " vs " +
                    rb.dump() + " (other reference files)");
  }
  return out;
}

std::vector<std::string> settingsDifferences(const RunResults& baseline,
                                             const RunResults& candidate,
                                             const std::vector<Tolerance>& gated) {
  const bool gatesLag = std::any_of(gated.begin(), gated.end(), [](const Tolerance& t) {
    return t.metric == "ghosting.lagEnergy" || t.metric == "ghosting.chromaLagEnergy";
  });
  std::vector<std::string> out;
  json a = baseline.settings.measurement(), b = candidate.settings.measurement();
  // Another --input-seed is another noise realisation of the same measurement, which the gate's
  // paired intervals, corrected together, tell from a change (shards of one run must still agree
  // on it). Measured over 15 pairs of six seeds, docs/statistics.md: the intervals hold their
  // level (changes' root-mean-square z 0.99) but on light_switch's relMSE (1.67).
  // Nor does a shard's plan (which run it is a slice of): the pairs are compared one by one.
  // Nor does the rule for lag energy after an unsettled event (settings.ghosting.
  // lagAfterUnsettled), unless the gate judges the lag figures it changed (`gated`: --metric
  // ghosting.lagEnergy or ghosting.chromaLagEnergy); merge, which ranks those, refuses to mix it.
  // Captures named by other paths (a folder moved, given relative once and absolute once) are the
  // same sequences when every capture of both runs records its content: the scenes' checksums,
  // compared below, decide. Without them (older runs) the paths are all there is.
  const auto capturesRecordContent = [](const RunResults& run) {
    if (!run.scenes.is_object()) return true;
    for (auto it = run.scenes.begin(); it != run.scenes.end(); ++it)
      if (it.value().is_object() && it.value().value("source", "") == "capture" &&
          !it.value().value("content", json::object()).value("inputs", json()).is_string())
        return false;
    return true;
  };
  const bool contentDecides = capturesRecordContent(baseline) && capturesRecordContent(candidate);
  for (json* s : {&a, &b}) {
    if (contentDecides) s->erase("captures");
    // The display transform's citation was corrected (Narkowicz's fit was published in 2016): the
    // same curve, so runs recorded before compare as equal.
    if (s->contains("display") && (*s)["display"].is_string()) {
      std::string text = (*s)["display"];
      if (const size_t at = text.find("Narkowicz 2015"); at != std::string::npos)
        (*s)["display"] = text.replace(at, 14, "Narkowicz 2016");
    }
    if (s->contains("render") && (*s)["render"].is_object()) (*s)["render"].erase("inputSeed");
    s->erase("plan");
    if (s->contains("ghosting") && (*s)["ghosting"].is_object() && !gatesLag)
      (*s)["ghosting"].erase("lagAfterUnsettled");
  }
  // A low-resolution buffer rendered in one run only (a contender there reads it) changes none of
  // the frames both runs measure (its paths are its own): not a difference when no pair the two
  // runs have in common read it in either (each pair records readsLowres; a pair that does not
  // say, from an older run, might have). Rendered in both at other settings, it is one. A pair
  // that failed in either run has no numbers to compare (and records nothing of what it read).
  auto lowres = [](const json& s) {
    return s.contains("render") && s["render"].contains("lowresFactor");
  };
  auto commonPairsReadNoLowres = [&] {
    std::set<std::string> inBaseline, common;
    for (const PairResult& p : baseline.pairs)
      if (p.ok()) inBaseline.insert(key(p));
    for (const PairResult& p : candidate.pairs)
      if (p.ok() && inBaseline.count(key(p))) common.insert(key(p));
    for (const RunResults* run : {&baseline, &candidate})
      for (const PairResult& p : run->pairs) {
        if (!common.count(key(p))) continue;
        const json& reads = p.part("readsLowres");
        if (!reads.is_boolean() || reads.get<bool>()) return false;
      }
    return true;
  };
  if (lowres(a) != lowres(b) && commonPairsReadNoLowres())
    for (json* s : {&a, &b})
      if (s->contains("render") && (*s)["render"].is_object())
        for (const char* k : {"lowresFactor", "lowresSpp"}) (*s)["render"].erase(k);
  collectDifferences(a, b, "settings", out);
  // A slice of a run (one shard) against a whole run, or another slice: the pairs it lacks would
  // read as "new" or "missing", and a regression in them would pass. Shards are merged first.
  // ("0/1", "merged" and none are whole runs.)
  auto slice = [](const std::string& s) {
    const size_t slash = s.find('/');
    return slash != std::string::npos && s.substr(slash + 1) != "1";
  };
  const std::string sa = baseline.settings.shard(), sb = candidate.settings.shard();
  if ((slice(sa) || slice(sb)) && sa != sb)
    out.push_back(
        "settings.shard: \"" + sa + "\" vs \"" + sb +
        "\" (a slice of a run is compared with the same slice of another only; `arena merge` "
        "its shards first)");
  const json& as = baseline.scenes;
  const json& bs = candidate.scenes;
  for (auto it = as.begin(); it != as.end(); ++it) {
    if (!bs.contains(it.key()) || !it.value().is_object() || !bs[it.key()].is_object()) continue;
    for (const char* field : {"width", "height", "frames"}) {
      const json x = it.value().value(field, json()), y = bs[it.key()].value(field, json());
      if (x != y) out.push_back("scenes." + it.key() + "." + field + ": " + x.dump() + " vs " + y.dump());
    }
    // Other inputs under one scene name (a scene file edited, a capture's frames exported again):
    // every denoiser saw other frames, so no change is the denoiser's alone. Runs written before
    // 2026-12-06 record no content: not compared.
    const json x = it.value().value("content", json::object()).value("inputs", json()),
               y = bs[it.key()].value("content", json::object()).value("inputs", json());
    if (x.is_string() && y.is_string() && x != y)
      out.push_back(
          "scenes." + it.key() + ".content.inputs: " + x.dump() + " vs " + y.dump() +
          " (other inputs: the scene's file (any of its text) or assets, or the capture's "
          "frames or description, changed)");
  }
  return out;
}

double parseTolerance(const std::string& text) {
  const double v = parseFraction(text, "--tolerance",
                                 "a finite non-negative number or percentage, e.g. 2% or 0.02");
  // A bare number is a fraction: "2" is 200%, a gate that passes almost anything, most likely
  // meant as 2%. A tolerance of 100% or more is written as a percentage.
  if (v >= 1 && !text.empty() && text.back() != '%')
    throw Error("--tolerance '" + text + "': a bare number is a fraction (" + text + " is " +
                shortestText(v * 100) + "%); write " + text + "% for " + text + " percent, or " +
                shortestText(v * 100) + "% if that is meant");
  return v;
}

std::vector<Tolerance> parseGate(const std::vector<std::string>& metrics,
                                 const std::string& toleranceText) {
  double all = 0.02;
  bool allGiven = false;
  std::vector<std::pair<std::string, double>> own;  // METRIC=VALUE, in order
  size_t from = 0;
  while (from <= toleranceText.size()) {
    const size_t comma = std::min(toleranceText.find(',', from), toleranceText.size());
    const std::string item = toleranceText.substr(from, comma - from);
    from = comma + 1;
    if (item.empty())
      throw Error("--tolerance '" + toleranceText +
                  "': an empty item (expected e.g. 2% or 2%,ghosting.lagEnergy=10%)");
    if (const size_t eq = item.find('='); eq != std::string::npos) {
      std::string metric = item.substr(0, eq);
      if (metric == "flip") metric = "ldrFlip";
      if (std::any_of(own.begin(), own.end(), [&](const auto& o) { return o.first == metric; }))
        throw Error("--tolerance '" + toleranceText + "': " + metric +
                    "'s own given twice (which is meant?)");
      try {
        own.push_back({metric, parseTolerance(item.substr(eq + 1))});
      } catch (const Error& e) {
        throw Error("--tolerance " + item + ": " + e.what());
      }
    } else {
      if (allGiven)
        throw Error("--tolerance '" + toleranceText + "': two values for every metric (" +
                    shortestText(all * 100) + "% and " + item +
                    "); one metric's own is written METRIC=VALUE");
      all = parseTolerance(item);
      allGiven = true;
    }
  }
  std::vector<Tolerance> tolerances;
  for (const std::string& m : metrics) tolerances.push_back({m, all});
  tolerances = gateTolerances(std::move(tolerances), all);
  for (const auto& [metric, value] : own) {
    const auto it = std::find_if(tolerances.begin(), tolerances.end(),
                                 [&name = metric](const Tolerance& t) { return t.metric == name; });
    if (it == tolerances.end())
      requireGateMetric(metric, "--tolerance " + metric + "=" + shortestText(value * 100) + "%");
    if (it == tolerances.end()) {
      std::string gated;
      for (const Tolerance& t : tolerances) gated += (gated.empty() ? "" : ", ") + t.metric;
      throw Error("--tolerance " + metric + "=" + shortestText(value * 100) + "%: " + metric +
                  " is not among the metrics the gate judges (" + gated +
                  "); name it with --metric");
    }
    it->relative = value;
  }
  return tolerances;
}

double parseConfidence(const std::string& text) {
  const double v =
      parseFraction(text, "--confidence", "a level in (0, 1) or a percentage, e.g. 95% or 0.95");
  if (!(v > 0 && v < 1))
    throw Error("--confidence '" + text + "': expected a level in (0, 1), e.g. 95% or 0.95");
  return v;
}

std::vector<Tolerance> gateTolerances(std::vector<Tolerance> tolerances, double relative) {
  if (tolerances.empty())
    for (const MetricDefinition* m : metricCatalog())
      if (m->gatedByDefault) tolerances.push_back({m->name, relative, true});
  for (Tolerance& t : tolerances) {
    if (t.metric == "flip") t.metric = "ldrFlip";
    requireGateMetric(t.metric, "--metric");
    if (!std::isfinite(t.relative) || t.relative < 0)
      throw Error("--tolerance of " + t.metric + " must be finite and non-negative");
  }
  // A metric named twice (`--metric relMse,relMse`, `flip` and `ldrFlip`) is judged once: twice,
  // its rows counted double and, judged together, raised the bar the others must clear.
  std::vector<Tolerance> once;
  for (Tolerance& t : tolerances)
    if (std::none_of(once.begin(), once.end(),
                     [&](const Tolerance& o) { return o.metric == t.metric; }))
      once.push_back(std::move(t));
  return once;
}

Correction parseCorrection(const std::string& text) {
  if (text == "holm") return Correction::Holm;
  if (text == "none") return Correction::None;
  throw Error("--correction '" + text +
              "': expected holm (the rows judged together, the default) or none (each row alone)");
}

const char* correctionName(Correction c) {
  return c == Correction::Holm ? "holm" : "none";
}

std::vector<ComparisonRow> compareRuns(const RunResults& base, const RunResults& cand,
                                       std::vector<Tolerance> tolerances,
                                       const BootstrapConfig& cfg, Correction correction,
                                       const std::map<std::string, std::string>& matches) {
  tolerances = gateTolerances(std::move(tolerances));
  std::map<std::string, const PairResult*> candPairs;
  std::set<std::string> baseScenes, candScenes;
  for (const PairResult& p : cand.pairs) candPairs[key(p)] = &p, candScenes.insert(p.scene);
  for (const PairResult& p : base.pairs) baseScenes.insert(p.scene);
  // The scenes the runs measured (their records), whichever pairs are compared (--denoisers).
  for (const auto& [runScenes, into] :
       {std::pair{&base.scenes, &baseScenes}, std::pair{&cand.scenes, &candScenes}})
    if (runScenes->is_object())
      for (auto it = runScenes->begin(); it != runScenes->end(); ++it) into->insert(it.key());
  bool shared = false;
  for (const std::string& s : baseScenes) shared |= candScenes.count(s) > 0;
  // Without a scene in common every baseline pair is missing (the gate fails) and every candidate
  // pair new, as below; their notes say why.
  const std::string noShared = shared ? "" : "the runs share no scene: ";
  std::vector<ComparisonRow> rows;
  // Rows resolved alone whose p-value the correction must tell more finely than the plan's
  // replicates can (the row, its scene, the baseline's and candidate's tiles).
  struct Sharper {
    size_t row;
    std::function<double(int replicates)> pValue;
  };
  std::vector<Sharper> sharper;
  EventReplicateCache resampled;  // each event's replicates, once for all its figures
  // Metrics that keep per-tile data in either run: one of them without tiles somewhere is data
  // missing; the others (ms, referenceRelMse, ...) never have tiles and are never judged by them.
  std::set<std::string> tiled;
  for (const RunResults* run : {&base, &cand})
    for (const PairResult& p : run->pairs)
      if (const json& t = p.part("tiles"); t.is_object())
        for (auto it = t.begin(); it != t.end(); ++it) tiled.insert(it.key());
  int comparedPairs = 0;  // pairs both runs ran
  std::set<std::string> baseKeys;
  std::set<std::string>
      baselineKeys;  // every baseline pair's: a candidate under one is not another's
  for (const PairResult& b : base.pairs) baselineKeys.insert(key(b));
  // A --match target is its baseline pair's: never matched to another by what it ran.
  std::set<std::string> targets;
  for (const auto& [from, to] : matches) targets.insert(to);
  for (const PairResult& c : cand.pairs)
    if (targets.count(c.label)) baselineKeys.insert(key(c));
  for (const PairResult& b : base.pairs) {
    baseKeys.insert(key(b));
    const std::string& scene = b.scene;
    const std::string& label = b.label;
    auto it = candPairs.find(key(b));
    const auto requested = matches.find(label);
    if (requested != matches.end()) {
      it = candPairs.find(scene + "\n" + requested->second);
      if (it != candPairs.end()) baseKeys.insert(it->first);  // not "new" below
    }
    // Labels were once written as typed ("svgf[sigmaL=2.0]"; now "svgf[sigmaL=2]"): a baseline
    // pair without its label in the candidate is matched by what it ran, the denoiser and its
    // resolved parameters, where exactly one candidate pair of the scene ran that.
    if (it == candPairs.end() && requested == matches.end() && b.ok() && !b.params.empty()) {
      auto same = candPairs.end();
      int ranOne = 0;
      for (auto c = candPairs.begin(); c != candPairs.end(); ++c)
        if (ranTheSame(b, *c->second) && !baselineKeys.count(c->first)) same = c, ++ranOne;
      if (ranOne == 1) {
        it = same;
        baseKeys.insert(it->first);  // not "new" below
      }
    }
    if (it == candPairs.end()) {
      std::string note = noShared + "pair not in the candidate run";
      if (requested != matches.end()) {
        note = "the candidate has no pair " + requested->second + " on this scene (--match)";
      } else {
        // The same denoiser under another label only the candidate has (another parameter):
        // what would compare them, said.
        // (Not one that ran what another baseline pair ran: it is compared with that one.)
        std::vector<std::string> others;
        for (const auto& [k, c] : candPairs) {
          if (c->scene != scene || c->denoiser != b.denoiser || baselineKeys.count(k)) continue;
          bool ranByAnother = false;
          for (const PairResult& o : base.pairs) ranByAnother = ranByAnother || ranTheSame(o, *c);
          if (!ranByAnother) others.push_back(c->label);
        }
        // Several of the baseline's configurations of it lack their label (a sweep's points
        // against one plain run): a --match pairs one label with one, and naming one of them
        // would read as if it were the candidate's under another name.
        int missingOfDenoiser = 0;
        for (const PairResult& o : base.pairs) {
          if (o.scene != scene || o.denoiser != b.denoiser || candPairs.count(key(o))) continue;
          bool ranThere = false;  // matched by what it ran, as above
          for (const auto& [k, c] : candPairs) ranThere = ranThere || ranTheSame(o, *c);
          missingOfDenoiser += !ranThere;
        }
        if (!others.empty() && missingOfDenoiser > 1)
          note +=
              "; the candidate ran " + b.denoiser + " only as " + others.front() +
              (others.size() > 1 ? " (and " + std::to_string(others.size() - 1) + " more)" : "") +
              ", another configuration than this one and " + std::to_string(missingOfDenoiser - 1) +
              " more of the baseline's";
        else if (!others.empty())
          note +=
              "; the candidate ran " + b.denoiser + " as " + others.front() +
              (others.size() > 1 ? " (and " + std::to_string(others.size() - 1) + " more)" : "") +
              ": `--match '" + label + "=" + others.front() +
              "'` compares them (arena compare, report --baseline, history)";
      }
      rows.push_back(pairRow(b, "missing", note));
      continue;
    }
    const PairResult& c = *it->second;
    const bool byRequest = requested != matches.end();
    if (!c.ok()) {
      rows.push_back(pairRow(b, "failed", c.error));
      if (c.label != b.label) rows.back().candidateLabel = c.label;
      rows.back().matchedByRequest = byRequest;
      continue;
    }
    if (!b.ok()) {  // nothing to hold the candidate to; that it runs now is said
      rows.push_back(pairRow(c, "new", "failed in the baseline run: " + b.error));
      continue;
    }
    ++comparedPairs;
    const std::string candidateLabel = c.label != label ? c.label : "";
    for (const Tolerance& t : tolerances) {
      if (isGatedEventFigure(t.metric)) continue;  // below, event by event
      ComparisonRow row{scene, label,      t.metric, kUndefined, kUndefined,     kUndefined,
                        {},    t.relative, "ok",     "",         candidateLabel, byRequest};
      const SummaryMean bm = b.mean(t.metric), cm = c.mean(t.metric);
      if (!bm.computed && !cm.computed) continue;  // e.g. FLIP switched off in both runs
      if (!cm.present() && !bm.present()) {
        // Absent in both (a sequence no longer than the warm-up): nothing to hold the candidate
        // to, said with both reasons rather than skipped.
        row.verdict = "absent";
        row.note = "baseline: " + bm.absent + "; candidate: " + cm.absent;
        rows.push_back(row);
        continue;
      }
      if (!cm.present()) {
        row.verdict = "missing";
        row.note = cm.absent;
        rows.push_back(row);
        continue;
      }
      if (!bm.present()) {
        row.verdict = "new";
        row.note = "absent in the baseline: " + bm.absent;
        rows.push_back(row);
        continue;
      }
      row.baseline = bm.mean;
      row.candidate = cm.mean;
      const double scale = std::max(std::abs(row.baseline), 1e-12);
      row.change = (row.candidate - row.baseline) / scale;
      const bool lowerIsBetter = findMetric(t.metric)->lowerIsBetter();
      // Paired over the frames and tiles both runs have, seeded by the scene like the run's own.
      // unjudgeable: a change beyond tolerance there fails the gate, as passing it would be a
      // verdict from no data. Runs read from results.db have no tiles by design (the dashboard
      // lists their changes as not judged, docs/ci-dashboard.md), nor do some metrics (ms).
      bool resolvedWorse = false, resolvedBetter = false, unjudgeable = false, noTilesKept = false;
      bool sharedFrames = false;  // the runs summarise other frames: compared on those both have
      int fewFrames = 0;  // the paired frames, where kFewSummarisedFrames or fewer: not judged
      std::optional<std::pair<MetricTiles, MetricTiles>> pairedTiles;  // baseline's, candidate's
      const json &bt = b.part("tiles"), &ct = c.part("tiles");
      if (bt.is_object() && ct.is_object() && bt.contains(t.metric) && ct.contains(t.metric)) {
        // A damaged tile record names its run, pair and field (it said only "tile data: sum is
        // not base64").
        const auto tilesOf = [&](const RunResults& run, const PairResult& p, const json& j) {
          try {
            return MetricTiles::fromJson(j[t.metric]);
          } catch (const Error& e) {
            throw Error(run.source + ": pair " + p.label + " on " + p.scene + ", tiles." +
                        t.metric + ": " + e.what());
          }
        };
        const MetricTiles baseTiles = tilesOf(base, b, bt), candTiles = tilesOf(cand, c, ct);
        // The interval comes from the tiles, the change from the summaries: the two must be one
        // measurement (a hand-edited mean showed +1107% with an interval of [+0%, +0%], and
        // passed).
        for (const auto& [which, tiles, mean] : {std::tuple{"baseline", &baseTiles, bm.mean},
                                                 std::tuple{"candidate", &candTiles, cm.mean}}) {
          // Float32 tile sums against the double summary: agreed within 1e-4 of the frames' own
          // size (a corrected relMSE near 0 is a difference of two larger terms).
          // Tiles of no finite value under a summary's mean, or of an infinite one on any frame (a
          // summary is absent where a frame's value is infinite; NaN is a frame it leaves
          // undefined), are damaged too: NaN sums, or one Inf that made the allowance infinite,
          // let the gate pass a real regression.
          double size = std::abs(mean);
          bool infinite = false;
          for (double v : tiles->frameValues()) {
            infinite = infinite || std::isinf(v);
            if (std::isfinite(v)) size = std::max(size, std::abs(v));
          }
          const double fromTiles = infinite ? kUndefined : tiles->mean();
          const std::string& source = (std::string(which) == "baseline" ? base : cand).source;
          if (!(std::abs(fromTiles - mean) <= 1e-4 * size + 1e-12))
            throw Error((source.empty() ? std::string() : source + ": ") + which + " run, " +
                        (std::string(which) == "baseline" ? label : c.label) + " on " + scene +
                        ": summary." + t.metric + ".mean " + std::to_string(mean) +
                        " disagrees with its per-tile data (" +
                        (std::isfinite(fromTiles) ? std::to_string(fromTiles)
                                                  : std::string("no finite value")) +
                        "); the results were edited or damaged, and the gate will not judge them");
        }
        const PairedChange d = pairedRelativeChange(candTiles, baseTiles, scene, cfg);
        pairedTiles.emplace(baseTiles, candTiles);
        // Runs that summarise other frames (compared with --allow-settings-mismatch): the change
        // is taken over the frames both have, as its interval is, or the two would disagree (a
        // +98% change with an interval of [+0%, +0%]).
        sharedFrames = !d.frames.empty() && (d.frames.size() != baseTiles.frames.size() ||
                                             d.frames.size() != candTiles.frames.size());
        if (sharedFrames) {
          row.baseline = d.b;
          row.candidate = d.a;
          row.change = d.change;
          row.note = "over the " + std::to_string(d.frames.size()) +
                     " frames both runs summarise (baseline " +
                     std::to_string(baseTiles.frames.size()) + ", candidate " +
                     std::to_string(candTiles.frames.size()) + ")";
        }
        if (d.ci.valid()) {
          row.changeCi = d.ci;
          row.pValue = d.pValue;
          if (int(d.frames.size()) <= kFewSummarisedFrames) fewFrames = int(d.frames.size());
          const bool above = d.ci.lo > 0, below = d.ci.hi < 0;
          resolvedWorse = lowerIsBetter ? above : below;
          resolvedBetter = lowerIsBetter ? below : above;
        } else {
          row.note += (row.note.empty() ? "" : "; ") + std::string("no interval (too few frames)");
          unjudgeable = true;
        }
      } else if (!base.keepsTiles || !cand.keepsTiles) {
        // Summaries of other frames (a warm-up or length changed, compared with
        // --allow-settings-mismatch) differ for that alone, and results.db keeps no per-frame
        // tiles to take the frames both have: no change is given, rather than a window's (the
        // same input read -2.7% across warm-up 2 and 3).
        const int bf = b.summary.at(t.metric).frames, cf = c.summary.at(t.metric).frames;
        if (bf != cf) {
          row.change = kUndefined;
          row.verdict = "not judged";
          row.note = "the runs summarise other frames (baseline " + std::to_string(bf) +
                     ", candidate " + std::to_string(cf) +
                     ") and results.db keeps no per-frame tiles to compare the frames both have "
                     "(judge the run directories)";
          rows.push_back(row);
          continue;
        }
        row.note = "no tile data for a paired interval (results.db keeps none)";
        noTilesKept = true;
        // Summarised on too few frames, a change within tolerance is no more a pass than one
        // resolved there from tiles (below): the runs' tiles would have been too few to judge by
        // (runs read from results.db on one frame passed the gate where their directories could
        // not).
        if (const MetricDefinition* m = findMetric(t.metric);
            m && recordedWithTiles(*m) && bf > 0 && bf <= kFewSummarisedFrames)
          fewFrames = bf;
      } else if (!tiled.count(t.metric)) {
        row.note = "no paired interval (" + t.metric + " keeps no per-tile data)";
      } else {
        row.note = "no tile data for a paired interval";
        unjudgeable = true;
      }
      const double worse = lowerIsBetter ? row.change : -row.change;
      judge(row, worse, resolvedWorse, resolvedBetter, unjudgeable, noTilesKept,
            sharedFrames && row.changeCi.valid());
      // Resolved on too few frames: the interval is too narrow to hold its level (statistics.hpp),
      // so neither verdict stands, and the row stays outside the rows judged together. The gate
      // does not fail on it, and says why (a gate on 1 frame failed 6 of 8 reruns of noise alone).
      if (fewFrames > 0) {
        row.fewFrames = true;
        row.pValue = kUndefined;
        if (row.verdict == "regressed" || row.verdict == "improved") {
          row.note += (row.note.empty() ? "" : "; ") + std::string(worse > 0 ? "worse" : "better") +
                      " beyond tolerance, resolved on only " + std::to_string(fewFrames) +
                      (fewFrames == 1 ? " frame" : " frames") +
                      " after the warm-up, too few for its interval to hold its level (" +
                      std::to_string(kFewSummarisedFrames + 1) + " or more frames judge it)";
          row.verdict = "not judged";
        }
      }
      if (correction == Correction::Holm && pairedTiles && needsSharperP(row, cfg.replicates))
        sharper.push_back({rows.size(), [&cfg, scene, tiles = std::move(*pairedTiles)](int n) {
                             return pairedChangePValue(tiles.second, tiles.first, scene, cfg, n);
                           }});
      rows.push_back(row);
    }
    // Event figures (`--metric ghosting.lagEnergy`, `cut.oldViewLeak`): a row per event or cut of
    // the pairs, matched by frame.
    for (const Tolerance& t : tolerances) {
      if (!isGatedEventFigure(t.metric)) continue;
      const size_t dot = t.metric.find('.');
      const std::string kind = t.metric.substr(0, dot), figure = t.metric.substr(dot + 1);
      const bool cut = kind == "cut";
      std::map<int, const json*> baseEvents, candEvents;
      for (const auto& [pair, into] : {std::pair{&b, &baseEvents}, std::pair{&c, &candEvents}})
        if (const json& list = pair->part(cut ? "cuts" : "ghosting"); list.is_array())
          for (const json& e : list) (*into)[e.value("eventFrame", -1)] = &e;
      std::set<int> frames;
      for (const auto* events : {&baseEvents, &candEvents})
        for (const auto& [frame, e] : *events) frames.insert(frame);
      for (const int frame : frames) {
        ComparisonRow row{
            scene,      label,          kind + "@" + std::to_string(frame) + "." + figure,
            kUndefined, kUndefined,     kUndefined,
            {},         t.relative,     "ok",
            "",         candidateLabel, byRequest};
        const std::string what =
            std::string(cut ? "camera cut" : "event") + " at frame " + std::to_string(frame);
        if ((!candEvents.count(frame) || !baseEvents.count(frame)) && base.keepsTiles &&
            cand.keepsTiles) {
          const bool inBaseline = baseEvents.count(frame) > 0;
          row.verdict = inBaseline ? "missing" : "new";
          row.note = std::string("the ") + (inBaseline ? "candidate" : "baseline") +
                     "'s pair has no " + what;
          rows.push_back(row);
          continue;
        }
        // A run read from results.db keeps no pair's events (a history mixing it with run
        // directories): nothing lost, nothing to judge.
        if (!base.keepsTiles || !cand.keepsTiles) {
          row.verdict = "not judged";
          row.note = std::string("the ") + (base.keepsTiles ? "candidate" : "baseline") +
                     " run was read from results.db, which keeps no pair's events (judge the run "
                     "directories, which keep them)";
          rows.push_back(row);
          continue;
        }
        const json &be = *baseEvents.at(frame), &ce = *candEvents.at(frame);
        // A damaged tile record names its run, pair and event.
        for (const auto& [which, run, pair, e] :
             {std::tuple{"baseline", &base, &b, &be}, std::tuple{"candidate", &cand, &c, &ce}})
          try {
            resampled.of(*e, cut, scene, cfg);
          } catch (const Error& x) {
            throw Error((run->source.empty() ? "" : run->source + ": ") + which + " run, " +
                        pair->label + " on " + scene + ", " + (cut ? "cuts" : "ghosting") +
                        "[frame " + std::to_string(frame) + "].tiles: " + x.what());
          }
        const EventFigureChange d = eventFigureChange(be, ce, cut, figure, scene, cfg, &resampled);
        for (const auto& [which, run, pair, disagrees] :
             {std::tuple{"baseline", &base, &b, &d.baselineDisagrees},
              std::tuple{"candidate", &cand, &c, &d.candidateDisagrees}})
          if (!disagrees->empty())
            throw Error((run->source.empty() ? "" : run->source + ": ") + which + " run, " +
                        pair->label + " on " + scene + ": " + *disagrees +
                        "; the results were edited or damaged, and the gate will not judge them");
        if (!d.baselineAbsent.empty() || !d.candidateAbsent.empty()) {
          row.verdict = d.candidateAbsent.empty()  ? "new"
                        : d.baselineAbsent.empty() ? "missing"
                                                   : "absent";
          row.note = row.verdict == "new"       ? "absent in the baseline: " + d.baselineAbsent
                     : row.verdict == "missing" ? d.candidateAbsent
                     : d.baselineAbsent == d.candidateAbsent
                         ? "in both runs: " + d.baselineAbsent
                         : "baseline: " + d.baselineAbsent + "; candidate: " + d.candidateAbsent;
          if (row.verdict == "new") row.candidate = d.candidate;
          if (row.verdict == "missing") row.baseline = d.baseline;
          rows.push_back(row);
          continue;
        }
        row.baseline = d.baseline;
        row.candidate = d.candidate;
        row.change = d.change;
        // Never settled in either run: both responses are cut at the window's end, so no change
        // can show there (an "ok" of +0% would claim a check that was not made).
        const bool response = figure == "responseFrames";
        if (response && d.baselineNever && d.candidateNever) {
          row.verdict = "not judged";
          row.note = "neither run settled within the window (both counted as its " +
                     shortestText(d.baseline) +
                     " frames from the event): the response is cut off there, and no change can "
                     "show; a longer sequence after the event measures it";
          rows.push_back(row);
          continue;
        }
        row.changeCi = d.changeCi;
        row.pValue = d.pValue;
        if (response && (d.baselineNever || d.candidateNever))
          row.note = "baseline " + responseText(d.baseline, d.baselineNever) + ", candidate " +
                     responseText(d.candidate, d.candidateNever);
        // A lag summed within a window the method never settled in is cut off at its end.
        if ((figure == "lagEnergy" || figure == "chromaLagEnergy") &&
            (d.baselineNever || d.candidateNever))
          row.note += (row.note.empty() ? "" : "; ") +
                      std::string(d.baselineNever && d.candidateNever ? "neither run settled"
                                  : d.baselineNever                   ? "the baseline never settled"
                                                    : "the candidate never settled") +
                      " within the window: its lag is cut off at the window's end (a lower bound)";
        if (d.baseline == 0 && d.candidate != 0)
          row.note += (row.note.empty() ? "" : "; ") +
                      std::string(
                          "the baseline's figure is 0, so any rise is beyond a relative "
                          "tolerance; the difference ") +
                      shortestText(d.candidate - d.baseline) +
                      (d.difference.valid() ? " [" + shortestText(d.difference.lo) + ", " +
                                                  shortestText(d.difference.hi) + "]"
                                            : std::string());
        // Without an interval: data missing or unpaired (rerun both) fails the gate where worse,
        // as for the summaries; an event no interval can judge at all (its changed region within
        // fewer than 4 effective tiles: moving_light_shadow's sits in one) is not judged, listed
        // apart, as failing it on noise would make the figure ungateable.
        const bool noInterval = !d.difference.valid();
        if (noInterval)
          row.note += (row.note.empty() ? "" : "; ") + ("no interval: " + d.noInterval);
        judge(row, row.change, !noInterval && d.difference.lo > 0,
              !noInterval && d.difference.hi < 0, noInterval && !d.noIntervalByDesign,
              noInterval && d.noIntervalByDesign, !noInterval,
              ": no interval can judge this event's figure, whatever is rerun; not judged (it does "
              "not fail the gate: check it by eye, or across --seeds)");
        if (correction == Correction::Holm && !noInterval && needsSharperP(row, cfg.replicates))
          sharper.push_back({rows.size(), [&cfg, &be, &ce, cut, figure, scene](int n) {
                               BootstrapConfig more = cfg;
                               more.replicates = n;
                               return eventFigureChange(be, ce, cut, figure, scene, more).pValue;
                             }});
        rows.push_back(row);
      }
    }
  }
  for (const PairResult& c : cand.pairs)
    if (!baseKeys.count(key(c)))
      rows.push_back(c.ok() ? pairRow(c, "new", noShared + "pair not in the baseline run")
                            : pairRow(c, "failed", c.error));  // new or not, a failure is one
  // Many rows at once: one resolved by its own interval alone may be the few in a hundred that
  // noise resolves. Corrected together, it must stay resolved among every row with an interval.
  if (correction == Correction::Holm) {
    const double alpha = 1 - cfg.confidence;
    const size_t family = size_t(std::count_if(
        rows.begin(), rows.end(), [](const ComparisonRow& r) { return std::isfinite(r.pValue); }));
    // The smallest threshold is alpha / m; a p-value of replicates cannot fall below 2 / (R + 1).
    // The rows that may fail or pass the gate on it are resampled to 4 m / alpha replicates (at
    // most kMaxGateReplicates: a larger gate resolves less, docs/statistics.md; compare says so).
    const int needed =
        int(std::min(std::ceil(4.0 * double(family) / alpha), double(kMaxGateReplicates)));
    if (needed > cfg.replicates)
      for (const Sharper& x : sharper) rows[x.row].pValue = x.pValue(needed);
    std::vector<double> pValues;
    for (const ComparisonRow& r : rows) pValues.push_back(r.pValue);
    const std::vector<bool> kept = holmRejections(pValues, alpha);
    for (size_t i = 0; i < rows.size(); ++i) {
      ComparisonRow& r = rows[i];
      // One row is its own family: its interval's verdict stands (the count's p-value and the
      // interpolated interval end can disagree at the margin).
      if ((r.verdict != "regressed" && r.verdict != "improved") || kept[i] || family == 1) continue;
      const bool worse = r.verdict == "regressed";
      r.verdict = "unresolved";
      char p[32], first[32];
      std::snprintf(p, sizeof p, "%.2g", r.pValue);
      std::snprintf(first, sizeof first, "%.2g", alpha / double(family));
      char level[32];
      std::snprintf(level, sizeof level, "%.2g", alpha);
      // Its interval's end can sit just past zero while the finer p-value, drawn from more
      // replicates, lies above alpha itself: "resolved alone" beside "p 0.056" read as a
      // contradiction, so the note says which measure resolved it.
      const bool pAboveAlpha = r.pValue > alpha;
      r.note += (r.note.empty() ? "" : "; ") + std::string(worse ? "worse" : "better") +
                " beyond tolerance and " +
                (pAboveAlpha ? "its interval alone ends just short of zero, but"
                             : "resolved alone, but") +
                " not among the " + std::to_string(family) + " rows judged together: Holm, p " + p +
                (pAboveAlpha ? " (from " + std::to_string(std::max(needed, cfg.replicates)) +
                                   " replicates, above " + level + " itself)"
                             : std::string()) +
                " against thresholds from " + first + "; --correction none judges each alone";
    }
  }
  // A metric the caller named must have been computed somewhere; the defaults skip a metric
  // neither run computed (FLIP switched off in both).
  if (comparedPairs > 0)
    for (const Tolerance& t : tolerances)
      if (!t.optional && std::none_of(rows.begin(), rows.end(), [&](const ComparisonRow& r) {
            return r.metric == t.metric || gatedEventFigureOf(r.metric) == t.metric;
          }))
        throw UnmeasuredMetric(
            "--metric " + t.metric + ": neither run computed it on the " +
            std::to_string(comparedPairs) + " pair(s) both ran (nothing to gate on; " +
            (isGatedEventFigure(t.metric)
                 ? std::string(
                       "an event figure is measured on scenes with scripted events or camera "
                       "cuts, and kept in run directories, not in results.db)")
                 : std::string("`arena metrics` says what each metric needs, e.g. FLIP's --flip "
                               "setting)")));
  // A gate that held nothing to anything (every figure absent, no pair both runs ran, a baseline
  // whose pairs all failed) has checked nothing: it fails, saying so, rather than pass on no data.
  const bool judged = std::any_of(rows.begin(), rows.end(), [](const ComparisonRow& r) {
    return r.verdict == "ok" || r.verdict == "improved" || r.verdict == "regressed" ||
           r.verdict == "unresolved" || r.verdict == "unverified" || r.verdict == "not judged";
  });
  if (!judged) {
    ComparisonRow none{"*",        "*", "*", kUndefined,         kUndefined,
                       kUndefined, {},  0,   "nothing compared", ""};
    none.note = "no figure was measured by both runs (" + std::to_string(comparedPairs) +
                " pair(s) both ran): the gate would pass having checked nothing";
    rows.push_back(none);
  }
  return rows;
}

json comparisonJson(const std::vector<ComparisonRow>& rows) {
  auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json out = json::array();
  for (const ComparisonRow& r : rows)
    out.push_back({{"scene", r.scene},
                   {"label", r.label},
                   {"metric", r.metric},
                   {"baseline", num(r.baseline)},
                   {"candidate", num(r.candidate)},
                   {"change", num(r.change)},
                   {"changeCi95", r.changeCi.toJson()},
                   // A row of a whole pair or run (metric "*") was held to no tolerance.
                   {"tolerance", r.metric == "*" ? json(nullptr) : json(r.tolerance)},
                   {"verdict", r.verdict},
                   {"fails", failsGate(r)},
                   {"p", num(r.pValue)},
                   {"note", r.note},
                   {"candidateLabel", r.candidateLabel.empty() ? r.label : r.candidateLabel},
                   {"matchedByRequest", r.matchedByRequest}});
  return out;
}

bool failsGate(const ComparisonRow& row) {
  return row.verdict == "regressed" || row.verdict == "unverified" || row.verdict == "missing" ||
         row.verdict == "failed" || row.verdict == "not comparable" ||
         row.verdict == "nothing compared";
}

bool anyRegression(const std::vector<ComparisonRow>& rows) {
  return std::any_of(rows.begin(), rows.end(), failsGate);
}

GateOutcome gateOutcome(const std::vector<ComparisonRow>& rows) {
  if (std::any_of(rows.begin(), rows.end(), [](const ComparisonRow& r) {
        return r.verdict == "regressed" || r.verdict == "missing" || r.verdict == "failed";
      }))
    return GateOutcome::Regressed;
  // Intervals on too few frames (ComparisonRow::fewFrames) cannot tell a change from noise either
  // way: the gate cannot pass such runs, whatever their rows read (a +303% change on one frame
  // passed as "not judged", exit 0), as it cannot pass a change it has no interval for. Said of
  // the runs, not of a row, so the outcome does not flip with the noise.
  const bool fewFrames =
      std::any_of(rows.begin(), rows.end(), [](const ComparisonRow& r) { return r.fewFrames; });
  return anyRegression(rows) || fewFrames ? GateOutcome::CouldNotJudge : GateOutcome::Pass;
}

const char* gateOutcomeName(GateOutcome outcome) {
  switch (outcome) {
    case GateOutcome::Regressed:
      return "regressed";
    case GateOutcome::CouldNotJudge:
      return "could not judge";
    case GateOutcome::Pass:
      break;
  }
  return "pass";
}

int gateExitCode(GateOutcome outcome) {
  return outcome == GateOutcome::Regressed ? 1 : outcome == GateOutcome::CouldNotJudge ? 2 : 0;
}

bool sameRunRecord(const RunResults& a, const RunResults& b) {
  if (a.created != b.created || a.name != b.name || a.pairs.size() != b.pairs.size() ||
      a.environment.value("git_commit", "") != b.environment.value("git_commit", ""))
    return false;
  for (size_t p = 0; p < a.pairs.size(); ++p) {
    const PairResult &x = a.pairs[p], &y = b.pairs[p];
    if (x.label != y.label || x.scene != y.scene || x.status != y.status ||
        x.summary.size() != y.summary.size())
      return false;
    for (const auto& [metric, summary] : x.summary) {
      const SummaryMean u = x.mean(metric), v = y.mean(metric);
      if (u.present() != v.present() || (u.present() && u.mean != v.mean)) return false;
    }
  }
  return true;
}

bool isContender(const PairResult& p, const std::vector<std::string>& names) {
  return std::find(names.begin(), names.end(), p.label) != names.end() ||
         std::find(names.begin(), names.end(), p.denoiser) != names.end();
}

std::string labelAsWritten(const std::set<std::string>& labels, const std::string& typed) {
  if (labels.count(typed)) return typed;
  // name, then key=value texts; false when the text has no brackets or does not close them.
  const auto parts = [](const std::string& label, std::vector<std::string>& out) {
    const size_t open = label.find('[');
    if (open == std::string::npos || label.back() != ']') return false;
    out = {trimmed(label.substr(0, open))};
    std::string inner = label.substr(open + 1, label.size() - open - 2);
    for (size_t start = 0;;) {
      const size_t comma = inner.find(',', start);
      // Spaces around a key or a value are the writer's layout ("svgf[ sigmaL = 8 ]").
      std::string item = inner.substr(start, comma - start);
      const size_t eq = item.find('=');
      out.push_back(eq == std::string::npos
                        ? trimmed(item)
                        : trimmed(item.substr(0, eq)) + "=" + trimmed(item.substr(eq + 1)));
      if (comma == std::string::npos) return true;
      start = comma + 1;
    }
  };
  const auto number = [](const std::string& text, double& x) {
    if (text.empty()) return false;
    char* end = nullptr;
    x = std::strtod(text.c_str(), &end);
    return end == text.c_str() + text.size() && std::isfinite(x);
  };
  const auto sameValue = [&](const std::string& a, const std::string& b) {
    const size_t ea = a.find('='), eb = b.find('=');
    if (ea == std::string::npos || eb == std::string::npos) return a == b;
    if (a.substr(0, ea) != b.substr(0, eb)) return false;
    const std::string va = a.substr(ea + 1), vb = b.substr(eb + 1);
    double x = 0, y = 0;
    // The same number, or the same float (a built-in reads and labels floats: 4.1234567 ran as
    // the float its label writes 4.1234565).
    return va == vb || (number(va, x) && number(vb, y) && (x == y || float(x) == float(y)));
  };
  // The parameters in any order ("svgf[sigmaL=8,iterations=3]" for the run's
  // "svgf[iterations=3,sigmaL=8]"): compared key by key.
  const auto byKey = [](std::vector<std::string>& p) {
    std::sort(p.begin() + 1, p.end(), [](const std::string& a, const std::string& b) {
      return a.substr(0, a.find('=')) < b.substr(0, b.find('='));
    });
  };
  std::vector<std::string> want;
  if (!parts(typed, want)) return {};
  byKey(want);
  std::string found;
  for (const std::string& label : labels) {
    std::vector<std::string> have;
    if (!parts(label, have) || have.size() != want.size() || have[0] != want[0]) continue;
    byKey(have);
    bool same = true;
    for (size_t i = 1; i < have.size() && same; ++i) same = sameValue(have[i], want[i]);
    if (!same) continue;
    if (!found.empty()) return {};
    found = label;
  }
  return found;
}

std::vector<std::string> withMatchedLabels(std::vector<std::string> names,
                                           const std::map<std::string, std::string>& matches) {
  // Until nothing is added: a chain (A=B, B=C over a history) is one contender.
  for (bool added = true; added;) {
    added = false;
    for (const auto& [from, to] : matches)
      for (const auto& [have, partner] : {std::pair{from, to}, std::pair{to, from}})
        if (std::find(names.begin(), names.end(), have) != names.end() &&
            std::find(names.begin(), names.end(), partner) == names.end()) {
          names.push_back(partner);
          added = true;
        }
  }
  return names;
}

std::string labelList(const std::set<std::string>& labels) {
  std::string list;
  for (const std::string& l : labels) list += (list.empty() ? "" : ", ") + l;
  return list;
}

std::pair<std::string, std::string> splitLabelMatch(const std::string& a) {
  // A label may hold '=' itself (svgf[sigmaL=8]): the first '=' outside brackets splits.
  size_t split = std::string::npos;
  int depth = 0;
  bool balanced = true;  // every ']' closes an earlier '[', and every '[' is closed
  for (size_t i = 0; i < a.size(); ++i) {
    depth += a[i] == '[' ? 1 : a[i] == ']' ? -1 : 0;
    balanced = balanced && depth >= 0;
    if (a[i] == '=' && depth == 0 && split == std::string::npos) split = i;
  }
  balanced = balanced && depth == 0;
  if (!balanced)
    throw Error(
        "--match " + a +
        ": its brackets do not pair up; expected BASELINE=CANDIDATE, two labels as the runs "
        "write them (e.g. 'svgf=svgf[sigmaL=8]')");
  if (split == std::string::npos || split == 0 || split + 1 == a.size())
    throw Error("--match " + a +
                ": expected BASELINE=CANDIDATE, two labels (e.g. 'svgf=svgf[sigmaL=8]')");
  // Spaces around a label are the writer's layout (' svgf = svgf[sigmaL=8] '), not the label's.
  const std::string from = trimmed(a.substr(0, split)), to = trimmed(a.substr(split + 1));
  if (from.empty() || to.empty())
    throw Error("--match " + a +
                ": expected BASELINE=CANDIDATE, two labels (e.g. 'svgf=svgf[sigmaL=8]')");
  return {from, to};
}

std::map<std::string, std::string> checkLabelMatches(const std::vector<std::string>& assignments,
                                                     const RunResults& baseline,
                                                     const RunResults& candidate) {
  const auto labelsOf = [](const RunResults& run) {
    std::set<std::string> labels;
    for (const PairResult& p : run.pairs) labels.insert(p.label);
    return labels;
  };
  const std::set<std::string> base = labelsOf(baseline), cand = labelsOf(candidate);
  std::map<std::string, std::string> matches;
  std::set<std::string> matched;
  for (const std::string& a : assignments) {
    // As the runs write them: a number typed another way names the label it reads as.
    auto [from, to] = splitLabelMatch(a);
    if (const std::string label = labelAsWritten(base, from); !label.empty()) from = label;
    if (const std::string label = labelAsWritten(cand, to); !label.empty()) to = label;
    if (!base.count(from))
      throw Error("--match " + a + ": the baseline has no pair labelled " + from +
                  " (its labels: " + labelList(base) + ")");
    if (!cand.count(to))
      throw Error("--match " + a + ": the candidate has no pair labelled " + to +
                  " (its labels: " + labelList(cand) + ")");
    if (from == to)  // as history says it: nothing for the option to do
      throw Error("--match " + a + ": matches " + from +
                  " with itself; a label is matched with itself already");
    if (auto it = matches.find(from); it != matches.end() && it->second == to)
      continue;  // the same match given twice (a CI script's list and its default): one match
    if (matches.count(from)) throw Error("--match " + a + ": " + from + " is matched twice");
    if (!matched.insert(to).second) throw Error("--match " + a + ": " + to + " is matched twice");
    if (base.count(to))
      throw Error("--match " + a + ": the baseline has a pair labelled " + to +
                  " too, which is compared with the candidate's by its label");
    if (cand.count(from))
      throw Error("--match " + a + ": the candidate has a pair labelled " + from +
                  " too, which is compared with the baseline's by its label");
    matches[from] = to;
  }
  return matches;
}

void keepContenders(RunResults& baseline, RunResults& candidate, std::vector<std::string> names,
                    const std::map<std::string, std::string>& matches) {
  std::set<std::string> all;
  for (const RunResults* run : {&baseline, &candidate})
    for (const PairResult& p : run->pairs) all.insert(p.label);
  for (std::string& name : names) {
    // A label typed otherwise than the runs wrote it (sigmaL=8.0) names theirs, as with --match.
    if (const std::string label = labelAsWritten(all, name); !label.empty()) name = label;
    const auto has = [&](const RunResults& run) {
      return std::any_of(run.pairs.begin(), run.pairs.end(),
                         [&](const PairResult& p) { return isContender(p, {name}); });
    };
    if (has(baseline) || has(candidate)) continue;
    throw Error("--denoisers " + name +
                ": neither run has a pair of that label or denoiser (their labels: " +
                labelList(all) + ")");
  }
  names = withMatchedLabels(std::move(names), matches);
  // A pair the other run ran with the same denoiser and parameters under another label (a sweep's
  // point against a plain run's --param) is the one compareRuns pairs with it by what it ran:
  // naming either keeps both (naming one read the other "new", and the gate "nothing compared").
  std::vector<bool> keepBaseline, keepCandidate;
  for (const PairResult& p : baseline.pairs) keepBaseline.push_back(isContender(p, names));
  for (const PairResult& p : candidate.pairs) keepCandidate.push_back(isContender(p, names));
  for (size_t i = 0; i < baseline.pairs.size(); ++i)
    for (size_t k = 0; k < candidate.pairs.size(); ++k)
      if (keepBaseline[i] != keepCandidate[k] && ranTheSame(baseline.pairs[i], candidate.pairs[k]))
        keepBaseline[i] = keepCandidate[k] = true;
  for (auto [run, keep] :
       {std::pair{&baseline, &keepBaseline}, std::pair{&candidate, &keepCandidate}}) {
    std::vector<PairResult> kept;
    for (size_t i = 0; i < run->pairs.size(); ++i)
      if ((*keep)[i]) kept.push_back(std::move(run->pairs[i]));
    run->pairs = std::move(kept);
  }
  // A --match whose pairs the names dropped would be asked for and do nothing.
  for (const auto& [from, to] : matches)
    if (std::none_of(baseline.pairs.begin(), baseline.pairs.end(),
                     [&label = from](const PairResult& p) { return p.label == label; }))
      throw Error("--match " + from + "=" + to +
                  ": --denoisers keeps neither label; name one of them with --denoisers, or leave "
                  "this --match out");
}

}  // namespace arena
