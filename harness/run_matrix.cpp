#include "harness/run_matrix.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <random>
#include <set>

#include "core/display.hpp"
#include "core/env_info.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "harness/image_files.hpp"
#include "harness/reference_quality.hpp"
#include "metrics/results.hpp"
#include "metrics/error.hpp"
#include "metrics/error_maps.hpp"
#include "metrics/flip.hpp"
#include "metrics/ghosting.hpp"
#include "metrics/ghosting_intervals.hpp"
#include "metrics/statistics.hpp"
#include "metrics/summary.hpp"
#include "metrics/temporal.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

std::string nowIso() {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

std::string safeName(const std::string& label) {
  std::string s = label;
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || std::string("._=,-[]").find(c) != std::string::npos)) c = '_';
  return s;
}

std::string frameName(const char* prefix, int t) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s_%04d.png", prefix, t);
  return buf;
}

// Everything about a scene that every pair shares: frames, references, display transforms, masks.
struct SceneData {
  Sequence sequence;
  std::vector<LayerSet> frames;       // per frame
  std::vector<LayerSet> references;   // per distinct reference
  std::vector<DisplayTransform> displays;  // per distinct reference (metrics.md, "Display exposure")
  std::vector<Image> referenceDisplay;
  std::vector<double> referenceRelMse, noisyRelMse;
  struct Event {
    SequenceEvent event;
    int begin = 0, end = 0;
    std::vector<Image> masks;  // per window frame
    size_t chromaOnlyPixels = 0;
  };
  std::vector<Event> events;
  struct Cut {
    int frame = 0, segmentEnd = 0;  // the new view lasts [frame, segmentEnd]
  };
  std::vector<Cut> cuts;
  std::vector<int> chosenFrames;
  // Non-finite values in the cache's inputs, per "file kind: layer.channel" (reported, never silent).
  std::map<std::string, long> nonFinite;
  // Each metric's own floor: the metric between a reference-noise-only image and the reference.
  nlohmann::json floors = nlohmann::json::object();
  size_t referenceIndex(int t) const { return size_t(sequence.info().referenceOfFrame[size_t(t)]); }
  const LayerSet& reference(int t) const { return references[referenceIndex(t)]; }
  const DisplayTransform& displayAt(int t) const { return displays[referenceIndex(t)]; }
  const Image& referenceDisplayAt(int t) const { return referenceDisplay[referenceIndex(t)]; }
};

int meshIdOf(const Scene& scene, const std::string& name) {
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (scene.objects[i].name == name) return int(i);
  for (size_t i = 0; i < scene.lights.size(); ++i)
    if (scene.lights[i].name == name) return int(scene.objects.size() + i);
  return -1;
}

// Counts non-finite values per layer.channel into `counts` under "kind: layer.c".
void countNonFinite(const LayerSet& layers, const std::string& kind, std::map<std::string, long>& counts) {
  for (const auto& [name, image] : layers.all())
    for (int c = 0; c < image.channels(); ++c) {
      long n = 0;
      const float* plane = image.plane(c);
      for (size_t i = 0; i < image.pixelCount(); ++i) n += !std::isfinite(plane[i]);
      if (n) counts[kind + ": " + name + "." + std::to_string(c)] += n;
    }
}

std::string describeCounts(const std::map<std::string, long>& counts) {
  std::string out;
  for (const auto& [where, n] : counts) out += (out.empty() ? "" : ", ") + where + " x" + std::to_string(n);
  return out;
}

// An image with the reference's own noise and nothing else: an independent half-sample estimate
// when the cache has one (colorHalf: r_hat - half = (other half - half) / 2 has exactly Var(r_hat)),
// else r_hat plus Gaussian noise of the stored variance of the mean (the CLT's approximation,
// deterministic per scene). A perfect method would score this against the reference.
Image referenceNoiseImage(const LayerSet& ref, const std::string& seedName) {
  if (ref.has("colorHalf")) return ref.get("colorHalf");
  const Image &r = ref.get("color"), &var = ref.get("colorVar");
  Image out = r;
  std::mt19937_64 rng(Hasher().add("arena-floor").add(seedName).value());
  auto uniform = [&] { return (double(rng() >> 11) + 0.5) * 0x1.0p-53; };
  for (size_t i = 0; i < out.raw().size(); ++i) {
    const double z = std::sqrt(-2 * std::log(uniform())) * std::cos(2 * M_PI * uniform());  // Box-Muller
    out.raw()[i] = float(r.raw()[i] + std::sqrt(std::max(0.0f, var.raw()[i])) * z);
  }
  return out;
}

SceneData loadScene(const Scene& scene, const fs::path& dir, int warmup, const std::string& flip,
                    ExposureMode exposure) {
  SceneData s{Sequence::open(dir), {}, {}, {}, {}, {}, {}, {}, {}, {}, {}, nlohmann::json::object()};
  const SequenceInfo& info = s.sequence.info();
  for (int t = 0; t < info.frames; ++t) {
    s.frames.push_back(s.sequence.frame(t));
    countNonFinite(s.frames.back(), "frame " + std::to_string(t), s.nonFinite);
    if (t > 0) countNonFinite(s.sequence.gradients(t), "gradients " + std::to_string(t), s.nonFinite);
  }
  int refs = 0;
  for (int r : info.referenceOfFrame) refs = std::max(refs, r + 1);
  for (int r = 0; r < refs; ++r) {
    s.references.push_back(readExr(Sequence::referencePath(dir, r), channels::referenceLayers()).layers);
    std::map<std::string, long> bad;
    countNonFinite(s.references.back(), Sequence::referencePath(dir, r).string(), bad);
    // A non-finite reference cannot rank anything: every metric against it would be NaN or a
    // fake perfect score. The scene fails, naming the file and the channels.
    if (!bad.empty())
      throw Error("scene " + info.scene + ": the reference has non-finite values (" + describeCounts(bad) +
                  "); check the scene's emitters and materials (a value beyond float range becomes Inf)");
  }
  std::vector<const Image*> referenceColors;
  for (const LayerSet& r : s.references) referenceColors.push_back(&r.get("color"));
  s.displays = displayTransforms(referenceColors, exposure);
  for (size_t r = 0; r < s.references.size(); ++r)
    s.referenceDisplay.push_back(s.displays[r].apply(*referenceColors[r]));
  for (int t = 0; t < info.frames; ++t) {
    const LayerSet& ref = s.reference(t);
    s.referenceRelMse.push_back(referenceRelMse(ref.get("color"), ref.get("colorVar")));
    s.noisyRelMse.push_back(linearError(s.frames[size_t(t)].get("color"), ref.get("color"), &ref.get("colorVar")).relMse);
  }
  // Ghosting windows: [t0 - 5, t0 + 60], clipped to the sequence and ended before the next event
  // (ours: a second event would otherwise pollute the first one's steady state). A camera cut's
  // segment runs from the cut to the frame before the next event.
  GhostingConfig gc;
  std::vector<int> eventFrames;
  for (const SequenceEvent& e : info.events) eventFrames.push_back(e.frame);
  auto endBeforeNextEvent = [&](int from, int end) {
    for (int f : eventFrames)
      if (f > from) end = std::min(end, f - 1);
    return end;
  };
  for (const SequenceEvent& e : info.events) {
    if (e.frame < 1) continue;
    if (e.kind == "camera_cut") {
      s.cuts.push_back({e.frame, endBeforeNextEvent(e.frame, info.frames - 1)});
      continue;
    }
    SceneData::Event ev;
    ev.event = e;
    ev.begin = std::max(0, e.frame - gc.before);
    ev.end = endBeforeNextEvent(e.frame, std::min(info.frames - 1, e.frame + gc.after));
    Image base = changedRegion(s.reference(e.frame).get("color"),
                               s.reference(e.frame - 1).get("color"), gc, &ev.chromaOnlyPixels);
    const int objectId = e.kind == "object_moves" ? meshIdOf(scene, e.what) : -1;
    for (int t = ev.begin; t <= ev.end; ++t) {
      Image mask = base;
      if (objectId >= 0) {
        std::vector<const Image*> previous;
        for (int k = 1; k <= gc.trailFrames && t - k >= 0; ++k) previous.push_back(&s.frames[size_t(t - k)].get("meshId"));
        addTrail(mask, objectId, previous, s.frames[size_t(t)].get("meshId"));
      }
      ev.masks.push_back(std::move(mask));
    }
    s.events.push_back(std::move(ev));
  }
  std::set<int> chosen = {std::min(warmup, info.frames - 1), info.frames / 2, info.frames - 1};
  for (const SequenceEvent& e : info.events)
    for (int t : {e.frame, e.frame + 2})
      if (t < info.frames) chosen.insert(t);
  s.chosenFrames.assign(chosen.begin(), chosen.end());
  // Metric floors, per distinct reference used after the warm-up, then averaged over those frames.
  std::map<std::string, std::vector<double>> floorFrames;
  std::map<int, std::map<std::string, double>> perReference;
  for (int t = std::max(warmup, 0); t < info.frames; ++t) {
    const int r = info.referenceOfFrame[size_t(t)];
    if (!perReference.count(r)) {
      const LayerSet& ref = s.references[size_t(r)];
      const Image noise = referenceNoiseImage(ref, info.scene + "#" + std::to_string(r));
      const Image& color = ref.get("color");
      const Image noiseDisp = s.displays[size_t(r)].apply(noise);
      auto& f = perReference[r];
      f["relMse"] = linearError(noise, color, nullptr).relMse;
      f["psnr"] = psnrFromMse(meanSquaredError(noiseDisp, s.referenceDisplay[size_t(r)]));
      f["ssim"] = ssim(noiseDisp, s.referenceDisplay[size_t(r)]);
      if (flip != "none") f["ldrFlip"] = ldrFlip(s.referenceDisplay[size_t(r)], noiseDisp).mean;
      if (flip == "all") f["hdrFlip"] = hdrFlip(color, noise).mean;
    }
    for (const auto& [name, v] : perReference[r]) floorFrames[name].push_back(v);
  }
  for (const auto& [name, v] : floorFrames) {
    double sum = 0;
    for (double x : v) sum += x;
    s.floors[name] = sum / double(v.size());
  }
  s.floors["source"] = s.references.front().has("colorHalf") ? "independent half-sample reference"
                                                             : "reference plus Gaussian noise of its variance";
  return s;
}

json timingJson(const std::vector<std::vector<PassStats>>& passesPerFrame, const std::vector<double>& ms, int warmup,
                int width, int height) {
  json passes = json::array();
  if (!passesPerFrame.empty()) {
    const auto& names = passesPerFrame.back();
    for (size_t p = 0; p < names.size(); ++p) {
      std::vector<double> v;
      double taps = names[p].tapsPerPixel;
      for (const auto& f : passesPerFrame)
        if (p < f.size() && f[p].name == names[p].name) v.push_back(f[p].milliseconds);
      Summary s = summarize(v, std::min(warmup, int(v.size()) - 1));
      passes.push_back({{"name", names[p].name}, {"msMedian", s.median}, {"msP95", s.p95}, {"tapsPerPixel", taps}});
    }
  }
  Summary total = summarize(ms, std::min(warmup, int(ms.size()) - 1));
  double taps = 0;
  for (const json& p : passes) taps += p["tapsPerPixel"].get<double>();
  return {{"msMedian", total.median}, {"msP5", total.p5}, {"msP95", total.p95}, {"msMean", total.mean},
          {"msPerMegapixel", total.median / (double(width) * height * 1e-6)}, {"tapsPerPixel", taps},
          {"passes", passes}};
}

json runPair(const RunConfig& cfg, const SceneData& sd, const DenoiserRequest& req, const fs::path& imageDir,
             bool keepAll) {
  const SequenceInfo& info = sd.sequence.info();
  DenoiseRun run(req, sd.sequence);
  const int w = info.width, h = info.height;
  json frames = json::array();
  PairSeries series(info.frames, cfg.warmup);
  bool selfTimed = false;
  std::vector<std::vector<PassStats>> passes;
  std::vector<std::vector<double>> eventCurves(sd.events.size()), eventBias(sd.events.size()),
      eventChroma(sd.events.size()), cutLeak(sd.cuts.size());
  // The per-tile sums behind the event and cut curves: their intervals' spatial blocks
  // (metrics/ghosting_intervals.hpp).
  std::vector<EventTiles> eventTiles(sd.events.size());
  std::vector<CutTiles> cutTiles(sd.cuts.size());
  GhostingConfig gc;
  Image prevColor, prevDisplay, prevError;
  long sanitized = 0;
  const bool keepImages = cfg.keepFrames != "none";
  run.run([&](int t) -> const LayerSet& { return sd.frames[size_t(t)]; },
          [&](const DenoisedFrame& f) {
            const int t = f.frame;
            const LayerSet& ref = sd.reference(t);
            const Image &r = ref.get("color"), &var = ref.get("colorVar");
            const Image& rDisp = sd.referenceDisplayAt(t);
            json m = {{"frame", t}};
            // Each metric with the tile sums behind it (metrics/statistics.hpp: the bootstrap's blocks).
            auto put = [&](const char* name, double value, TileSums tiles, FrameTransform g) {
              m[name] = std::isfinite(value) ? json(value) : json(nullptr);
              series.record(name, t, value, std::move(tiles), g);
            };
            ErrorTiles et;
            ErrorStats e = linearError(f.color, r, &var, nullptr, kRelMseEpsilon, &et);
            for (size_t k = 0; k < sd.cuts.size(); ++k)
              if (t >= sd.cuts[k].frame && t <= sd.cuts[k].segmentEnd) cutTiles[k].relMse.add(t, et.relMse);
            Image disp = sd.displayAt(t).apply(f.color);
            put("relMse", e.relMse, std::move(et.relMse), FrameTransform::Mean);
            put("relMseCorrected", e.relMseCorrected, std::move(et.relMseCorrected), FrameTransform::Mean);
            put("mse", e.mse, et.mse, FrameTransform::Mean);
            put("rmse", e.rmse, std::move(et.mse), FrameTransform::Sqrt);
            TileSums tiles;
            const double psnr = psnrFromMse(meanSquaredError(disp, rDisp, &tiles));
            put("psnr", psnr, std::move(tiles), FrameTransform::Psnr);
            const double ssimValue = ssim(disp, rDisp, &tiles);
            put("ssim", ssimValue, std::move(tiles), FrameTransform::Mean);
            FlipResult ldr;
            if (cfg.flip != "none") {
              ldr = ldrFlip(rDisp, disp);
              put("ldrFlip", ldr.mean, tileSumsOfMap(ldr.map.raw(), w, h), FrameTransform::Mean);
            }
            if (cfg.flip == "all") {
              FlipResult hdr = hdrFlip(r, f.color);
              put("hdrFlip", hdr.mean, tileSumsOfMap(hdr.map.raw(), w, h), FrameTransform::Mean);
            }
            Image err(w, h, 3);
            for (size_t i = 0; i < err.raw().size(); ++i) err.raw()[i] = f.color.raw()[i] - r.raw()[i];
            if (t > 0) {
              const LayerSet& refPrev = sd.reference(t - 1);
              const double trmae = temporalRelativeMae(f.color, prevColor, r, refPrev.get("color"), 0.01, &tiles);
              put("tRmae", trmae, std::move(tiles), FrameTransform::Mean);
              const double tpsnr = temporalPsnr(disp, prevDisplay, rDisp, sd.referenceDisplayAt(t - 1), &tiles);
              put("tPsnr", tpsnr, std::move(tiles), FrameTransform::Psnr);
              WarpedFlicker wf = warpedFlicker(err, prevError, sd.frames[size_t(t)], sd.frames[size_t(t - 1)], {}, &tiles);
              // No consistent pixel (a cut, a full disocclusion): warped flicker is undefined there.
              if (wf.validFraction > 0) put("warpedFlicker", wf.value, std::move(tiles), FrameTransform::Sqrt);
              m["warpedValid"] = wf.validFraction;
            }
            // Effective spp (ours): 1-spp relMSE falls as 1/spp, so spp_eff = relMSE(noisy) / relMSE(method);
            // the reference-corrected values when both are positive.
            double noisyCorr = sd.noisyRelMse[size_t(t)] - sd.referenceRelMse[size_t(t)];
            bool corrected = noisyCorr > 0 && e.relMseCorrected > 0;
            const double spp = corrected ? noisyCorr / e.relMseCorrected
                                         : sd.noisyRelMse[size_t(t)] / std::max(e.relMse, 1e-12);
            put("effectiveSpp", spp, {}, FrameTransform::Mean);
            put("ms", f.milliseconds, {}, FrameTransform::Mean);
            if (f.selfTimed) {  // an external process timed itself; the harness's clock beside it
              put("msWall", f.wallMilliseconds, {}, FrameTransform::Mean);
              selfTimed = true;
            }
            // Disocclusion rays: low-resolution paths read per pixel (denoisers that read the buffer).
            if (run.readsLowres()) {
              put("extraRaysPerPixel", f.extraRaysPerPixel, {}, FrameTransform::Mean);
              // Their equivalent tracing time: the paths read at the rate the buffer rendered at on
              // the machine that rendered it (unknown, and absent, when another machine did).
              if (info.lowresPathsPerSecond > 0)
                put("tracingMs", f.extraRaysPerPixel * double(info.width) * double(info.height) /
                                     info.lowresPathsPerSecond * 1e3,
                    {}, FrameTransform::Mean);
            }
            put("referenceRelMse", sd.referenceRelMse[size_t(t)], {}, FrameTransform::Mean);
            for (size_t k = 0; k < sd.events.size(); ++k) {
              const auto& ev = sd.events[k];
              if (t < ev.begin || t > ev.end) continue;
              const Image& mask = ev.masks[size_t(t - ev.begin)];
              ErrorTiles inMask;
              TileSums biasTiles;
              eventCurves[k].push_back(linearError(f.color, r, &var, &mask, kRelMseEpsilon, &inMask).relMse);
              eventBias[k].push_back(signedBias(f.color, r, mask, gc.eps, &biasTiles));
              eventTiles[k].curve.add(t, std::move(inMask.relMse));
              eventTiles[k].bias.add(t, std::move(biasTiles));
              ColourTileSums colourTiles;
              eventChroma[k].push_back(chromaticityError(f.color, r, mask, &colourTiles));
              eventTiles[k].addColour(t, std::move(colourTiles));
            }
            for (size_t k = 0; k < sd.cuts.size(); ++k) {
              const auto& cut = sd.cuts[k];
              if (t >= cut.frame && t <= std::min(cut.frame + gc.recoveryFrames, cut.segmentEnd)) {
                TileSums leakTiles;
                cutLeak[k].push_back(oldViewLeak(f.color, r, sd.reference(cut.frame - 1).get("color"), &leakTiles));
                cutTiles[k].leak.add(t, std::move(leakTiles));
              }
            }
            passes.push_back(f.passes);
            sanitized += f.sanitized;
            frames.push_back(m);
            const bool chosen = std::find(sd.chosenFrames.begin(), sd.chosenFrames.end(), t) != sd.chosenFrames.end();
            if (keepImages && (keepAll || chosen)) {
              writePng(imageDir / frameName("frame", t), disp);
              if (cfg.flip != "none") writePng(imageDir / frameName("flip", t), applyColorMap(ldr.map, magmaColorMap()));
              writePng(imageDir / frameName("relerr", t), relativeErrorMap(f.color, r));
              if (keepAll) {
                LayerSet out;
                out.set("color", f.color);
                std::vector<LayerSpec> specs = {{"color", {"R", "G", "B"}}, {"color", {"R", "G", "B"}, false, true}};
                for (const char* signal : {"diffuse", "specular"}) {
                  const Image& image = std::string(signal) == "diffuse" ? f.diffuse : f.specular;
                  if (image.empty()) continue;  // a colour denoiser has no separate signals
                  out.set(signal, image);
                  specs.push_back({signal, {"R", "G", "B"}});
                }
                char name[64];
                std::snprintf(name, sizeof name, "frame_%04d.exr", t);
                writeExr(imageDir / name, out, specs,
                         {{"arena.denoiser", req.name}, {"arena.params", run.params().toJson().dump()}});
              }
            }
            prevColor = f.color;
            prevDisplay = std::move(disp);
            prevError = std::move(err);
          });
  json summary = series.summaries(sd.sequence.info().scene);
  json ghosting = json::array();
  for (size_t k = 0; k < sd.events.size(); ++k) {
    const auto& ev = sd.events[k];
    GhostingResult g =
        analyseGhosting(ev.event.frame, ev.begin, eventCurves[k], eventBias[k], eventChroma[k], gc);
    double maskPixels = 0;
    for (float v : ev.masks[size_t(ev.event.frame - ev.begin)].raw()) maskPixels += v;
    g.maskFraction = maskPixels / double(size_t(w) * h);
    g.maskChromaFraction = double(ev.chromaOnlyPixels) / double(size_t(w) * h);
    json j = g.toJson();
    j["kind"] = ev.event.kind;
    j["what"] = ev.event.what;
    const BootstrapConfig bc;
    addFigureIntervals(j, ghostingReplicates(ev.event.frame, eventTiles[k], eventSeedName(info.scene, ev.event.frame), bc, gc),
                       ghostingFigures(g), bc.confidence);
    j["tiles"] = eventTiles[k].toJson();
    ghosting.push_back(j);
  }
  json cuts = json::array();
  for (size_t k = 0; k < sd.cuts.size(); ++k) {
    const auto& cut = sd.cuts[k];
    const CutResult c = analyseCut(cut.frame, cut.segmentEnd, series.values("relMse"), cutLeak[k], gc);
    json j = c.toJson();
    const BootstrapConfig bc;
    addFigureIntervals(j, cutReplicates(cut.frame, cut.segmentEnd, cutTiles[k], cutSeedName(info.scene, cut.frame), bc, gc),
                       cutFigures(c, gc), bc.confidence);
    j["tiles"] = cutTiles[k].toJson();
    cuts.push_back(j);
  }
  json warnings = json::array();
  double refFloor = summarize(sd.referenceRelMse, cfg.warmup).mean;
  for (auto it = summary.begin(); it != summary.end(); ++it)
    if (it.value().contains("absent")) warnings.push_back(it.key() + " has no summary: " + it.value()["absent"].get<std::string>());
  if (summary.contains("relMse") && summary["relMse"].contains("mean") &&
      summary["relMse"]["mean"].get<double>() < 10.0 * refFloor)
    warnings.push_back("relMSE is within 10x of the reference's own noise floor (" + std::to_string(refFloor) +
                       "): the ranking on raw relMSE is unreliable; use relMseCorrected or a better reference");
  {  // issue 13: a reference that stopped at its sample cap above its target
    const std::vector<bool>& cappedReferences = sd.sequence.info().referenceCapped;
    int capped = 0;
    for (bool c : cappedReferences) capped += c;
    if (capped > 0)
      warnings.push_back(std::to_string(capped) + " of " + std::to_string(cappedReferences.size()) +
                         " reference(s) stopped at the sample cap above their target relMSE (see sequence.json "
                         "referenceEstimatedRelMse; `arena refine` can extend them)");
  }
  // Perceptual metrics cannot be corrected for reference noise: warn within 2x of their own floor.
  for (const char* name : {"ldrFlip", "hdrFlip", "ssim"}) {
    if (!sd.floors.contains(name) || !summary.contains(name) || !summary[name].contains("mean")) continue;
    const bool higherIsBetter = std::string(name) == "ssim";
    const double floor = sd.floors[name], value = summary[name]["mean"];
    const double err = higherIsBetter ? 1 - value : value, floorErr = higherIsBetter ? 1 - floor : floor;
    if (err < 2 * floorErr)
      warnings.push_back(std::string(name) + " " + std::to_string(value) + " is within 2x of the reference's own floor (" +
                         std::to_string(floor) + "): the reference's noise, not the method, dominates it");
  }
  if (sanitized > 0) warnings.push_back(std::to_string(sanitized) + " NaN/Inf input values were replaced by 0");
  json timing = timingJson(passes, series.values("ms"), cfg.warmup, w, h);
  // External processes time themselves: "ms" is what they reported, "msWall" the harness's clock
  // around the exchange (transfer included). Built-ins and plugins: the harness's clock.
  timing["msSource"] = selfTimed ? "reported by the process" : "harness wall clock";
  if (selfTimed) timing["msWallMedian"] = summarize(series.values("msWall"), cfg.warmup).median;
  json pair = {{"scene", info.scene}, {"denoiser", req.name}, {"label", req.label}, {"params", run.params().toJson()},
               {"status", "ok"}, {"frames", frames}, {"summary", summary},
               {"timing", timing}, {"ghosting", ghosting}, {"cuts", cuts},
               {"tiles", series.tilesJson()},
               {"warnings", warnings}, {"sanitizedInputs", sanitized},
               {"images", {{"dir", fs::relative(imageDir, cfg.out).string()}, {"all", keepAll && keepImages}}}};
  if (!run.info().origin.empty()) pair["origin"] = run.info().origin;
  if (run.info().signals == SignalMode::Color) pair["signals"] = "color";
  return pair;
}

// Another noise realisation of a scene's input, with its frames in memory.
struct SeedSequence {
  uint32_t inputSeed = 0;
  Sequence sequence;
  std::vector<LayerSet> frames;
};

// The bias^2 / variance split of a pair's error over the scene's input seeds (metrics/error.hpp):
// the denoiser runs on every seed's sequence from a reset history; per frame, the K outputs give
// bias^2 (error of their mean) and variance (their spread), summarised like every metric.
json biasVarianceOf(const RunConfig& cfg, const SceneData& sd, const std::vector<SeedSequence>& seeds,
                    const DenoiserRequest& req) {
  const SequenceInfo& info = sd.sequence.info();
  std::vector<std::vector<Image>> outputs(size_t(info.frames));
  auto collect = [&](const Sequence& sequence, const std::vector<LayerSet>& frames) {
    DenoiseRun run(req, sequence);
    run.run([&](int t) -> const LayerSet& { return frames[size_t(t)]; },
            [&](const DenoisedFrame& f) { outputs[size_t(f.frame)].push_back(f.color); });
  };
  collect(sd.sequence, sd.frames);
  json inputSeeds = json::array({cfg.render.inputSeed});
  for (const SeedSequence& s : seeds) {
    if (s.sequence.info().frames != info.frames) throw Error("bias/variance: seed sequences differ in frame count");
    collect(s.sequence, s.frames);
    inputSeeds.push_back(s.inputSeed);
  }
  PairSeries series(info.frames, cfg.warmup);
  json frames = json::array();
  for (int t = 0; t < info.frames; ++t) {
    std::vector<const Image*> out;
    for (const Image& i : outputs[size_t(t)]) out.push_back(&i);
    const LayerSet& ref = sd.reference(t);
    BiasVarianceTiles tiles;
    const BiasVariance bv = biasVariance(out, ref.get("color"), &ref.get("colorVar"), kRelMseEpsilon, &tiles);
    series.record("bias2", t, bv.bias2, {}, FrameTransform::Mean);
    series.record("bias2Corrected", t, bv.bias2Corrected, std::move(tiles.bias2Corrected), FrameTransform::Mean);
    series.record("variance", t, bv.variance, std::move(tiles.variance), FrameTransform::Mean);
    frames.push_back({{"frame", t}, {"bias2", bv.bias2}, {"bias2Corrected", bv.bias2Corrected}, {"variance", bv.variance}});
  }
  return {{"seeds", int(seeds.size()) + 1}, {"inputSeeds", inputSeeds},
          {"definition", "relMSE units: bias2 + variance = mean relMSE over the seeds; bias2Corrected subtracts "
                         "the reference's own noise term"},
          {"frames", frames}, {"summary", series.summaries(info.scene)}};
}

std::string clock(double s) {
  char buf[32];
  int total = int(std::lround(std::max(0.0, s)));
  std::snprintf(buf, sizeof buf, "%d:%02d", total / 60, total % 60);
  return buf;
}

}  // namespace

std::pair<int, int> parseShard(const std::string& text) {
  // Whole text, digits only: "0/1junk" or "1/4294967297" must not pass as something else.
  const std::string expected = "--shard '" + text + "': expected i/n with integers 0 <= i < n <= 100000, e.g. 0/4";
  size_t slash = text.find('/');
  auto number = [&](const std::string& digits) {
    if (digits.empty() || digits.size() > 6 || digits.find_first_not_of("0123456789") != std::string::npos)
      throw Error(expected);
    return std::stoi(digits);
  };
  if (slash == std::string::npos) throw Error(expected);
  const int i = number(text.substr(0, slash)), n = number(text.substr(slash + 1));
  if (n < 1 || n > 100000 || i >= n) throw Error(expected);
  return {i, n};
}

std::vector<std::string> failedPairs(const json& results) {
  std::vector<std::string> out;
  for (const json& p : results["pairs"])
    if (p["status"] != "ok") out.push_back(p["label"].get<std::string>() + " on " + p["scene"].get<std::string>() + ": " +
                                           p.value("error", ""));
  return out;
}

json runMatrix(const RunConfig& cfg) {
  if (cfg.out.empty()) throw Error("run: --out is required");
  if (cfg.scenes.empty()) throw Error("run: no scenes");
  if (cfg.seeds < 1 || cfg.seeds > 64) throw Error("run: --seeds " + std::to_string(cfg.seeds) + ": expected 1 to 64");
  const ExposureMode exposure = exposureModeFromName(cfg.exposure);
  std::vector<DenoiserRequest> denoisers;
  auto add = [&](DenoiserRequest r) {
    if (r.label.empty()) r.label = defaultLabel(r);
    for (auto& d : denoisers)
      if (d.label == r.label) return;
    DenoiserRegistry::instance().find(r.name);
    denoisers.push_back(std::move(r));
  };
  if (cfg.baselines)
    for (const char* baseline : {"passthrough", "temporal"}) {
      auto params = cfg.baselineParams.find(baseline);
      add({baseline, params == cfg.baselineParams.end() ? std::map<std::string, std::string>{} : params->second, ""});
    }
  for (const DenoiserRequest& r : cfg.denoisers) add(r);
  // Validate every parameter set before any work: a typo must fail in a second, not after an hour.
  for (const DenoiserRequest& r : denoisers) DenoiserRegistry::instance().find(r.name).schema.resolve(r.params, r.name);

  const bool keepAll = cfg.keepFrames == "all" || (cfg.keepFrames == "auto" && cfg.scenes.size() == 1 &&
                                                   denoisers.size() == (cfg.baselines ? 3u : 1u) && !cfg.denoisers.empty());
  checkRunOutputs(cfg.out);
  json results = {{"schema", kResultsSchemaVersion}, {"kind", "arena-run"}, {"name", cfg.name}, {"created", nowIso()},
                  {"environment", environmentInfo()},
                  {"settings", {{"render", cfg.render.pixelSettings(cfg.scenes.front())},
                                {"preset", cfg.render.preset}, {"warmup", cfg.warmup}, {"flip", cfg.flip},
                                {"seeds", cfg.seeds},
                                {"relMseEpsilon", kRelMseEpsilon},
                                {"exposure", exposureModeName(exposure)},
                                {"display", std::string(exposure == ExposureMode::PerFrame
                                                            ? "exposure from each frame's own reference"
                                                            : "exposure from the scene's first reference") +
                                                " (mean luminance -> 0.18), ACES filmic (Narkowicz 2015), clamp, sRGB"},
                                {"ghosting", GhostingConfig{}.toJson()},
                                {"oldViewLeak", "least-squares coefficient of d - r onto r(cut - 1) - r over pixels and "
                                                "channels (linear RGB), per frame cut..cut+5; 0 = nothing of the old "
                                                "view, 1 = all of it"},
                                {"tRmae", "Noisebase's form without its extra division by 3"},
                                {"flipPixelsPerDegree", 67},
                                {"shard", std::to_string(cfg.shardIndex) + "/" + std::to_string(cfg.shardCount)}}},
                  {"scenes", json::object()}, {"pairs", json::array()}};
  results["settings"]["render"].erase("width");
  results["settings"]["render"].erase("height");
  results["settings"]["render"].erase("frames");

  const size_t totalPairs = cfg.scenes.size() * denoisers.size();
  size_t pairIndex = 0, pairsDone = 0, pairsMine = 0;
  for (size_t k = 0; k < totalPairs; ++k) pairsMine += int(k % size_t(cfg.shardCount)) == cfg.shardIndex;
  const auto start = std::chrono::steady_clock::now();
  auto say = [&](const std::string& s) {
    if (cfg.progress) cfg.progress(s);
  };
  for (const Scene& scene : cfg.scenes) {
    std::vector<const DenoiserRequest*> mine;
    for (const DenoiserRequest& r : denoisers)
      if (int(pairIndex++ % size_t(cfg.shardCount)) == cfg.shardIndex) mine.push_back(&r);
    if (mine.empty()) continue;
    fs::path dir;
    std::unique_ptr<SceneData> sd;
    std::vector<SeedSequence> seedSequences;
    std::string sceneError;
    try {
      dir = renderSequence(scene, cfg.render, cfg.cache, cfg.progress);
      sd = std::make_unique<SceneData>(loadScene(scene, dir, cfg.warmup, cfg.flip, exposure));
      for (int k = 1; k < cfg.seeds; ++k) {
        RenderSettings seeded = cfg.render;
        seeded.inputSeed = cfg.render.inputSeed + uint32_t(k);
        const fs::path seedDir = renderSequence(scene, seeded, cfg.cache, cfg.progress);
        SeedSequence s{seeded.inputSeed, Sequence::open(seedDir), {}};
        for (int t = 0; t < s.sequence.info().frames; ++t) s.frames.push_back(s.sequence.frame(t));
        seedSequences.push_back(std::move(s));
      }
    } catch (const std::exception& e) {
      sceneError = e.what();
    }
    if (sd) {
      const SequenceInfo& info = sd->sequence.info();
      fs::path sceneImages = cfg.out / "images" / scene.name;
      json events = json::array();
      for (auto& e : info.events) events.push_back({{"frame", e.frame}, {"kind", e.kind}, {"what", e.what}});
      if (cfg.keepFrames != "none")
        for (int t : sd->chosenFrames) {
          writePng(sceneImages / frameName("reference", t), sd->referenceDisplayAt(t));
          writePng(sceneImages / frameName("noisy", t),
                   sd->displayAt(t).apply(sd->frames[size_t(t)].get("color")));
        }
      std::vector<double> exposures;
      for (int t = 0; t < info.frames; ++t) exposures.push_back(sd->displayAt(t).exposure);
      results["scenes"][scene.name] = {
          {"purpose", scene.purpose}, {"sequence", dir.string()}, {"hash", info.hash}, {"width", info.width},
          {"height", info.height}, {"frames", info.frames}, {"events", events},
          {"referenceSpp", info.referenceSpp}, {"referenceRelMse", sd->referenceRelMse},
          {"referenceCapped", info.referenceCapped}, {"referenceEstimatedRelMse", info.referenceEstimatedRelMse},
          {"noisyRelMse", sd->noisyRelMse}, {"exposure", exposures.front()}, {"exposurePerFrame", exposures},
          {"chosenFrames", sd->chosenFrames}, {"images", fs::relative(sceneImages, cfg.out).string()},
          {"floors", sd->floors}, {"nonFiniteInputs", sd->nonFinite}};
      // Asset scenes (issue 18): the models' credits and the loader's counted fallbacks.
      if (!scene.credits.empty() || !scene.warnings.empty()) {
        json credits = json::array();
        for (const Credit& c : scene.credits)
          credits.push_back({{"asset", c.asset},
                             {"author", c.author},
                             {"license", c.license},
                             {"source", c.source}});
        results["scenes"][scene.name]["assets"] = {{"credits", credits},
                                                   {"warnings", scene.warnings}};
      }
    }
    for (const DenoiserRequest* r : mine) {
      auto t0 = std::chrono::steady_clock::now();
      json pair;
      try {
        if (!sd) throw Error("scene " + scene.name + " could not be prepared: " + sceneError);
        pair = runPair(cfg, *sd, *r, cfg.out / "images" / scene.name / safeName(r->label), keepAll);
        if (!seedSequences.empty()) pair["biasVariance"] = biasVarianceOf(cfg, *sd, seedSequences, *r);
      } catch (const std::exception& e) {
        pair = {{"scene", scene.name}, {"denoiser", r->name}, {"label", r->label}, {"params", json::object()},
                {"status", "failed"}, {"error", e.what()}};
      }
      results["pairs"].push_back(pair);
      ++pairsDone;
      double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      char buf[512];
      std::snprintf(buf, sizeof buf, "[%zu/%zu] %s on %s: %s in %.1f s (ETA %s)", pairsDone, pairsMine, r->label.c_str(),
                    scene.name.c_str(), pair["status"] == "ok" ? "done" : "FAILED", took,
                    clock(elapsed / double(pairsDone) * double(pairsMine - pairsDone)).c_str());
      say(buf);
      if (pair["status"] != "ok") say("  error: " + pair["error"].get<std::string>());
    }
  }
  if (cfg.finish) finishRun(results, cfg);
  return results;
}

void finishRun(json& results, const RunConfig& cfg) {
  results["statistics"] = analyseRun(results);
  addReferenceQuality(results, cfg.warmup, cfg.referenceNotes);
  commitResults(cfg.out, results);
}

json replaceScenes(json results, const json& part) {
  std::map<std::string, json> newPairs;  // scene \n label -> pair
  for (const json& p : part.at("pairs")) newPairs[p.at("scene").get<std::string>() + "\n" + p.at("label").get<std::string>()] = p;
  for (auto it = part.at("scenes").begin(); it != part.at("scenes").end(); ++it) {
    if (!results["scenes"].contains(it.key())) throw Error("replaceScenes: scene " + it.key() + " is not in the run");
    results["scenes"][it.key()] = it.value();
  }
  for (json& p : results["pairs"]) {
    const std::string scene = p.at("scene").get<std::string>();
    if (!part["scenes"].contains(scene)) continue;
    const auto found = newPairs.find(scene + "\n" + p.at("label").get<std::string>());
    if (found == newPairs.end())
      throw Error("replaceScenes: pair " + p.at("label").get<std::string>() + " on " + scene + " is missing from the part");
    p = found->second;
  }
  return results;
}

json mergeRuns(const std::vector<fs::path>& runs, const fs::path& out) {
  if (runs.empty()) throw Error("merge: no runs given");
  checkRunOutputs(out);  // creates --out when missing
  json merged;
  std::set<std::string> seen;
  // A gate must not pass on a partial study: every shard i/n of one n, each exactly once.
  std::map<int, std::string> shards;
  int shardCount = 0;
  for (const fs::path& run : runs) {
    json r = loadResults(run);
    const std::string shard = r["settings"].value("shard", "");
    if (shard == "merged") throw Error(run.string() + ": already a merged run; merge the shards it came from");
    const auto [i, n] = parseShard(shard);
    if (shardCount && n != shardCount)
      throw Error(run.string() + ": shard " + shard + " is of another split than " + shards.begin()->second + "'s /" +
                  std::to_string(shardCount));
    shardCount = n;
    if (!shards.emplace(i, run.string()).second)
      throw Error(run.string() + ": shard " + shard + " is already given by " + shards[i]);
    if (merged.is_null()) {
      merged = r;
      merged["pairs"] = json::array();
      merged["scenes"] = json::object();
      merged["settings"]["shard"] = "merged";
    } else {
      json a = merged["settings"], b = r["settings"];
      a.erase("shard");
      b.erase("shard");
      if (a != b) throw Error(run.string() + ": settings differ from " + runs.front().string() + "; only shards of one run can be merged");
    }
    for (auto it = r["scenes"].begin(); it != r["scenes"].end(); ++it) merged["scenes"][it.key()] = it.value();
    for (json& p : r["pairs"]) {
      std::string key = p["scene"].get<std::string>() + "\n" + p["label"].get<std::string>();
      if (!seen.insert(key).second)
        throw Error(run.string() + ": pair " + p["label"].get<std::string>() + " on " + p["scene"].get<std::string>() +
                    " appears in two shards");
      merged["pairs"].push_back(p);
    }
  }
  std::string missing;
  for (int i = 0; i < shardCount; ++i)
    if (!shards.count(i)) missing += (missing.empty() ? "" : ", ") + std::to_string(i) + "/" + std::to_string(shardCount);
  if (!missing.empty()) throw Error("merge: incomplete shard set, missing " + missing + "; nothing was written");
  for (const fs::path& run : runs)
    if (fs::exists(run / "images"))
      fs::copy(run / "images", out / "images", fs::copy_options::recursive | fs::copy_options::skip_existing);
  merged["statistics"] = analyseRun(merged);
  addReferenceQuality(merged, merged["settings"].value("warmup", 8));
  commitResults(out, merged);
  return merged;
}

}  // namespace arena
