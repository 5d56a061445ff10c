#pragma once
// The registered variants, in the order charts list them. Each variant's .cpp defines its
// `xxxInfo()`; adding a denoiser means adding one line here and one in builtinDenoisers().
#include <vector>

#include "denoisers/denoiser.hpp"

namespace arena {

DenoiserInfo passthroughInfo();
DenoiserInfo temporalInfo();
DenoiserInfo eawInfo();
DenoiserInfo svgfInfo();
DenoiserInfo asvgfInfo();
DenoiserInfo slgfInfo();
DenoiserInfo reblurInfo();
DenoiserInfo hybridInfo();
DenoiserInfo reEngineInfo();

inline std::vector<DenoiserInfo> builtinDenoisers() {
  return {passthroughInfo(), temporalInfo(), eawInfo(), svgfInfo(), asvgfInfo(), slgfInfo(),
          reblurInfo(), hybridInfo(), reEngineInfo()};
}

}  // namespace arena
