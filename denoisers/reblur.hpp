#pragma once
// ReBLUR, recurrent blur (Zhadan, "Fast Denoising with Self Stabilizing Recurrent Blurs", GTC
// 2020; NVIDIA NRD's REBLUR). The pipeline is in reblur.cpp, top to bottom; this header exposes
// the class so tests can look at every pass's output.
#include <string>
#include <utility>
#include <vector>

#include "denoisers/common/footprint.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/hit_point_reprojection.hpp"
#include "denoisers/common/mip_chain.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/poisson_blur.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/denoiser.hpp"

namespace arena {

enum class ReblurHistoryFix { Off, Sparse, Mip };

struct ReblurSettings {
  ReprojectionSettings reprojection;
  HitPointReprojectionSettings hitPoint;
  SurfaceWeightSettings weights;  // plane distance, normal (+ hit distance, roughness: specular)
  bool preBlur = true;
  float preBlurRadius = 30.0f;          // NRD diffusePrepassBlurRadius 30
  float specularPreBlurRadius = 50.0f;  // NRD specularPrepassBlurRadius 50
  int maxAccumulatedFrames = 30;        // NRD maxAccumulatedFrameNum 30
  int maxFastAccumulatedFrames = 6;     // NRD maxFastAccumulatedFrameNum 6
  bool hitPointReprojection = true;     // specular only
  // The specular hit distance the guides read: the 1-spp sample's ("specHitDist", what a real
  // tracer has) or the noise-free mirror ray's oracle ("specHitDistMirror").
  std::string hitDistanceChannel = "specHitDist";
  bool hitDistancePreBlur = true;  // NRD pre-pass: the hit distance blurred with the radiance
  float hitPointRoughness = 0.6f;  // virtual amount = 1 - smoothstep(0, this, roughness) (ours)
  ReblurHistoryFix historyFix = ReblurHistoryFix::Sparse;
  int historyFixFrames = 3;        // NRD historyFixFrameNum 3
  float historyFixStride = 14.0f;  // NRD historyFixStrideBetweenSamples 14
  bool historyFixNrd = true;       // NRD v4: 20 taps at stride / (2 + N); false: 24 at (F - N) / F
  bool radiusNrd = true;           // NRD: radius 1 / (1 + N_prev); false: sqrt(1 / (1 + N))
  bool antiFirefly = true;         // NRD enableAntiFirefly (on here, as the brief asks)
  bool fastHistoryClamp = true;    // NRD HistoryFix: the recurrent history clamped to the fast one
  bool blur = true, postBlur = true;
  float minBlurRadius = 1.0f;   // NRD minBlurRadius 1
  float maxBlurRadius = 30.0f;  // NRD maxBlurRadius 30
  bool recurrent = true;        // the post-blurred result is the history (the "R" of ReBLUR)
  bool stabilization = true;
  bool antiLag = true;
  float antilagSigmaScale = 2.0f;  // NRD antilag sigmaScale 2
  // The radii and the stride above, minBlurRadius included, follow the one footprint policy of
  // every denoiser (footprint.hpp): pixels as given (native) or pixels at a reference height.
  Footprint footprint;
};

std::vector<ParamSpec> reblurParamSpecs();
ReblurSettings reblurSettings(const ParamSet& params);

class Reblur : public Denoiser {
 public:
  Reblur(const ReblurSettings& settings, SignalKind kind);
  std::vector<std::string> requiredChannels() const override;
  void setup(int width, int height) override;
  void reset() override;
  void denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) override;

  // Every pass's output of the last frame, in pipeline order (for tests and debugging).
  std::vector<std::pair<std::string, const Image*>> passOutputs() const;

 private:
  void reproject(const FrameContext& ctx);
  void preBlurPass(const DenoiserInputs& in, int frameIndex);
  void reprojectVirtual(const FrameContext& ctx);
  void temporalAccumulation();
  void historyFixPass();
  void antiFireflyPass();
  void blurPasses(int frameIndex);
  void storeRecurrentHistory();
  void stabilize(Image& output);
  void storeHistory();

  // History of pixel i from one plane of a previous-frame image: surface motion, or for the
  // specular signal a roughness-weighted blend with the hit-point reprojection.
  // Eight consecutive pixels' history, their taps decoded once and read from several planes: the
  // surface taps, and for the specular signal the hit-point taps, blended by virtualAmount_ where
  // both are valid; 0 where neither is.
  struct HistoryBlock {
    HistoryLanes surface, hitPoint;
    Lanes8 hitPointAmount{};
    LaneMask8 valid() const { return surface.valid | hitPoint.valid; }
    Lanes8 apply(const float* plane) const {
      const Lanes8 fromSurface = surface.apply(plane);
      if (!anyLane(hitPoint.valid)) return fromSurface;
      const Lanes8 fromHitPoint = hitPoint.apply(plane);
      const Lanes8 both = hitPointAmount * fromHitPoint + (1.0f - hitPointAmount) * fromSurface;
      return selectFloat(hitPoint.valid, selectFloat(surface.valid, both, fromHitPoint),
                         fromSurface);
    }
  };
  // Pixels i .. i + count - 1 (count <= 8).
  HistoryBlock history(size_t i, int count) const;

  ReblurSettings s_;
  SignalKind kind_;
  float pixelScale_ = 1.0f;  // footprint.hpp: pixels per published pixel
  GBufferView gbuffer_;
  const float* roughness_ = nullptr;
  const float* hitDistance_ = nullptr;
  Image derivatives_;
  Reprojection surface_;
  HitPointReprojection virtual_;
  bool useVirtual_ = false;
  Image virtualAmount_;  // per pixel: weight of the hit-point history (specular)
  GBufferHistory previousGBuffer_;
  MipChain mips_;
  bool hasHistory_ = false;
  // History (persistent).
  Image slowHistory_, fastHistory_, accumulatedFramesHistory_, stabilizedHistory_;
  // Per frame.
  Image preBlurred_, temporal_, fast_, accumulatedFrames_, previousFrames_, fixed_, fireflyFree_,
      blurred_, postBlurred_, radiusScale_, stabilized_;
  Image preBlurIn_, preBlurOut_, blurredHitDistance_;  // specular pre-blur with the hit distance
  const Image* historyFixed_ = &temporal_;  // the history fix's result: fixed_, or temporal_
  RowTapCounter youngPerRow_;               // the history fix's young pixels, counted per row
};

}  // namespace arena
