// `svgf`: Spatiotemporal Variance-Guided Filtering (Schied et al. 2017; seed 003). Per frame:
//   1. reproject the history with per-tap depth/normal/mesh-id tests (§4.1),
//   2. accumulate colour and luminance moments with an exponential moving average (§4.1, §4.2),
//   3. estimate the luminance variance: temporal from the moments, spatial 7x7 while h < 4 (§4.2);
//      there the colour too becomes the 7x7 bilateral mean (Falcor; `youngColor`),
//   4. run N à-trous iterations guided by depth, normal and variance-scaled luminance, propagating
//      the variance (§4.3, §4.4); the output of iteration `feedbackTap` becomes the colour history.
// Re-modulation by albedo is the harness's; the paper's final TAA is not part of SVGF proper.
#include "denoisers/svgf.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/variants.hpp"

namespace arena {

Svgf::Svgf(const SvgfSettings& settings, std::string name)
    : settings_(settings), name_(std::move(name)) {}

std::vector<std::string> Svgf::requiredChannels() const {
  // position: the depth test of reprojection accounts for camera motion with it.
  return {"depth", "normal", "meshId", "motion", "position"};
}

void Svgf::setup(int width, int height) {
  settings_.atrous.footprintScale = settings_.footprint.scale(height);
  derivatives_ = Image(width, height, kGeometryDerivativeChannels);
  reprojection_.setup(width, height);
  previousGBuffer_.setup(width, height);
  colorHistory_ = Image(width, height, 3);
  momentsHistory_ = Image(width, height, 2);
  previousHistoryLength_ = Image(width, height, 1);
  accumulated_ = Image(width, height, 3);
  moments_ = Image(width, height, 2);
  historyLength_ = Image(width, height, 1);
  variance_ = Image(width, height, 1);
  filteredVariance_ = Image(width, height, 1);
  youngColorMean_ = settings_.youngColor == YoungColor::Spatial ? Image(width, height, 3) : Image();
  for (Image& image : colorPingPong_) image = Image(width, height, 3);
  for (Image& image : variancePingPong_) image = Image(width, height, 1);
  varianceTaps_.setup(height);
  hasHistory_ = false;
}

void Svgf::reset() {
  hasHistory_ = false;
}

void Svgf::denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) {
  if (ctx.reset) reset();
  gbuffer_ = GBufferView::fromFrame(in.frame, requiredChannels(), name_);
  computeDerivatives();
  reproject(ctx);
  const AdaptiveAlpha alpha = adaptiveAlpha(ctx, in);
  accumulate(in, alpha);
  correctAccumulation(ctx, in, alpha.floor);
  estimateVariance();
  filterWavelet(output);
  storeHistory();
}

void Svgf::computeDerivatives() {
  ScopedPass pass(this, "derivatives", 4);
  computeGeometryDerivatives(gbuffer_, derivatives_);
}

void Svgf::reproject(const FrameContext& ctx) {
  ScopedPass pass(this, "reproject", 4);
  if (hasHistory_) {
    reprojection_.compute(gbuffer_, derivatives_, previousGBuffer_.view(), settings_.reprojection,
                          &ctx.camera, &ctx.previousCamera);
  } else {
    reprojection_.invalidateAll();  // first frame or camera cut: every pixel starts over
  }
  pass.setTaps(reprojection_.testedTapsPerPixel());
}

void Svgf::accumulate(const DenoiserInputs& in, const AdaptiveAlpha& alpha) {
  // Colour, moments and history length are resampled by the same reprojection decision.
  ScopedPass pass(this, "temporal accumulation", 3 * reprojection_.readTapsPerPixel());
  // One sweep for the three (updateHistoryLength, accumulateTemporally, accumulateMoments).
  accumulateColorAndMoments(
      reprojection_, previousHistoryLength_, settings_.maxHistory, in.signal, colorHistory_,
      momentsHistory_, {settings_.alpha, alpha.floor, alpha.antilag},
      {settings_.momentsAlpha, alpha.floor, alpha.antilag}, historyLength_, accumulated_, moments_);
}

void Svgf::estimateVariance() {
  ScopedPass pass(this, "variance", 0);
  Image* youngColor = settings_.youngColor == YoungColor::Spatial ? &youngColorMean_ : nullptr;
  pass.setTaps(arena::estimateVariance(moments_, historyLength_, accumulated_, gbuffer_,
                                       derivatives_, settings_.variance, variance_, varianceTaps_,
                                       youngColor));
  // Falcor's SVGFFilterMoments hands the à-trous the filtered colour of a young history (and so,
  // through the feedback tap, the next frame's history).
  if (youngColor)
    replaceYoungColor(*youngColor, historyLength_, gbuffer_, settings_.variance, accumulated_);
}

void Svgf::filterWavelet(Image& output) {
  const int iterations = settings_.iterations;
  if (settings_.feedbackTap == 0) {
    ScopedPass pass(this, "feedback", 0);
    parallelCopy(accumulated_, colorHistory_);
  }
  if (iterations == 0) {
    parallelCopy(accumulated_, output);
    return;
  }
  const AtrousGuide guide{gbuffer_, &derivatives_, &filteredVariance_};
  const Image* color = &accumulated_;
  const Image* variance = &variance_;
  for (int i = 0; i < iterations; ++i) {
    const std::string iteration = std::to_string(i + 1);
    if (settings_.atrous.edges.luminance) {
      // §4.4: the luminance weight reads a 3x3-Gaussian-blurred variance; the variance passed on
      // to the next iteration stays unblurred.
      ScopedPass pass(this, "variance prefilter " + iteration, 9);
      prefilterVariance3x3(*variance, gbuffer_, filteredVariance_);
    }
    ScopedPass pass(this, "atrous " + iteration, atrousIterationTaps(i, settings_.atrous));
    Image& colorOut = i + 1 == iterations ? output : colorPingPong_[size_t(i % 2)];
    Image& varianceOut = variancePingPong_[size_t(i % 2)];
    atrousIteration(i, settings_.atrous, guide, settings_.atrous.edges.sigmaColor, *color, colorOut,
                    variance, &varianceOut);
    if (i + 1 == settings_.feedbackTap)  // §4.3: this iteration's output is the colour history
      parallelCopy(colorOut, colorHistory_);
    color = &colorOut;
    variance = &varianceOut;
  }
}

void Svgf::storeHistory() {
  ScopedPass pass(this, "store history", 0);
  previousGBuffer_.store(gbuffer_);
  std::swap(moments_, momentsHistory_);
  std::swap(historyLength_, previousHistoryLength_);
  hasHistory_ = true;
}

const ParamTable<SvgfSettings>& svgfParams() {
  using S = SvgfSettings;
  using E = EdgeStoppingSettings;
  auto edge = [](auto field) { return member(&S::atrous, &AtrousSettings::edges, field); };
  static const ParamTable<S> table =
      ParamTable<S>()
          .integer("iterations", &S::iterations, 5, 0, 10,
                   "à-trous iterations (SVGF paper 5, about 65x65 px; Falcor 4)")
          .include(atrousKernelParams(), &S::atrous)
          .real("alpha", &S::alpha, 0.2, 0.0, 1.0,
                "colour blend floor, alpha = max(alpha, 1/h) (SVGF paper 0.2; Falcor 0.05)")
          .real("momentsAlpha", &S::momentsAlpha, 0.2, 0.0, 1.0,
                "moments blend floor (SVGF paper and Falcor 0.2)")
          .integer("maxHistory", &S::maxHistory, 32, 1, 4096,
                   "history length cap; bounds 1/h from below (Falcor 32; with alpha 0.2 only "
                   "h < 5 matters)")
          .integer("feedbackTap", &S::feedbackTap, 1, 0, 10,
                   "à-trous iteration (1-based) whose output is next frame's colour history; 0 = "
                   "the accumulated colour (SVGF paper: 1, the first; Falcor's 0-based "
                   "mFeedbackTap = 1 is its second iteration, 2 here)")
          .choice("youngColor", &S::youngColor, "accumulated",
                  {{"spatial", YoungColor::Spatial}, {"accumulated", YoungColor::Accumulated}},
                  "colour of a pixel with h < 4 entering the à-trous: the 7x7 bilateral mean of "
                  "the variance estimate (Falcor SVGFFilterMoments) or the accumulated colour "
                  "(the SVGF paper estimates only the variance)")
          .real("sigmaZ", edge(&E::sigmaZ), 1.0, 0.0, 1e6,
                "depth stopping sigma_z, SVGF eq. 3 (paper 1)")
          .real("sigmaN", edge(&E::sigmaN), 128.0, 0.0, 1e4,
                "normal stopping exponent sigma_n, SVGF eq. 4 (paper and Falcor 128)")
          .real("sigmaL", edge(&E::sigmaL), 4.0, 0.0, 1e6,
                "luminance stopping sigma_l, SVGF eq. 5 (paper 4; Falcor phiColor 10)")
          .real("sigmaX", edge(&E::sigmaX), 0.05, 1e-9, 1e9,
                "position stopping sigma_x, exp(-|x(p)-x(q)|^2/sigma_x), world units squared "
                "(ours; used with edge.position)")
          .boolean("edge.depth", edge(&E::depth), true, "depth stopping term (SVGF eq. 3)")
          .boolean("edge.normal", edge(&E::normal), true, "normal stopping term (SVGF eq. 4)")
          .boolean("edge.luminance", edge(&E::luminance), true,
                   "variance-scaled luminance term (SVGF eq. 5)")
          .boolean("edge.id", edge(&E::id), false,
                   "mesh-id term: never filter across meshes (the talk; separates a poster from "
                   "the coplanar wall)")
          .boolean("edge.position", edge(&E::position), false,
                   "world-position term (Dammertz 2010)")
          .include(reprojectionParams(), &S::reprojection)
          .include(footprintParams(), &S::footprint)
          .fixed([](S& s) {
            s.atrous.edges.normalForm = NormalWeightForm::CosinePower;  // SVGF eq. 4
            s.atrous.edges.color = false;
          })
          .check([](const S& s, const std::string& owner) {
            if (s.feedbackTap > s.iterations)
              throw Error(owner + ".feedbackTap=" + std::to_string(s.feedbackTap) + " exceeds " +
                          owner + ".iterations=" + std::to_string(s.iterations) +
                          "; use a feedbackTap in [0, iterations] (0 = no spatial feedback)");
          });
  return table;
}

DenoiserInfo svgfInfo() {
  return {"svgf",
          "Spatiotemporal variance-guided filtering: reprojected accumulation, variance, "
          "variance-guided à-trous (Schied et al. 2017)",
          svgfParams().schema(), [](const ParamSet& params, SignalKind) {
            return std::make_unique<Svgf>(svgfParams().settings(params, "svgf"));
          }};
}

}  // namespace arena
