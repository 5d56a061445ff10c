#pragma once
// The CEDEC 2021 talk's own denoiser (Silicon Studio, Kawaguchi:
// "リアルタイムレイトレーシング時代を 生き抜くためのデノイザー開発入門", seed 000, section 5.1),
// with the CAPCOM RE ENGINE ablations (seed 004). The pipeline is in hybrid.cpp, top to bottom;
// this header exposes the class so tests can look at every pass's output.
#include <string>
#include <utility>
#include <vector>

#include "denoisers/common/atrous.hpp"
#include "denoisers/common/filter_space.hpp"
#include "denoisers/common/footprint.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/history_clamp.hpp"
#include "denoisers/common/hit_point_reprojection.hpp"
#include "denoisers/common/mip_chain.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/common/specular_lobe.hpp"
#include "denoisers/denoiser.hpp"
#include "denoisers/param_table.hpp"

namespace arena {

// The clip box's moments: the pre-spatial 3x3's own (the talk's literal design), or with the
// pre-spatial mean and second moment averaged over mip level clipMipLevel of the talk's optional
// mip chain (2^level px blocks, bilaterally upsampled): enough 1-spp samples that the box
// estimates the local distribution (see hybrid.cpp): centre and sigma both from the mip.
enum class ClipSupport { Box3x3, Mip };
// Where the luminance threshold fires, in units of the local luminance sigma (default) or relative
// to the larger luminance (the first version here; fires on noise alone for sparse 1-spp signals).
enum class LumaMode { Sigma, Relative };
// The post-spatial luminance term: the variance propagated through the à-trous (SVGF §4.3) or the
// temporal variance at every iteration.
enum class PostVariance { Propagate, Fixed };
// The signals the post median runs on (the talk: an option against specular fireflies).
enum class MedianSignals { Specular, Both };

// Every field named after its parameter ("edge.position" -> edgePosition) is set from
// hybridParams() (hybrid.cpp), which declares its default, range and meaning once.
struct HybridSettings {
  ReprojectionSettings reprojection;
  HitPointReprojectionSettings hitPointTests;  // the hit-point reprojection's consistency tests
  SpecularLobeSettings lobe;                   // lobe.diffuseSharpness: "lobeDiffuseSharpness"
  // Edge-stopping (the talk: "3D座標 + Specular Lobe + ID + 輝度").
  bool edgePosition, edgeLobe, edgeLuminance, edgeId;
  float sigmaX;    // world units^2
  float lobeBeta;  // exponent on the SG similarity (the talk's beta; 1 = Tokuyoshi's)
  float sigmaL;    // luminance term
  // 2. Disocclusion.
  bool maskBlur;
  // 3. Pre-spatial.
  bool preMip;
  int preMipLevels;
  // 4. Temporal.
  bool hitPoint;  // specular: hit-point reprojection below hitPointRoughness
  // The specular hit distance read (parameter "hitDistance"): the 1-spp sample's ("specHitDist")
  // or the mirror oracle's ("specHitDistMirror").
  std::string hitDistanceChannel;
  float hitPointRoughness;
  int maxHistory;
  bool disocclusionFill;
  bool varianceClip;
  ClipSupport clipSupport;
  int clipMipLevel;
  HistoryClampMode clipMode;
  float clipGamma;  // box half-width in sigma
  bool lumaThreshold;
  LumaMode lumaMode;
  float lumaSigma, lumaTau;
  bool capcomRejection;
  float capcomTau;
  // 5. Post-spatial.
  int postIterations;
  PostVariance postVariance;
  bool median;
  MedianSignals medianSignals;
  bool medianEdgeAware;  // ours: never across meshes or creases (thin features survive)
  bool postMip;
  int postMipLevels;
  // 6. Stabiliser.
  bool stabilizer;
  float stabilizerAlpha;
  FilterSpace space;    // CAPCOM: Reinhard-compressed instead of linear
  Footprint footprint;  // footprint.hpp: the à-trous steps at this resolution
};

// The talk's parameters and the CAPCOM ablations, each bound to its field.
const ParamTable<HybridSettings>& hybridParams();

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
