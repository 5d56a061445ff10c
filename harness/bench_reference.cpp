// `arena bench reference`: how fast each reference sampler converges. In one process, per scene:
// a "gold" reference (Owen-scrambled Sobol, uniform, `--gold-factor` times the samples, under
// another seed so it shares no samples with the compared references), then at
// about the same sample count, each timed: the independent sampler (uniform, the first version's
// references), Sobol (uniform) and Sobol with adaptive allocation per tile (a uniform pilot of a
// quarter of the samples, then the rounds of nextReferenceAllocation until the frame's mean reaches
// the count). Each one's true relMSE against the gold, minus the gold's own estimated noise term
// (metrics.md's correction). A gain is a ratio of relMSE x seconds (independent / the other): the
// relMSE ratio at equal wall time for an estimator whose error falls as 1/time (true of the
// independent sampler; Sobol's falls faster, so this understates its gain at longer times). The
// line ends with the gain of the references as rendered (adaptive Sobol).
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/atomic_file.hpp"
#include "core/env_info.hpp"
#include "core/error.hpp"
#include "harness/commands.hpp"
#include "harness/scene_selection.hpp"
#include "metrics/error.hpp"
#include "tracer/render.hpp"

namespace arena::cli {

namespace {

struct Measured {
  double seconds = 0, relMse = 0, estimatedRelMse = 0, spp = 0;
};

Measured measure(const Scene& scene, RenderSettings settings, const std::string& sampler, bool adaptive, int frame,
                 int spp, const LayerSet& gold) {
  settings.referenceSampler = sampler;
  SequenceRenderer renderer(scene, settings);
  RayCounts counts;
  const int perReplicate = std::max(1, spp / renderer.referenceReplicates());
  renderer.frameScene(frame);  // the Embree build is not part of a sampler's time
  const auto t0 = std::chrono::steady_clock::now();
  ReferenceSums sums = renderer.emptyReferenceSums(0, renderer.referenceReplicates());
  if (adaptive) {
    renderer.extendReference(frame, sums, std::max(1, perReplicate / 4), counts);  // the pilot
    // A tile may get up to 8x the mean count.
    for (;;) {  // the references' rounds; the last one is cut to the count (rounding may miss it)
      const bool last = kReferenceRoundGrowth * sums.meanSpp() >= 0.99 * perReplicate * sums.replicates;
      const std::vector<int> next =
          nextReferenceAllocation(sums, 8 * perReplicate, kReferenceRoundGrowth, perReplicate);
      if (next == sums.tileSamples) break;
      renderer.extendReference(frame, sums, next, counts);
      if (last) break;
    }
  } else {
    renderer.extendReference(frame, sums, perReplicate, counts);
  }
  Measured m;
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  m.spp = sums.meanSpp();
  const LayerSet ref = referenceLayersFromSums(sums);
  m.relMse = linearError(ref.get("color"), gold.get("color"), &gold.get("colorVar")).relMseCorrected;
  m.estimatedRelMse = estimatedReferenceRelMse(sums);
  return m;
}

}  // namespace

void addBenchReferenceCommand(CLI::App* bench) {
  auto* cmd = bench->add_subcommand("reference",
                                    "Reference samplers: true relMSE against a long gold render at "
                                    "equal time, independent vs sobol");
  struct Options {
    std::string scenes = "cornell_static,camera_pan_occluder", resolution = "128x72", json;
    std::string scenesDir = defaultScenesDir();
    int spp = 128, goldFactor = 32, frame = 0, replicates = RenderSettings().referenceReplicates, maxBounces = 0;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("--scenes", o->scenes, "Scenes, comma-separated, or 'all'");
  cmd->add_option("--resolution", o->resolution, "Resolution, WIDTHxHEIGHT");
  cmd->add_option("--spp", o->spp, "Samples per pixel of the compared references")->check(CLI::Range(8, 1 << 16));
  cmd->add_option("--gold-factor", o->goldFactor, "The gold reference has this many times the samples")
      ->check(CLI::Range(4, 1024));
  cmd->add_option("--replicates", o->replicates,
                  "Independent randomisations of the compared references (the gold keeps the default)")
      ->check(CLI::Range(2, 64));
  cmd->add_option("--max-bounces", o->maxBounces,
                  "Override the scenes' maximum path length (gold included): comparing two lengths shows which "
                  "part of the error the longer paths carry")
      ->check(CLI::Range(1, 64));
  cmd->add_option("--frame", o->frame, "Frame whose state is rendered")->check(CLI::NonNegativeNumber);
  cmd->add_option("--scenes-dir", o->scenesDir, "Directory of scene files");
  cmd->add_option("--json", o->json, "Write results to this JSON file");
  cmd->callback([o] {
    RenderOptions ro;
    ro.resolution = o->resolution;
    ro.maxBounces = o->maxBounces;
    RenderSettings settings = ro.settings();
    nlohmann::json out = {{"resolution", o->resolution},
                          {"spp", o->spp},
                          {"goldFactor", o->goldFactor},
                          {"maxBounces", o->maxBounces > 0 ? nlohmann::json(o->maxBounces) : nlohmann::json("scene")},
                          {"scenes", nlohmann::json::array()},
                          {"environment", environmentInfo()}};
    for (const Scene& scene : selectScenes(o->scenes, o->scenesDir)) {
      if (o->frame >= scene.frames)
        throw Error("--frame " + std::to_string(o->frame) + ": scene " + scene.name + " has " +
                    std::to_string(scene.frames) + " frames");
      RenderSettings goldSettings = settings;
      goldSettings.referenceSampler = "sobol";
      SequenceRenderer goldRenderer(withIndependentSeed(scene), goldSettings);
      ReferenceSums goldSums;
      RayCounts counts;
      const auto g0 = std::chrono::steady_clock::now();
      goldRenderer.extendReference(o->frame, goldSums,
                                   std::max(1, o->spp * o->goldFactor / goldRenderer.referenceReplicates()), counts);
      const double goldSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - g0).count();
      const LayerSet gold = referenceLayersFromSums(goldSums);
      const double goldNoise = estimatedReferenceRelMse(goldSums);
      settings.referenceReplicates = o->replicates;
      const Measured ind = measure(scene, settings, "independent", false, o->frame, o->spp, gold);
      const Measured sob = measure(scene, settings, "sobol", false, o->frame, o->spp, gold);
      const Measured ada = measure(scene, settings, "sobol", true, o->frame, o->spp, gold);
      auto gainOver = [&](const Measured& m) {
        return (ind.relMse * ind.seconds) / std::max(m.relMse * m.seconds, 1e-300);
      };
      const double sobolGain = gainOver(sob), gain = gainOver(ada);
      std::printf(
          "%-22s %d spp: independent relMSE %.3e in %.2f s (est. %.3e) | sobol %.3e in %.2f s "
          "(est. %.3e, gain "
          "%.1fx) | adaptive %.0f spp %.3e in %.2f s (est. %.3e) | gold %d spp in %.1f s, own "
          "noise %.1e | gain "
          "%.1fx\n",
          scene.name.c_str(), goldSums.replicates * std::max(1, o->spp / goldSums.replicates), ind.relMse, ind.seconds,
          ind.estimatedRelMse, sob.relMse, sob.seconds, sob.estimatedRelMse, sobolGain, ada.spp, ada.relMse,
          ada.seconds, ada.estimatedRelMse, goldSums.spp(), goldSeconds, goldNoise, gain);
      std::fflush(stdout);
      out["scenes"].push_back(
          {{"scene", scene.name},
           {"independent",
            {{"relMse", ind.relMse}, {"seconds", ind.seconds}, {"estimatedRelMse", ind.estimatedRelMse}}},
           {"sobol", {{"relMse", sob.relMse}, {"seconds", sob.seconds}, {"estimatedRelMse", sob.estimatedRelMse}}},
           {"adaptive",
            {{"relMse", ada.relMse},
             {"seconds", ada.seconds},
             {"estimatedRelMse", ada.estimatedRelMse},
             {"spp", ada.spp}}},
           {"sobolGain", sobolGain},
           {"goldSpp", goldSums.spp()},
           {"goldSeconds", goldSeconds},
           {"goldRelMse", goldNoise},
           {"gain", gain}});
    }
    if (!o->json.empty()) writeTextAtomically(o->json, out.dump(2));
  });
}

}  // namespace arena::cli
