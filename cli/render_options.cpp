#include "cli/render_options.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "harness/scene_selection.hpp"

namespace arena::cli {

// Unset overrides are 0 (or -1): the CLI checks below reject those values when given explicitly, so
// "0" can never quietly mean "the default".
RenderSettings RenderOptions::settings() const {
  RenderSettings s = RenderSettings::fromPreset(preset);
  if (!resolution.empty())
    std::tie(s.width, s.height) = parseResolution("--resolution", resolution);
  if (frames > 0) s.frames = frames;
  if (referenceSpp > 0) {
    s.referenceSpp = referenceSpp;
    s.referenceMinSpp = std::min(s.referenceMinSpp, referenceSpp);
  }
  if (referenceRelError >= 0) s.referenceRelError = referenceRelError;
  s.maxBounces = maxBounces;
  if (inputSeed < 0 || inputSeed > 0xffffffffll)
    throw Error("--input-seed " + std::to_string(inputSeed) + ": expected 0 to 4294967295");
  s.inputSeed = uint32_t(inputSeed);
  s.referenceSampler = referenceSampler;
  s.referenceTile = referenceTile;
  if (lowresFactor < -1 || lowresFactor == 1)
    throw Error("--lowres-factor " + std::to_string(lowresFactor) + ": expected 0 (none) or a block size >= 2");
  if (lowresSpp < 1 || lowresSpp > 4096)
    throw Error("--lowres-spp " + std::to_string(lowresSpp) + ": expected a count in [1, 4096]");
  s.lowresFactor = std::max(lowresFactor, 0);
  s.lowresSpp = lowresSpp;
  return s;
}

CLI::Validator finiteRange(double lo, double hi) {
  const std::string range =
      "[" + CLI::detail::to_string(lo) + ", " + CLI::detail::to_string(hi) + "]";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double v = 0;
        if (!CLI::detail::lexical_cast(text, v) || !std::isfinite(v) || v < lo || v > hi)
          return "value " + text + " is not a finite number in " + range;
        return "";
      },
      "FLOAT in " + range);
}

CLI::Validator writableFile(const std::string& writer) {
  return CLI::Validator(
      [writer](std::string& text) -> std::string {
        namespace fs = std::filesystem;
        std::error_code ec;
        if (text.empty()) return "an empty file name; expected the JSON file to write";
        if (text == "-")
          return "'-' would be a file of that name (standard output is not written here); expected "
                 "a file name";
        if (text.back() == '/') return text + " ends in a folder separator; expected a file name";
        const fs::path path = text;
        // A link would be replaced by the file, not written through: named as what it is.
        if (fs::is_symlink(fs::symlink_status(path, ec)))
          return text + " is a symbolic link (the file would replace it); name the file itself";
        const fs::file_status status = fs::status(path, ec);
        if (fs::is_directory(status)) return text + " is a directory; expected a file name";
        if (fs::exists(status) && !fs::is_regular_file(status))
          return text +
                 " is not a regular file (a device, a pipe or a socket); expected a file to write";
        if (fs::is_regular_file(status)) {
          // Replaced only where this writer wrote it: anything else is somebody's data.
          const std::string refuse =
              text + " exists and is not a file `arena " + writer + "` wrote (";
          const std::string remedy = "); name a new file, or remove this one to replace it";
          const auto size = fs::file_size(path, ec);
          if (ec || size >= (16u << 20))
            return refuse + "a bench's JSON is smaller than its " + std::to_string(size >> 20) +
                   " MiB" + remedy;
          std::ifstream in(path);
          if (!in)
            return text + ": cannot be read (" + std::strerror(errno) +
                   "); expected a file to write";
          const nlohmann::json earlier =
              nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
          const bool marked = earlier.is_object() && earlier.contains("arenaBench") &&
                              earlier["arenaBench"].is_string() &&
                              earlier["arenaBench"].get<std::string>() == writer;
          // Files of builds before the mark (2026-12-07) have none: removed once by hand.
          if (!marked)
            return refuse + "no \"arenaBench\": \"" + writer +
                   "\" in it; a bench's JSON of a build before that mark has none either" + remedy;
        }
        // Missing folders are created when it is written; one that exists as a file cannot be.
        fs::path existing = ".";
        for (fs::path folder = path.parent_path(); !folder.empty(); folder = folder.parent_path()) {
          if (fs::exists(folder, ec)) {
            if (!fs::is_directory(folder, ec))
              return text + ": " + folder.string() + " is not a directory";
            existing = folder;
            break;
          }
          if (folder == folder.parent_path()) break;
        }
        // A folder that takes no file (read-only, /proc) is found now, not after the work.
        const fs::path probe = temporaryPathFor(existing / "probe");
        {
          std::ofstream out(probe);
          if (!out)
            return text + ": cannot create a file in " + existing.string() + " (" +
                   std::strerror(errno) + ")";
        }
        fs::remove(probe, ec);
        return "";
      },
      "FILE");
}

void writeMarkedJson(const std::string& path, const std::string& writer, nlohmann::json out) {
  out["arenaBench"] = writer;
  writeTextAtomically(path, jsonText(out, 2));
}

CLI::Validator lowresFactorCheck(int max) {
  return CLI::Validator(
      [max](std::string& text) -> std::string {
        int v = -1;
        const bool integer = CLI::detail::lexical_cast(text, v);
        if (!integer || v < 0 || v == 1 || v > max)
          return "--lowres-factor " + text + ": expected 0 (none) or a block size in [2, " +
                 std::to_string(max) + "]";
        return "";
      },
      "INT in [0 or 2 - " + std::to_string(max) + "]");
}

void addRenderOptions(CLI::App* cmd, RenderOptions& o) {
  cmd->add_option("--preset", o.preset,
                  "quick (the scene's resolution) or paper (1280x720, 4096 spp)")
      ->check(CLI::IsMember({"quick", "paper"}))
      ->default_str("quick");
  cmd->add_option("--resolution", o.resolution, "Override the resolution, WIDTHxHEIGHT")
      ->default_str("the scene's; paper: 1280x720");
  cmd->add_option("--frames", o.frames,
                  "Override the frame count (a run or study summarises only the frames after its "
                  "--warmup, 8 by default)")
      ->check(CLI::Range(1, kMaxSceneFrames))
      ->default_str("the scene's");
  cmd->add_option(
         "--ref-spp", o.referenceSpp,
         "Maximum samples per pixel of the references (rounded up to a multiple of their 4 "
         "replicates)")
      ->check(CLI::Range(1, 1 << 20))
      ->default_str("quick: 512, paper: 4096");
  cmd->add_option("--ref-rel-error", o.referenceRelError,
                  "Adaptive stopping: stop a reference when its estimated relative error is below "
                  "this (0: off)")
      ->check(finiteRange(0.0, 1.0))
      ->default_str("quick: 0.01, paper: 0");
  cmd->add_option("--max-bounces", o.maxBounces, "Override the scene's maximum path length")
      ->check(CLI::Range(1, 64))
      ->default_str("the scene's");
  cmd->add_option("--input-seed", o.inputSeed,
                  "Another noise realisation of the 1-spp input (0: the scene's seed); references are unchanged")
      ->default_val(0);
  cmd->add_option("--ref-sampler", o.referenceSampler,
                  "References' sampler: sobol (Owen-scrambled, default) or independent (1-spp frames: always independent)")
      ->check(CLI::IsMember({"sobol", "independent"}));
  cmd->add_option("--ref-tile", o.referenceTile,
                  "Adaptive allocation of reference samples per tile of this many pixels square, "
                  "toward --ref-rel-error (0: one tile, every pixel the same count)")
      ->check(CLI::Range(0, 1024))
      ->default_val(8);
  cmd->add_option(
         "--lowres-factor", o.lowresFactor,
         "Also render a low-resolution, many-sample buffer per frame, one texel per FxF block "
         "(CAPCOM 2023 disocclusion rays; 0: none)")
      ->check(lowresFactorCheck(1 << 16))
      ->default_str(
          "run, sweep, study: 8 when a denoiser reads it (reengine's disocclusionRays=auto or on), "
          "else none; render: none");
  cmd->add_option("--lowres-spp", o.lowresSpp, "Paths per low-resolution texel (default 16)");
  cmd->add_option("--cache", o.cacheDir, "Sequence cache directory")->default_val("cache");
  cmd->add_option("--scenes-dir", o.scenesDir, "Directory of scene files")
      ->default_str(o.scenesDir);
}

}  // namespace arena::cli
