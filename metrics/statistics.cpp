#include "metrics/statistics.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <set>

#include "core/error.hpp"
#include "core/hash.hpp"
#include "metrics/error.hpp"

namespace arena {

using nlohmann::json;

const char* transformName(FrameTransform t) {
  switch (t) {
    case FrameTransform::Mean:
      return "mean";
    case FrameTransform::Sqrt:
      return "sqrt";
    case FrameTransform::Psnr:
      return "psnr";
  }
  return "mean";
}

FrameTransform parseTransform(const std::string& name) {
  if (name == "mean") return FrameTransform::Mean;
  if (name == "sqrt") return FrameTransform::Sqrt;
  if (name == "psnr") return FrameTransform::Psnr;
  throw Error("tile data: unknown frame transform '" + name + "' (expected mean, sqrt or psnr)");
}

namespace {

double applyTransform(FrameTransform t, double mean) {
  switch (t) {
    case FrameTransform::Mean:
      return mean;
    case FrameTransform::Sqrt:
      return std::sqrt(std::max(mean, 0.0));
    case FrameTransform::Psnr:
      return psnrFromMse(mean);
  }
  return mean;
}

// Float32 arrays as base64 keep the tile data of a run a few hundred kB instead of megabytes of
// 17-digit JSON numbers; float precision is ample for resampling.
constexpr char kBase64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::string encodeFloats(const std::vector<float>& v) {
  std::string bytes(v.size() * 4, '\0');
  if (!v.empty()) std::memcpy(bytes.data(), v.data(), bytes.size());  // x86-64: little-endian
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t n = uint32_t(uint8_t(bytes[i])) << 16;
    if (i + 1 < bytes.size()) n |= uint32_t(uint8_t(bytes[i + 1])) << 8;
    if (i + 2 < bytes.size()) n |= uint32_t(uint8_t(bytes[i + 2]));
    out += kBase64[(n >> 18) & 63];
    out += kBase64[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kBase64[(n >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kBase64[n & 63] : '=';
  }
  return out;
}

std::vector<float> decodeFloats(const std::string& text, size_t expected, const char* what) {
  auto value = [](char c) -> int {
    const char* p = std::strchr(kBase64, c);
    return c != '\0' && p ? int(p - kBase64) : -1;
  };
  if (text.size() % 4 != 0)
    throw Error(std::string("tile data: ") + what + " is not base64 (length not a multiple of 4)");
  std::string bytes;
  for (size_t i = 0; i < text.size(); i += 4) {
    int v[4];
    for (int k = 0; k < 4; ++k) {
      v[k] = text[i + size_t(k)] == '=' ? 0 : value(text[i + size_t(k)]);
      if (v[k] < 0) throw Error(std::string("tile data: ") + what + " is not base64");
    }
    const uint32_t n =
        uint32_t(v[0]) << 18 | uint32_t(v[1]) << 12 | uint32_t(v[2]) << 6 | uint32_t(v[3]);
    bytes += char((n >> 16) & 255);
    if (text[i + 2] != '=') bytes += char((n >> 8) & 255);
    if (text[i + 3] != '=') bytes += char(n & 255);
  }
  if (bytes.size() != expected * 4)
    throw Error(std::string("tile data: ") + what + " holds " + std::to_string(bytes.size() / 4) +
                " values, expected " + std::to_string(expected));
  std::vector<float> out(expected);
  if (expected) std::memcpy(out.data(), bytes.data(), bytes.size());
  return out;
}

// Value of one row under a tile draw (all tiles when `tiles` is null); NaN when the drawn tiles
// hold no data (e.g. no valid warped pixel).
double rowValue(const MetricTiles& m, size_t row, const std::vector<int>* tiles) {
  const TileSums& t = m.rows[row];
  double s = 0, n = 0;
  if (!tiles || t.sum.size() == 1) {
    s = t.totalSum();
    n = t.totalCount();
  } else {
    for (int k : *tiles) {
      s += t.sum[size_t(k)];
      n += t.count[size_t(k)];
    }
  }
  return n > 0 ? applyTransform(m.transform, s / n) : kUndefined;
}

double meanOfFinite(const std::vector<double>& v) {
  double s = 0;
  int n = 0;
  for (double x : v)
    if (std::isfinite(x)) s += x, ++n;
  return n ? s / n : kUndefined;
}

uint64_t seedOf(const std::string& name) {
  return Hasher().add("arena-bootstrap").add(name).value();
}

}  // namespace

void MetricTiles::add(int frame, TileSums tiles) {
  if (!rows.empty() && tiles.sum.size() != rows.front().sum.size())
    throw Error("tile data: frame " + std::to_string(frame) + " has another tile count");
  frames.push_back(frame);
  rows.push_back(std::move(tiles));
}

void MetricTiles::addScalar(int frame, double value) {
  add(frame, TileSums{{value}, {1.0}});
}

std::vector<double> MetricTiles::frameValues() const {
  std::vector<double> v;
  for (size_t r = 0; r < rows.size(); ++r) v.push_back(rowValue(*this, r, nullptr));
  return v;
}

double MetricTiles::valueUnder(size_t row, const std::vector<int>& tiles) const {
  if (row >= rows.size()) throw Error("tile data: row " + std::to_string(row) + " out of range");
  for (int k : tiles)
    if (k < 0 || size_t(k) >= rows[row].sum.size())
      throw Error("tile data: tile " + std::to_string(k) + " out of range");
  return rowValue(*this, row, &tiles);
}

double MetricTiles::mean() const {
  return meanOfFinite(frameValues());
}

MetricTiles MetricTiles::restrictedTo(const std::vector<int>& wanted) const {
  MetricTiles out;
  out.transform = transform;
  for (int f : wanted) {
    auto it = std::find(frames.begin(), frames.end(), f);
    if (it == frames.end()) throw Error("tile data: frame " + std::to_string(f) + " is missing");
    out.add(f, rows[size_t(it - frames.begin())]);
  }
  return out;
}

json MetricTiles::toJson() const {
  std::vector<float> sums, counts;
  // Most metrics count the same pixels every frame: then one row of counts is stored.
  bool sameCounts = true;
  for (const TileSums& t : rows) sameCounts &= t.count == rows.front().count;
  for (const TileSums& t : rows) {
    for (double v : t.sum) sums.push_back(float(v));
    if (!sameCounts || counts.empty())
      for (double v : t.count) counts.push_back(float(v));
  }
  json j = {{"transform", transformName(transform)},
            {"frames", frames},
            {"tiles", tileCount()},
            {"sum", encodeFloats(sums)},
            {"count", encodeFloats(counts)}};
  if (sameCounts && !rows.empty()) j["countPerFrame"] = false;
  return j;
}

MetricTiles MetricTiles::fromJson(const json& j) {
  if (!j.is_object() || !j.contains("frames") || !j.contains("tiles") || !j.contains("sum") ||
      !j.contains("count"))
    throw Error("tile data: expected an object with transform, frames, tiles, sum and count");
  MetricTiles m;
  m.transform = parseTransform(j.value("transform", "mean"));
  const std::vector<int> frames = j["frames"].get<std::vector<int>>();
  const int tiles = j["tiles"].get<int>();
  if (tiles < 0 || tiles > 1 << 16)
    throw Error("tile data: tile count " + std::to_string(tiles) + " out of range");
  const size_t n = frames.size() * size_t(tiles);
  const std::vector<float> sums = decodeFloats(j["sum"].get<std::string>(), n, "sum");
  const bool perFrame = j.value("countPerFrame", true);
  const std::vector<float> counts = decodeFloats(
      j["count"].get<std::string>(), perFrame ? n : (frames.empty() ? 0 : size_t(tiles)), "count");
  for (size_t r = 0; r < frames.size(); ++r) {
    TileSums t;
    for (int k = 0; k < tiles; ++k) {
      t.sum.push_back(sums[r * size_t(tiles) + size_t(k)]);
      t.count.push_back(counts[(perFrame ? r * size_t(tiles) : 0) + size_t(k)]);
    }
    m.add(frames[r], std::move(t));
  }
  return m;
}

json Interval::toJson() const {
  if (!valid()) return nullptr;
  // + 0.0 writes a -0 (a difference of 0 negated) as 0: "[-0, 0]" read as a sign where none is.
  return json::array({lo + 0.0, hi + 0.0});
}

std::optional<Interval> Interval::fromJson(const json& j) {
  if (j.is_null()) return Interval{};
  if (!j.is_array() || j.size() != 2 || !j[0].is_number() || !j[1].is_number()) return std::nullopt;
  if (j[0].get<double>() > j[1].get<double>()) return std::nullopt;  // [high, low]: not an interval
  return Interval{j[0].get<double>(), j[1].get<double>()};
}

ResamplingPlan::ResamplingPlan(int frames, int tiles, const std::string& seedName,
                               const BootstrapConfig& cfg) {
  if (frames < 1 || tiles < 1 || cfg.replicates < 1) return;
  blockLength_ = std::clamp(int(std::lround(std::cbrt(double(frames)))), 1, frames);
  std::mt19937_64 rng(seedOf(seedName));
  // Integer draws by rejection-free modulo of 64-bit values: the bias (< 2^-50) is irrelevant here,
  // and unlike std::uniform_int_distribution the sequence is the same in every standard library.
  auto draw = [&](int n) { return int(rng() % uint64_t(n)); };
  // Circular blocks (Politis and Romano 1992): a block may start at any frame and wraps from the
  // last to the first, so every frame is drawn equally often. Blocks that stopped at the end drew
  // the first and last frames a third as often as the others (block length 3): the replicates'
  // mean left the point estimate, 2.9% below it on a temporal filter still converging, and the
  // percentile interval with it (a statistician's audit).
  for (int b = 0; b < cfg.replicates; ++b) {
    std::vector<int> rows;
    while (int(rows.size()) < frames) {
      const int s = draw(frames);
      for (int k = 0; k < blockLength_ && int(rows.size()) < frames; ++k)
        rows.push_back((s + k) % frames);
    }
    std::vector<int> picks(static_cast<size_t>(tiles));
    for (int& p : picks) p = draw(tiles);
    frameRows_.push_back(std::move(rows));
    tiles_.push_back(std::move(picks));
  }
}

std::vector<double> replicateValues(const MetricTiles& m, const ResamplingPlan& plan) {
  std::vector<double> out(size_t(plan.replicates()), kUndefined);
  for (int b = 0; b < plan.replicates(); ++b) {
    double s = 0;
    int n = 0;
    for (int row : plan.frameRows(b)) {
      if (size_t(row) >= m.rows.size())
        throw Error("bootstrap: plan and tile data disagree on the frame count");
      const double v = rowValue(m, size_t(row), &plan.tiles(b));
      if (std::isfinite(v)) s += v, ++n;
    }
    if (n) out[size_t(b)] = s / n;
  }
  return out;
}

Interval percentileInterval(std::vector<double> v, double confidence) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.size() < 20 || !(confidence > 0 && confidence < 1)) return {};
  std::sort(v.begin(), v.end());
  auto quantile = [&](double q) {
    const double pos = q * double(v.size() - 1);
    const size_t lo = size_t(std::floor(pos)), hi = std::min(lo + 1, v.size() - 1);
    return v[lo] + (pos - double(lo)) * (v[hi] - v[lo]);
  };
  const double tail = (1 - confidence) / 2;
  return {quantile(tail), quantile(1 - tail)};
}

namespace {
// The median of the finite replicates, the mean of the two middle values where their count is
// even, so that the replicates of b - a give exactly the negated interval of a - b's (one middle
// value, the upper, put the two intervals of one pair a few units of the fourth digit apart).
double finiteMedian(const std::vector<double>& replicates) {
  std::vector<double> finite;
  for (double v : replicates)
    if (std::isfinite(v)) finite.push_back(v);
  if (finite.empty()) return kUndefined;
  const size_t half = finite.size() / 2;
  std::nth_element(finite.begin(), finite.begin() + long(half), finite.end());
  double m = finite[half];
  if (finite.size() % 2 == 0)
    m = 0.5 * (m + *std::max_element(finite.begin(), finite.begin() + long(half)));
  return m;
}
}  // namespace

Interval widenedInterval(const std::vector<double>& replicates, double confidence, double widen) {
  const Interval q = percentileInterval(replicates, confidence);
  if (!q.valid() || widen == 1.0) return q;
  const double m = finiteMedian(replicates);
  return {m - widen * (m - q.lo), m + widen * (q.hi - m)};
}

std::vector<double> widenedReplicates(std::vector<double> replicates, double widen) {
  if (widen == 1.0) return replicates;
  const double m = finiteMedian(replicates);
  for (double& v : replicates)
    if (std::isfinite(v)) v = m + widen * (v - m);
  return replicates;
}

Interval meanInterval(const MetricTiles& m, const std::string& seedName,
                      const BootstrapConfig& cfg) {
  if (m.empty()) return {};
  // One frame of a value per frame (a time, a sample count): nothing varies in any replicate, and
  // an interval of zero width would claim a certainty nothing measured. None, as without data.
  if (m.tileCount() <= 1 && m.frames.size() < 2) return {};
  const ResamplingPlan plan(int(m.frames.size()), std::max(cfg.grid.count(), m.tileCount()),
                            seedName, cfg);
  if (m.tileCount() != 1 && m.tileCount() != cfg.grid.count())
    throw Error("bootstrap: tile data has " + std::to_string(m.tileCount()) + " tiles, the grid " +
                std::to_string(cfg.grid.count()));
  return percentileInterval(replicateValues(m, plan), cfg.confidence);
}

std::vector<int> commonFrames(const std::vector<const MetricTiles*>& series) {
  if (series.empty()) return {};
  std::set<int> common(series.front()->frames.begin(), series.front()->frames.end());
  for (const MetricTiles* s : series) {
    std::set<int> mine(s->frames.begin(), s->frames.end()), keep;
    std::set_intersection(common.begin(), common.end(), mine.begin(), mine.end(),
                          std::inserter(keep, keep.end()));
    common = std::move(keep);
  }
  return {common.begin(), common.end()};
}

namespace {

// Replicates of several series over their common frames, with one plan.
std::vector<std::vector<double>> pairedReplicates(const std::vector<const MetricTiles*>& series,
                                                  const std::vector<int>& frames,
                                                  const std::string& seedName,
                                                  const BootstrapConfig& cfg,
                                                  std::vector<double>* means) {
  int tiles = 1;
  for (const MetricTiles* s : series) tiles = std::max(tiles, s->tileCount());
  for (const MetricTiles* s : series)
    if (s->tileCount() != 1 && s->tileCount() != tiles)
      throw Error("bootstrap: the series being compared have different tile grids");
  const ResamplingPlan plan(int(frames.size()), tiles, seedName, cfg);
  std::vector<std::vector<double>> out;
  for (const MetricTiles* s : series) {
    MetricTiles aligned = s->restrictedTo(frames);
    if (means) means->push_back(aligned.mean());
    out.push_back(replicateValues(aligned, plan));
  }
  return out;
}

double relativeChange(double x, double base) {
  return (x - base) / std::max(std::abs(base), 1e-12);
}

// Whether two replicate values are one number but for rounding: within kRoundingResolution of the
// larger (or of `floor`, for values near 0 whose difference is itself relative, as log ratios
// are). The tile sums are float32 (about seven significant digits), and two outputs alike but for
// rounding (a switch that moves the filter's weights by an ulp) differ there by rounding alone: a
// replicate that draws only such tiles must count as no difference, or an interval's end lands
// within rounding of zero and its sign decides "resolved" (a sweep's edge.id read "better" at
// [-1.07e-3, -1.28e-11], "tie" at [-8.6e-4, +1.6e-10]).
bool sameButForRounding(double a, double b, double floor = 0) {
  return std::abs(a - b) <=
         std::max(kRoundingResolution * std::max(std::abs(a), std::abs(b)), floor);
}

// A replicate's relative change, 0 where the two values differ by rounding alone.
double replicateChange(double x, double base) {
  return sameButForRounding(x, base) ? 0.0 : relativeChange(x, base);
}

}  // namespace

std::vector<double> replicateDifferences(const std::vector<double>& a, const std::vector<double>& b,
                                         double floor) {
  std::vector<double> d(a.size());
  for (size_t i = 0; i < a.size(); ++i)
    d[i] = sameButForRounding(a[i], b[i], floor) ? 0.0 : a[i] - b[i];
  return d;
}

double changePValue(const std::vector<double>& changes) {
  size_t finite = 0, atMost = 0, atLeast = 0;
  for (double c : changes) {
    if (!std::isfinite(c)) continue;
    ++finite;
    atMost += c <= 0;
    atLeast += c >= 0;
  }
  if (finite == 0) return kUndefined;
  return std::min(1.0, 2 * double(std::min(atMost, atLeast) + 1) / double(finite + 1));
}

PairedDifference pairedDifference(const MetricTiles& a, const MetricTiles& b,
                                  const std::string& seedName, const BootstrapConfig& cfg) {
  const std::vector<int> frames = commonFrames({&a, &b});
  if (frames.empty()) return {};
  std::vector<double> means;
  auto reps = pairedReplicates({&a, &b}, frames, seedName, cfg, &means);
  return {means[0] - means[1],
          percentileInterval(replicateDifferences(reps[0], reps[1]), cfg.confidence)};
}

PairedChange pairedRelativeChange(const MetricTiles& a, const MetricTiles& b,
                                  const std::string& seedName, const BootstrapConfig& cfg) {
  PairedChange out;
  out.frames = commonFrames({&a, &b});
  if (out.frames.empty()) return out;
  std::vector<double> means;
  auto reps = pairedReplicates({&a, &b}, out.frames, seedName, cfg, &means);
  out.a = means[0];
  out.b = means[1];
  out.change = relativeChange(out.a, out.b);
  std::vector<double> changes(reps[0].size());
  for (size_t i = 0; i < changes.size(); ++i) changes[i] = replicateChange(reps[0][i], reps[1][i]);
  out.ci = percentileInterval(changes, cfg.confidence);
  out.pValue = changePValue(changes);
  return out;
}

double pairedChangePValue(const MetricTiles& a, const MetricTiles& b, const std::string& seedName,
                          const BootstrapConfig& cfg, int replicates) {
  const std::vector<int> frames = commonFrames({&a, &b});
  if (frames.empty() || cfg.replicates < 1) return kUndefined;
  std::vector<double> changes;
  for (int batch = 1; int(changes.size()) < replicates; ++batch) {
    const std::string seed = batch == 1 ? seedName : seedName + "#" + std::to_string(batch);
    const auto reps = pairedReplicates({&a, &b}, frames, seed, cfg, nullptr);
    for (size_t i = 0; i < reps[0].size(); ++i)
      changes.push_back(replicateChange(reps[0][i], reps[1][i]));
  }
  return changePValue(changes);
}

std::vector<bool> holmRejections(const std::vector<double>& pValues, double alpha) {
  std::vector<size_t> order;
  for (size_t i = 0; i < pValues.size(); ++i)
    if (std::isfinite(pValues[i])) order.push_back(i);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t x, size_t y) { return pValues[x] < pValues[y]; });
  std::vector<bool> rejected(pValues.size(), false);
  const size_t m = order.size();
  for (size_t k = 0; k < m; ++k) {
    if (!(pValues[order[k]] <= alpha / double(m - k))) break;
    rejected[order[k]] = true;
  }
  return rejected;
}

namespace {

// rank = 1 + number of methods resolved better; ties = not resolved either way.
void assignRanks(std::vector<RankedMethod>& methods, const std::vector<std::vector<bool>>& better,
                 const std::vector<std::vector<bool>>& resolved) {
  for (size_t i = 0; i < methods.size(); ++i) {
    methods[i].rank = 1;
    for (size_t j = 0; j < methods.size(); ++j) {
      if (i == j) continue;
      if (resolved[i][j] && better[j][i]) ++methods[i].rank;
      if (!resolved[i][j]) methods[i].tiedWith.push_back(methods[j].label);
    }
  }
}

void sortRanking(std::vector<RankedMethod>& methods, bool lowerIsBetter) {
  std::stable_sort(methods.begin(), methods.end(),
                   [&](const RankedMethod& a, const RankedMethod& b) {
                     if (a.rank != b.rank) return a.rank < b.rank;
                     return lowerIsBetter ? a.value < b.value : a.value > b.value;
                   });
}

json rankingJson(const std::vector<RankedMethod>& ranking, const char* valueName) {
  json out = json::array();
  for (const RankedMethod& m : ranking) {
    json entry = {{"label", m.label},
                  {"rank", m.rank},
                  {valueName, m.value},
                  {"ci95", m.ci.toJson()},
                  {"tiedWith", m.tiedWith}};
    if (std::isfinite(m.extraPathsPerPixel)) entry["extraPathsPerPixel"] = m.extraPathsPerPixel;
    if (!m.oracleLayers.empty()) entry["oracleLayers"] = m.oracleLayers;
    out.push_back(std::move(entry));
  }
  return out;
}

}  // namespace

void LeftOutMethods::leaveOut(const std::string& label, const std::string& why) {
  excluded += (excluded.empty() ? "" : "; ") + label + ": " + why;
  leftOut.push_back({label, why});
}

std::string LeftOutMethods::reasonFor(const std::string& label,
                                      const std::vector<std::string>& labels) const {
  if (!leftOut.empty()) {
    for (const auto& [l, why] : leftOut)
      if (l == label) return why;
    return "";
  }
  size_t at = 0;
  for (;; at += label.size()) {
    at = excluded.find(label + ": ", at);
    if (at == std::string::npos) return "";
    if (at == 0 || (at >= 2 && excluded.compare(at - 2, 2, "; ") == 0)) break;
  }
  const size_t from = at + label.size() + 2;
  size_t to = excluded.size();
  for (const std::string& other : labels)
    if (const size_t next = excluded.find("; " + other + ": ", from); next < to) to = next;
  return excluded.substr(from, to - from);
}

void LeftOutMethods::writeTo(json& j) const {
  if (!excluded.empty()) j["excluded"] = excluded;
  if (leftOut.empty()) return;
  json& list = j["leftOut"] = json::array();
  for (const auto& [label, why] : leftOut) list.push_back({{"label", label}, {"why", why}});
}

SceneRanking rankScene(const std::string& metric, bool lowerIsBetter,
                       const std::vector<std::pair<std::string, const MetricTiles*>>& methods,
                       const std::string& seedName, const BootstrapConfig& cfg) {
  std::vector<const MetricTiles*> series;
  std::vector<std::string> labels;
  std::vector<std::pair<std::string, std::string>> excluded;  // label, why
  for (const auto& [label, m] : methods) {
    if (!m || m->empty()) {
      excluded.push_back({label, "no " + metric + " data"});
      continue;
    }
    // A tile sum stored as inf (beyond float's range) or NaN would be skipped by the means below.
    const bool finite = std::all_of(m->rows.begin(), m->rows.end(), [](const TileSums& t) {
      return std::all_of(t.sum.begin(), t.sum.end(), [](double v) { return std::isfinite(v); });
    });
    if (!finite) {
      excluded.push_back(
          {label, "a " + metric + " tile sum is not finite (a value beyond float range)"});
      continue;
    }
    labels.push_back(label);
    series.push_back(m);
  }
  const std::vector<int> frames = commonFrames(series);
  std::vector<double> means;
  std::vector<std::vector<double>> reps;
  if (!series.empty() && !frames.empty()) {
    reps = pairedReplicates(series, frames, seedName, cfg, &means);
  } else {
    for (const std::string& label : labels)
      excluded.push_back({label, "no frame that every method measured"});
    labels.clear();
  }
  SceneRanking out = rankReplicates(metric, lowerIsBetter, labels, means, reps, cfg.confidence);
  out.scene = seedName;
  for (const auto& [label, why] : excluded) out.leaveOut(label, why);
  return out;
}

SceneRanking rankReplicates(const std::string& metric, bool lowerIsBetter,
                            const std::vector<std::string>& labels,
                            const std::vector<double>& values,
                            const std::vector<std::vector<double>>& reps, double confidence,
                            double widen) {
  if (values.size() != labels.size() || reps.size() != labels.size())
    throw Error("ranking on " + metric + ": labels, values and replicates differ in count");
  SceneRanking out;
  out.metric = metric;
  const size_t n = labels.size();
  std::vector<std::vector<bool>> better(n, std::vector<bool>(n, false)),
      resolved(n, std::vector<bool>(n, false));
  for (size_t i = 0; i < n; ++i) {
    out.ranking.push_back(
        {labels[i], 0, values[i], widenedInterval(reps[i], confidence, widen), {}});
    out.replicates[labels[i]] = reps[i];
  }
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      SceneRanking::Pair p{
          labels[i],
          labels[j],
          {values[i] - values[j],
           widenedInterval(replicateDifferences(reps[i], reps[j]), confidence, widen)}};
      const bool r = p.d.resolved();
      resolved[i][j] = resolved[j][i] = r;
      better[i][j] = lowerIsBetter ? p.d.diff < 0 : p.d.diff > 0;
      better[j][i] = !better[i][j];
      out.resolvedPairs += r;
      out.pairs.push_back(std::move(p));
    }
  assignRanks(out.ranking, better, resolved);
  sortRanking(out.ranking, lowerIsBetter);
  return out;
}

json SceneRanking::toJson() const {
  json p = json::array();
  for (const Pair& x : pairs)
    p.push_back({{"a", x.a},
                 {"b", x.b},
                 {"diff", x.d.diff},
                 {"ci95", x.d.ci.toJson()},
                 {"resolved", x.d.resolved()}});
  json j = {{"metric", metric},
            {"ranking", rankingJson(ranking, "mean")},
            {"pairs", p},
            {"resolvedPairs", resolvedPairs},
            {"totalPairs", int(pairs.size())}};
  writeTo(j);
  return j;
}

OverallRanking rankOverall(const std::vector<const SceneRanking*>& scenes,
                           const std::vector<std::string>& preferredBaselines, bool lowerIsBetter,
                           double confidence) {
  OverallRanking out;
  if (scenes.empty()) return out;
  // Methods ranked on every scene with a positive value (the log ratio needs one); a method
  // missing from any scene, the first included, is named with the reason.
  std::vector<std::string> labels;
  for (const SceneRanking* s : scenes) {
    for (const RankedMethod& m : s->ranking) labels.push_back(m.label);
    for (const auto& [label, why] : s->leftOut) labels.push_back(label);
  }
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  // The first scene that leaves a method out names it, with that scene's reason; how many more
  // scenes do is counted.
  auto onScene = [](const SceneRanking& s) {
    return s.scene.empty() ? std::string("a scene") : s.scene;
  };
  std::vector<std::string> kept;
  for (const std::string& label : labels) {
    std::string why;
    int more = 0;
    for (const SceneRanking* s : scenes) {
      auto it = std::find_if(s->ranking.begin(), s->ranking.end(),
                             [&](const RankedMethod& m) { return m.label == label; });
      std::string reason;
      if (it == s->ranking.end()) {
        auto left = std::find_if(s->leftOut.begin(), s->leftOut.end(),
                                 [&](const auto& l) { return l.first == label; });
        reason = left == s->leftOut.end()
                     ? "not run on " + onScene(*s)
                     : "not ranked on " + onScene(*s) + " (" + left->second + ")";
      } else if (!(it->value > 0)) {
        reason = "value <= 0 on " + onScene(*s) + " (a geometric mean needs positive values)";
      }
      if (reason.empty()) continue;
      if (why.empty())
        why = reason;
      else
        ++more;
    }
    if (more > 0)
      why += " and on " + std::to_string(more) + (more == 1 ? " other scene" : " other scenes");
    if (why.empty())
      kept.push_back(label);
    else
      out.leaveOut(label, why);
  }
  // An overall score is a method's error relative to another's: with one method there is nothing
  // to compare, and its score against itself (1, interval [1, 1]) would read as a result.
  if (kept.size() == 1)
    out.leaveOut(kept.front(),
                 "the only method ranked on every scene (an overall score compares two or more)");
  if (kept.size() < 2) return out;
  out.baseline = kept.front();
  for (auto it = preferredBaselines.rbegin(); it != preferredBaselines.rend(); ++it)
    if (std::find(kept.begin(), kept.end(), *it) != kept.end()) out.baseline = *it;
  out.normalisation = "geometric mean over " + std::to_string(scenes.size()) +
                      (scenes.size() == 1 ? " scene of " : " scenes of ") + scenes.front()->metric +
                      " / " + scenes.front()->metric + "(" + out.baseline + ")";
  auto valueOn = [](const SceneRanking* s, const std::string& label) {
    for (const RankedMethod& m : s->ranking)
      if (m.label == label) return m.value;
    return kUndefined;
  };
  // Per method: the mean over scenes of log(value / baseline), point and replicates.
  const size_t reps = scenes.front()->replicates.at(kept.front()).size();
  std::vector<double> logScore(kept.size(), 0.0);
  std::vector<std::vector<double>> logReps(kept.size(), std::vector<double>(reps, 0.0));
  for (size_t i = 0; i < kept.size(); ++i)
    for (const SceneRanking* s : scenes) {
      logScore[i] +=
          std::log(valueOn(s, kept[i]) / valueOn(s, out.baseline)) / double(scenes.size());
      const auto& a = s->replicates.at(kept[i]);
      const auto& b = s->replicates.at(out.baseline);
      for (size_t r = 0; r < reps && r < a.size(); ++r)
        logReps[i][r] += std::log(a[r] / b[r]) / double(scenes.size());
    }
  const size_t n = kept.size();
  std::vector<std::vector<bool>> better(n, std::vector<bool>(n, false)),
      resolved(n, std::vector<bool>(n, false));
  for (size_t i = 0; i < n; ++i) {
    std::vector<double> expReps(reps);
    for (size_t r = 0; r < reps; ++r) expReps[r] = std::exp(logReps[i][r]);
    out.ranking.push_back(
        {kept[i], 0, std::exp(logScore[i]), percentileInterval(expReps, confidence), {}});
  }
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      // Log ratios: a difference is itself relative, so rounding's floor is absolute.
      const Interval ci = percentileInterval(
          replicateDifferences(logReps[i], logReps[j], kRoundingResolution), confidence);
      resolved[i][j] = resolved[j][i] = ci.valid() && !ci.containsZero();
      SceneRanking::Pair pair;
      pair.a = kept[i];
      pair.b = kept[j];
      pair.d.diff = logScore[i] - logScore[j];
      pair.d.ci = ci;
      out.pairs.push_back(std::move(pair));
      better[i][j] = lowerIsBetter ? logScore[i] < logScore[j] : logScore[i] > logScore[j];
      better[j][i] = !better[i][j];
    }
  assignRanks(out.ranking, better, resolved);
  sortRanking(out.ranking, lowerIsBetter);
  return out;
}

json OverallRanking::toJson() const {
  json p = json::array();
  for (const SceneRanking::Pair& x : pairs)
    p.push_back({{"a", x.a},
                 {"b", x.b},
                 {"logRatio", x.d.diff},
                 {"ci95", x.d.ci.toJson()},
                 {"resolved", x.d.resolved()}});
  json j = {{"normalisation", normalisation},
            {"baseline", baseline},
            {"ranking", rankingJson(ranking, "score")}};
  if (!pairs.empty()) j["pairs"] = p;
  writeTo(j);
  return j;
}

}  // namespace arena
