#include "metrics/ghosting.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/error.hpp"
#include "metrics/summary.hpp"

namespace arena {

namespace {

std::array<double, 3> chromaticity(double r, double g, double b) {
  const double s = r + g + b;
  if (s <= 0) return {0, 0, 0};
  return {r / s, g / s, b / s};
}

double distance(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                   (a[2] - b[2]) * (a[2] - b[2]));
}

// b_pre-like baseline: the median of |v| over the (up to) `count` entries before index `first`.
double medianAbsBefore(const std::vector<double>& v, size_t first, int count) {
  std::vector<double> pre;
  for (size_t i = first > size_t(count) ? first - size_t(count) : 0; i < first && i < v.size(); ++i)
    pre.push_back(std::abs(v[i]));
  return pre.empty() ? 0.0 : percentile(pre, 50);
}

double excessSum(const std::vector<double>& v, size_t first, double baseline) {
  double s = 0;
  for (size_t i = first; i < v.size(); ++i) s += std::max(0.0, std::abs(v[i]) - baseline);
  return s;
}

}  // namespace

nlohmann::json GhostingConfig::toJson() const {
  return {
      {"tau", tau},
      {"chromaTau", chromaTau},
      {"chroma", "Euclidean distance of (R,G,B)/(R+G+B), pixels brighter than eps in both frames"},
      {"eps", eps},
      {"biasThreshold", biasThreshold},
      {"windowBefore", before},
      {"windowAfter", after},
      {"steadyFrames", steadyFrames},
      {"minFramesFromEvent", minFramesFromEvent},
      {"trailFrames", trailFrames},
      {"cutRecoveryFrames", recoveryFrames},
      // Since lag energy after an event a method never settled from became undefined: shards
      // and runs from before measured it as 0 there, and merge and compare refuse to mix them.
      {"lagAfterUnsettled",
       "undefined where the previous event never settled and b_pre rose above its own before it "
       "by more than biasThreshold (lagAbsent)"},
      {"intervals",
       "tile bootstrap (metrics/ghosting_intervals.hpp): the image's 4x4 tiles drawn with "
       "replacement "
       "once per replicate for the whole window (frames are not resampled), the curves and figures "
       "recomputed (the chromaticity error from the drawn tiles' summed colours), 1000 "
       "replicates, percentile intervals, seeded by scene and event; none when the changed "
       "region spreads over fewer than 4 effective tiles"}};
}

Image changedRegion(const Image& r0, const Image& rBefore, const GhostingConfig& c,
                    size_t* chromaOnly) {
  if (!r0.sameShape(rBefore)) throw Error("changed region: references differ in size");
  Image mask(r0.width(), r0.height(), 1);
  size_t added = 0;
  for (size_t i = 0; i < r0.pixelCount(); ++i) {
    const double a[3] = {r0.plane(0)[i], r0.plane(1)[i], r0.plane(2)[i]};
    const double b[3] = {rBefore.plane(0)[i], rBefore.plane(1)[i], rBefore.plane(2)[i]};
    const double l0 = luminance(a[0], a[1], a[2]), l1 = luminance(b[0], b[1], b[2]);
    const bool brightness = std::abs(l0 - l1) > c.tau * (l1 + c.eps);
    const bool colour =
        !brightness && std::min(l0, l1) > c.eps &&
        distance(chromaticity(a[0], a[1], a[2]), chromaticity(b[0], b[1], b[2])) > c.chromaTau;
    mask.plane(0)[i] = brightness || colour ? 1.0f : 0.0f;
    added += colour;
  }
  if (chromaOnly) *chromaOnly = added;
  return mask;
}

void addTrail(Image& mask, int objectId, const std::vector<const Image*>& previous,
              const Image& current) {
  for (size_t i = 0; i < mask.pixelCount(); ++i) {
    if (int(current.plane(0)[i]) == objectId) continue;
    for (const Image* p : previous)
      if (int(p->plane(0)[i]) == objectId) {
        mask.plane(0)[i] = 1.0f;
        break;
      }
  }
}

double signedBias(const Image& d, const Image& r, const Image& mask, double eps, TileSums* tiles) {
  double s = 0, n = 0;
  TileAccumulator acc(d.width(), d.height());
  for (size_t i = 0; i < d.pixelCount(); ++i) {
    if (mask.plane(0)[i] == 0) continue;
    double ld = luminance(d.plane(0)[i], d.plane(1)[i], d.plane(2)[i]);
    double lr = luminance(r.plane(0)[i], r.plane(1)[i], r.plane(2)[i]);
    const double term = (ld - lr) / (lr + eps);
    s += term;
    n += 1;
    if (tiles) acc.add(int(i % size_t(d.width())), int(i / size_t(d.width())), term, 1.0);
  }
  if (tiles) *tiles = acc.finish();
  return n > 0 ? s / n : 0.0;
}

double chromaticityErrorOfSums(const std::array<double, 3>& d, const std::array<double, 3>& r) {
  if (r[0] + r[1] + r[2] <= 0) return 0.0;
  return distance(chromaticity(d[0], d[1], d[2]), chromaticity(r[0], r[1], r[2]));
}

double chromaticityError(const Image& d, const Image& r, const Image& mask, ColourTileSums* tiles) {
  std::array<double, 3> sd = {0, 0, 0}, sr = {0, 0, 0};
  std::vector<TileAccumulator> acc;
  if (tiles) acc.assign(6, TileAccumulator(d.width(), d.height()));
  for (size_t i = 0; i < d.pixelCount(); ++i) {
    if (mask.plane(0)[i] == 0) continue;
    const int x = int(i % size_t(d.width())), y = int(i / size_t(d.width()));
    for (int c = 0; c < 3; ++c) {
      sd[size_t(c)] += d.plane(c)[i];
      sr[size_t(c)] += r.plane(c)[i];
      if (tiles) {
        acc[size_t(c)].add(x, y, d.plane(c)[i], 1.0);
        acc[size_t(3 + c)].add(x, y, r.plane(c)[i], 1.0);
      }
    }
  }
  if (tiles)
    for (size_t c = 0; c < 3; ++c) {
      tiles->denoised[c] = acc[c].finish();
      tiles->reference[c] = acc[3 + c].finish();
    }
  return chromaticityErrorOfSums(sd, sr);
}

namespace {
// "the window holds N frame(s) from the event on<where>, fewer than the <needed> <forWhat>", or ""
// when the window [.., windowEnd] holds at least `needed` frames from t0 on.
std::string tooFewFromEvent(int t0, int windowEnd, int needed, const std::string& where,
                            const std::string& forWhat) {
  const int fromEvent = windowEnd - t0 + 1;
  if (fromEvent >= needed) return "";
  return "the window holds " + std::to_string(std::max(fromEvent, 0)) +
         " frame(s) from the event on" + where + ", fewer than the " + std::to_string(needed) +
         " " + forWhat;
}
}  // namespace

std::string ghostingWindowProblem(int t0, int windowEnd, const GhostingConfig& c) {
  return tooFewFromEvent(
      t0, windowEnd, c.minFramesFromEvent,
      " (to frame " + std::to_string(windowEnd) + ": the sequence ends or the next event comes)",
      "needed to tell a response from a steady state");
}

std::string steadyStateProblem(int t0, int windowEnd, const GhostingConfig& c) {
  return tooFewFromEvent(
      t0, windowEnd, c.steadyFrames, "",
      "the steady state E_ss is the median of (frames before the event held the old state)");
}

GhostingResult analyseGhosting(int t0, int begin, const std::vector<double>& curve,
                               const std::vector<double>& bias, const std::vector<double>& chroma,
                               const GhostingConfig& c) {
  if (bias.size() != curve.size() || (!chroma.empty() && chroma.size() != curve.size()))
    throw Error("ghosting: the E_M, bias and chromaticity curves differ in length");
  GhostingResult g;
  g.eventFrame = t0;
  g.windowBegin = begin;
  g.windowEnd = begin + int(curve.size()) - 1;
  g.curve = curve;
  g.bias = bias;
  g.chroma = chroma;
  g.responseThreshold = c.biasThreshold;
  if (curve.empty()) return g;
  const size_t n = curve.size();
  const size_t first = size_t(std::clamp(t0 - begin, 0, int(n) - 1));
  // Secondary figures on E_M. The steady state never reaches before t0: those frames hold the
  // old state (a lower error there made a method that never settled look ghost-free).
  g.steadyAbsent = steadyStateProblem(t0, g.windowEnd, c);
  if (g.steadyAbsent.empty()) {
    const size_t steadyFrom = n - size_t(c.steadyFrames);
    g.steadyBegin = begin + int(steadyFrom);
    g.steadyState =
        percentile(std::vector<double>(curve.begin() + long(steadyFrom), curve.end()), 50);
    g.peakExcess = *std::max_element(curve.begin() + long(first), curve.end()) - g.steadyState;
    for (size_t i = first; i < n; ++i) g.ghostEnergy += std::max(0.0, curve[i] - g.steadyState);
  } else {
    g.steadyBegin = -1;
    g.steadyState = g.peakExcess = g.ghostEnergy = std::numeric_limits<double>::quiet_NaN();
  }
  // Response: one past the last frame from t0 on whose |b_M| exceeds the threshold.
  size_t lastAbove = n;
  for (size_t i = first; i < n; ++i)
    if (std::abs(bias[i]) > c.biasThreshold) lastAbove = i;
  g.settled = lastAbove != n - 1;
  g.responseFrames = lastAbove == n ? 0 : int(lastAbove - first) + 1;
  g.biasPre = medianAbsBefore(bias, first, c.before);
  g.lagEnergy = excessSum(bias, first, g.biasPre);
  if (!chroma.empty()) {
    g.chromaPre = medianAbsBefore(chroma, first, c.before);
    g.chromaLagEnergy = excessSum(chroma, first, g.chromaPre);
  }
  double b = 0;
  int k = 0;
  for (size_t i = first; i < std::min(n, first + 5); ++i, ++k) b += bias[i];
  g.signedBias = k > 0 ? b / k : 0.0;
  return g;
}

nlohmann::json GhostingResult::toJson() const {
  auto num = [](double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
  };
  nlohmann::json j = {
      {"eventFrame", eventFrame},
      {"windowBegin", windowBegin},
      {"windowEnd", windowEnd},
      {"curve", curve},
      {"bias", bias},
      {"steadyState", num(steadyState)},
      {"steadyBegin", steadyBegin >= 0 ? nlohmann::json(steadyBegin) : nlohmann::json(nullptr)},
      {"peakExcess", num(peakExcess)},
      {"ghostEnergy", num(ghostEnergy)},
      {"signedBias", signedBias},
      {"biasPre", biasPre},
      {"lagEnergy", lagEnergy},
      {"settled", settled},
      {"responseThreshold", responseThreshold},
      {"maskFraction", maskFraction},
      {"maskChromaFraction", maskChromaFraction}};
  j["responseFrames"] = settled ? nlohmann::json(responseFrames) : nlohmann::json(nullptr);
  if (!settled) j["response"] = "never settled within the window";
  if (!steadyAbsent.empty()) j["steadyAbsent"] = steadyAbsent;
  if (!chroma.empty()) {
    j["chromaError"] = chroma;
    j["chromaPre"] = chromaPre;
    j["chromaLagEnergy"] = chromaLagEnergy;
  }
  return j;
}

double oldViewLeak(const Image& d, const Image& r, const Image& old, TileSums* tiles) {
  if (!d.sameShape(r) || !old.sameShape(r))
    throw Error("old-view leak: images differ in size or channels");
  double ed = 0, dd = 0;
  TileAccumulator acc(r.width(), r.height());
  const size_t pixels = r.pixelCount();
  for (size_t i = 0; i < r.raw().size(); ++i) {
    const double diff = double(old.raw()[i]) - r.raw()[i];
    const double e = (double(d.raw()[i]) - r.raw()[i]) * diff;
    ed += e;
    dd += diff * diff;
    if (tiles) {  // planar layout: index i is pixel i % pixels of channel i / pixels
      const size_t p = i % pixels;
      acc.add(int(p % size_t(r.width())), int(p / size_t(r.width())), e, diff * diff);
    }
  }
  if (tiles) *tiles = acc.finish();
  return dd > 0 ? ed / dd : std::numeric_limits<double>::quiet_NaN();
}

CutResult analyseCut(int cut, int segmentEnd, const std::vector<double>& relMse,
                     const std::vector<double>& leak, const GhostingConfig& c) {
  if (cut < 0 || segmentEnd < cut || size_t(segmentEnd) >= relMse.size())
    throw Error("camera cut at frame " + std::to_string(cut) + ": segment end " +
                std::to_string(segmentEnd) + " outside the sequence");
  CutResult out;
  out.cutFrame = cut;
  out.steadyBegin = cut + c.recoveryFrames + 1;
  out.steadyEnd = segmentEnd;
  std::vector<double> steady;
  for (int t = out.steadyBegin; t <= segmentEnd; ++t) steady.push_back(relMse[size_t(t)]);
  out.steadyState = steady.empty() ? 0.0 : percentile(steady, 50);
  const double s = out.steadyState > 0 ? out.steadyState : NAN;
  out.atCut = relMse[size_t(cut)] / s;
  for (int t = cut + 1; t <= std::min(cut + c.recoveryFrames, segmentEnd); ++t) {
    out.recoveryFrames.push_back(t);
    out.recovery.push_back(relMse[size_t(t)] / s);
  }
  out.oldViewLeak = std::numeric_limits<double>::quiet_NaN();
  for (size_t k = 0; k < leak.size(); ++k) {
    out.leakFrames.push_back(cut + int(k));
    out.leak.push_back(leak[k]);
    if (std::isfinite(leak[k]))
      out.oldViewLeak = std::isfinite(out.oldViewLeak)
                            ? std::max(out.oldViewLeak, std::abs(leak[k]))
                            : std::abs(leak[k]);
  }
  return out;
}

nlohmann::json CutResult::toJson() const {
  nlohmann::json j = {
      {"kind", "camera_cut"},
      {"eventFrame", cutFrame},
      {"recoveryFrames", recoveryFrames},
      // The steady frames' first and last; none (null) when the segment ends
      // first, its last frame then in segmentEnd.
      {"steadyFrames",
       steadyEnd >= steadyBegin ? nlohmann::json{steadyBegin, steadyEnd} : nlohmann::json(nullptr)},
      {"leakFrames", leakFrames},
      {"leak", leak},
      {"oldViewLeak",
       std::isfinite(oldViewLeak) ? nlohmann::json(oldViewLeak) : nlohmann::json(nullptr)}};
  if (!std::isfinite(oldViewLeak) && !leak.empty())
    j["oldViewLeakAbsent"] =
        "the reference of frame " + std::to_string(cutFrame - 1) +
        " equals the references after the cut: no old view can show (did the camera cut here?)";
  if (steadyEnd >= steadyBegin && steadyState > 0) {
    j["steadyState"] = steadyState;
    j["atCut"] = atCut;
    j["recovery"] = recovery;
  } else {
    if (steadyEnd < steadyBegin) j["segmentEnd"] = steadyEnd;
    j["absent"] = "no frames after frame " + std::to_string(steadyBegin - 1) +
                  " before the segment ends: no steady state to compare with";
  }
  return j;
}

}  // namespace arena
