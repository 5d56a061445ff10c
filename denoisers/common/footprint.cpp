#include "denoisers/common/footprint.hpp"

#include <algorithm>
#include <cmath>

namespace arena {

float Footprint::scale(int height) const {
  if (policy == FootprintPolicy::Native || referenceHeight <= 0.0f) return 1.0f;
  return float(height) / referenceHeight;
}

int atrousStep(int iteration, float scale) {
  if (scale == 1.0f) return 1 << iteration;
  const int step = int(std::lround(std::ldexp(double(scale), iteration)));
  return iteration == 0 ? std::max(step, 1) : step;
}

bool atrousRunsAt1080p(int iteration, float scale, int height) {
  return atrousStep(iteration, scale * 1080.0f / float(height)) != 0;
}

int scaledMipLevel(int level, float scale) {
  if (scale == 1.0f) return level;
  return std::max(1, int(std::lround(double(level) + std::log2(double(scale)))));
}

// The default policy is chosen here, once (footprint.hpp says why scaled).
const ParamTable<Footprint>& footprintParams() {
  static const ParamTable<Footprint> table =
      ParamTable<Footprint>()
          .choice("footprint", &Footprint::policy, "scaled",
                  {{"native", FootprintPolicy::Native}, {"scaled", FootprintPolicy::Scaled}},
                  "spatial footprints: scaled = published pixel constants are pixels at "
                  "footprintHeight, scaled by height / footprintHeight (keeps the screen "
                  "extent); native = published pixel constants at any resolution (Falcor, "
                  "Q2RTX, NRD; keeps the sample count); the same for every built-in denoiser (an "
                  "external one's footprint is its own)")
          .real("footprintHeight", &Footprint::referenceHeight, 1080, 1, 100000,
                "footprint=scaled: the image height the pixel constants are tuned for "
                "(1080: NRD, SVGF paper)");
  return table;
}

}  // namespace arena
