// `eaw`: Edge-Avoiding À-Trous Wavelet filter (Dammertz, Sewtz, Hanika, Lensch 2010; seed 002),
// spatial only. Five iterations of the 5x5 B3 kernel with taps 2^i apart, weighted by colour,
// normal and world-position stopping; the colour sigma is halved every iteration so later, wider
// iterations smooth only small illumination differences. Each iteration filters the previous
// one's output (the paper keeps only the coarsest level c_N and drops the detail coefficients).
#include <algorithm>
#include <cmath>
#include <string>

#include "denoisers/common/atrous.hpp"
#include "denoisers/common/footprint.hpp"
#include "denoisers/common/gbuffer.hpp"
#include "denoisers/denoiser.hpp"
#include "denoisers/variants.hpp"

namespace arena {

namespace {

// Set from eawParams() below, which declares each default, range and meaning once.
struct EawSettings {
  int iterations;
  bool normalPerStep;     // seed 002's code: the normal distance divided by stepwidth^2
  AtrousSettings atrous;  // kernel and the Dammertz terms (sigmaColor, edge.color, ...)
  Footprint footprint;
};

class EdgeAvoidingAtrous final : public Denoiser {
 public:
  explicit EdgeAvoidingAtrous(const EawSettings& settings) : settings_(settings) {}

  std::vector<std::string> requiredChannels() const override {
    return {"normal", "position", "meshId"};
  }

  void setup(int width, int height) override {
    settings_.atrous.footprintScale = settings_.footprint.scale(height);
    for (Image& image : pingPong_) image = Image(width, height, 3);
  }

  void reset() override {}  // no history

  void denoise(const FrameContext&, const DenoiserInputs& in, Image& output) override {
    const GBufferView gbuffer = GBufferView::fromFrame(in.frame, requiredChannels(), "eaw");
    const AtrousGuide guide{gbuffer, nullptr, nullptr};
    const Image* source = &in.signal;
    for (int i = 0; i < settings_.iterations; ++i) {
      ScopedPass pass(this, "atrous " + std::to_string(i + 1),
                      atrousIterationTaps(i, settings_.atrous));
      Image& target = i + 1 == settings_.iterations ? output : pingPong_[size_t(i % 2)];
      // Dammertz §2.2: sigma_rt^i = 2^-i sigma_rt. (Seed 002's code multiplies by 2^i instead.)
      const float colorSigma = std::ldexp(settings_.atrous.edges.sigmaColor, -i);
      // Seed 002's shader divides the squared normal distance by stepwidth^2 (the normal term
      // loosens as the taps spread); sigma_n x step^2 is the same weight.
      AtrousSettings iteration = settings_.atrous;
      if (settings_.normalPerStep) {
        const float step = float(atrousStep(i, settings_.atrous.footprintScale));
        iteration.edges.sigmaN *= std::max(step, 1.0f) * std::max(step, 1.0f);
      }
      atrousIteration(i, iteration, guide, colorSigma, *source, target);
      source = &target;
    }
  }

 private:
  EawSettings settings_;
  Image pingPong_[2];
};

const ParamTable<EawSettings>& eawParams() {
  using S = EawSettings;
  using E = EdgeStoppingSettings;
  auto edge = [](auto field) { return member(&S::atrous, &AtrousSettings::edges, field); };
  static const ParamTable<S> table =
      ParamTable<S>()
          .integer("iterations", &S::iterations, 5, 1, 10,
                   "à-trous iterations; 5 reach about 65x65 px (Dammertz 2010: 5)")
          .include(atrousKernelParams(), &S::atrous)
          .real("sigmaColor", edge(&E::sigmaColor), 2.0, 1e-6, 1e6,
                "colour sigma_rt of exp(-|c(p)-c(q)|^2/sigma_rt) at iteration 0, halved every "
                "iteration (ours: demodulated radiance differences of ~1.4 weigh 1/e)")
          .real("sigmaNormal", edge(&E::sigmaN), 0.1, 1e-6, 1e6,
                "normal sigma_n of exp(-|n(p)-n(q)|^2/sigma_n) (ours: 10 deg weighs 0.74, 45 deg "
                "0.003)")
          .real("sigmaPosition", edge(&E::sigmaX), 0.05, 1e-9, 1e9,
                "position sigma_x of exp(-|x(p)-x(q)|^2/sigma_x), world units squared (ours, for "
                "metre-scale scenes)")
          .boolean("normalPerStep", &S::normalPerStep, true,
                   "normal distance divided by stepwidth^2 each iteration (seed 002's Dammertz "
                   "code; false: one sigma for every iteration)")
          .boolean("edge.color", edge(&E::color), true, "colour stopping term (Dammertz)")
          .boolean("edge.normal", edge(&E::normal), true, "normal stopping term (Dammertz)")
          .boolean("edge.position", edge(&E::position), true,
                   "world-position stopping term (Dammertz)")
          .boolean("edge.id", edge(&E::id), false,
                   "mesh-id stopping term (not in the paper; seed 002's code has it)")
          .include(footprintParams(), &S::footprint)
          .fixed([](S& s) {
            // Dammertz 2010 has no depth or luminance term; its normal term is a Gaussian of the
            // normal distance.
            s.atrous.edges.depth = false;
            s.atrous.edges.luminance = false;
            s.atrous.edges.normalForm = NormalWeightForm::GaussianDistance;
          });
  return table;
}

}  // namespace

DenoiserInfo eawInfo() {
  DenoiserInfo info{
      "eaw",
      "Edge-avoiding à-trous wavelet filter, colour/normal/position stopping, "
      "spatial only (Dammertz et al. 2010)",
      eawParams().schema(), [](const ParamSet& params, SignalKind) {
        return std::make_unique<EdgeAvoidingAtrous>(eawParams().settings(params, "eaw"));
      }};
  info.keepsHistory = false;  // spatial only: reset() has nothing to drop
  return info;
}

}  // namespace arena
