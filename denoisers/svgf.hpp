#pragma once
// SVGF, Spatiotemporal Variance-Guided Filtering (Schied et al. 2017; seed 003), as a class whose
// stages A-SVGF (Schied et al. 2018) reuses: it derives from Svgf and supplies a per-pixel
// temporal alpha through adaptiveAlpha(), computed after the reprojection of the frame.
#include <string>
#include <vector>

#include "denoisers/common/atrous.hpp"
#include "denoisers/common/footprint.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/common/temporal_accumulation.hpp"
#include "denoisers/common/variance.hpp"
#include "denoisers/denoiser.hpp"
#include "denoisers/param_table.hpp"

namespace arena {

// While h < 4, the à-trous starts from the 7x7 bilateral mean of the accumulated colour (Falcor
// SVGFFilterMoments) or from the accumulated colour itself (the SVGF paper, which estimates only
// the variance spatially; the default: the mean raises disoccluded relMSE, FIDELITY.md).
enum class YoungColor { Spatial, Accumulated };

// Every field named after its parameter is set from svgfParams() (svgf.cpp), which declares its
// default, range and meaning once; the rest are SVGF's fixed choices.
struct SvgfSettings {
  ReprojectionSettings reprojection;
  float alpha;         // colour EMA floor
  float momentsAlpha;  // moments EMA floor
  float maxHistory;    // history length cap
  VarianceSettings variance;
  YoungColor youngColor;
  int iterations;         // à-trous iterations
  int feedbackTap;        // 1-based iteration feeding the history (0: the accumulated colour)
  AtrousSettings atrous;  // kernel and the edge-stopping terms (sigmaZ, edge.depth, ...)
  Footprint footprint;    // footprint.hpp: the à-trous steps at this resolution
};

// SVGF's parameters, each bound to its field (A-SVGF and SLGF include them in their own tables);
// settings() throws an Error naming the owner when feedbackTap exceeds iterations.
const ParamTable<SvgfSettings>& svgfParams();

class Svgf : public Denoiser {
 public:
  explicit Svgf(const SvgfSettings& settings, std::string name = "svgf");

  std::vector<std::string> requiredChannels() const override;
  void setup(int width, int height) override;
  void reset() override;
  // The paper's pipeline, top to bottom (see svgf.cpp).
  void denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) override;

  // Of the last frame (for tests): the luminance variance the à-trous started from, and h.
  const Image& lastVariance() const { return variance_; }
  const Image& lastHistoryLength() const { return previousHistoryLength_; }

 protected:
  // A-SVGF's hook: called once per frame after reprojection() and before accumulation; returns
  // per-pixel images (plane 0) for colour and moments alike, or nullptrs for plain SVGF: `floor`
  // raises the EMA floor, alpha = max(settings alpha, it, 1/h) (A-SVGF eq. 15 literally);
  // `antilag` is Q2RTX's lambda, shortening h before alpha = lerp(max(alpha, 1/h), 1, lambda)
  // (temporal_accumulation.hpp).
  struct AdaptiveAlpha {
    const Image* floor = nullptr;
    const Image* antilag = nullptr;
  };
  virtual AdaptiveAlpha adaptiveAlpha(const FrameContext&, const DenoiserInputs&) { return {}; }
  // SLGF's hook: called once per frame right after accumulate() (with the alpha image it used) and
  // before estimateVariance(); may rewrite accumulated_, moments_ and historyLength_, e.g. re-blend
  // a corrected reprojected history (colorHistory_ / momentsHistory_ still hold frame i - 1's
  // history here). Does nothing by default, so plain SVGF is unchanged.
  virtual void correctAccumulation(const FrameContext&, const DenoiserInputs&, const Image*) {}

  // The stages, each one timed pass, in paper order.
  void computeDerivatives();                // ddx/ddy of depth, normal
  void reproject(const FrameContext& ctx);  // §4.1 consistency tests
  void accumulate(const DenoiserInputs& in, const AdaptiveAlpha& alpha);  // §4.1, §4.2
  void estimateVariance();            // §4.2 temporal / 7x7 spatial (+ Falcor's young colour)
  void filterWavelet(Image& output);  // §4.3 à-trous + feedback
  void storeHistory();                // history for frame i + 1

  SvgfSettings settings_;
  std::string name_;
  GBufferView gbuffer_;  // this frame's guides (valid during denoise())
  Image derivatives_;
  Reprojection reprojection_;
  GBufferHistory previousGBuffer_;
  bool hasHistory_ = false;
  // History (persist across frames; reset() discards them).
  Image colorHistory_, momentsHistory_, previousHistoryLength_;
  // Per-frame (transient) buffers.
  Image accumulated_, moments_, historyLength_, variance_, filteredVariance_, youngColorMean_;
  Image colorPingPong_[2], variancePingPong_[2];
  RowTapCounter varianceTaps_;
};

}  // namespace arena
