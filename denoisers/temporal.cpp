// `temporal`: reprojected temporal accumulation only, no spatial filter (NRD's REFERENCE-style
// accumulator): the accurate-but-laggy end of every chart. Its history is the accumulated
// signal itself; alpha = max(alphaMin, 1/h) with h capped at maxHistory.
#include <algorithm>

#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/common/temporal_accumulation.hpp"
#include "denoisers/denoiser.hpp"
#include "denoisers/variants.hpp"

namespace arena {

namespace {

// Set from temporalParams() below, which declares each default, range and meaning once.
struct TemporalSettings {
  ReprojectionSettings reprojection;
  float maxHistory;
  float alphaMin;
};

class TemporalAccumulation final : public Denoiser {
 public:
  explicit TemporalAccumulation(const TemporalSettings& settings) : settings_(settings) {}

  std::vector<std::string> requiredChannels() const override {
    return {"depth", "normal", "meshId", "motion", "position"};
  }

  void setup(int width, int height) override {
    derivatives_ = Image(width, height, kGeometryDerivativeChannels);
    reprojection_.setup(width, height);
    previousGBuffer_.setup(width, height);
    colorHistory_ = Image(width, height, 3);
    historyLength_ = Image(width, height, 1);
    previousHistoryLength_ = Image(width, height, 1);
    hasHistory_ = false;
  }

  void reset() override { hasHistory_ = false; }

  void denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) override {
    if (ctx.reset) reset();
    const GBufferView gbuffer = GBufferView::fromFrame(in.frame, requiredChannels(), "temporal");
    {
      ScopedPass pass(this, "derivatives", 4);
      computeGeometryDerivatives(gbuffer, derivatives_);
    }
    {
      ScopedPass pass(this, "reproject", 4);
      if (hasHistory_) {
        reprojection_.compute(gbuffer, derivatives_, previousGBuffer_.view(),
                              settings_.reprojection, &ctx.camera, &ctx.previousCamera);
      } else {
        reprojection_.invalidateAll();
      }
      pass.setTaps(reprojection_.testedTapsPerPixel());
    }
    {
      // Disocclusions (and sky, never reprojected) get alpha = 1: the input passes through.
      ScopedPass pass(this, "accumulate", 2 * reprojection_.readTapsPerPixel());
      // updateHistoryLength and accumulateTemporally in one sweep.
      accumulateWithHistoryLength(reprojection_, previousHistoryLength_, settings_.maxHistory,
                                  in.signal, colorHistory_, {settings_.alphaMin, nullptr},
                                  historyLength_, output);
    }
    {
      ScopedPass pass(this, "store history", 0);
      parallelCopy(output, colorHistory_);
      previousGBuffer_.store(gbuffer);
      std::swap(historyLength_, previousHistoryLength_);
      hasHistory_ = true;
    }
  }

 private:
  TemporalSettings settings_;
  Image derivatives_;
  Reprojection reprojection_;
  GBufferHistory previousGBuffer_;
  Image colorHistory_, historyLength_, previousHistoryLength_;
  bool hasHistory_ = false;
};

const ParamTable<TemporalSettings>& temporalParams() {
  using S = TemporalSettings;
  static const ParamTable<S> table =
      ParamTable<S>()
          .integer("maxHistory", &S::maxHistory, 32, 1, 4096,
                   "history length cap h_max; alpha never falls below 1/h_max (Falcor's cap 32)")
          .real("alphaMin", &S::alphaMin, 0.0, 0.0, 1.0,
                "floor of the blend weight alpha = max(alphaMin, 1/h); 0 (ours) leaves "
                "1/maxHistory as the floor, i.e. a running mean of the last 32 frames, "
                "converging on a static view (Falcor 0.05, SVGF paper 0.2)")
          .include(reprojectionParams(), &S::reprojection);
  return table;
}

}  // namespace

DenoiserInfo temporalInfo() {
  return {"temporal",
          "Reprojected temporal accumulation only, alpha = max(alphaMin, 1/h) (NRD REFERENCE-like "
          "baseline; Falcor/SVGF reprojection tests)",
          temporalParams().schema(), [](const ParamSet& params, SignalKind) {
            return std::make_unique<TemporalAccumulation>(
                temporalParams().settings(params, "temporal"));
          }};
}

}  // namespace arena
