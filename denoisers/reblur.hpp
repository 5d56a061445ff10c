#pragma once
// ReBLUR, recurrent blur (Zhdan, "Fast Denoising with Self Stabilizing Recurrent Blurs", GTC
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
#include "denoisers/param_table.hpp"

namespace arena {

enum class ReblurHistoryFix { Off, Sparse, Mip };
// The history-fix grid: NRD v4's 20 taps at stride / (2 + N), or all 24 at stride (F - N) / F.
enum class HistoryFixShape { Nrd, Ours };
// The blur radius scale: NRD's 1 / (1 + N_prev), or sqrt(1 / (1 + N)) of the incremented counter.
enum class RadiusFalloff { Nrd, Sqrt };
// The fast-history clamp's blend back to the unclamped value: NRD's 1 / (1 + 2 N_prev), or the
// first version's 1 / (1 + N_prev).
enum class FastHistoryBlend { Nrd, Ours };
// Where the stabiliser's clamp box comes from: this frame's post-blurred result (NRD
// TemporalStabilization) or the fast history (the first version).
enum class StabilizationBox { Current, Fast };

// Every field named after its parameter is set from reblurParams() (reblur.cpp), which declares
// its default, range and meaning once (NRD's ReblurSettings names in the meanings).
struct ReblurSettings {
  ReprojectionSettings reprojection;
  HitPointReprojectionSettings hitPointTests;  // the virtual reprojection's consistency tests
  SurfaceWeightSettings weights;  // plane distance, normal (+ hit distance, roughness: specular)
  bool preBlur;
  float preBlurRadius, specularPreBlurRadius;
  int maxAccumulatedFrames, maxFastAccumulatedFrames;
  bool hitPoint;  // specular only: hit-point (virtual) reprojection
  // The specular hit distance the guides read (parameter "hitDistance"): the 1-spp sample's
  // ("specHitDist", what a real tracer has) or the noise-free mirror ray's oracle
  // ("specHitDistMirror").
  std::string hitDistanceChannel;
  bool hitDistancePreBlur;  // NRD pre-pass: the hit distance blurred with the radiance
  float hitPointRoughness;  // virtual amount = 1 - smoothstep(0, this, roughness)
  ReblurHistoryFix historyFix;
  int historyFixFrames;
  float historyFixStride;
  HistoryFixShape historyFixShape;
  RadiusFalloff radiusFalloff;
  bool antiFirefly;
  bool fastHistoryClamp;  // NRD HistoryFix: the recurrent history clamped to the fast one
  FastHistoryBlend fastHistoryBlend;
  bool blur, postBlur;
  float minBlurRadius, maxBlurRadius;
  bool recurrent;  // the post-blurred result is the history (the "R" of ReBLUR)
  bool stabilization, antiLag;
  float antilagSigmaScale;
  StabilizationBox stabilizationBox;
  // The radii and the stride above, minBlurRadius included, follow the one footprint policy of
  // every denoiser (footprint.hpp): pixels as given (native) or pixels at a reference height.
  Footprint footprint;
};

// ReBLUR's parameters, each bound to its field.
const ParamTable<ReblurSettings>& reblurParams();

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
