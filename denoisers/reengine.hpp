#pragma once
// CAPCOM RE ENGINE's 2023 ray-tracing denoiser ("Advances in Ray Tracing", CAPCOM Open Conference
// Professional RE:2023, seed 004): the pipeline is in reengine.cpp, top to bottom, in the talk's
// order; this header exposes the class so tests can look at every stage's output.
#include <string>
#include <utility>
#include <vector>

#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/hit_point_reprojection.hpp"
#include "denoisers/common/lowres_upsample.hpp"
#include "denoisers/common/mip_chain.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/poisson_blur.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/denoiser.hpp"

namespace arena {

struct ReEngineSettings {
  ReprojectionSettings reprojection;
  HitPointReprojectionSettings hitPoint;
  bool reinhard = false;  // filter space: linear (the talk's fix) or Reinhard (their old path)
  // Geometry weights of every propagation (plane distance, normal; + hit distance and roughness
  // for the specular signal).
  SurfaceWeightSettings weights;
  // 1. Spatial propagation (before the temporal filter).
  bool propagation1 = true;
  float propagationRadius = 16.0f;  // pixels at h = 1, shrinking as 1/sqrt(h) (ours)
  float minRadius = 1.0f;           // pixels (ours)
  // 2. Temporal filter.
  int maxHistory = 32;  // h cap, alpha = 1/h (ours; Falcor 32)
  bool lumaRejection = true;
  float rejectionTau = 0.5f;   // relative luminance gap tolerated (ours)
  float oneFrameAlpha = 0.5f;  // weight of the new frame in the stabilised one-frame EMA (ours)
  float roughnessThreshold = 0.3f;  // slide 30: "例えば0.3"
  bool roughAsDiffuse = true;       // slides 30-31: rough specular takes the diffuse policy
  enum class SpecularMotion { Geometry, Virtual, Merge };
  SpecularMotion specularMotion = SpecularMotion::Merge;  // slide 34
  float mergeSigma = 1.0f;  // moment-based merge: candidate weight exp(-d^2/2 mergeSigma^2) (ours)
  bool specularColorClamp = true;  // slide 34: specular clamps the colour
  float clampGamma = 1.5f;         // box half-width in sigma (ours; Salvi 1..2)
  // 3. Spatial propagation (after the temporal filter; its result is the history).
  bool propagation2 = true;
  float propagation2Radius = 8.0f;  // pixels at h = 1 (ours)
  // 4. Variance check.
  bool varianceCheck = true;
  float varianceTarget = 0.25f;  // relative noise of the mean that asks for the large scale (ours)
  // 5. Spatial merge of a small and a large scale.
  bool spatialMerge = true;
  int mergeLevels = 3;       // large scale: mip level 3 = 8x8 (ours)
  float mergeWeight = 0.5f;  // large-scale share where the variance check is off (ours)
  // 6. Deflicker.
  bool deflicker = true;
  float deflickerAlpha = 0.5f;  // new-frame weight of the deflicker EMA (ours)
  float deflickerGamma = 1.0f;  // its 3x3 clamp box in sigma (ours)
  // 7. Spatial upscaling of the disocclusion rays (slides 19-21).
  enum class DisocclusionRays { Auto, On, Off };
  DisocclusionRays rays = DisocclusionRays::Auto;
  int lowresMaxHistory = 4;    // read the low-resolution buffer where h < this (ours)
  float lowresWeight = 0.9f;   // its blend weight at h = 1, falling linearly to 0 (ours)
  bool lowresFeedback = true;  // the blended value enters the history (ours)
  LowresUpsampleSettings upsample;
  // 8. Spatial filter.
  bool spatialFilter = true;
  float sigmaL = 4.0f;  // luminance term (SVGF 4)
};

std::vector<ParamSpec> reEngineParamSpecs();
ReEngineSettings reEngineSettings(const ParamSet& params);

class ReEngine : public Denoiser {
 public:
  ReEngine(const ReEngineSettings& settings, SignalKind kind);
  std::vector<std::string> requiredChannels() const override;
  bool wantsLowres() const override { return s_.rays != ReEngineSettings::DisocclusionRays::Off; }
  void setup(int width, int height) override;
  void reset() override;
  void denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) override;

  std::vector<std::pair<std::string, const Image*>> passOutputs() const;
  double lastRaysPerPixel() const { return raysPerPixel_; }

 private:
  void toFilterSpace(const Image& signal);
  void reproject(const FrameContext& ctx);
  void spatialPropagation1(const FrameContext& ctx);
  void temporalFilter();
  void spatialPropagation2(const FrameContext& ctx);
  void varianceCheck();
  void spatialMerge();
  void deflicker();
  void spatialUpscaling(const LowresInputs* lowres);
  void spatialFilter();
  void fromFilterSpace(Image& output);
  void storeHistory();

  bool diffuseLike(size_t i) const;  // diffuse, or rough specular under the roughness policy
  bool needsMoments() const;
  // A previous-frame plane read through pixel i's history source (geometry and/or virtual
  // motion, merged with share_[i]); 0 where there is none.
  float historyAt(size_t i, const float* plane) const;

  ReEngineSettings s_;
  SignalKind kind_;
  GBufferView gbuffer_;
  const float* roughness_ = nullptr;
  const float* hitDistance_ = nullptr;
  Image derivatives_;
  Reprojection surface_;
  HitPointReprojection virtual_;
  bool useVirtual_ = false;
  GBufferHistory previousGBuffer_;
  MipChain mips_;
  LowresUpsampler upsampler_;
  int upsamplerFactor_ = 0;
  bool hasHistory_ = false;
  double raysPerPixel_ = 0;
  int width_ = 0, height_ = 0;
  // History (persistent).
  Image colorHistory_, lengthHistory_, momentsHistory_, oneFrameHistory_, deflickerHistory_;
  // Per frame.
  Image signal_, share_, valid_, radius_, momentInput_, propagated_, oneFrame_, temporal_,
      historyLength_, moments_, propagated2_, noise_, lumVariance_, filteredVariance_, large_,
      merged_, fireflyClamped_, reprojectedDeflicker_, deflickered_, need_, upscaled_, confidence_,
      lowWeight_, upscaledBlend_, final_;
  RowTapCounter taps_;
};

}  // namespace arena
