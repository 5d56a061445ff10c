// `passthrough`: the noisy 1-spp input, unfiltered -- the fast, inaccurate end of every chart.
#include "denoisers/denoiser.hpp"
#include "denoisers/variants.hpp"

namespace arena {

namespace {

class Passthrough final : public Denoiser {
 public:
  std::vector<std::string> requiredChannels() const override { return {}; }
  void setup(int, int) override {}
  void reset() override {}
  void denoise(const FrameContext&, const DenoiserInputs& in, Image& output) override {
    ScopedPass pass(this, "copy", 0);
    output = in.signal;
  }
};

}  // namespace

DenoiserInfo passthroughInfo() {
  DenoiserInfo info{"passthrough", "The noisy 1-spp input, unfiltered (baseline)", ParamSchema{},
                    [](const ParamSet&, SignalKind) { return std::make_unique<Passthrough>(); }};
  info.identity = true;
  info.keepsHistory = false;
  return info;
}

}  // namespace arena
