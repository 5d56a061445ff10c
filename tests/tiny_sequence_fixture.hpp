#pragma once
// The shared fixture of reblur_test.cpp and hybrid_test.cpp: tiny rendered sequences (64x36,
// <= 24 frames, 64-spp references) kept in memory, a denoiser run over one, relMSE against its
// references, and the check that every pass of a denoiser keeps a constant signal constant.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>

#include "core/error.hpp"
#include "denoisers/common/atrous.hpp"
#include "denoisers/common/reprojection.hpp"
#include "denoisers/common/temporal_accumulation.hpp"
#include "denoisers/hybrid.hpp"
#include "denoisers/reblur.hpp"
#include "harness/denoise_run.hpp"
#include "harness/run_matrix.hpp"
#include "metrics/error.hpp"
#include "metrics/ghosting.hpp"
#include "tests/test_util.hpp"

namespace arena::test::tiny_sequence {

namespace fs = std::filesystem;
constexpr int kWidth = 64, kHeight = 36, kReferenceSpp = 64;

inline fs::path cacheDir() {
  static fs::path dir = test::freshDir("tiny_sequence_cache");
  return dir;
}

// A rendered sequence with its frames and references in memory.
struct Loaded {
  Sequence sequence;
  std::vector<LayerSet> frames, references;
};

inline const Loaded& loaded(const std::string& scene, int frames) {
  static std::map<std::string, std::unique_ptr<Loaded>> cache;
  const std::string key = scene + "/" + std::to_string(frames);
  auto it = cache.find(key);
  if (it != cache.end()) return *it->second;
  const fs::path dir = renderSequence(test::shippedScene(scene),
                                      test::tinySettings(kWidth, kHeight, frames, kReferenceSpp),
                                      cacheDir(), nullptr);
  auto l = std::make_unique<Loaded>(Loaded{Sequence::open(dir), {}, {}});
  for (int t = 0; t < l->sequence.info().frames; ++t) {
    l->frames.push_back(l->sequence.frame(t));
    l->references.push_back(l->sequence.reference(t));
  }
  return *cache.emplace(key, std::move(l)).first->second;
}

inline std::vector<DenoisedFrame> denoise(const Loaded& l, const std::string& name,
                                   const std::map<std::string, std::string>& params = {}) {
  DenoiseRun run({name, params, name}, l.sequence);
  std::vector<DenoisedFrame> out;
  run.run([&](int t) -> const LayerSet& { return l.frames[size_t(t)]; },
          [&](const DenoisedFrame& f) { out.push_back(f); });
  return out;
}

// Mean relMSE (metrics.md, eps 0.01) of one layer over frames t >= warmup.
inline double meanRelMse(const Loaded& l, const std::vector<DenoisedFrame>& run, const std::string& layer,
                  int warmup) {
  double sum = 0;
  int n = 0;
  for (size_t t = size_t(warmup); t < run.size(); ++t) {
    const Image& d = layer == "specular"  ? run[t].specular
                     : layer == "diffuse" ? run[t].diffuse
                                          : run[t].color;
    sum += linearError(d, l.references[t].get(layer), nullptr).relMse;
    ++n;
  }
  return sum / n;
}

inline double noisyRelMse(const Loaded& l, const std::string& layer, int warmup) {
  double sum = 0;
  int n = 0;
  for (size_t t = size_t(warmup); t < l.frames.size(); ++t, ++n)
    sum += linearError(l.frames[t].get(layer), l.references[t].get(layer), nullptr).relMse;
  return sum / n;
}

inline double maxAbsDifference(const Image& a, const Image& b) {
  double m = 0;
  for (size_t i = 0; i < a.raw().size(); ++i)
    m = std::max(m, double(std::abs(a.raw()[i] - b.raw()[i])));
  return m;
}

inline FrameContext contextOf(const Loaded& l, int t) {
  FrameContext ctx;
  ctx.frameIndex = t;
  ctx.width = l.sequence.info().width;
  ctx.height = l.sequence.info().height;
  ctx.camera = l.sequence.info().cameras[size_t(t)];
  ctx.previousCamera = l.sequence.info().cameras[size_t(std::max(t - 1, 0))];
  ctx.reset = t == 0;
  return ctx;
}

inline std::unique_ptr<Denoiser> create(const std::string& name, SignalKind kind,
                                 const std::map<std::string, std::string>& params = {}) {
  const DenoiserInfo& info = DenoiserRegistry::instance().find(name);
  return info.create(info.schema.resolve(params, name), kind);
}

// Every pass of a denoiser on a real moving G-buffer (glossy_orbit) with a constant signal: each
// 3-channel pass output equals the constant (in Reinhard space, `compressed`, the compressed one),
// and so does the output.
template <class Variant>
inline void expectConstantThroughEveryPass(const std::string& name,
                                    const std::map<std::string, std::string>& params,
                                    bool compressed = false) {
  const Loaded& l = loaded("glossy_orbit", 24);
  for (SignalKind kind : {SignalKind::Diffuse, SignalKind::Specular}) {
    auto denoiser = create(name, kind, params);
    auto* variant = dynamic_cast<Variant*>(denoiser.get());
    ASSERT_NE(variant, nullptr);
    denoiser->setup(kWidth, kHeight);
    Image signal(kWidth, kHeight, 3), output(kWidth, kHeight, 3);
    for (int c = 0; c < 3; ++c)
      std::fill_n(signal.plane(c), kWidth * kHeight, 0.3f + 0.2f * float(c));
    Image internal = signal;
    if (compressed)  // Reinhard: c / (1 + L(c))
      for (float& v : internal.raw()) v /= 1.0f + luminance(0.3f, 0.5f, 0.7f);
    for (int t = 0; t < 8; ++t) {
      denoiser->denoise(contextOf(l, t), {signal, l.frames[size_t(t)], nullptr}, output);
      for (const auto& [pass, image] : variant->passOutputs()) {
        if (image->channels() != 3) continue;
        for (size_t i = 0; i < image->raw().size(); ++i)
          ASSERT_NEAR(image->raw()[i], internal.raw()[i], 2e-5f)
              << name << " pass '" << pass << "' frame " << t << " " << signalName(kind);
      }
      for (size_t i = 0; i < output.raw().size(); ++i)
        ASSERT_NEAR(output.raw()[i], signal.raw()[i], 2e-5f);
    }
  }
}

}  // namespace arena::test::tiny_sequence
