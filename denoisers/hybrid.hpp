#pragma once
// The CEDEC 2021 talk's own denoiser (Silicon Studio, Kawaguchi:
// "リアルタイムレイトレーシング時代を 生き抜くためのデノイザー開発入門", seed 000, section 5.1),
// with the CAPCOM RE ENGINE ablations (seed 004). The pipeline is in hybrid.cpp, top to bottom;
// this header exposes the class so tests can look at every pass's output.
#include <string>
#include <utility>
#include <vector>

#include "denoisers/common/atrous.hpp"
#include "denoisers/common/footprint.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/history_clamp.hpp"
#include "denoisers/common/hit_point_reprojection.hpp"
#include "denoisers/common/mip_chain.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/common/specular_lobe.hpp"
#include "denoisers/denoiser.hpp"

namespace arena {

struct HybridSettings {
  ReprojectionSettings reprojection;
  HitPointReprojectionSettings hitPoint;
  SpecularLobeSettings lobe;
  // Edge-stopping (the talk: "3D座標 + Specular Lobe + ID + 輝度").
  bool edgePosition = true, edgeLobe = true, edgeLuminance = true, edgeId = true;
  float sigmaX = 0.05f;   // world units^2 (ours)
  float lobeBeta = 1.0f;  // exponent on the SG similarity (the talk's beta; 1 = Tokuyoshi's)
  float sigmaL = 4.0f;    // luminance term (SVGF's 4)
  // 2. Disocclusion.
  bool maskBlur = true;
  // 3. Pre-spatial.
  bool preMip = false;
  int preMipLevels = 2;
  // 4. Temporal.
  bool hitPointReprojection = true;
  // The specular hit distance read: the 1-spp sample's ("specHitDist") or the mirror oracle's
  // ("specHitDistMirror").
  std::string hitDistanceChannel = "specHitDist";
  float hitPointRoughness = 0.3f;  // specular: hit-point reprojection below this roughness (ours)
  int maxHistory = 24;             // the talk: h capped at 24-30
  bool disocclusionFill = true;
  bool varianceClip = true;
  // The clip box's moments: the pre-spatial 3x3's own (the talk's literal design), or with the
  // pre-spatial mean and second moment averaged over mip level clipMipLevel of the talk's optional
  // mip chain (2^level px blocks, bilaterally upsampled): enough 1-spp samples that the box
  // estimates the local distribution (see hybrid.cpp): centre and sigma both from the mip.
  bool clipMip = false;
  int clipMipLevel = 2;
  HistoryClampMode clipMode = HistoryClampMode::Clip;
  float clipGamma = 1.5f;  // box half-width in sigma (ours; Salvi: 1..2)
  bool lumaThreshold = true;
  // Where the threshold fires, in units of the local luminance sigma (default) or relative to the
  // larger luminance (the first version here; fires on noise alone for sparse 1-spp signals).
  bool lumaRelative = false;
  float lumaSigma = 2.0f;  // ours: sigma units (see hybrid.cpp)
  float lumaTau = 0.8f;    // relative (ours)
  bool capcomRejection = false;
  float capcomTau = 0.5f;  // relative (ours)
  // 5. Post-spatial.
  int postIterations = 3;
  bool propagateVariance = true;  // SVGF §4.3 through the post à-trous
  bool median = true;
  bool medianBothSignals = false;  // the talk: an option against specular fireflies
  bool medianEdgeAware = true;     // ours: never across meshes or creases (thin features survive)
  bool postMip = false;
  int postMipLevels = 2;
  // 6. Stabiliser.
  bool stabilizer = false;
  float stabilizerAlpha = 0.5f;
  // CAPCOM: filter in Reinhard-compressed space instead of linear.
  bool reinhard = false;
  Footprint footprint;  // footprint.hpp: the à-trous steps at this resolution
};

std::vector<ParamSpec> hybridParamSpecs();
HybridSettings hybridSettings(const ParamSet& params);

class Hybrid : public Denoiser {
 public:
  Hybrid(const HybridSettings& settings, SignalKind kind);
  std::vector<std::string> requiredChannels() const override;
  void setup(int width, int height) override;
  void reset() override;
  void denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) override;

  std::vector<std::pair<std::string, const Image*>> passOutputs() const;
  // The history length h of the last frame (1 where it was disoccluded or the threshold fired).
  const Image& lastHistoryLength() const { return lengthHistory_; }
  // Of the last frame: the luminance variance of the temporal stage (the post à-trous' first
  // input) and the one the last post à-trous iteration's luminance term read (propagated).
  const Image& lastVariance() const { return variance_; }
  const Image& lastPostVariance() const {
    return lastPostVariance_ < 0 ? variance_ : variancePingPong_[size_t(lastPostVariance_)];
  }

 private:
  void toFilterSpace(const Image& signal);
  void metadata(const FrameContext& ctx);
  void disocclusion(const FrameContext& ctx);
  void preSpatial();
  void clipMoments();
  void temporal();
  void postSpatial();
  void stabilize();
  void fromFilterSpace(Image& output);
  void storeHistory();

  // 0 disoccluded, 1 surface motion, 2 hit point.
  int historySource(size_t i) const;
  float historySample(size_t i, const float* plane) const;
  bool usesPreSpatial() const;
  bool usesMedian() const;

  HybridSettings s_;
  SignalKind kind_;
  float footprintScale_ = 1.0f;
  GBufferView gbuffer_;
  const float* roughness_ = nullptr;
  const float* hitDistance_ = nullptr;
  Image derivatives_, lobes_;
  Reprojection surface_;
  HitPointReprojection virtual_;
  bool useVirtual_ = false;
  GBufferHistory previousGBuffer_;
  MipChain preMips_, postMips_, clipMips_;
  bool hasHistory_ = false;
  // History (persistent).
  Image colorHistory_, lengthHistory_, momentsHistory_, oneFrameHistory_, stabilizerHistory_;
  // Per frame.
  // preSquared_/preMoments_: r^2, g^2, b^2 and the luminance's own l^2 (its variance keeps the
  // channels' covariance).
  // clipBase_/clipWide_: the pre-spatial r, g, b, r^2, g^2, b^2 and their mip-averaged upsample.
  Image preSquared_, clipBase_, clipWide_;
  Image signal_, mask_, blurredMask_, historyLength_, preSpatial_, preMoments_, preWide_, levels_,
      temporal_, moments_, variance_, filteredVariance_, variancePingPong_[2], oneFrame_, median_,
      atrous_[3], post_, reprojectedStabilizer_, stabilized_;
  RowTapCounter taps_;
  int lastPostVariance_ = -1;  // -1: variance_, else the variancePingPong_ index
};

}  // namespace arena
