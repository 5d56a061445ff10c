#include "tracer/sequence_cache.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/hash.hpp"
#include "core/json_reader.hpp"
#include "core/sequence.hpp"
#include "core/stage_clock.hpp"

namespace arena {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Round-trips a double exactly by default; `digits` for display.
std::string formatDouble(double v, int digits = 17) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

std::string formatSeconds(double s) {
  char buf[32];
  int total = int(std::lround(s));
  std::snprintf(buf, sizeof buf, "%d:%02d", total / 60, total % 60);
  return buf;
}

}  // namespace

std::string sequenceHash(const Scene& scene, const RenderSettings& settings) {
  json px = settings.pixelSettings(scene);
  px.erase("preset");  // a name; the values it stands for are hashed
  return Hasher().add(scene.contentHash).add(jsonText(px)).hex();
}

fs::path sequenceDir(const Scene& scene, const RenderSettings& settings, const fs::path& cacheRoot) {
  return cacheRoot / (scene.name + "-" + sequenceHash(scene, settings).substr(0, 12));
}

RenderSettings referenceHomeSettings(RenderSettings settings) {
  settings.inputSeed = 0;
  settings.lowresFactor = 0;
  settings.lowresSpp = RenderSettings().lowresSpp;
  return settings;
}

fs::path referenceDir(const Scene& scene, const RenderSettings& settings, const fs::path& cacheRoot) {
  return sequenceDir(scene, referenceHomeSettings(settings), cacheRoot);
}

fs::path referenceSumsPath(const fs::path& dir, int r) {
  return fs::path(Sequence::referencePath(dir, r)).replace_extension(".sums");
}

fs::path replicateSumsPath(const fs::path& dir, int r, int replicate) {
  char suffix[32];
  std::snprintf(suffix, sizeof suffix, ".replicate_%02d.sums", replicate);
  return fs::path(Sequence::referencePath(dir, r)).replace_extension(suffix);
}

ReferenceSums interleaveReplicates(const std::vector<ReferenceSums>& parts) {
  if (parts.empty()) throw Error("no replicate sums to merge");
  ReferenceSums out;
  out.width = parts[0].width;
  out.height = parts[0].height;
  out.tileSize = parts[0].tileSize;
  out.tileSamples = parts[0].tileSamples;
  for (const ReferenceSums& p : parts) {
    if (p.width != out.width || p.height != out.height || p.tileSize != out.tileSize ||
        p.tileSamples != out.tileSamples || p.firstReplicate != out.replicates)
      throw Error("replicate sums do not fit together (size, samples or replicate " + std::to_string(p.firstReplicate) +
                  " out of order)");
    out.replicates += p.replicates;
  }
  const size_t n = size_t(out.width) * size_t(out.height);
  constexpr int V = ReferenceSums::kValues;
  out.sum.resize(n * size_t(out.replicates) * V);
  for (size_t i = 0; i < n; ++i)
    for (const ReferenceSums& p : parts)
      std::copy_n(&p.sum[i * size_t(p.replicates) * V], size_t(p.replicates) * V,
                  &out.sum[(i * size_t(out.replicates) + size_t(p.firstReplicate)) * V]);
  return out;
}

namespace {
// Format 02: per-tile sample counts (01 had one count per replicate).
constexpr char kSumsMagic[8] = {'A', 'R', 'S', 'U', 'M', 'S', '0', '2'};
}  // namespace

void writeReferenceSums(const fs::path& path, const ReferenceSums& sums, const std::string& hash, int index) {
  const std::string header =
      json{{"hash", hash},
           {"index", index},
           {"width", sums.width},
           {"height", sums.height},
           {"replicates", sums.replicates},
           {"firstReplicate", sums.firstReplicate},
           {"tileSize", sums.tileSize},
           {"tileSamples", sums.tileSamples},
           {"roundTarget", sums.roundPending() ? sums.roundTarget : std::vector<int>{}},
           {"values", ReferenceSums::kValues},
           // Of the doubles that follow: a damaged byte there would change the refined reference.
           {"checksum", checksumHex(wordChecksum(sums.sum.data(), sums.sum.size() * 2))}}
          .dump();
  writeAtomically(path, [&](const fs::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    const uint32_t size = uint32_t(header.size());
    out.write(kSumsMagic, sizeof kSumsMagic);
    out.write(reinterpret_cast<const char*>(&size), sizeof size);
    out.write(header.data(), std::streamsize(header.size()));
    out.write(reinterpret_cast<const char*>(sums.sum.data()), std::streamsize(sums.sum.size() * sizeof(double)));
    out.flush();  // a full disk shows here, with errno still the write's (ENOSPC, EFBIG)
    if (!out) throw Error(osError(tmp, "cannot write the reference sums", errno ? errno : EIO));
  });
}

ReferenceSums readReferenceSums(const fs::path& path, const std::string& hash, int index) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw Error(path.string() + ": missing (the reference cannot be extended; re-render it with `arena render`)");
  char magic[8] = {};
  uint32_t size = 0;
  in.read(magic, sizeof magic);
  in.read(reinterpret_cast<char*>(&size), sizeof size);
  if (!in || std::memcmp(magic, kSumsMagic, sizeof magic) != 0 || size > (1u << 20))
    throw Error(path.string() + ": not a reference sums file (bad magic or header)");
  std::string header(size, '\0');
  in.read(header.data(), std::streamsize(size));
  ReferenceSums sums;
  std::string checksum;
  try {
    const json h = json::parse(header);
    if (h.at("hash").get<std::string>() != hash || h.at("index").get<int>() != index)
      throw Error(path.string() + ": written for another scene/settings or reference (hash " +
                  h.at("hash").get<std::string>() + ", index " + std::to_string(h.at("index").get<int>()) + ")");
    if (h.at("values").get<int>() != ReferenceSums::kValues)
      throw Error(path.string() + ": field 'values' is " + h.at("values").dump() + ", expected " +
                  std::to_string(ReferenceSums::kValues));
    sums.width = h.at("width").get<int>();
    sums.height = h.at("height").get<int>();
    sums.replicates = h.at("replicates").get<int>();
    sums.firstReplicate = h.at("firstReplicate").get<int>();
    sums.tileSize = h.at("tileSize").get<int>();
    sums.tileSamples = h.at("tileSamples").get<std::vector<int>>();
    sums.roundTarget = h.value("roundTarget", std::vector<int>{});  // absent before 2026-11-27: none pending
    checksum = h.value("checksum", std::string());                  // absent before 2026-11-28
  } catch (const json::exception& e) {
    throw Error(path.string() + ": malformed header: " + e.what());
  }
  if (sums.width < 1 || sums.height < 1 || sums.replicates < 1 || sums.tileSize < 1 || sums.firstReplicate < 0 ||
      sums.width > (1 << 16) || sums.height > (1 << 16) || sums.replicates > 64 ||
      sums.tileSamples.size() != size_t(sums.tilesX()) * size_t(sums.tilesY()) || sums.minPerReplicate() < 1)
    throw Error(path.string() +
                ": header has an empty or invalid size (width, height, replicates, tileSize, "
                "tileSamples: one count "
                ">= 1 per tile)");
  bool roundFits = sums.roundTarget.empty() || sums.roundTarget.size() == sums.tileSamples.size();
  for (size_t i = 0; roundFits && i < sums.roundTarget.size(); ++i) roundFits = sums.roundTarget[i] >= sums.tileSamples[i];
  if (!roundFits)
    throw Error(path.string() + ": header field 'roundTarget' must be empty or hold one count per tile, each at least "
                "the tile's 'tileSamples'");
  sums.sum.resize(size_t(sums.width) * size_t(sums.height) * size_t(sums.replicates) * ReferenceSums::kValues);
  in.read(reinterpret_cast<char*>(sums.sum.data()), std::streamsize(sums.sum.size() * sizeof(double)));
  if (!in || in.peek() != std::ifstream::traits_type::eof()) throw Error(path.string() + ": truncated or oversized");
  if (!checksum.empty() &&
      checksumHex(wordChecksum(sums.sum.data(), sums.sum.size() * 2)) != checksum)
    throw Error(
        path.string() +
        ": its sums do not match the checksum they were written with (the file is damaged)");
  return sums;
}

namespace {

// A cached file is trusted only if it is a complete EXR with every expected channel, written for
// this exact hash, kind and index.
bool cachedFileValid(const fs::path& path, const std::string& hash, const std::string& kind, int index,
                     const std::vector<LayerSpec>& specs, std::string& why) {
  if (!fs::exists(path)) {
    why = "missing";
    return false;
  }
  try {
    // A full read: a truncated tile or line only shows when its pixels are decoded.
    ExrContents contents = readExr(path, specs);
    auto attr = [&](const char* name) {
      auto it = contents.attributes.find(name);
      return it == contents.attributes.end() ? std::string() : it->second;
    };
    if (attr("arena.hash") != hash || attr("arena.kind") != kind || attr("arena.index") != std::to_string(index)) {
      why = "written for another scene/settings (foreign or stale)";
      return false;
    }
  } catch (const std::exception& e) {
    why = e.what();
    if (why.find("Early end of file") != std::string::npos || why.find("truncated") != std::string::npos)
      why = "truncated";
    return false;
  }
  return true;
}

}  // namespace

namespace {

// Writes reference r's EXR (means, variances, colorHalf; attributes: spp, estimate, capped) and its
// sums, and records them in `info`.
void writeReferenceFiles(const fs::path& dir, const std::string& hash, const std::string& sceneName, int r,
                         const ReferenceResult& ref, const ReferenceSums& sums, SequenceInfo& info) {
  ExrAttributes attrs{{"arena.hash", hash},
                      {"arena.kind", "reference"},
                      {"arena.index", std::to_string(r)},
                      {"arena.scene", sceneName},
                      {"arena.spp", std::to_string(ref.spp)},
                      {"arena.sppRange", std::to_string(ref.sppMin) + "-" + std::to_string(ref.sppMax)},
                      {"arena.estimatedRelMse", formatDouble(ref.estimatedRelMse)},
                      {"arena.capped", ref.capped ? "1" : "0"}};
  writeReferenceSums(referenceSumsPath(dir, r), sums, hash, r);
  writeExr(Sequence::referencePath(dir, r), ref.layers, channels::referenceLayers(), attrs,
           ExrCompression::None, ExrChecksums::PerChannel);
  info.referenceSpp[size_t(r)] = ref.spp;
  info.referenceEstimatedRelMse[size_t(r)] = ref.estimatedRelMse;
  info.referenceCapped[size_t(r)] = ref.capped;
}

// `remedy`: what the command that stopped it offers (render: --ref-spp; refine: --max-spp).
std::string cappedWarning(const std::string& sceneName, int r, const ReferenceResult& ref,
                          const std::string& remedy) {
  return "[" + sceneName + "] WARNING: reference " + std::to_string(r) + " stopped at its cap of " +
         std::to_string(ref.sppMax) + " spp per pixel (mean " + std::to_string(ref.spp) +
         ") with estimated relMSE " + formatDouble(ref.estimatedRelMse, 3) + " above its target " +
         formatDouble(ref.targetRelMse, 3) + " (a relMSE: a relative error of " +
         formatDouble(std::sqrt(ref.targetRelMse), 3) + "; " + remedy + ")";
}

// Makes dir's reference r the one in its home (a hard link, or a copy where links are refused),
// unless dir already holds those bytes (a complete cache is only read).
void shareReference(const fs::path& home, const fs::path& dir, int r) {
  const fs::path source = Sequence::referencePath(home, r), target = Sequence::referencePath(dir, r);
  if (fs::exists(target) && (fs::equivalent(source, target) || readText(source) == readText(target))) return;
  const fs::path tmp = fs::path(target).concat(".link.tmp");
  fs::remove(tmp);
  std::error_code linkError;
  fs::create_hard_link(source, tmp, linkError);
  if (linkError) fs::copy_file(source, tmp, fs::copy_options::overwrite_existing);
  fs::rename(tmp, target);
}

}  // namespace

fs::path refineSequence(const Scene& scene, const RenderSettings& settings,
                        const fs::path& cacheRoot, double targetRelMse, int maxSpp,
                        const ProgressFn& progress, int fromFrame) {
  if (!(targetRelMse > 0)) throw Error("refine: --target must be a positive relMSE, got " + formatDouble(targetRelMse));
  // Refinement rewrites references other processes may be reading: it waits until none is.
  const DirectoryLock lock(cacheRoot, DirectoryLock::Mode::Exclusive, DirectoryLock::IfHeld::Wait,
                           "refining the references of " + scene.name);
  StageTimer timer(Stage::Refinement);
  const fs::path dir = sequenceDir(scene, settings, cacheRoot);
  if (!fs::exists(dir / "sequence.json"))
    throw Error("refine: " + scene.name + " has no rendered sequence for these settings at " + dir.string() +
                " (run `arena render` with the same options first)");
  SequenceInfo info = Sequence::open(dir).info();
  SequenceRenderer renderer(scene, settings);
  // The references (and their sums) live in their home, shared by every input seed.
  const fs::path home = referenceDir(scene, settings, cacheRoot);
  // Refining rewrites both directories: what a killed refinement left there goes first.
  removeStaleTemporaries(dir);
  if (home != dir) removeStaleTemporaries(home);
  const std::string hash = sequenceHash(scene, referenceHomeSettings(settings));
  const int references = int(info.referenceSpp.size());
  int refined = 0;
  try {
    for (int r = 0; r < references; ++r) {
      const int firstFrame =
          int(std::find(info.referenceOfFrame.begin(), info.referenceOfFrame.end(), r) - info.referenceOfFrame.begin());
      const double before = info.referenceEstimatedRelMse[size_t(r)];
      if (before > 0 && before <= targetRelMse) continue;
      if (!info.referenceUsedFrom(r, fromFrame)) continue;
      ReferenceSums sums = readReferenceSums(referenceSumsPath(home, r), hash, r);
      const auto t0 = std::chrono::steady_clock::now();
      const ReferenceResult ref = renderer.continueReference(firstFrame, sums, targetRelMse, maxSpp);
      const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const int spp = info.referenceSpp[size_t(r)];
      writeReferenceFiles(home, hash, scene.name, r, ref, sums, info);
      ++refined;
      if (home != dir) shareReference(home, dir, r);
      if (progress) {
        progress("[" + scene.name + "] reference " + std::to_string(r) + ": " + std::to_string(spp) + " -> " +
                 std::to_string(ref.spp) + " spp, est. relMSE " + formatDouble(before, 3) + " -> " +
                 formatDouble(ref.estimatedRelMse, 3) + " in " + formatSeconds(sec));
        if (ref.capped)
          progress(cappedWarning(scene.name, r, ref, "raise --max-spp, or loosen --target"));
      }
    }
  } catch (...) {
    // A reference that fails (e.g. its sums are gone) leaves the ones before it refined on disk:
    // sequence.json records them before the error goes on, so that nothing describes them wrongly.
    if (refined > 0) writeTextAtomically(dir / "sequence.json", jsonText(info.toJson(), 1));
    throw;
  }
  info.settings["refineTargetRelMse"] = targetRelMse;
  writeTextAtomically(dir / "sequence.json", jsonText(info.toJson(), 1));
  return dir;
}

fs::path renderSequence(const Scene& scene, const RenderSettings& settings,
                        const fs::path& cacheRoot, const ProgressFn& progress, const Shard& shard) {
  if (shard.count < 1 || shard.index < 0 || shard.index >= shard.count)
    throw Error("--shard " + std::to_string(shard.index) + "/" + std::to_string(shard.count) +
                ": expected i/n with 0 <= i < n");
  // Renders share the cache (each file is written atomically); a refinement waits for them.
  const DirectoryLock lock(cacheRoot, DirectoryLock::Mode::Shared, DirectoryLock::IfHeld::Wait,
                           "rendering " + scene.name);
  StageTimer timer(Stage::Frames);  // the references inside it count as theirs
  const std::string hash = sequenceHash(scene, settings);
  const fs::path dir = sequenceDir(scene, settings, cacheRoot);
  if (!fs::is_directory(dir)) fs::create_directories(dir);
  removeStaleTemporaries(dir);  // of a killed render
  // References do not depend on the input seed or the low-res buffer: they are rendered (and
  // refined) once, in the directory of the settings without those, and linked from the others.
  const std::string refHash = sequenceHash(scene, referenceHomeSettings(settings));
  const fs::path refDir = referenceDir(scene, settings, cacheRoot);
  if (refDir != dir) {
    if (!fs::is_directory(refDir)) fs::create_directories(refDir);
    removeStaleTemporaries(refDir);
  }
  SequenceRenderer renderer(scene, settings);
  const int frames = renderer.frames();
  auto say = [&](const std::string& s) {
    if (progress) progress(s);
  };
  for (const std::string& w : scene.warnings) say("[" + scene.name + "] asset fallback: " + w);

  SequenceInfo info;
  info.scene = scene.name;
  info.purpose = scene.purpose;
  info.hash = hash;
  info.width = renderer.width();
  info.height = renderer.height();
  info.frames = frames;
  info.settings = settings.pixelSettings(scene);
  for (const SceneEvent& e : scene.events)
    if (e.frame < frames)
      info.events.push_back({e.frame, e.kind, e.what, e.kind == EventKind::ObjectMoves ? scene.meshIdOf(e.what) : -1});
  // Frames with equal animation state share one reference.
  std::map<uint64_t, int> referenceOfState;
  std::vector<int> firstFrameOfReference;
  for (int t = 0; t < frames; ++t) {
    SceneState st = evaluateState(renderer.scene(), t, renderer.width(), renderer.height());
    info.cameras.push_back(st.camera);
    auto [it, inserted] = referenceOfState.emplace(st.hash(), int(firstFrameOfReference.size()));
    if (inserted) firstFrameOfReference.push_back(t);
    info.referenceOfFrame.push_back(it->second);
  }
  const fs::path infoPath = dir / "sequence.json";

  const auto start = std::chrono::steady_clock::now();
  const int jobs = frames + int(firstFrameOfReference.size());
  int jobsDone = 0, jobsRendered = 0;
  auto report = [&](const std::string& what, const RayCounts& c, double seconds) {
    ++jobsDone;
    ++jobsRendered;
    double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    double eta = elapsed / jobsRendered * (jobs - jobsDone);
    char buf[256];
    std::snprintf(buf, sizeof buf, "[%s] %s (%d/%d)  %.2f Mpaths/s %.2f Mrays/s  ETA %s", scene.name.c_str(),
                  what.c_str(), jobsDone, jobs, double(c.paths) / seconds * 1e-6, double(c.rays) / seconds * 1e-6,
                  formatSeconds(eta).c_str());
    say(buf);
  };
  auto attributes = [&](const char* kind, int index) {
    return ExrAttributes{{"arena.hash", hash},
                         {"arena.kind", kind},
                         {"arena.index", std::to_string(index)},
                         {"arena.scene", scene.name}};
  };
  // Frames, gradient samples and low-resolution buffers are written uncompressed, as references
  // are: ZIP makes a 256x144 frame (35 channels) 2.8x smaller, but takes about 66 ms to write it
  // against 5-15 ms, while the other core waits (a frame's files are written between frames), and
  // 43 ms to read it against 26 ms. docs/performance.md, 2026-11-28 (thirteenth).
  auto writeInput = [&](const fs::path& path, const LayerSet& layers,
                        const std::vector<LayerSpec>& specs, const char* kind, int index) {
    writeExr(path, layers, specs, attributes(kind, index), ExrCompression::None,
             ExrChecksums::PerChannel);
  };

  // The low-resolution buffer's path rate on this machine, measured where it is rendered: the run
  // charges a denoiser that reads the buffer its equivalent tracing time (paths read / this rate).
  double lowresPaths = 0, lowresSeconds = 0;
  double inputPaths = 0, inputSeconds = 0;  // the 1-spp frames' (A-SVGF's gradient samples' rate)
  auto timedLowres = [&](int t) {
    RayCounts counts;
    const auto t0 = std::chrono::steady_clock::now();
    LayerSet buffer = renderer.renderLowres(t, counts);
    lowresSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    lowresPaths += double(counts.paths);
    return buffer;
  };

  int unit = 0;  // Shard's work units, numbered independently of what the cache holds
  for (int t = 0; t < frames; ++t) {
    if (!shard.owns(unit++)) continue;
    std::string why, whyGrad;
    const fs::path fp = Sequence::framePath(dir, t), gp = Sequence::gradientPath(dir, t);
    bool frameOk = cachedFileValid(fp, hash, "frame", t, channels::frameLayers(), why);
    bool gradOk = t == 0 || cachedFileValid(gp, hash, "gradients", t, channels::gradientLayers(), whyGrad);
    std::string whyLow;
    const fs::path lp = Sequence::lowresPath(dir, t);
    bool lowOk = settings.lowresFactor <= 0 || cachedFileValid(lp, hash, "lowres", t, channels::lowresLayers(), whyLow);
    if (frameOk && gradOk && !lowOk) {  // only the low-res buffer is missing
      say("[" + scene.name + "] " + (fs::exists(lp) ? "re-rendering " : "rendering ") + lp.filename().string() +
          (fs::exists(lp) ? ": " + whyLow : ""));
      writeInput(lp, timedLowres(t), channels::lowresLayers(), "lowres", t);
      lowOk = true;
    }
    if (frameOk && gradOk && lowOk) {
      ++jobsDone;
      continue;
    }
    if (fs::exists(fp) && !frameOk) say("[" + scene.name + "] re-rendering " + fp.filename().string() + ": " + why);
    if (t > 0 && fs::exists(gp) && !gradOk)
      say("[" + scene.name + "] re-rendering " + gp.filename().string() + ": " + whyGrad);
    auto t0 = std::chrono::steady_clock::now();
    SequenceRenderer::FrameResult r = renderer.renderFrame(t);
    double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    inputSeconds += sec;
    inputPaths += double(r.counts.paths);
    writeInput(fp, r.frame, channels::frameLayers(), "frame", t);
    if (t > 0) writeInput(gp, r.gradients, channels::gradientLayers(), "gradients", t);
    if (settings.lowresFactor > 0)
      writeInput(lp, timedLowres(t), channels::lowresLayers(), "lowres", t);
    report("frame " + std::to_string(t), r.counts, sec);
  }
  info.referenceSpp.assign(firstFrameOfReference.size(), 0);
  info.referenceEstimatedRelMse.assign(firstFrameOfReference.size(), 0.0);
  info.referenceCapped.assign(firstFrameOfReference.size(), false);
  // A fixed sample count (no target) splits each reference into one unit per replicate.
  const bool perReplicateUnits = !(settings.referenceRelError > 0);
  const int K = renderer.referenceReplicates();
  const int fixedPerReplicate = std::max(1, (std::max(1, settings.referenceSpp) + K - 1) / K);
  for (size_t r = 0; r < firstFrameOfReference.size(); ++r) {
    const int firstUnit = unit;
    unit += perReplicateUnits ? K : 1;
    bool mine = false;
    for (int u = firstUnit; u < unit; ++u) mine |= shard.owns(u);
    if (!mine) continue;
    std::string why;
    const fs::path rp = Sequence::referencePath(refDir, int(r));
    if (cachedFileValid(rp, refHash, "reference", int(r), channels::referenceLayers(), why)) {
      const ExrAttributes a = readExrAttributes(rp);
      info.referenceSpp[r] = std::stoi(a.at("arena.spp"));
      info.referenceEstimatedRelMse[r] = std::stod(a.at("arena.estimatedRelMse"));
      info.referenceCapped[r] = a.at("arena.capped") == "1";
      ++jobsDone;
      continue;
    }
    if (fs::exists(rp)) say("[" + scene.name + "] re-rendering " + rp.filename().string() + ": " + why);
    StageTimer referenceTimer(Stage::References);
    auto t0 = std::chrono::steady_clock::now();
    ReferenceSums sums;
    RayCounts counts;
    if (perReplicateUnits) {
      // Each replicate's sums come from its shard's slice file or are rendered here; the whole is
      // written only by an unsharded render (the merge).
      std::vector<ReferenceSums> parts;
      for (int k = 0; k < K; ++k) {
        if (!shard.owns(firstUnit + k) && shard.count > 1) continue;
        const fs::path slice = replicateSumsPath(refDir, int(r), k);
        ReferenceSums part;
        if (fs::exists(slice)) {
          try {
            part = readReferenceSums(slice, refHash, int(r));
            if (part.firstReplicate != k || part.replicates != 1 || part.minPerReplicate() != fixedPerReplicate ||
                part.maxPerReplicate() != fixedPerReplicate)
              throw Error(slice.string() + ": holds another replicate or sample count");
          } catch (const Error& e) {
            say("[" + scene.name + "] re-rendering " + slice.filename().string() + ": " + e.what());
            part = ReferenceSums();
          }
        }
        if (part.replicates == 0) {
          part = renderer.emptyReferenceSums(k, 1);
          renderer.extendReference(firstFrameOfReference[r], part, fixedPerReplicate, counts);
          if (shard.count > 1) writeReferenceSums(slice, part, refHash, int(r));
        }
        parts.push_back(std::move(part));
      }
      if (shard.count > 1) {
        double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        report("reference " + std::to_string(r) + " (" + std::to_string(parts.size()) + " replicate(s) of shard " +
                   std::to_string(shard.index) + "/" + std::to_string(shard.count) + ")",
               counts, sec);
        continue;
      }
      sums = interleaveReplicates(parts);
    }
    ReferenceResult ref = renderer.continueReference(
        firstFrameOfReference[r], sums, settings.referenceRelError * settings.referenceRelError, settings.referenceSpp);
    ref.counts += counts;
    double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    writeReferenceFiles(refDir, refHash, scene.name, int(r), ref, sums, info);
    for (int k = 0; k < K && perReplicateUnits; ++k) fs::remove(replicateSumsPath(refDir, int(r), k));
    report("reference " + std::to_string(r) + " (" + std::to_string(ref.spp) + " spp, " + std::to_string(ref.sppMin) +
               "-" + std::to_string(ref.sppMax) + " per tile, est. relMSE " + formatDouble(ref.estimatedRelMse, 3) +
               ")",
           ref.counts, sec);
    if (ref.capped)
      say(cappedWarning(scene.name, int(r), ref,
                        "raise --ref-spp, loosen --ref-rel-error, or `arena refine` it later"));
  }
  if (shard.count > 1) {
    say("[" + scene.name + "] shard " + std::to_string(shard.index) + "/" + std::to_string(shard.count) +
        " done; `arena render` without --shard merges the shards");
    return dir;
  }
  if (refDir != dir)
    for (size_t r = 0; r < firstFrameOfReference.size(); ++r) shareReference(refDir, dir, int(r));
  // A complete cache is only read: a read-only mount (or another user's cache) must stay usable.
  std::string existing;
  try {
    existing = readText(infoPath);
  } catch (const Error&) {
  }
  if (lowresSeconds > 0 && lowresPaths > 0) {
    info.lowresPathsPerSecond = lowresPaths / lowresSeconds;
  } else if (!existing.empty()) {  // nothing rendered now: keep the rate measured when it was
    try {
      info.lowresPathsPerSecond = nlohmann::json::parse(existing).value("lowresPathsPerSecond", 0.0);
    } catch (const nlohmann::json::exception&) {
    }
  }
  if (inputSeconds > 0 && inputPaths > 0) {
    info.inputPathsPerSecond = inputPaths / inputSeconds;
  } else if (!existing.empty()) {
    try {
      info.inputPathsPerSecond = nlohmann::json::parse(existing).value("inputPathsPerSecond", 0.0);
    } catch (const nlohmann::json::exception&) {
    }
  }
  const std::string infoText = jsonText(info.toJson(), 1);
  if (existing != infoText) writeTextAtomically(infoPath, infoText);
  return dir;
}

}  // namespace arena
