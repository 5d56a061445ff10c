#include "metrics/metric_registry.hpp"

#include <algorithm>
#include <cctype>
#include <set>

#include "core/error.hpp"

namespace arena {

// The families, each defined in the file that computes it. Registering a family is two lines here:
// its declaration and its entry in metricFamilies().
MetricFamily linearErrorFamily();      // error.cpp
MetricFamily flipFamily();             // flip.cpp
MetricFamily displayErrorFamily();     // error.cpp
MetricFamily temporalFlickerFamily();  // temporal.cpp
MetricFamily runFactsFamily();         // run_facts.cpp
MetricFamily multiScaleStabilityFamily();  // stability.cpp

// A metric's name is a key in results.json, results.db and --metric: declared once, by one family,
// as an identifier (a second declaration would silently replace the first one's values).
void checkFamilies(const std::vector<MetricFamily>& families) {
  std::set<std::string> names;
  for (const MetricFamily& f : families)
    for (const MetricDefinition& m : f.metrics) {
      const bool identifier =
          !m.name.empty() && std::islower(static_cast<unsigned char>(m.name[0])) &&
          std::all_of(m.name.begin(), m.name.end(),
                      [](char c) { return std::isalnum(static_cast<unsigned char>(c)); });
      if (!identifier)
        throw Error("metric registry: '" + m.name +
                    "' is not a name (a lower-case letter, then letters and digits)");
      if (!names.insert(m.name).second)
        throw Error("metric registry: '" + m.name +
                    "' is declared twice (each metric once, by the family that computes it)");
      if (m.description.empty())
        throw Error("metric registry: '" + m.name +
                    "' has no description (arena metrics lists it)");
    }
}

void requireOwnMetric(const MetricFamily& family, const std::string& metric) {
  if (std::any_of(family.metrics.begin(), family.metrics.end(),
                  [&](const MetricDefinition& m) { return m.name == metric; }))
    return;
  std::string own, meant;
  const auto lower = [](std::string t) {
    for (char& c : t) c = char(std::tolower(static_cast<unsigned char>(c)));
    return t;
  };
  for (const MetricDefinition& m : family.metrics) {
    own += (own.empty() ? "" : ", ") + m.name;
    if (lower(m.name) == lower(metric)) meant = m.name;  // a slip of case: logLumMAE for logLumMae
  }
  throw Error("the metric family of " + own + " put '" + metric + "', which it does not declare" +
              (meant.empty() ? std::string() : " (did you mean '" + meant + "'?)") +
              " (a family puts only its own metrics)");
}

bool recordedWithTiles(const MetricDefinition& m) {
  return m.reads != MetricInput::Run && !m.frameScalar;
}

void requireTilesWhereDeclared(const MetricDefinition& m, double value, const TileSums& tiles) {
  // Its interval resamples tiles; without them it would resample frames only, an interval several
  // times too narrow (a contributor's trial: 8x), and nothing would say so.
  if (tiles.empty() && recordedWithTiles(m) && std::isfinite(value))
    throw Error(
        "the family that puts " + m.name + " put it without its tile sums: a metric that " +
        "reads images records them (put(name, value, tiles), docs/extending.md), which its " +
        "interval resamples (a frame's scalar derived from others declares frameScalar)");
}

const std::vector<MetricFamily>& metricFamilies() {
  static const std::vector<MetricFamily> families = [] {
    std::vector<MetricFamily> all = {
        linearErrorFamily(),     flipFamily(),     displayErrorFamily(),
        temporalFlickerFamily(), runFactsFamily(), multiScaleStabilityFamily(),
    };
    checkFamilies(all);
    return all;
  }();
  return families;
}

const FrameView* FrameView::previous(int lag) const {
  return lag >= 1 && size_t(lag) <= history.size() ? history[size_t(lag - 1)] : nullptr;
}

bool FrameView::cutWithin(int lag) const {
  return std::any_of(cutFrames.begin(), cutFrames.end(), [&](int c) { return c > frame - lag && c <= frame; });
}

bool MetricFamily::needsReference() const {
  return std::all_of(metrics.begin(), metrics.end(), [](const MetricDefinition& m) { return m.needsReference; });
}

std::vector<const MetricDefinition*> metricCatalog() {
  std::vector<const MetricDefinition*> out;
  for (const MetricFamily& f : metricFamilies())
    for (const MetricDefinition& m : f.metrics) out.push_back(&m);
  return out;
}

const MetricDefinition* findMetric(const std::string& name) {
  for (const MetricDefinition* m : metricCatalog())
    if (m->name == name) return m;
  return nullptr;
}

const MetricDefinition& requireMetric(const std::string& name, const std::string& what) {
  if (const MetricDefinition* m = findMetric(name)) return *m;
  std::string names;
  for (const MetricDefinition* m : metricCatalog()) names += (names.empty() ? "" : ", ") + m->name;
  throw Error(what + ": unknown metric '" + name + "'; the metrics are: " + names);
}

nlohmann::json metricCatalogJson() {
  nlohmann::json out = nlohmann::json::array();
  for (const MetricDefinition* m : metricCatalog())
    out.push_back({{"name", m->name},
                   {"unit", m->unit},
                   {"better", m->betterName()},
                   {"lowerIsBetter", m->lowerIsBetter()},
                   {"needsReference", m->needsReference},
                   {"reads", m->reads == MetricInput::Linear    ? "linear"
                             : m->reads == MetricInput::Display ? "display"
                                                                : "run"},
                   {"transform", transformName(m->transform)},
                   {"floor", m->floor == FloorRule::ReferenceNoise ? "reference noise" : "none"},
                   {"ranked", m->ranked},
                   {"gatedByDefault", m->gatedByDefault},
                   {"overall", m->overall},
                   {"reportColumn", m->reportColumn},
                   {"chart", m->chart == ReportChart::Error      ? "error"
                             : m->chart == ReportChart::Temporal ? "temporal"
                                                                 : ""},
                   {"title", m->title.empty() ? m->name : m->title},
                   {"meaning", m->description}});
  return out;
}

}  // namespace arena
