#include "metrics/metric_registry.hpp"

#include <algorithm>

#include "core/error.hpp"

namespace arena {

// The families, each declared in the file that computes it. Registering a metric is one line here.
MetricFamily linearErrorFamily();      // error.cpp
MetricFamily flipFamily();             // flip.cpp
MetricFamily displayErrorFamily();     // error.cpp
MetricFamily temporalFlickerFamily();  // temporal.cpp
MetricFamily runFactsFamily();         // run_facts.cpp
MetricFamily multiScaleStabilityFamily();  // stability.cpp

const std::vector<MetricFamily>& metricFamilies() {
  static const std::vector<MetricFamily> families = {
      linearErrorFamily(),
      flipFamily(),
      displayErrorFamily(),
      temporalFlickerFamily(),
      runFactsFamily(),
      multiScaleStabilityFamily(),
  };
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
