#pragma once
// CAPCOM RE ENGINE's 2023 ray-tracing denoiser ("Advances in Ray Tracing", CAPCOM Open Conference
// Professional RE:2023, seed 004): the pipeline is in reengine.cpp, top to bottom, in the talk's
// order; this header exposes the class so tests can look at every stage's output.
#include <string>
#include <utility>
#include <vector>

#include "denoisers/common/filter_space.hpp"
#include "denoisers/common/footprint.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/common/hit_point_reprojection.hpp"
#include "denoisers/common/lowres_upsample.hpp"
#include "denoisers/common/mip_chain.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/common/poisson_blur.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/denoiser.hpp"
#include "denoisers/param_table.hpp"

namespace arena {

// Every field named after its parameter is set from reEngineParams() (reengine.cpp), which
// declares its default, range and meaning once (with the slide it comes from).
struct ReEngineSettings {
  ReprojectionSettings reprojection;
  HitPointReprojectionSettings hitPointTests;  // the virtual motion's consistency tests
  FilterSpace space;  // linear (the talk's fix) or Reinhard (their old path)
  // Geometry weights of every propagation (plane distance, normal; + hit distance and roughness
  // for the specular signal).
  SurfaceWeightSettings weights;
  // footprint.hpp: the propagation radii and the merge's mip level at this resolution.
  Footprint footprint;
  // 1. Spatial propagation (before the temporal filter).
  bool propagation1;
  float propagationRadius;  // pixels (at footprintHeight) at h = 1, shrinking as 1/sqrt(h)
  float minRadius;          // pixels (at footprintHeight)
  // 2. Temporal filter.
  int maxHistory;  // h cap, alpha = 1/h
  bool lumaRejection;
  enum class RejectionMode { Sigma, Relative };
  RejectionMode rejectionMode;  // the gap in standard errors (default) or relative (first version)
  float rejectionSigma;         // sigma mode: standard errors tolerated
  float rejectionTau;           // relative mode: relative luminance gap tolerated
  float oneFrameAlpha;       // weight of the new frame in the stabilised one-frame EMA
  float roughnessThreshold;  // slide 30: "例えば0.3"
  bool roughAsDiffuse;       // slides 30-31: rough specular takes the diffuse policy
  enum class SpecularMotion { Geometry, Virtual, Merge };
  SpecularMotion specularMotion;  // slide 34
  float mergeSigma;               // moment-based merge: candidate weight exp(-d^2/2 mergeSigma^2)
  bool specularColorClamp;        // slide 34: specular clamps the colour
  float clampGamma;               // box half-width in sigma
  // 3. Spatial propagation (after the temporal filter; its result is the history).
  bool propagation2;
  float propagation2Radius;  // pixels (at footprintHeight) at h = 1
  // 4. Variance check.
  bool varianceCheck;
  float varianceTarget;  // relative noise of the mean that asks for the large scale
  // 5. Spatial merge of a small and a large scale.
  bool spatialMerge;
  int mergeLevels;    // large scale: mip level (at footprintHeight)
  float mergeWeight;  // large-scale share where the variance check is off
  // 6. Deflicker.
  bool deflicker;
  float deflickerAlpha;  // new-frame weight of the deflicker EMA
  float deflickerGamma;  // its 3x3 clamp box in sigma
  bool deflickerEdgeAware;  // firefly clamp: only same-mesh neighbours of a similar normal
  // 7. Spatial upscaling of the disocclusion rays (slides 19-21).
  enum class DisocclusionRays { Auto, On, Off };
  DisocclusionRays disocclusionRays;
  int lowresMaxHistory;             // read the low-resolution buffer where h < this
  float lowresWeight;               // its blend weight at h = 1, falling linearly to 0
  bool lowresFeedback;              // the blended value enters the history
  LowresUpsampleSettings upsample;  // "directionalUpscale", "momentClamp"
  // 8. Spatial filter.
  bool spatialFilter;
  float sigmaL;  // luminance term
};

// RE ENGINE's parameters, each bound to its field.
const ParamTable<ReEngineSettings>& reEngineParams();

class ReEngine : public Denoiser {
 public:
  ReEngine(const ReEngineSettings& settings, SignalKind kind);
  std::vector<std::string> requiredChannels() const override;
  bool wantsLowres() const override {
    return s_.disocclusionRays != ReEngineSettings::DisocclusionRays::Off;
  }
  bool needsLowres() const override {
    return s_.disocclusionRays == ReEngineSettings::DisocclusionRays::On;
  }
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

  bool sameSurface3x3(size_t p, size_t q) const;
  bool diffuseLike(size_t i) const;  // diffuse, or rough specular under the roughness policy
  // Samples averaged into a pixel's mean each frame: pass 1's distinct pixels (propagation on),
  // else 1.
  float samplesPerFrame(size_t i) const;
  // The 1-spp luminance variance around pixel i, E[l^2] - E[l]^2 over the noise statistics'
  // gather (channels' covariance kept).
  float spatialLumaVariance(size_t i) const;
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
  float footprintScale_ = 1.0f;  // footprint.hpp: pixels per published pixel
  int mergeLevel_ = 0;           // the large scale's mip level at this resolution
  bool hasHistory_ = false;
  double raysPerPixel_ = 0;
  int width_ = 0, height_ = 0;
  // History (persistent).
  Image colorHistory_, lengthHistory_, momentsHistory_, oneFrameHistory_, deflickerHistory_;
  // Per frame.
  Image signal_, share_, valid_, radius_, momentInput_, propagated_, oneFrame_, temporal_,
      historyLength_, rejection_, gatherCount_, noiseRadius_, noiseMoments_, moments_, propagated2_, noise_, lumVariance_, filteredVariance_, large_,
      merged_, fireflyClamped_, reprojectedDeflicker_, deflickered_, need_, upscaled_, confidence_,
      lowWeight_, upscaledBlend_, final_;
  RowTapCounter taps_;
};

}  // namespace arena
