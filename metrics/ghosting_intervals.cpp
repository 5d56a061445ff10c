#include "metrics/ghosting_intervals.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include "core/error.hpp"
#include "core/text.hpp"

namespace arena {

using nlohmann::json;

namespace {

// Figures ranked between methods (lower is better); signed bias ranks by its magnitude.
const std::vector<std::string> kRankedEventFigures = {
    "lagEnergy", "responseFrames", "peakExcess", "ghostEnergy", "absSignedBias", "chromaLagEnergy"};

// The rows of `m` must be the consecutive frames first, first + 1, ... (a window).
void requireConsecutive(const MetricTiles& m, int first, const char* what) {
  for (size_t i = 0; i < m.frames.size(); ++i)
    if (m.frames[i] != first + int(i))
      throw Error(std::string("event tile data: ") + what +
                  " rows are not the consecutive frames from " + std::to_string(first) + " (row " +
                  std::to_string(i) + " is frame " + std::to_string(m.frames[i]) + ")");
}

// (sum n_k)^2 / sum n_k^2 over the tiles' data counts summed over every row: how many tiles the
// data really spreads over (1 when it sits in one tile, the tile count when spread evenly).
double effectiveTiles(const MetricTiles& m) {
  std::vector<double> perTile(size_t(m.tileCount()), 0.0);
  for (const TileSums& row : m.rows)
    for (size_t k = 0; k < row.count.size(); ++k) perTile[k] += std::abs(row.count[k]);
  double s = 0, s2 = 0;
  for (double n : perTile) s += n, s2 += n * n;
  return s2 > 0 ? s * s / s2 : 0.0;
}

// One replicate's curve: each row under the draw. A row that holds data but none in the drawn
// tiles makes the replicate undefined (returns false); a row without any data is 0, as the run's
// own value is (an empty region's mean is reported as 0).
bool curveUnder(const MetricTiles& m, const std::vector<int>& draw, std::vector<double>& out) {
  out.assign(m.rows.size(), 0.0);
  for (size_t r = 0; r < m.rows.size(); ++r) {
    const double v = m.valueUnder(r, draw);
    if (std::isfinite(v))
      out[r] = v;
    else if (m.rows[r].totalCount() != 0)
      return false;
  }
  return true;
}

// Why the chromaticity figures cannot be resampled from `e`'s colour sums ("" when they can):
// none stored (older results), or rows that are not the bias rows' frames and tiles.
std::string colourMismatch(const EventTiles& e) {
  if (!e.hasColour())
    return "no per-tile colour sums stored for this event (results written before they were)";
  for (const auto* side : {&e.denoisedColour, &e.referenceColour})
    for (size_t c = 0; c < 3; ++c)
      if ((*side)[c].frames != e.bias.frames || (*side)[c].tileCount() != e.bias.tileCount())
        return std::string("the ") + (side == &e.denoisedColour ? "denoised" : "reference") +
               " colour's " + "RGB"[c] + " tile sums cover " +
               std::to_string((*side)[c].frames.size()) + " frames x " +
               std::to_string((*side)[c].tileCount()) + " tiles, the event's window " +
               std::to_string(e.bias.frames.size()) + " x " + std::to_string(e.bias.tileCount()) +
               ": not resampled";
  return "";
}

FigureReplicates allAbsent(std::vector<std::string> figures, const std::string& why) {
  FigureReplicates r;
  r.figures = std::move(figures);
  for (const std::string& f : r.figures) r.absent[f] = why;
  return r;
}

// The replicate loop shared by events and cuts: `figuresOf(draw, out)` fills the figures of one
// tile draw (false: undefined under that draw); the identity draw gives the point figures, and a
// figure undefined there has no interval.
template <class FiguresOf>
void resample(FigureReplicates& r, int tiles, const std::string& seedName,
              const BootstrapConfig& cfg, const FiguresOf& figuresOf) {
  std::vector<int> identity(static_cast<size_t>(tiles));
  for (int k = 0; k < tiles; ++k) identity[size_t(k)] = k;
  std::map<std::string, double> point;
  if (!figuresOf(identity, point)) throw Error("event intervals: the full data gives no figures");
  r.point = point;
  for (const std::string& f : r.figures)
    if (!r.absent.count(f) && !std::isfinite(point.count(f) ? point[f] : kUndefined))
      r.absent[f] = "the figure itself is undefined for this event";
  r.widen = smallSampleWidening(r.effectiveTiles, cfg.confidence);
  // Frames are not resampled (see the header): a plan over one "frame" is a plan of tile draws.
  const ResamplingPlan plan(1, tiles, seedName, cfg);
  std::map<std::string, double> figures;
  for (int b = 0; b < plan.replicates(); ++b) {
    figures.clear();
    const bool ok = figuresOf(plan.tiles(b), figures);
    for (const std::string& f : r.figures)
      r.replicates[f].push_back(ok && figures.count(f) ? figures[f] : kUndefined);
  }
}

}  // namespace

void EventTiles::addColour(int frame, ColourTileSums sums) {
  for (size_t c = 0; c < 3; ++c) {
    denoisedColour[c].add(frame, std::move(sums.denoised[c]));
    referenceColour[c].add(frame, std::move(sums.reference[c]));
  }
}

bool EventTiles::hasColour() const {
  for (size_t c = 0; c < 3; ++c)
    if (denoisedColour[c].empty() || referenceColour[c].empty()) return false;
  return true;
}

json EventTiles::toJson() const {
  json j = {{"curve", curve.toJson()}, {"bias", bias.toJson()}};
  if (hasColour()) {
    json& colour = j["colour"];
    for (size_t c = 0; c < 3; ++c) {
      colour["denoised"].push_back(denoisedColour[c].toJson());
      colour["reference"].push_back(referenceColour[c].toJson());
    }
  }
  return j;
}

EventTiles EventTiles::fromJson(const json& j) {
  if (!j.is_object() || !j.contains("curve") || !j.contains("bias"))
    throw Error("event tile data: expected an object with curve and bias");
  EventTiles e{MetricTiles::fromJson(j["curve"]), MetricTiles::fromJson(j["bias"]), {}, {}};
  if (!j.contains("colour")) return e;  // written before the colour sums were stored
  const json& colour = j["colour"];
  for (const char* side : {"denoised", "reference"}) {
    const std::string field = std::string("event tile data: colour.") + side;
    if (!colour.is_object() || !colour.contains(side) || !colour[side].is_array() ||
        colour[side].size() != 3)
      throw Error(field + ": expected an array of 3 channels' tile sums (R, G, B)");
    for (size_t c = 0; c < 3; ++c) {
      try {
        (side == std::string("denoised") ? e.denoisedColour : e.referenceColour)[c] =
            MetricTiles::fromJson(colour[side][c]);
      } catch (const std::exception& x) {
        throw Error(field + "[" + std::to_string(c) + "] (" + "RGB"[c] + "): " + x.what());
      }
    }
  }
  return e;
}

json CutTiles::toJson() const {
  return {{"relMse", relMse.toJson()}, {"leak", leak.toJson()}};
}

CutTiles CutTiles::fromJson(const json& j) {
  if (!j.is_object() || !j.contains("relMse") || !j.contains("leak"))
    throw Error("cut tile data: expected an object with relMse and leak");
  return {MetricTiles::fromJson(j["relMse"]), MetricTiles::fromJson(j["leak"])};
}

std::vector<std::string> ghostingFigureNames() {
  return {"lagEnergy",     "responseFrames", "peakExcess",      "ghostEnergy", "signedBias",
          "absSignedBias", "steadyState",    "chromaLagEnergy", "chromaPre"};
}

std::vector<std::string> cutFigureNames(const GhostingConfig& c) {
  std::vector<std::string> out = {"atCut"};
  for (int k = 1; k <= c.recoveryFrames; ++k) out.push_back("recovery" + std::to_string(k));
  out.push_back("oldViewLeak");
  return out;
}

std::map<std::string, double> ghostingFigures(const GhostingResult& g) {
  const int fromEvent = g.windowEnd - g.eventFrame + 1;  // window frames from t0
  return {{"lagEnergy", g.lagEnergy},
          {"responseFrames", g.settled ? double(g.responseFrames) : double(fromEvent)},
          {"peakExcess", g.peakExcess},
          {"ghostEnergy", g.ghostEnergy},
          {"signedBias", g.signedBias},
          {"absSignedBias", std::abs(g.signedBias)},
          {"steadyState", g.steadyState},
          {"chromaLagEnergy", g.chroma.empty() ? kUndefined : g.chromaLagEnergy},
          {"chromaPre", g.chroma.empty() ? kUndefined : g.chromaPre}};
}

std::map<std::string, double> cutFigures(const CutResult& c, const GhostingConfig& gc) {
  const bool steady = c.steadyEnd >= c.steadyBegin && c.steadyState > 0;
  std::map<std::string, double> out = {{"atCut", steady ? c.atCut : kUndefined},
                                       {"oldViewLeak", c.oldViewLeak}};
  for (int k = 1; k <= gc.recoveryFrames; ++k)
    out["recovery" + std::to_string(k)] =
        steady && size_t(k) <= c.recovery.size() ? c.recovery[size_t(k - 1)] : kUndefined;
  return out;
}

std::string eventSeedName(const std::string& scene, int eventFrame) {
  return scene + "#event@" + std::to_string(eventFrame);
}

std::string cutSeedName(const std::string& scene, int cutFrame) {
  return scene + "#cut@" + std::to_string(cutFrame);
}

FigureReplicates ghostingReplicates(int t0, const EventTiles& tiles, const std::string& seedName,
                                    const BootstrapConfig& cfg, const GhostingConfig& gc) {
  if (tiles.curve.empty() || tiles.bias.empty())
    return allAbsent(ghostingFigureNames(), "no per-tile data for this event");
  if (tiles.curve.frames != tiles.bias.frames || tiles.curve.tileCount() != tiles.bias.tileCount())
    throw Error("event tile data: the E_M and bias rows differ in frames or tiles");
  const int begin = tiles.bias.frames.front();
  requireConsecutive(tiles.curve, begin, "E_M");
  if (t0 < begin || t0 > tiles.bias.frames.back())
    throw Error("event tile data: event frame " + std::to_string(t0) + " outside the window " +
                std::to_string(begin) + ".." + std::to_string(tiles.bias.frames.back()));
  if (std::string why = ghostingWindowProblem(t0, tiles.bias.frames.back(), gc); !why.empty())
    return allAbsent(ghostingFigureNames(), why);
  FigureReplicates r;
  r.figures = ghostingFigureNames();
  r.effectiveTiles = effectiveTiles(tiles.bias);
  char tilesText[32];
  std::snprintf(tilesText, sizeof tilesText, "%.1f", r.effectiveTiles);
  if (r.effectiveTiles == 0) return allAbsent(r.figures, "the changed region is empty");
  if (r.effectiveTiles < kMinEffectiveTiles) {
    FigureReplicates a =
        allAbsent(r.figures, std::string("the changed region spreads over ") + tilesText +
                                 " effective tiles of " + std::to_string(tiles.bias.tileCount()) +
                                 ", fewer than 4: too few spatial blocks to resample");
    a.effectiveTiles = r.effectiveTiles;
    a.tooFewTiles = true;
    return a;
  }
  const std::string noColour = colourMismatch(tiles);
  for (const char* f : {"chromaLagEnergy", "chromaPre"})
    if (!noColour.empty()) r.absent[f] = noColour;
  if (std::string why = steadyStateProblem(t0, tiles.bias.frames.back(), gc); !why.empty())
    for (const char* f : {"steadyState", "peakExcess", "ghostEnergy"}) r.absent[f] = why;
  r.neverSettled["responseFrames"] = double(tiles.bias.frames.back() - t0 + 1);
  std::vector<double> curve, bias, chroma;
  std::array<std::vector<double>, 3> d, ref;
  resample(r, tiles.bias.tileCount(), seedName, cfg,
           [&](const std::vector<int>& draw, std::map<std::string, double>& out) {
             if (!curveUnder(tiles.curve, draw, curve) || !curveUnder(tiles.bias, draw, bias))
               return false;
             chroma.clear();
             if (noColour.empty()) {
               // Each frame's chromaticity error from the drawn tiles' mean colours.
               for (size_t c = 0; c < 3; ++c)
                 if (!curveUnder(tiles.denoisedColour[c], draw, d[c]) ||
                     !curveUnder(tiles.referenceColour[c], draw, ref[c]))
                   return false;
               for (size_t i = 0; i < bias.size(); ++i)
                 chroma.push_back(chromaticityErrorOfSums({d[0][i], d[1][i], d[2][i]},
                                                          {ref[0][i], ref[1][i], ref[2][i]}));
             }
             out = ghostingFigures(analyseGhosting(t0, begin, curve, bias, chroma, gc));
             return true;
           });
  return r;
}

FigureReplicates cutReplicates(int cut, int segmentEnd, const CutTiles& tiles,
                               const std::string& seedName, const BootstrapConfig& cfg,
                               const GhostingConfig& gc) {
  if (tiles.relMse.empty() || tiles.leak.empty())
    return allAbsent(cutFigureNames(gc), "no per-tile data for this cut");
  if (tiles.relMse.tileCount() != tiles.leak.tileCount())
    throw Error("cut tile data: relMSE and leak rows have different tile counts");
  requireConsecutive(tiles.relMse, cut, "relMSE");
  requireConsecutive(tiles.leak, cut, "leak");
  if (tiles.relMse.frames.back() != segmentEnd)
    throw Error("cut tile data: relMSE rows end at frame " +
                std::to_string(tiles.relMse.frames.back()) + ", the segment at " +
                std::to_string(segmentEnd));
  FigureReplicates r;
  r.figures = cutFigureNames(gc);
  r.effectiveTiles = effectiveTiles(tiles.relMse);
  if (r.effectiveTiles < kMinEffectiveTiles) {
    FigureReplicates a =
        allAbsent(r.figures, "the frame spreads over fewer than 4 effective tiles");
    a.effectiveTiles = r.effectiveTiles;
    a.tooFewTiles = r.effectiveTiles > 0;
    return a;
  }
  std::vector<double> rows, leak;
  std::vector<double> relMse(size_t(segmentEnd) + 1, kUndefined);
  resample(r, tiles.relMse.tileCount(), seedName, cfg,
           [&](const std::vector<int>& draw, std::map<std::string, double>& out) {
             if (!curveUnder(tiles.relMse, draw, rows) || !curveUnder(tiles.leak, draw, leak))
               return false;
             // A frame whose view did not change has no leak (oldViewLeak), not a leak of 0.
             for (size_t f = 0; f < leak.size(); ++f)
               if (tiles.leak.rows[f].totalCount() == 0) leak[f] = kUndefined;
             std::copy(rows.begin(), rows.end(), relMse.begin() + cut);
             out = cutFigures(analyseCut(cut, segmentEnd, relMse, leak, gc), gc);
             return true;
           });
  return r;
}

double smallSampleWidening(double blocks, double confidence) {
  if (!(blocks >= 2) || !(confidence > 0 && confidence < 1)) return 1.0;
  // z: the standard normal quantile of (1 + confidence) / 2, by bisection on erfc.
  const double tail = (1 - confidence) / 2;
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    const double mid = (lo + hi) / 2;
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > tail ? lo : hi) = mid;
  }
  const double z = (lo + hi) / 2, nu = blocks - 1;
  // Student's t quantile by its expansion in 1 / nu (Abramowitz & Stegun 26.7.5); within 1% of
  // the exact value from nu = 3 on, and larger blocks counts are what the intervals need.
  const double z2 = z * z;
  const double t = z + z * (z2 + 1) / (4 * nu) + z * ((5 * z2 + 16) * z2 + 3) / (96 * nu * nu) +
                   z * (((3 * z2 + 19) * z2 + 17) * z2 - 15) / (384 * nu * nu * nu);
  return std::sqrt(blocks / nu) * t / z;
}

namespace {

// Figures that cannot be negative: an interval reaching below 0 is cut there (the truth lies in
// the figure's range, so cutting keeps the coverage). The signed bias alone can be: the peak
// excess is a maximum over frames that include the steady state's own, so at least 0 since the
// steady state no longer reaches before the event (docs/metrics.md, "Clipped windows").
bool nonNegative(const std::string& f) {
  return f != "signedBias";
}

// The response is a whole number of frames: its interval is the whole numbers inside the
// percentile interval (which interpolation and the small-sample widening leave fractional, "2
// [0.877, 3.12]"), so [1, 3]: the same values, no coverage lost. One holding none keeps its ends.
Interval clipped(Interval iv, const std::string& f) {
  if (iv.valid() && nonNegative(f)) iv.lo = std::max(iv.lo, 0.0), iv.hi = std::max(iv.hi, 0.0);
  if (iv.valid() && f == "responseFrames") {
    const double lo = std::ceil(iv.lo - 1e-9), hi = std::floor(iv.hi + 1e-9);
    if (lo <= hi) iv.lo = lo, iv.hi = hi;
  }
  return iv;
}

Interval figureInterval(const FigureReplicates& r, const std::string& f, double confidence) {
  const auto it = r.replicates.find(f);
  if (it == r.replicates.end()) return {};
  return clipped(widenedInterval(it->second, confidence, r.widen), f);
}

}  // namespace

void addFigureIntervals(json& j, const FigureReplicates& r,
                        const std::map<std::string, double>& point, double confidence) {
  json ci = json::object(), absent = json::object();
  for (const std::string& f : r.figures) {
    if (r.absent.count(f)) {
      absent[f] = r.absent.at(f);
      continue;
    }
    if (!std::isfinite(point.count(f) ? point.at(f) : kUndefined)) {
      absent[f] = "the figure itself is undefined for this event";
      continue;
    }
    const Interval iv = figureInterval(r, f, confidence);
    if (!iv.valid()) {
      absent[f] = "fewer than 20 replicates define the figure";
      continue;
    }
    json bounds = iv.toJson();
    if (r.neverSettled.count(f)) {  // a bound at "never settled" is no number of frames
      const double never = r.neverSettled.at(f);
      if (iv.lo >= never) bounds[0] = nullptr;
      if (iv.hi >= never) bounds[1] = nullptr;
    }
    ci[f] = bounds;
  }
  j["ci95"] = ci;
  if (!absent.empty()) j["ci95Absent"] = absent;
  if (r.neverSettled.size())
    j["ci95NeverSettled"] = "a null bound of responseFrames means: never settled within the window";
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", r.effectiveTiles);
  j["ciEffectiveTiles"] = std::stod(text);
}

namespace {

// A pair's point figures from its stored event or cut JSON (the values the run reported).
std::map<std::string, double> pointFigures(const json& j, bool cut, const GhostingConfig& gc) {
  auto num = [&](const char* k) {
    return j.contains(k) && j[k].is_number() ? j[k].get<double>() : kUndefined;
  };
  std::map<std::string, double> out;
  if (cut) {
    out["atCut"] = num("atCut");
    out["oldViewLeak"] = num("oldViewLeak");
    for (int k = 1; k <= gc.recoveryFrames; ++k) {
      const bool has = j.contains("recovery") && j["recovery"].size() >= size_t(k);
      out["recovery" + std::to_string(k)] =
          has ? j["recovery"][size_t(k - 1)].get<double>() : kUndefined;
    }
    return out;
  }
  for (const char* k : {"lagEnergy", "peakExcess", "ghostEnergy", "signedBias", "steadyState",
                        "chromaLagEnergy", "chromaPre"})
    out[k] = num(k);
  out["absSignedBias"] = std::abs(out["signedBias"]);
  // settled is null where the event has no figures (an empty changed region): no value then.
  const bool neverSettled =
      j.contains("settled") && j["settled"].is_boolean() && !j["settled"].get<bool>();
  out["responseFrames"] =
      neverSettled ? num("windowEnd") - num("eventFrame") + 1 : num("responseFrames");
  return out;
}

// A pair's stored event or cut (eventFrame, its tiles) resampled with its scene's seed: every
// method of the scene, and the same scene in another run, draws the same tiles.
FigureReplicates storedReplicates(const json& e, bool cut, const std::string& scene,
                                  const BootstrapConfig& cfg, const GhostingConfig& gc) {
  const int frame = e.value("eventFrame", -1);
  FigureReplicates r;
  if (!e.contains("tiles")) {
    r = allAbsent(cut ? cutFigureNames(gc) : ghostingFigureNames(),
                  "no per-tile data stored (an older run)");
  } else if (cut) {
    // The segment's last frame: the steady frames' last, or where there are none (null; an older
    // run wrote them as an empty range, [first, last] with first > last), segmentEnd.
    const json steady = e.value("steadyFrames", json());
    const int segmentEnd = steady.is_array() && steady.size() == 2 ? steady.at(1).get<int>()
                                                                   : e.value("segmentEnd", frame);
    r = cutReplicates(frame, segmentEnd, CutTiles::fromJson(e["tiles"]), cutSeedName(scene, frame),
                      cfg, gc);
  } else {
    r = ghostingReplicates(frame, EventTiles::fromJson(e["tiles"]), eventSeedName(scene, frame),
                           cfg, gc);
  }
  // Lag figures the evaluation left undefined (a method still lagging from the event before): the
  // ranking excludes it with the evaluation's reason.
  if (!cut && e.contains("lagAbsent") && e["lagAbsent"].is_string())
    for (const char* f : {"lagEnergy", "chromaLagEnergy"})
      r.absent[f] = e["lagAbsent"].get<std::string>();
  return r;
}

// Why a stored event or cut has no value of `figure`: the run's own reason where it wrote one.
std::string absentReason(const json& e, bool cut, const std::string& figure) {
  const auto text = [&](const json& j, const std::string& key) {
    return j.is_object() && j.contains(key) && j[key].is_string() ? j[key].get<std::string>()
                                                                  : std::string();
  };
  if (!cut && e.value("settled", json(false)).is_null())
    return "no figures for this event (its changed region is empty)";
  std::string why = cut && figure == "oldViewLeak" ? text(e, "oldViewLeakAbsent")
                    : cut                          ? text(e, "absent")
                                                   : "";
  if (why.empty()) why = text(e.value("ci95Absent", json()), figure);
  return why.empty() ? "the figure is undefined for this " + std::string(cut ? "cut" : "event")
                     : why;
}

// The tiles' frames and count of a stored event or cut ("" when it has none): two runs' draws are
// the same tiles only where these agree.
std::string tileShape(const json& e, bool cut) {
  if (!e.contains("tiles")) return "";
  const MetricTiles m =
      cut ? CutTiles::fromJson(e["tiles"]).relMse : EventTiles::fromJson(e["tiles"]).bias;
  if (m.frames.empty()) return "";
  return "frames " + std::to_string(m.frames.front()) + ".." + std::to_string(m.frames.back()) +
         ", " + std::to_string(m.tileCount()) + " tiles";
}

std::map<std::string, SceneRanking> rankFigures(const std::vector<std::string>& ranked,
                                                const std::vector<std::string>& labels,
                                                const std::vector<std::map<std::string, double>>& points,
                                                const std::vector<FigureReplicates>& reps,
                                                const BootstrapConfig& cfg) {
  std::map<std::string, SceneRanking> byFigure;
  for (const std::string& f : ranked) {
    std::vector<std::string> kept;
    std::vector<double> values;
    std::vector<std::vector<double>> replicates;
    std::vector<std::pair<std::string, std::string>> excluded;  // label, why
    double widen = 1.0;  // the largest of the methods' (they share the region, so the same)
    for (size_t i = 0; i < labels.size(); ++i) {
      const double v = points[i].count(f) ? points[i].at(f) : kUndefined;
      std::string why = reps[i].absent.count(f) ? reps[i].absent.at(f) : "";
      if (why.empty() && !std::isfinite(v)) why = "no value";
      if (!why.empty()) {
        excluded.push_back({labels[i], why});
        continue;
      }
      kept.push_back(labels[i]);
      widen = std::max(widen, reps[i].widen);
      values.push_back(v);
      replicates.push_back(reps[i].replicates.at(f));
    }
    // The same interval kind as the pair's own figures (addFigureIntervals).
    SceneRanking r = rankReplicates(f, true, kept, values, replicates, cfg.confidence, widen);
    for (RankedMethod& m : r.ranking) m.ci = clipped(m.ci, f);  // as the pair's own figure
    for (const auto& [label, why] : excluded) r.leaveOut(label, why);
    r.replicates.clear();  // the figure's replicates serve no overall score
    byFigure[f] = std::move(r);
  }
  return byFigure;
}

}  // namespace

SceneEvents rankSceneEvents(std::vector<std::pair<std::string, const json*>> pairs,
                            const std::string& scene, const BootstrapConfig& cfg) {
  const GhostingConfig gc;
  // By label, so that the pairs' order (a merge of shards puts them shard by shard) changes
  // nothing.
  std::stable_sort(pairs.begin(), pairs.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  SceneEvents out;
  for (const bool cut : {false, true}) {
    const char* key = cut ? "cuts" : "ghosting";
    std::set<int> frames;
    for (const auto& [label, p] : pairs)
      for (const json& e : p->value(key, json::array())) frames.insert(e.value("eventFrame", -1));
    for (int frame : frames) {
      std::vector<std::string> labels;
      std::vector<std::map<std::string, double>> points;
      std::vector<FigureReplicates> reps;
      EventStatistics event;
      event.eventFrame = frame;
      bool named = false;
      for (const auto& [label, p] : pairs)
        for (const json& e : p->value(key, json::array())) {
          if (e.value("eventFrame", -1) != frame) continue;
          if (!named) {  // the first pair's (by label) kind and object name the event
            event.kind = e.value("kind", cut ? "camera_cut" : "");
            if (!cut) event.what = e.value("what", "");
            named = true;
          }
          labels.push_back(label);
          points.push_back(pointFigures(e, cut, gc));
          reps.push_back(storedReplicates(e, cut, scene, cfg, gc));
        }
      event.byFigure =
          rankFigures(cut ? cutFigureNames(gc) : kRankedEventFigures, labels, points, reps, cfg);
      (cut ? out.cuts : out.events).push_back(std::move(event));
    }
  }
  return out;
}

std::map<std::string, double> storedFigures(const json& e, bool cut) {
  return pointFigures(e, cut, GhostingConfig{});
}

std::vector<std::string> gatedEventFigureNames(const GhostingConfig& gc) {
  std::vector<std::string> out;
  for (const std::string& f : kRankedEventFigures) out.push_back("ghosting." + f);
  for (const std::string& f : cutFigureNames(gc)) out.push_back("cut." + f);
  return out;
}

bool isGatedEventFigure(const std::string& name) {
  const std::vector<std::string> names = gatedEventFigureNames();
  return std::find(names.begin(), names.end(), name) != names.end();
}

std::string gatedEventFigureOf(const std::string& rowMetric) {
  const size_t at = rowMetric.find('@'), dot = rowMetric.find('.');
  if (at == std::string::npos || dot == std::string::npos || dot < at) return "";
  const std::string name = rowMetric.substr(0, at) + rowMetric.substr(dot);
  return isGatedEventFigure(name) ? name : "";
}

std::string storedFigureAbsence(const json& e, bool cut, const std::string& figure, double value) {
  // The evaluation's own reason first (a method still lagging from the event before), then the
  // figure's.
  if (!cut && (figure == "lagEnergy" || figure == "chromaLagEnergy") &&
      e.value("lagAbsent", json()).is_string())
    return e["lagAbsent"].get<std::string>();
  return std::isfinite(value) ? "" : absentReason(e, cut, figure);
}

const FigureReplicates& EventReplicateCache::of(const json& e, bool cut, const std::string& scene,
                                                const BootstrapConfig& cfg) {
  auto it = byEvent.find(&e);
  if (it == byEvent.end())
    it = byEvent.emplace(&e, storedReplicates(e, cut, scene, cfg, GhostingConfig{})).first;
  return it->second;
}

EventFigureChange eventFigureChange(const json& baseEvent, const json& candEvent, bool cut,
                                    const std::string& figure, const std::string& scene,
                                    const BootstrapConfig& cfg, EventReplicateCache* cache) {
  const GhostingConfig gc;
  EventFigureChange out;
  const json* events[2] = {&baseEvent, &candEvent};
  FigureReplicates reps[2];
  for (int k = 0; k < 2; ++k) {
    const json& e = *events[k];
    reps[k] = cache ? cache->of(e, cut, scene, cfg) : storedReplicates(e, cut, scene, cfg, gc);
    const std::map<std::string, double> point = pointFigures(e, cut, gc);
    double& value = k == 0 ? out.baseline : out.candidate;
    std::string& absent = k == 0 ? out.baselineAbsent : out.candidateAbsent;
    value = point.count(figure) ? point.at(figure) : kUndefined;
    absent = storedFigureAbsence(e, cut, figure, value);
    if (!absent.empty()) value = kUndefined;
    if (!cut)
      (k == 0 ? out.baselineNever : out.candidateNever) =
          e.value("settled", json()).is_boolean() && !e["settled"].get<bool>();
  }
  if (!out.baselineAbsent.empty() || !out.candidateAbsent.empty()) return out;
  // The stored figure against its tiles' (float32 sums against the run's doubles: within 1e-3 of
  // the figure's size; a response may cross its threshold a frame apart).
  for (int k = 0; k < 2; ++k) {
    const double stored = k == 0 ? out.baseline : out.candidate;
    const auto it = reps[k].point.find(figure);
    if (it == reps[k].point.end() || !std::isfinite(it->second)) continue;
    const double fromTiles = it->second;
    const bool agree = figure == "responseFrames"
                           ? std::abs(fromTiles - stored) <= 1
                           : std::abs(fromTiles - stored) <=
                                 1e-3 * std::max(std::abs(stored), std::abs(fromTiles)) + 1e-6;
    if (!agree)
      (k == 0 ? out.baselineDisagrees : out.candidateDisagrees) =
          std::string(cut ? "cuts" : "ghosting") + "[frame " +
          std::to_string((k == 0 ? baseEvent : candEvent).value("eventFrame", -1)) + "]." + figure +
          " " + shortestText(stored) + " disagrees with its per-tile data (" +
          shortestText(fromTiles) + ")";
  }
  if (!out.baselineDisagrees.empty() || !out.candidateDisagrees.empty()) return out;
  const double scale = std::abs(out.baseline);
  out.change = scale > 0           ? (out.candidate - out.baseline) / scale
               : out.candidate > 0 ? std::numeric_limits<double>::infinity()
               : out.candidate < 0 ? -std::numeric_limits<double>::infinity()
                                   : 0.0;
  for (int k = 0; k < 2; ++k)
    if (reps[k].absent.count(figure)) {
      out.noInterval =
          std::string(k == 0 ? "baseline" : "candidate") + ": " + reps[k].absent.at(figure);
      out.noIntervalByDesign = reps[k].tooFewTiles;
      return out;
    }
  const std::string shapes[2] = {tileShape(baseEvent, cut), tileShape(candEvent, cut)};
  if (shapes[0] != shapes[1]) {
    out.noInterval = "the runs' tiles of this event differ (" + shapes[0] + " vs " + shapes[1] +
                     "): their draws are not paired";
    return out;
  }
  const std::vector<double>&b = reps[0].replicates.at(figure), &c = reps[1].replicates.at(figure);
  // (A difference of rounding alone is none, as in every paired difference: statistics.hpp.)
  const std::vector<double> differences = replicateDifferences(c, b);
  const double widen = std::max(reps[0].widen, reps[1].widen);
  out.difference = widenedInterval(differences, cfg.confidence, widen);
  if (!out.difference.valid()) {
    out.noInterval = "fewer than 20 replicates define the figure in both runs";
    return out;
  }
  // A response's difference is a whole number of frames in every replicate: the whole numbers
  // inside the interval, as the figure's own interval (clipped).
  if (figure == "responseFrames") {
    const double lo = std::ceil(out.difference.lo - 1e-9),
                 hi = std::floor(out.difference.hi + 1e-9);
    if (lo <= hi) out.difference = {lo, hi};
  }
  // A figure that cannot be negative cannot fall by more than its baseline: the difference's
  // lower end is cut at -baseline (the change's at -100%), as the figure's own interval is cut at
  // 0 ("+38.7% [-17897.0%, +5442.4%]" on a lag energy before).
  if (nonNegative(figure) && out.baseline >= 0) {
    out.difference.lo = std::max(out.difference.lo, -out.baseline);
    out.difference.hi = std::max(out.difference.hi, -out.baseline);
  }
  // The p-value counts the widened replicates, as the interval does.
  out.pValue = changePValue(widenedReplicates(differences, widen));
  if (scale > 0) out.changeCi = {out.difference.lo / scale, out.difference.hi / scale};
  return out;
}

}  // namespace arena
