#include "denoisers/common/footprint.hpp"

#include <algorithm>
#include <cmath>

namespace arena {

namespace {
const char* policyName(FootprintPolicy policy) {
  return policy == FootprintPolicy::Scaled ? "scaled" : "native";
}
constexpr double kDefaultReferenceHeight = 1080.0;
}  // namespace

float Footprint::scale(int height) const {
  if (policy == FootprintPolicy::Native || referenceHeight <= 0.0f) return 1.0f;
  return float(height) / referenceHeight;
}

int atrousStep(int iteration, float scale) {
  if (scale == 1.0f) return 1 << iteration;
  const int step = int(std::lround(std::ldexp(double(scale), iteration)));
  return iteration == 0 ? std::max(step, 1) : step;
}

std::vector<ParamSpec> footprintParamSpecs() {
  return {
      ParamSpec::choice("footprint", policyName(kDefaultFootprintPolicy), {"native", "scaled"},
                        "spatial footprints: scaled = published pixel constants are pixels at "
                        "footprintHeight, scaled by height / footprintHeight (keeps the screen "
                        "extent); native = published pixel constants at any resolution (Falcor, "
                        "Q2RTX, NRD; keeps the sample count); the same for every denoiser"),
      ParamSpec::real("footprintHeight", kDefaultReferenceHeight, 1, 100000,
                      "footprint=scaled: the image height the pixel constants are tuned for "
                      "(1080: NRD, SVGF paper)"),
  };
}

Footprint footprintParam(const ParamSet& params) {
  Footprint f;
  f.policy =
      params.getChoice("footprint") == "scaled" ? FootprintPolicy::Scaled : FootprintPolicy::Native;
  f.referenceHeight = params.getFloat("footprintHeight");
  return f;
}

}  // namespace arena
