#include "cli/printout.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include "core/text.hpp"
#include "harness/gpu_cost.hpp"
#include "harness/reference_quality.hpp"
#include "metrics/metric_registry.hpp"

namespace arena::cli {

using nlohmann::json;

std::string figureText(double v) {
  if (!std::isfinite(v)) return "–";
  const double a = std::abs(v);
  if (a == 0) return "0";
  char buf[64];
  if (a < 1e-3 || a >= 1e5) {
    std::snprintf(buf, sizeof buf, "%.2e", v);  // 1.23e-04 -> 1.23e-4, as JavaScript writes it
    std::string s = buf;
    const size_t e = s.find('e');
    std::string mantissa = s.substr(0, e), exponent = s.substr(e + 1);
    const char sign = exponent[0];
    exponent = exponent.substr(1);
    while (exponent.size() > 1 && exponent[0] == '0') exponent.erase(0, 1);
    return mantissa + "e" + sign + exponent;
  }
  // Four significant digits, then the shortest text of that number (JavaScript's
  // Number(v.toPrecision(4)).toString()).
  std::snprintf(buf, sizeof buf, "%.4g", v);
  double rounded = std::strtod(buf, nullptr);
  std::snprintf(buf, sizeof buf, "%.15g", rounded);
  return buf;
}

std::string intervalText(const Interval& ci) {
  if (!ci.valid()) return "–";
  std::string text = "[";  // appended, not "[" + string: GCC 12 warns falsely (-Wrestrict) on that
  text += figureText(ci.lo);
  text += ", ";
  text += figureText(ci.hi);
  text += "]";
  return text;
}

// A scene's pairs whose outputs were bit-identical (pairs[].outputChecksum), "asvgf = svgf" per
// group: a tie between them measures one output twice.
std::vector<std::vector<const PairResult*>> identicalOutputGroups(const RunResults& results,
                                                                  const std::string& scene) {
  // Groups in the order of their first member in the run (a sweep's grid order), not by checksum.
  std::vector<std::string> order;
  std::map<std::string, std::vector<const PairResult*>> byChecksum;
  for (const PairResult& p : results.pairs)
    if (p.scene == scene && p.ok() && p.detail.contains("outputChecksum") &&
        p.detail["outputChecksum"].is_string()) {
      const std::string checksum = p.detail["outputChecksum"].get<std::string>();
      if (!byChecksum.count(checksum)) order.push_back(checksum);
      byChecksum[checksum].push_back(&p);
    }
  std::vector<std::vector<const PairResult*>> groups;
  for (const std::string& checksum : order)
    if (byChecksum[checksum].size() >= 2) groups.push_back(byChecksum[checksum]);
  return groups;
}

std::string identicalOutputsText(const RunResults& results, const std::string& scene) {
  std::string text;
  for (const std::vector<const PairResult*>& group : identicalOutputGroups(results, scene)) {
    if (!text.empty()) text += "; ";
    for (size_t k = 0; k < group.size(); ++k) text.append(k ? " = " : "").append(group[k]->label);
  }
  return text;
}

std::vector<std::string> otherAbsentSummaryLines(const RunResults& results) {
  const std::vector<AbsentSummary> relMse = absentSummaries(results, {"relMse"});
  std::vector<std::string> out;
  for (const AbsentSummary& a : absentSummaries(results, {})) {
    const bool said = a.metric == "relMse" || a.why.rfind("the scene has no reference", 0) == 0 ||
                      std::any_of(relMse.begin(), relMse.end(), [&](const AbsentSummary& r) {
                        return r.scene == a.scene && r.why == a.why;
                      });
    if (!said) out.push_back(absentSummaryText(a));
  }
  return out;
}

PairWarningCount countPairWarnings(const RunResults& results) {
  PairWarningCount c;
  for (const PairResult& p : results.pairs) {
    const size_t n = p.part("warnings").is_array() ? p.part("warnings").size() : 0;
    c.warnings += n;
    c.pairs += n > 0;
  }
  return c;
}

std::string tiedText(const RankedMethod& m) {
  // A large sweep ties a method with a hundred others: the first ten, and how many more.
  constexpr size_t kNamed = 10;
  std::string s;
  for (size_t k = 0; k < m.tiedWith.size() && k < kNamed; ++k)
    s += (s.empty() ? "" : ", ") + m.tiedWith[k];
  if (m.tiedWith.size() > kNamed)
    s += " and " + std::to_string(m.tiedWith.size() - kNamed) + " more (results.json, the report)";
  return s.empty() ? "" : "tied with " + s;
}

namespace {

// The width of a ranking's label column: `minimum`, or the longest label and two spaces where a
// label is longer (a sweep's labels carry their parameters), so the columns after it stay aligned.
// A ranked method's label, marked "(+paths)" when it read paths beyond the frame's own 1-spp ones
// (reengine's disocclusion rays, asvgf's gradient samples) and "(oracle)" when it read a layer no
// real-time engine has: not on equal terms with the others.
std::string rankedLabel(const RankedMethod& m) {
  return m.label + (m.extraPathsPerPixel > 0 ? " (+paths)" : "") +
         (m.oracleLayers.empty() ? "" : " (oracle)");
}

}  // namespace

std::string markedLabel(const RunResults& results, const std::string& label) {
  RankedMethod m;
  m.label = label;
  if (results.statistics) {
    if (auto it = results.statistics->extraPathsPerPixel.find(label);
        it != results.statistics->extraPathsPerPixel.end())
      m.extraPathsPerPixel = it->second;
    if (auto it = results.statistics->oracleLayers.find(label);
        it != results.statistics->oracleLayers.end())
      m.oracleLayers = it->second;
  }
  return rankedLabel(m);
}

namespace {

// A rank as every table prints it: "3", "3=" when tied with others, "-" when not ranked.
std::string rankText(const RankedMethod& m) {
  if (m.rank <= 0) return "-";
  return std::to_string(m.rank) + (m.tiedWith.empty() ? "" : "=");
}

// Whether a ranking lists a method above one with a lower (better) value: ranks count the methods
// resolved better, so one whose differences are less certain can stand above a lower mean.
bool ranksAboveALowerValue(const std::vector<RankedMethod>& ranking) {
  for (size_t i = 0; i < ranking.size(); ++i)
    for (size_t j = i + 1; j < ranking.size(); ++j)
      if (ranking[i].rank < ranking[j].rank && ranking[j].value < ranking[i].value) return true;
  return false;
}

size_t labelColumn(const std::vector<RankedMethod>& ranking, size_t minimum) {
  size_t width = minimum;
  for (const RankedMethod& m : ranking) width = std::max(width, displayWidth(rankedLabel(m)) + 2);
  return width;
}

// `text` right-aligned in `width` characters ("–", the missing value, is one character of three
// bytes: std::setw would pad it two short).
std::string rightAligned(const std::string& text, size_t width) {
  const size_t w = displayWidth(text);
  return w < width ? std::string(width - w, ' ') + text : text;
}

}  // namespace

std::string sceneSizesText(const RunResults& results) {
  std::set<std::string> sizes;
  for (const auto& [name, scene] : results.scenes.items())
    if (scene.is_object() && scene.contains("width") && scene.contains("height"))
      sizes.insert(scene["width"].dump() + "x" + scene["height"].dump());
  std::string text;
  for (const std::string& size : sizes) text += (text.empty() ? "" : ", ") + size;
  return text;
}

void printSeedSplit(std::ostream& out, const RunResults& results) {
  const int seeds = results.settings.seeds();
  if (seeds < 2) return;
  size_t sceneWidth = 22, labelWidth = 26;
  for (const PairResult& p : results.pairs) {
    sceneWidth = std::max(sceneWidth, displayWidth(p.scene) + 2);
    labelWidth = std::max(labelWidth, displayWidth(p.label) + 2);
  }
  // Each cell "mean  [lo, hi]"; the columns as wide as their longest cell.
  std::vector<std::array<std::string, 5>> rows;
  for (const PairResult& p : results.pairs) {
    const nlohmann::json& split = p.part("biasVariance");
    if (!p.ok() || !split.is_object()) continue;
    const nlohmann::json summary = split.value("summary", nlohmann::json::object());
    const auto term = [&](const char* name) {
      const nlohmann::json s = summary.value(name, nlohmann::json::object());
      if (!s.contains("mean") || !s["mean"].is_number()) return std::string("–");
      const std::optional<Interval> ci = Interval::fromJson(s.value("ci95", nlohmann::json()));
      return figureText(s["mean"].get<double>()) + "  " + intervalText(ci ? *ci : Interval{});
    };
    rows.push_back({p.scene, p.label, term("bias2"), term("variance"), term("bias2Corrected")});
  }
  if (rows.empty()) return;  // every pair failed: no split to show
  std::array<std::string, 5> header = {"scene", "denoiser", "bias2", "variance", "bias2Corrected"};
  std::array<size_t, 5> width = {sceneWidth, labelWidth, 0, 0, 0};
  for (const auto& row : rows)
    for (size_t k = 2; k < 5; ++k)
      width[k] = std::max({width[k], displayWidth(row[k]) + 2, displayWidth(header[k]) + 2});
  out << "\nerror over the " << seeds
      << " input seeds (relMSE units, mean after the warm-up [95% interval]; bias2 + variance = "
         "the seeds' mean relMSE, bias2Corrected less the reference's own noise; the relMSE above "
         "is the first seed's):\n";
  rows.insert(rows.begin(), header);
  for (const auto& row : rows) {
    for (size_t k = 0; k < 4; ++k) out << paddedText(row[k], width[k]);
    out << row[4] << "\n";
  }
}

void printOverallRanking(std::ostream& out, const RunResults& results) {
  if (!results.statistics || !results.statistics->overall) return;
  const OverallRanking& o = *results.statistics->overall;
  if (o.ranking.empty())
    out << "\noverall: none\n";
  else
    out << "\noverall: " << o.normalisation << " (lower is better)\n";
  // A shard ranks its slice of the pairs: said, lest its ranks be read as the run's.
  if (const std::string shard = results.settings.shard();
      !shard.empty() && shard != "merged" && shard != "0/1")
    out << "  (shard " << shard << ": these ranks and scores are of this slice of the pairs alone; "
        << "`arena merge` of every shard gives the run's)\n";
  const size_t column = labelColumn(o.ranking, 26);
  for (const RankedMethod& m : o.ranking) {
    out << "  " << std::left << std::setw(4) << rankText(m) << paddedText(rankedLabel(m), column)
        << rightAligned(figureText(m.value), 11) << "  "
        << paddedText(m.label == o.baseline
                          ? "(1 by definition)"
                          : intervalText(m.ci),  // the baseline's [1, 1] is no certainty
                      24)
        << tiedText(m) << "\n";
  }
  if (!o.excluded.empty()) out << "  not ranked overall: " << o.excluded << "\n";
  // The noisy input at rank 1 (tied: a method resolved better than it would rank it lower) is no
  // finding about denoising but about the intervals: said, lest a rank column be copied as one.
  for (const RankedMethod& m : o.ranking)
    if (m.label == "passthrough" && m.rank == 1 && o.ranking.size() > 1)
      out << "  passthrough, the noisy input itself, "
          << (m.tiedWith.empty() ? "ranks first: every method is resolved worse than no denoising"
                                 : "shares rank 1: no method is resolved better than no denoising")
          << " on these scenes and frames (its interval " << intervalText(m.ci) << ")"
          << (m.tiedWith.empty() ? "" : "; more frames or scenes narrow the intervals") << "\n";
  // Ranks 1, 2, 3 beside overlapping intervals read as an error without the first part; "3="
  // above "4=" with a lower score without the second.
  if (!o.ranking.empty())
    out << "  (rank: 1 + the methods resolved better, on paired differences (the same frames and "
           "tiles), which resolve differences where each method's own interval above overlaps "
           "another's"
        << (std::any_of(o.ranking.begin(), o.ranking.end(),
                        [](const RankedMethod& m) { return !m.tiedWith.empty(); })
                ? "; =: tied with those named, a difference not resolved, so tied methods may hold "
                  "different ranks"
                : "")
        << (ranksAboveALowerValue(o.ranking)
                ? "; a method above one with a lower score has fewer methods resolved better than "
                  "it (its differences are less certain), not a better score"
                : "")
        << ")\n";
  if (std::any_of(o.ranking.begin(), o.ranking.end(),
                  [](const RankedMethod& m) { return m.extraPathsPerPixel > 0; }))
    out << "  (+paths): read paths beyond the frame's 1-spp ones (results.json: "
           "statistics.extraPaths; their tracing time is each pair's tracingMs)\n";
  if (std::any_of(o.ranking.begin(), o.ranking.end(),
                  [](const RankedMethod& m) { return !m.oracleLayers.empty(); }))
    out << "  (oracle): read a layer no real-time engine has, not ranked on equal terms "
           "(results.json: statistics.oracle)\n";
  // The contenders that are not built in, with where each came from (a process's manifest, a
  // plugin's library, a capture's stored output): a reader of the ranking should know.
  const std::map<std::string, std::string> origins = contenderOrigins(results);
  std::vector<std::string> outside;
  for (const RankedMethod& m : o.ranking)
    if (const auto it = origins.find(m.label); it != origins.end())
      outside.push_back(m.label + " (" + it->second + ")");
  if (!outside.empty()) {
    out << "  not built in:";
    for (size_t k = 0; k < outside.size(); ++k) out << (k ? "; " : " ") << outside[k];
    out << "\n";
  }
}

void printOtherOverallScores(std::ostream& out, const RunResults& results) {
  if (!results.statistics || !results.statistics->overall) return;
  const RunStatistics& st = *results.statistics;
  std::vector<std::pair<std::string, const OverallRanking*>> metrics;
  for (const auto& [name, o] : st.overallByMetric)
    if (!o.ranking.empty()) metrics.push_back({name, &o});
  if (metrics.empty()) return;
  // Rows in the relMSE ranking's order, then any method ranked only on another metric.
  std::vector<std::string> rows;
  for (const RankedMethod& m : st.overall->ranking) rows.push_back(m.label);
  for (const auto& [name, o] : metrics)
    for (const RankedMethod& m : o->ranking)
      if (std::find(rows.begin(), rows.end(), m.label) == rows.end()) rows.push_back(m.label);
  size_t column = 26;
  for (const std::string& label : rows)
    column = std::max(column, displayWidth(markedLabel(results, label)) + 2);
  constexpr size_t kCell = 14;
  out << "\noverall on the other metrics (rank and score, each the relMSE one's normalisation on "
         "that metric; lower is better)\n"
      << "  " << std::string(column, ' ');
  for (const auto& [name, o] : metrics) out << rightAligned(name, kCell);
  out << "\n";
  for (const std::string& label : rows) {
    out << "  " << paddedText(markedLabel(results, label), column);
    for (const auto& [name, o] : metrics) {
      const auto it = std::find_if(o->ranking.begin(), o->ranking.end(),
                                   [&](const RankedMethod& m) { return m.label == label; });
      out << (it == o->ranking.end() ? rightAligned("-", kCell)
                                     : "  " + paddedText(rankText(*it), 4) +
                                           rightAligned(figureText(it->value), kCell - 6));
    }
    out << "\n";
  }
  for (const auto& [name, o] : metrics) {
    if (o->baseline != st.overall->baseline)
      out << "  " << name << ": relative to " << (o->baseline.empty() ? "(none)" : o->baseline)
          << "\n";
    if (!o->excluded.empty() && o->excluded != st.overall->excluded)
      out << "  not ranked overall on " << name << ": " << o->excluded << "\n";
  }
  out << "  (=: tied, as above; intervals and pairs: results.json statistics.overallByMetric, the "
         "report's rankings)\n";
}

std::string changePercentText(double change) {
  if (!std::isfinite(change)) return "-";
  const double p = change * 100;
  char text[32];
  if (p != 0 && std::abs(p) < 0.05)
    std::snprintf(text, sizeof text, "%+.2g%%", p);
  else
    std::snprintf(text, sizeof text, "%+.1f%%", p == 0 ? 0.0 : p);
  return text;
}

// Two significant digits, never in exponent form, trailing zeros dropped (as %g): 0.34, 4.2, 7,
// 120.
std::string twoDigitsText(double v) {
  if (!std::isfinite(v) || v <= 0) return figureText(v);
  const double step = std::pow(10.0, std::floor(std::log10(v)) - 1);
  const double rounded = std::round(v / step) * step;
  char text[32];
  std::snprintf(text, sizeof text, "%.*f", std::max(0, -int(std::floor(std::log10(step) + 1e-9))),
                rounded);
  std::string out = text;
  if (out.find('.') != std::string::npos) {
    out.erase(out.find_last_not_of('0') + 1);
    if (out.back() == '.') out.pop_back();
  }
  return out;
}

std::string otherOverallFirstsText(const RunResults& results) {
  if (!results.statistics) return "";
  std::string text;
  for (const auto& [name, o] : results.statistics->overallByMetric) {
    std::string firsts;
    for (const RankedMethod& m : o.ranking)
      if (m.rank == 1) firsts += (firsts.empty() ? "" : ", ") + m.label;
    if (firsts.empty()) continue;
    // A temporal metric is named for what it measures: "tRmae" alone does not say flicker.
    const MetricDefinition* m = findMetric(name);
    const bool temporal = m && m->chart == ReportChart::Temporal;
    text += (text.empty() ? "" : "; ") + name + (temporal ? " (flicker) " : " ") + firsts;
  }
  return text;
}

namespace {

// The order of the methods by time: the CPU ms measured here against the GPU ms the cost model
// predicts at 1080p on the first device (issue 31: does the order change?). Each label's time is
// its mean over the scenes where both were measured.
void printSpeedOrder(std::ostream& out, const RunResults& results) {
  std::map<std::string, std::pair<double, double>> sums;  // label -> (CPU, GPU) sums
  std::map<std::string, int> counts, traced;
  std::map<std::string, double> tracing;  // label -> sum of its extra paths' tracing ms
  std::vector<std::string> labels;
  std::set<std::string> unmodelled;  // CPU-timed methods the cost model does not price
  std::string device;
  std::string otherDevices;  // the devices priced after the first (the report's Time menu)
  double tolerance = 0;      // as the run's predictions say how to order them (the report's too)
  for (const PairResult& p : results.pairs) {
    const json& t = p.timing();
    if (t.contains("gpuPredicted") && t["gpuPredicted"].is_object())
      if (const json o = t["gpuPredicted"].value("orderTolerance", json()); o.is_number())
        tolerance = std::max(tolerance, o.get<double>());
    if (p.ok() && p.clock() == "cpu" && !t.contains("gpuPredicted")) unmodelled.insert(p.label);
    if (!p.ok() || p.clock() != "cpu" || !t.contains("gpuPredicted") ||
        !t["gpuPredicted"].is_object())
      continue;
    const json devices = t["gpuPredicted"].value("devices", json::array());
    if (devices.empty() || !devices[0].value("msMedian", json()).is_number() || !t.value("msMedian", json()).is_number())
      continue;
    device = devices[0].value("device", "");
    otherDevices.clear();
    for (size_t k = 1; k < devices.size(); ++k)
      otherDevices += (otherDevices.empty() ? "" : ", ") + devices[k].value("device", "?");
    const std::string& label = p.label;
    if (!counts.count(label)) labels.push_back(label);
    sums[label].first += t["msMedian"].get<double>();
    sums[label].second += devices[0]["msMedian"].get<double>();
    ++counts[label];
    // Extra paths (asvgf's gradient samples, reengine's disocclusion rays): their tracing time is
    // not in the denoiser's, so the order marks them with it (median, as the time's).
    if (const auto found = p.summary.find("tracingMs");
        found != p.summary.end() && std::isfinite(found->second.median)) {
      tracing[label] += found->second.median;
      ++traced[label];
    }
  }
  if (labels.size() < 2) return;
  std::vector<double> cpu, gpu;
  for (const std::string& l : labels) {
    cpu.push_back(sums[l].first / counts[l]);
    gpu.push_back(sums[l].second / counts[l]);
  }
  // onCpu: the CPU line, whose extra paths' tracing time (CPU ms too) is given beside the time. The
  // model's times have two significant digits: it is within about 2x of measured and published
  // timings (docs/gpu-cost.md), and four digits would read as a measurement.
  auto order = [&](const std::vector<double>& ms, bool onCpu) {
    std::vector<size_t> idx(labels.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    std::stable_sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return ms[a] < ms[b]; });
    // Two times that print alike are not ordered by the print ("20.89 < 20.89"); predicted times
    // within the run's tolerance of their group's first are not ordered by the model (" ≈ ").
    std::vector<double> ascending;
    for (size_t i : idx) ascending.push_back(ms[i]);
    const std::vector<std::string> grouped = orderSeparators(ascending, tolerance);
    std::string text, previous;
    for (size_t k = 0; k < idx.size(); ++k) {
      const size_t i = idx[k];
      const std::string figure = onCpu ? figureText(ms[i]) : twoDigitsText(ms[i]);
      const std::string separator = !onCpu ? grouped[k] : figure == previous ? " = " : " < ";
      text += (text.empty() ? "" : separator) + labels[i] + " " + figure;
      if (traced.count(labels[i]))
        text +=
            onCpu ? " (+paths: " + figureText(tracing[labels[i]] / traced[labels[i]]) + " tracing)"
                  : " (+paths)";
      previous = figure;
    }
    return text;
  };
  for (const std::string& l : labels) unmodelled.erase(l);  // priced on another scene
  // What the CPU times are: this machine at the scenes' sizes, with the load when the run began
  // (a run beside other work reads slower).
  std::string where = sceneSizesText(results);
  if (const json load = results.environment.value("loadAverage", json());
      load.is_array() && !load.empty() && load[0].is_number())
    where += (where.empty() ? "" : ", ") + std::string("load ") +
             figureText(load[0].get<double>()) + " at the start";
  // Orders of medians: no interval separates two times here, so "<" is the order of the numbers,
  // not a resolved difference; with two methods the correlation can only be +-1.
  out << "\nspeed, ms per frame (mean over scenes of each pair's median, ordered; no interval: "
         "close times may swap between runs; the report charts each axis)\n"
      << "  CPU measured here" << (where.empty() ? "" : " (" + where + ")") << ": "
      << order(cpu, true) << "\n"
      << "  GPU predicted, " << device
      << " 1080p (a model, 2 digits: it misses its validation goal, so read an order of magnitude "
         "and an order of methods, not a budget; "
      << (tolerance > 0 ? "≈: less than " + figureText(100 * tolerance) +
                              "% above the first of its group, not ordered by it; "
                        : std::string())
      << "docs/gpu-cost.md"
      << (otherDevices.empty() ? std::string()
                               : "; also priced: " + otherDevices + ", in the report")
      << "): " << order(gpu, false) << "\n"
      << "  rank correlation of the two orders (Spearman): "
      << (labels.size() < 3
              ? "not given for " + std::to_string(labels.size()) + " methods (it can only be +-1)"
              : spearmanText(spearman(cpu, gpu), labels.size()))
      << "\n";
  if (!traced.empty())
    out << "  (+paths: T tracing): read paths beyond the frame's 1-spp ones, whose tracing, T ms "
           "at "
           "the render's rate, is not in the time ordered (the GPU model prices none)\n";
  if (!unmodelled.empty()) {
    std::string names;
    for (const std::string& l : unmodelled) names += (names.empty() ? "" : ", ") + l;
    out << "  not in these orders (no predicted GPU time): " << names << "\n";
  }
}

// The study's ranking with ties (metrics/statistics.hpp): per scene on relMSE, then overall on the
// per-scene normalised score. Methods whose difference is not resolved at 95% share "tied with".
void printSceneRankings(std::ostream& out, const RunResults& results) {
  if (!results.statistics) return;
  const RunStatistics& st = *results.statistics;
  out << "\nranking on relMSE with 95% intervals (" << st.method << ")\n";
  for (const auto& [name, scene] : st.scenes) {
    const SceneRanking& s = scene.ranking;
    out << "\n" << name << ": " << s.resolvedPairs << " of " << s.pairs.size() << " pairwise differences resolved\n";
    const size_t column = labelColumn(s.ranking, 26);
    for (const RankedMethod& m : s.ranking)
      out << "  " << std::left << std::setw(4) << rankText(m) << paddedText(rankedLabel(m), column)
          << rightAligned(figureText(m.value), 11) << "  " << paddedText(intervalText(m.ci), 24)
          << tiedText(m) << "\n";
    if (!s.excluded.empty()) out << "  not ranked: " << s.excluded << "\n";
    if (const std::string same = identicalOutputsText(results, name); !same.empty())
      out << "  identical outputs (bit for bit, every frame): " << same << "\n";
    if (ranksAboveALowerValue(s.ranking))
      out << "  (a method above one with a lower mean has fewer methods resolved better than it: "
             "its differences are less certain)\n";
  }
}

// A figure with its interval: "0.123 [0.1, 0.15]", "-" when absent; a null bound of the response
// is "never settled" (metrics/ghosting_intervals.hpp).
std::string figureWithInterval(const json& e, const char* name) {
  const bool never = std::string(name) == "responseFrames" && e.contains("response");
  if (!never && (!e.contains(name) || !e[name].is_number())) return "-";
  std::ostringstream o;
  if (never)
    o << "never";
  else
    o << std::setprecision(3) << e[name].get<double>();
  const json ci = e.value("ci95", json::object()).value(name, json());
  if (ci.is_array()) {
    auto bound = [](const json& b) {
      std::ostringstream t;
      t << std::setprecision(3);
      if (b.is_number()) t << b.get<double>();
      else t << "never";
      return t.str();
    };
    o << " [" << bound(ci[0]) << ", " << bound(ci[1]) << "]";
  } else {
    o << " (no interval)";
  }
  return o.str();
}

}  // namespace

void printEventTables(std::ostream& out, const RunResults& results) {
  if (!results.statistics) return;
  for (const auto& entry : results.statistics->scenes) {
    const std::string& name = entry.first;  // read by the lambdas below
    entry.second.forEachEvent([&](const EventStatistics& ev, bool cut) {
      const int frame = ev.eventFrame;
      const char* rankedOn = cut ? "oldViewLeak" : "lagEnergy";
      const auto figure = ev.byFigure.find(rankedOn);
      const SceneRanking none;
      const SceneRanking& ranking = figure == ev.byFigure.end() ? none : figure->second;
      out << "\n" << name << ": " << ev.kind << (ev.what.empty() ? "" : " " + ev.what) << " at frame " << frame
          << ": ranked on " << rankedOn << " (" << ranking.resolvedPairs << " of " << ranking.pairs.size()
          << " pairs resolved)\n";
      std::string steadyAbsent;  // the window's reason, the same for every method
      std::string neverSettled;  // methods whose E_ss is taken from frames still lagging
      std::string stateless;     // methods at rank 1 that keep no history: first by construction
      // A pair the ranking leaves out (its figure undefined: a cut with no old view, a lag after an
      // event it never settled from) keeps its row, unranked ("-"), with its other figures.
      std::vector<RankedMethod> rows = ranking.ranking;
      for (const PairResult& p : results.pairs)
        if (p.scene == name && p.part(cut ? "cuts" : "ghosting").is_array() &&
            std::none_of(rows.begin(), rows.end(),
                         [&](const RankedMethod& m) { return m.label == p.label; })) {
          RankedMethod unranked;
          unranked.label = p.label;
          rows.push_back(unranked);
        }
      const size_t column = labelColumn(rows, 22);
      for (const RankedMethod& m : rows) {
        const json* e = nullptr;
        const PairResult* pair = nullptr;
        for (const PairResult& p : results.pairs)
          if (p.scene == name && m.label == p.label && p.part(cut ? "cuts" : "ghosting").is_array())
            for (const json& x : p.part(cut ? "cuts" : "ghosting"))
              if (x.value("eventFrame", -1) == frame) e = &x, pair = &p;
        if (!e) continue;
        if (m.rank == 1 && !pair->keepsHistory())
          stateless += (stateless.empty() ? "" : ", ") + m.label;
        out << "  " << std::left << std::setw(4) << rankText(m) << paddedText(m.label, column);
        for (const char* f : cut ? std::vector<const char*>{"oldViewLeak", "atCut"}
                                 : std::vector<const char*>{"lagEnergy", "responseFrames", "peakExcess", "chromaLagEnergy"})
          out << f << " " << std::setw(26) << figureWithInterval(*e, f) << " ";
        out << tiedText(m) << "\n";
        if (e->contains("steadyAbsent")) steadyAbsent = e->value("steadyAbsent", "");
        if (!cut && e->value("settled", json()).is_boolean() && !(*e)["settled"].get<bool>() &&
            e->value("steadyState", json()).is_number())
          neverSettled += (neverSettled.empty() ? "" : ", ") + m.label;
      }
      if (!steadyAbsent.empty())
        out << "  peakExcess and ghostEnergy: none, " << steadyAbsent << "\n";
      if (!neverSettled.empty())
        out << "  never settled within the window: " << neverSettled
            << " (E_ss is then a median of frames still lagging: their peakExcess and ghostEnergy "
               "read low, lower bounds)\n";
      if (!ranking.excluded.empty()) out << "  not ranked: " << ranking.excluded << "\n";
      if (!stateless.empty())
        out << "  " << stateless
            << " at rank 1 keep(s) no history between frames: no lag and no jump by construction, "
               "not a finding about denoising (their error is in the scene's ranking)\n";
      if (ranksAboveALowerValue(ranking.ranking))
        out << "  (a method above one with a lower " << rankedOn
            << " has fewer methods resolved better than it: its differences are less certain)\n";
    });
  }
}

namespace {

// One line per scene: the best method on relMSE (rank 1, first in the ranking) with its mean and
// interval, and the methods not resolved from it -- the winner, or the tied group.
void printSceneWinners(std::ostream& out, const RunResults& results) {
  if (!results.statistics || results.statistics->scenes.empty()) return;
  const auto& scenes = results.statistics->scenes;
  out << "\nper scene: the best on relMSE with its 95% interval, and the methods not resolved from it\n";
  size_t width = 0;
  for (const auto& [name, scene] : scenes) width = std::max(width, displayWidth(name));
  for (const auto& [name, scene] : scenes) {
    const SceneRanking& s = scene.ranking;
    out << "  " << paddedText(name, width + 2);
    if (s.ranking.empty()) {
      out << "not ranked" << (s.excluded.empty() ? "" : ": " + s.excluded) << "\n";
      continue;
    }
    const RankedMethod& best = s.ranking[0];
    if (s.ranking.size() == 1) {  // nothing to be best among
      out << "only " << best.label << " ranked: not compared\n";
      continue;
    }
    const std::string tied = tiedText(best), same = identicalOutputsText(results, name);
    out << rankedLabel(best) << " " << figureText(best.value) << " " << intervalText(best.ci)
        << (tied.empty() ? "" : "; " + tied) << (same.empty() ? "" : "; identical outputs: " + same)
        << "\n";
  }
  // A denoiser not resolved better than the noisy input on a scene did not show that it denoises
  // there (the winners above do not say it, and a tie below rank 1 is easy to miss).
  std::string tiedWithInput, worseThanInput;
  for (const auto& [name, scene] : scenes) {
    const std::vector<RankedMethod>& ranking = scene.ranking.ranking;
    const auto input = std::find_if(ranking.begin(), ranking.end(),
                                    [](const RankedMethod& m) { return m.label == "passthrough"; });
    if (input == ranking.end()) continue;
    std::string tied, worse;
    for (const RankedMethod& m : ranking) {
      if (m.label == input->label) continue;
      const bool isTied = std::find(input->tiedWith.begin(), input->tiedWith.end(), m.label) !=
                          input->tiedWith.end();
      // Worse by the pair's own difference (relMSE: lower is better), not by rank: ranks need not
      // be transitive, so a method resolved better than the input can rank below it.
      bool resolvedWorse = m.rank > input->rank;
      for (const SceneRanking::Pair& p : scene.ranking.pairs)
        if ((p.a == m.label && p.b == input->label) || (p.b == m.label && p.a == input->label))
          resolvedWorse = p.d.resolved() && (p.a == m.label ? p.d.diff > 0 : p.d.diff < 0);
      if (isTied)
        tied += (tied.empty() ? "" : ", ") + m.label;
      else if (resolvedWorse)
        worse += (worse.empty() ? "" : ", ") + m.label;
    }
    if (!tied.empty()) tiedWithInput += (tiedWithInput.empty() ? "" : "; ") + name + ": " + tied;
    if (!worse.empty())
      worseThanInput += (worseThanInput.empty() ? "" : "; ") + name + ": " + worse;
  }
  if (!tiedWithInput.empty())
    out << "  not resolved from the noisy input (passthrough, no denoising) on relMSE: "
        << tiedWithInput << "\n";
  if (!worseThanInput.empty())
    out << "  resolved WORSE than the noisy input on relMSE: " << worseThanInput << "\n";
}

// The methods still lagging at the end of a scripted event's window, per event: the headline
// scores average lag away (a method first on flicker may never settle after a light goes off).
void printUnsettled(std::ostream& out, const RunResults& results) {
  struct Event {
    std::string scene, kind;
    int frame = 0, window = 0;
    std::vector<std::string> labels;
  };
  std::vector<Event> events;
  for (const PairResult& p : results.pairs) {
    if (!p.ok()) continue;
    for (const json& g : p.part("ghosting").is_array() ? p.part("ghosting") : json::array()) {
      if (!g.is_object() || !g.value("settled", json()).is_boolean() || g["settled"].get<bool>())
        continue;
      const int frame = g.value("eventFrame", -1);
      auto it = std::find_if(events.begin(), events.end(), [&](const Event& e) {
        return e.scene == p.scene && e.frame == frame;
      });
      if (it == events.end()) {
        events.push_back(
            {p.scene, g.value("kind", ""), frame, g.value("windowEnd", frame) - frame + 1, {}});
        it = events.end() - 1;
      }
      it->labels.push_back(p.label);
    }
  }
  if (events.empty()) return;
  out << "\nnever settled after a scripted event (still lagging where its window ends; --verbose: "
         "the event figures)\n";
  for (const Event& e : events) {
    std::string labels;
    for (const std::string& l : e.labels) labels += (labels.empty() ? "" : ", ") + l;
    out << "  " << e.scene << " @" << e.frame << " " << e.kind << " (" << e.window
        << " frames from it): " << labels << "\n";
  }
}

// The warnings that concern a scene, once per scene: results.scenes.<scene>.warnings (capped
// references, non-finite inputs) and the asset loader's fallbacks.
std::vector<std::string> sceneWarningLines(const RunResults& results) {
  std::vector<std::string> lines;
  for (const auto& [name, scene] : results.scenes.items()) {
    for (const json& w : scene.value("warnings", json::array())) lines.push_back(name + ": " + w.get<std::string>());
    const size_t fallbacks = scene.value("assets", json::object()).value("warnings", json::array()).size();
    if (fallbacks > 0)
      lines.push_back(name + ": " + std::to_string(fallbacks) + " asset loader fallback(s) (results.json scenes." + name +
                      ".assets.warnings)");
  }
  return lines;
}

}  // namespace

void printStudyTables(std::ostream& out, const RunResults& results) {
  printSceneRankings(out, results);
  printOtherOverallScores(out, results);
  printEventTables(out, results);
  const std::vector<std::string> absent = absentSummaryLines(results, {"relMse"});
  if (!absent.empty()) out << "\nabsent summaries\n";
  for (const std::string& line : absent) out << "  " << line << "\n";
  out << "\nreference quality (noise floor / best real denoiser's corrected relMSE, goal <= " << kReferenceQualityGoal
      << ")\n";
  for (const std::string& line : referenceQualityLines(results.scenes)) out << "  " << line << "\n";
}

void printStudySummary(std::ostream& out, const RunResults& results, const StudyOutputs& where) {
  printOverallRanking(out, results);
  if (const std::string firsts = otherOverallFirstsText(results); !firsts.empty())
    out << "  rank 1 overall on the other metrics: " << firsts << " (--verbose: their table)\n";
  printSpeedOrder(out, results);
  printSceneWinners(out, results);
  printUnsettled(out, results);
  // docs/references.md: said plainly, once, where a scene's references are too noisy to rank it.
  std::vector<std::string> missed;
  for (const auto& [name, scene] : results.scenes.items())
    if (scene.contains("referenceQuality") && !scene["referenceQuality"].value("meets", false))
      missed.push_back(scene["referenceQuality"].value("verdict", name));
  if (!missed.empty())
    out << "\nreference quality goal (noise floor <= " << kReferenceQualityGoal
        << " x the best corrected relMSE) missed on " << missed.size() << " scene(s)\n";
  for (const std::string& line : missed) out << "  " << line << "\n";
  if (const std::vector<std::string> between = segmentQualityLines(results.scenes);
      !between.empty()) {
    out << "\nreference quality goal missed between events (met for the whole scene) on "
        << between.size()
        << " scene(s): the event figures there carry more of the reference's noise\n";
    for (const std::string& line : between) out << "  " << line << "\n";
  }
  const std::vector<std::string> warnings = sceneWarningLines(results);
  if (!warnings.empty()) out << "\nwarnings\n";
  for (const std::string& line : warnings) out << "  " << line << "\n";
  const PairWarningCount counted = countPairWarnings(results);
  const size_t pairWarnings = counted.warnings, pairsWarned = counted.pairs;
  const size_t absent = absentSummaryLines(results, {"relMse"}).size();
  if (pairWarnings > 0 || absent > 0) {
    out << "\n";
    if (pairWarnings > 0)
      out << pairWarnings << " warning(s) on " << pairsWarned << " pair(s) (floors, absent summaries, sanitised "
          << "inputs): listed per scene in the report and in results.json pairs[].warnings\n";
    if (absent > 0) out << "relMSE summaries are absent in " << absent << " case(s): --verbose says where and why\n";
  }
  out << "\nstudy finished in " << int(where.seconds / 60) << " min " << int(where.seconds) % 60 << " s "
      << "(--verbose: every ranking, event and verdict)\n"
      << "results: " << where.results << ", " << where.database << "\n"
      << "report:  " << where.report << "\n";
}

}  // namespace arena::cli
