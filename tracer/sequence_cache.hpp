#pragma once
// The sequence cache: where a scene's sequence lives (<cache>/<scene>-<hash>/, the hash of the scene
// and every setting that shapes its pixels), which cached files are trusted (complete, with every
// channel, written for this hash, kind and index), how references are shared between input seeds
// and low-resolution variants (one home, hard links), the .sums files that let a reference be
// extended, shards of a render and their exact merge, and the two entry points that fill it:
// renderSequence and refineSequence. tracer/render.hpp renders; this module decides what is
// rendered and keeps it.
#include <filesystem>
#include <string>
#include <vector>

#include "tracer/render.hpp"

namespace arena {

std::string sequenceHash(const Scene& scene, const RenderSettings& settings);
std::filesystem::path sequenceDir(const Scene& scene, const RenderSettings& settings,
                                  const std::filesystem::path& cacheRoot);
// The settings whose sequence directory is the home of the references of `settings`: the same
// without an input seed or a low-res buffer (references depend on neither). Its hash is the one
// reference files carry; other directories hold links to them.
RenderSettings referenceHomeSettings(RenderSettings settings);
std::filesystem::path referenceDir(const Scene& scene, const RenderSettings& settings,
                                   const std::filesystem::path& cacheRoot);

// The cache keeps each reference's sums beside its EXR (reference_NNN.sums: a magic, a JSON header
// with the sequence hash, index and sizes, then the doubles), so `arena refine` can extend it.
std::filesystem::path referenceSumsPath(const std::filesystem::path& dir, int r);
void writeReferenceSums(const std::filesystem::path& path, const ReferenceSums& sums, const std::string& hash,
                        int index);
// Throws naming the file and what is wrong (missing, foreign, truncated, malformed header).
ReferenceSums readReferenceSums(const std::filesystem::path& path, const std::string& hash, int index);
// A shard's slice of a fixed-count reference: one replicate (reference_NNN.replicate_KK.sums).
std::filesystem::path replicateSumsPath(const std::filesystem::path& dir, int r, int replicate);
// Slices holding replicates 0.., in order, as one ReferenceSums (exact: a copy).
ReferenceSums interleaveReplicates(const std::vector<ReferenceSums>& parts);

// A deterministic slice of a render's work (`arena render --shard i/n`): work unit u belongs to
// shard u mod n. Units: frame t is unit t (frame and gradients); then per reference either one unit
// (adaptive references: the stopping rule needs every replicate) or, with a fixed sample count
// (--ref-rel-error 0), one unit per replicate. A shard writes its units' files and no
// sequence.json; an unsharded render of the same settings afterwards merges (exactly: replicate
// sums are concatenated, not re-added) and renders anything still missing.
struct Shard {
  int index = 0, count = 1;
  bool owns(int unit) const { return unit % count == index; }
};

// Renders (or resumes) the sequence into <cacheRoot>/<scene>-<hash>/ and returns that directory.
std::filesystem::path renderSequence(const Scene& scene, const RenderSettings& settings,
                                     const std::filesystem::path& cacheRoot, const ProgressFn& progress,
                                     const Shard& shard = {});

// `arena refine`: extends every reference of the already rendered sequence (scene, settings) whose
// estimated relMSE is above targetRelMse, continuing its adaptive rounds until it meets the
// target or maxSpp, and rewrites its files and sequence.json. Bit-identical to rendering with that
// target in one go (the same rounds over the same samples). References that only frames
// before fromFrame use are left as they are (the study: those no summary reads,
// harness/reference_quality.hpp's firstFrameSummariesRead).
std::filesystem::path refineSequence(const Scene& scene, const RenderSettings& settings,
                                     const std::filesystem::path& cacheRoot, double targetRelMse, int maxSpp,
                                     const ProgressFn& progress, int fromFrame = 0);

}  // namespace arena
