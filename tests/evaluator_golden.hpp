#pragma once
// The run whose results.json the evaluation stage must reproduce bit for bit (issue 28's move of
// every metric out of the harness): three tiny scenes with a light event, a moving object and a
// camera cut, every kind of baseline and three filters, two input seeds (bias/variance). What the
// golden keeps is everything that does not depend on the clock or on paths.
#include <nlohmann/json.hpp>
#include <string>

#include "core/hash.hpp"
#include "harness/run_matrix.hpp"
#include "tests/test_util.hpp"

namespace arena::test {

inline RunConfig goldenRunConfig(const std::filesystem::path& out, const std::filesystem::path& cache) {
  RunConfig c;
  c.name = "golden";
  c.out = out;
  c.cache = cache;
  c.render = tinySettings(40, 24, 16, 32);
  c.scenes = {shippedScene("light_switch"), shippedScene("moving_object"), shippedScene("camera_cut")};
  c.denoisers = {{"svgf", {}, ""}, {"asvgf", {}, ""}, {"reblur", {}, ""}};
  c.warmup = 4;
  c.flip = "all";
  c.keepFrames = "none";
  c.seeds = 2;
  return c;
}

// A bulky entry (tile sums in base64, every paired difference) as the hash of its JSON text: compared
// bit for bit without keeping hundreds of kilobytes of it in the repository.
inline void hashEntry(nlohmann::json& owner, const char* key) {
  if (!owner.contains(key)) return;
  owner[std::string(key) + "Hash"] = Hasher().add(owner[key].dump()).hex();
  owner.erase(key);
}

// The results without what the clock or the machine decides (times, dates, paths, environment).
inline nlohmann::json goldenPart(nlohmann::json r) {
  for (const char* k : {"created", "environment"}) r.erase(k);
  for (auto& [name, scene] : r["scenes"].items()) {
    scene.erase("sequence");
    scene.erase("images");
    // The suggested refine command names the run's cache, a directory of this process's.
    if (scene.contains("referenceQuality") && scene["referenceQuality"].contains("verdict")) {
      std::string verdict = scene["referenceQuality"]["verdict"];
      const size_t at = verdict.find(" --cache ");
      if (const size_t end = verdict.find(" --target", at);
          at != std::string::npos && end != std::string::npos)
        verdict.replace(at + 9, end - (at + 9), "CACHE");
      scene["referenceQuality"]["verdict"] = verdict;
    }
  }
  for (nlohmann::json& p : r["pairs"]) {
    p.erase("timing");
    p.erase("images");
    for (const char* m : {"ms", "msWall", "tracingMs"}) {
      if (p.contains("summary")) p["summary"].erase(m);
      if (p.contains("tiles")) p["tiles"].erase(m);
      if (p.contains("frames"))
        for (nlohmann::json& f : p["frames"]) f.erase(m);
    }
    hashEntry(p, "tiles");
    for (const char* k : {"ghosting", "cuts"})
      if (p.contains(k))
        for (nlohmann::json& e : p[k]) hashEntry(e, "tiles");
  }
  // Per scene the ranking stays readable; every paired difference, the other metrics' rankings and
  // the event figures' rankings are compared through their hash.
  if (r.contains("statistics") && r["statistics"].contains("scenes"))
    for (auto& [name, scene] : r["statistics"]["scenes"].items())
      for (const char* k : {"byMetric", "events", "cuts", "pairs"}) hashEntry(scene, k);
  return r;
}

}  // namespace arena::test
