// End-to-end claims of the framework on real (tiny) rendered sequences: SVGF against the noisy
// input, temporal accumulation converging, and the id edge-stopping ablation on the coplanar poster.
#include "harness/denoise_run.hpp"

#include <gtest/gtest.h>

#include <set>

#include "core/error.hpp"
#include "metrics/error.hpp"
#include "tests/test_util.hpp"

namespace arena {
namespace {

struct PerFrame {
  std::vector<double> relMse;
  std::vector<Image> color;
};

PerFrame denoise(const Sequence& seq, const DenoiserRequest& req) {
  PerFrame out;
  DenoiseRun run(req, seq);
  std::vector<LayerSet> frames;
  for (int t = 0; t < seq.info().frames; ++t) frames.push_back(seq.frame(t));
  run.run([&](int t) -> const LayerSet& { return frames[size_t(t)]; },
          [&](const DenoisedFrame& f) {
            LayerSet ref = seq.reference(f.frame);
            out.relMse.push_back(linearError(f.color, ref.get("color"), &ref.get("colorVar")).relMse);
            out.color.push_back(f.color);
          });
  return out;
}

double meanFrom(const std::vector<double>& v, size_t from) {
  double s = 0;
  for (size_t i = from; i < v.size(); ++i) s += v[i];
  return s / double(v.size() - from);
}

Sequence tinySequence(const std::string& scene, int w, int h, int frames, int spp) {
  static auto cache = test::freshDir("integration_cache");
  return Sequence::open(renderSequence(test::shippedScene(scene), test::tinySettings(w, h, frames, spp), cache, nullptr));
}

// A denoiser made to look: it declares depth, records the layers it is handed and, told to,
// reads the normal it did not declare.
class Peeker final : public Denoiser {
 public:
  Peeker(std::vector<std::set<std::string>>* seen, bool readsNormal)
      : seen_(seen), readsNormal_(readsNormal) {}
  std::vector<std::string> requiredChannels() const override { return {"depth"}; }
  void setup(int, int) override {}
  void reset() override {}
  void denoise(const FrameContext&, const DenoiserInputs& in, Image& output) override {
    std::set<std::string> names;
    for (const auto& [name, image] : in.frame.all()) names.insert(name);
    seen_->push_back(names);
    if (readsNormal_) static_cast<void>(in.frame.get("normal", "peeker"));
    output = in.signal;
  }

 private:
  std::vector<std::set<std::string>>* seen_;
  bool readsNormal_;
};

// Every contender reads the same information: a denoiser is handed the layers it declares and its
// signal, as a plugin is sent them, and no other (the frame holds normals, positions, albedo and an
// oracle hit distance too); one that reads a layer it did not declare fails, named.
TEST(DenoiseRun, ADenoiserIsHandedOnlyTheLayersItDeclares) {
  Sequence seq = tinySequence("cornell_static", 32, 18, 2, 4);
  std::vector<std::set<std::string>> seen;
  bool readsNormal = false;
  const DenoiserInfo info{"peeker", "test", ParamSchema{}, [&](const ParamSet&, SignalKind) {
                            return std::make_unique<Peeker>(&seen, readsNormal);
                          }};
  std::vector<LayerSet> frames;
  for (int t = 0; t < seq.info().frames; ++t) frames.push_back(seq.frame(t));
  ASSERT_TRUE(frames[0].has("normal") && frames[0].has("albedo"));
  const auto frameOf = [&](int t) -> const LayerSet& { return frames[size_t(t)]; };
  {
    DenoiseRun run(info, {"peeker", {}, "peeker"}, seq);
    run.run(frameOf, [](const DenoisedFrame&) {});
  }
  ASSERT_EQ(seen.size(), 4u);  // two frames, two signals
  EXPECT_EQ(seen[0], (std::set<std::string>{"diffuse", "specular", "depth"}));
  EXPECT_EQ(seen[3], seen[0]);
  readsNormal = true;
  DenoiseRun peeking(info, {"peeker", {}, "peeker"}, seq);
  try {
    peeking.run(frameOf, [](const DenoisedFrame&) {});
    ADD_FAILURE() << "an undeclared read ran";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("peeker: missing channel 'normal': peeker reads layer "
                                         "'normal', which the frame holds but it does not declare "
                                         "(requiredChannels())"),
              std::string::npos)
        << e.what();
  }
}

TEST(Integration, SvgfIsTenTimesBetterThanTheNoisyInputOnTheStaticCornellBox) {
  Sequence seq = tinySequence("cornell_static", 96, 54, 16, 256);
  const double noisy = meanFrom(denoise(seq, {"passthrough", {}, ""}).relMse, 8);
  const double svgf = meanFrom(denoise(seq, {"svgf", {}, ""}).relMse, 8);
  // Measured 2026-11-22 at 96x54, 256-spp references: noisy 0.17, svgf about 0.011 (16x).
  EXPECT_LT(svgf * 10.0, noisy) << "svgf " << svgf << " noisy " << noisy;
}

TEST(Integration, TemporalAccumulationConvergesFrameByFrame) {
  Sequence seq = tinySequence("cornell_static", 96, 54, 16, 256);
  auto err = denoise(seq, {"temporal", {}, ""}).relMse;
  for (size_t t = 1; t < 10; ++t) EXPECT_LT(err[t], err[t - 1]) << "frame " << t;
  EXPECT_LT(err[9] * 5, err[0]);
}

TEST(Integration, TheIdTermKeepsTheCoplanarPosterEdge) {
  Sequence seq = tinySequence("coplanar_poster", 128, 72, 10, 256);
  const LayerSet first = seq.frame(0);
  const Image& id = first.get("meshId");
  // The band of pixels within 2 px of the poster/wall boundary (same depth and normal on both sides).
  Image band(id.width(), id.height(), 1);
  int bandPixels = 0;
  for (int y = 2; y < id.height() - 2; ++y)
    for (int x = 2; x < id.width() - 2; ++x) {
      bool edge = false;
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) edge = edge || (id.at(x + dx, y + dy) != id.at(x, y) && id.at(x, y) >= 1 && id.at(x + dx, y + dy) >= 1);
      band.at(x, y) = edge ? 1.0f : 0.0f;
      bandPixels += edge;
    }
  ASSERT_GT(bandPixels, 50);
  auto bandError = [&](const std::string& idTerm) {
    PerFrame r = denoise(seq, {"svgf", {{"edge.id", idTerm}}, ""});
    LayerSet ref = seq.reference(9);
    return linearError(r.color[9], ref.get("color"), &ref.get("colorVar"), &band).relMse;
  };
  const double withId = bandError("true"), withoutId = bandError("false");
  // Without the id term, the poster's albedo-demodulated light is shared with the wall across the
  // edge only through colour; the measured gap is large (see the note), 1.5x is the assertion.
  EXPECT_LT(withId * 1.5, withoutId) << "with id " << withId << ", without " << withoutId;
  std::printf("coplanar poster edge band relMSE: id on %.5f, id off %.5f\n", withId, withoutId);
}

}  // namespace
}  // namespace arena
