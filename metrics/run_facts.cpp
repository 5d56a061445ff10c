// The run's facts that are not pixels, recorded per frame like every metric so they get the same
// summaries and intervals: the denoiser's time and the extra paths it read (docs/metrics.md, "Time").
#include <cmath>

#include "metrics/metric_registry.hpp"

namespace arena {

// Registered in metric_registry.cpp.
MetricFamily runFactsFamily() {
  MetricFamily f;
  f.metrics = {
      {.name = "ms", .unit = "ms", .needsReference = false, .reads = MetricInput::Run,
       .description = "wall time of the denoiser per frame (both signals), ms"},
      {.name = "msWall", .unit = "ms", .needsReference = false, .reads = MetricInput::Run,
       .description = "the harness's clock around an external process's exchange (transfer included), ms"},
      {.name = "extraRaysPerPixel", .unit = "paths/pixel", .needsReference = false, .reads = MetricInput::Run,
       .description = "extra paths read per pixel per frame: low-resolution disocclusion rays (reengine), "
                      "re-shaded gradient samples (asvgf)"},
      {.name = "tracingMs", .unit = "ms", .needsReference = false, .reads = MetricInput::Run,
       .description = "those paths' equivalent tracing time per frame at the render's own rate, ms"},
  };
  f.measure = [](const FrameView& v, const MetricOptions&, FrameRecorder& out) {
    const FrameFacts& facts = v.facts;
    // A time not known (a stored output whose capture records none) is undefined, not a value.
    if (!std::isnan(facts.milliseconds)) out.put("ms", facts.milliseconds);
    // An external process timed itself ("ms"); the harness's clock around the exchange beside it.
    if (facts.wallMilliseconds) out.put("msWall", *facts.wallMilliseconds);
    if (!facts.extraRaysPerPixel) return;
    out.put("extraRaysPerPixel", *facts.extraRaysPerPixel);
    // The paths read, at the rate they rendered at on the machine that rendered them (unknown,
    // and absent, when another machine did).
    if (facts.extraPathsPerSecond > 0)
      out.put("tracingMs", *facts.extraRaysPerPixel * double(v.output->width()) * double(v.output->height()) /
                               facts.extraPathsPerSecond * 1e3);
  };
  return f;
}

}  // namespace arena
