// `arena export`, `arena import blender`, `arena validate`: captures in and out (docs/captures.md).
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>

#include "cli/commands.hpp"
#include "cli/render_options.hpp"
#include "core/blender_import.hpp"
#include "core/capture.hpp"
#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "harness/scene_selection.hpp"
#include "metrics/capture_checks.hpp"
#include "metrics/evaluator.hpp"
#include "tracer/sequence_cache.hpp"

namespace arena::cli {

namespace {

void printChecks(const CaptureValidation& v) {
  // The name column as wide as the longest name: values line up whatever the checks are called.
  size_t nameWidth = 28;
  for (const CaptureCheck& c : v.checks) nameWidth = std::max(nameWidth, c.name.size() + 1);
  for (const CaptureCheck& c : v.checks) {
    std::cout << "  " << std::left << std::setw(5) << checkStatusName(c.status)
              << std::setw(int(nameWidth)) << c.name << std::right << std::setw(12)
              << std::setprecision(4);
    if (std::isnan(c.value))
      std::cout << "-";  // not measured (the detail says why)
    else
      std::cout << c.value;
    if (std::isfinite(c.failAbove)) std::cout << "  (fail above " << c.failAbove << ")";
    else if (c.status != CheckStatus::Pass) std::cout << "  (warn above " << c.warnAbove << ")";
    std::cout << (c.unit.empty() ? "" : "  " + c.unit) << (c.detail.empty() ? "" : "\n        " + c.detail) << "\n";
  }
}

// Prints every check of a capture and of its stored outputs; returns the worse verdict (a bad
// output fails validation here, while a run fails only that output's pair).
CheckStatus printValidation(const std::filesystem::path& dir) {
  const Sequence sequence = Sequence::open(dir);
  const EvaluationInput input = readSequenceForEvaluation(sequence);
  const CaptureValidation v = validateCapture(sequence, input);
  std::cout << "validation of " << dir.string() << " (" << sequence.info().scene << ", "
            << sequence.info().width << "x" << sequence.info().height << ", "
            << sequence.info().frames << " frames; layers:";
  const std::vector<std::string>& derived = sequence.capture().derived;
  for (const std::string& l : sequence.info().availableLayers())
    if (std::find(derived.begin(), derived.end(), l) == derived.end()) std::cout << " " << l;
  if (!derived.empty()) {  // computed on reading (position from depth and the cameras)
    std::cout << "; derived:";
    for (const std::string& l : derived) std::cout << " " << l;
  }
  std::cout << ")\n";
  printChecks(v);
  std::cout << "verdict: " << checkStatusName(v.status()) << "\n";
  // The checks judge the references against the input; whether they are clean enough to rank
  // methods depends on the methods' errors, which only a run measures.
  if (!input.references.empty())
    std::cout << "(whether the references are clean enough to rank methods, their noise floor "
                 "against the best method's error, is judged by `arena run`'s reference-quality "
                 "verdict, not here: validate runs no denoiser)\n";
  const CaptureValidation outputs = validateCaptureOutputs(sequence.capture(), input.references);
  if (outputs.checks.size() > 1 ||
      outputs.status() != CheckStatus::Pass) {  // more than "none undeclared"
    std::cout << "stored outputs (--denoisers file:NAME)\n";
    printChecks(outputs);
    std::cout << "verdict on the stored outputs: " << checkStatusName(outputs.status()) << "\n";
  }
  return std::max(v.status(), outputs.status());
}

}  // namespace

void addCaptureCommands(CLI::App& app) {
  {
    auto* cmd = app.add_subcommand("export", "Write a scene's cached sequence as a capture (docs/captures.md)");
    auto opt = std::make_shared<RenderOptions>();
    auto scene = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    auto outputs = std::make_shared<std::vector<std::string>>();
    cmd->add_option("scene", *scene, "Scene name or file")->required();
    cmd->add_option("--out", *out, "The capture folder to write (must not exist)")->required();
    cmd->add_option("--output", *outputs,
                    "NAME=DIR: store a denoiser's output frames (DIR/frame_NNNN.exr, as `arena run --keep-frames "
                    "all` writes them) as the capture's file:NAME contender, repeatable");
    addRenderOptions(cmd, *opt);
    cmd->callback([=] {
      const std::vector<Scene> scenes = selectScenes(*scene, opt->scenesDir, "scene");
      if (scenes.size() != 1)
        throw Error("export: one scene at a time ('" + *scene + "' names " +
                    std::to_string(scenes.size()) + ")");
      std::map<std::string, std::filesystem::path> stored;
      for (const std::string& o : *outputs) {
        const size_t eq = o.find('=');
        if (eq == std::string::npos || eq == 0 || eq + 1 == o.size())
          throw Error("--output '" + o + "': expected NAME=DIR");
        stored[o.substr(0, eq)] = o.substr(eq + 1);
        if (!isPlainName(o.substr(0, eq)))
          throw Error("--output " + quotedText(o) +
                      ": NAME must be a folder name in UTF-8 without spaces, slashes, commas or "
                      "control characters, "
                      "not . or ..");
        if (!std::filesystem::is_directory(o.substr(eq + 1)))
          throw Error("--output '" + o + "': " + o.substr(eq + 1) + " is not a folder");
      }
      // Said before the render, which can take minutes: a capture is written to a new folder.
      if (std::filesystem::exists(*out))
        throw Error(*out + ": already exists; a capture is written to a new folder");
      const auto dir = renderSequence(scenes.front(), opt->settings(), opt->cacheDir,
                                      [](const std::string& line) { std::cout << line << std::endl; });
      exportCapture(Sequence::open(dir), *out, stored);
      std::cout << "capture: " << *out << "\n";
    });
  }
  {
    auto* cmd = app.add_subcommand("import", "Turn another renderer's frames into a capture");
    cmd->require_subcommand(1);
    auto* blender = cmd->add_subcommand(
        "blender", "Blender Cycles frames written by scripts/blender/render_capture.py -> a capture, validated");
    auto source = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    auto name = std::make_shared<std::string>();
    blender->add_option("source", *source, "The folder render_capture.py wrote")->required()->check(CLI::ExistingDirectory);
    blender->add_option("--out", *out, "The capture folder to write (must not exist)")->required();
    auto viewLayer = std::make_shared<std::string>();
    blender->add_option("--name", *name, "The capture's name (default: the source folder's)");
    blender->add_option(
        "--view-layer", *viewLayer,
        "The view layer to read, where the files hold several (default: the only one)");
    blender->callback([=] {
      importBlender(*source, *out, {*name, *viewLayer});
      const CaptureDescription written = readCaptureDescription(*out);
      std::cout << "capture: " << *out << " (view layer '"
                << written.source.value("viewLayer", std::string()) << "')\n";
      if (const double share = written.source.value("normalsRenormalised", 0.0); share > 0)
        std::cout << "  normals renormalised on " << std::setprecision(3) << 100 * share
                  << std::setprecision(6)
                  << "% of the surface pixels (Cycles averages a pixel's samples: over an edge, "
                     "two normals' mean is shorter than 1)\n";
      if (printValidation(*out) == CheckStatus::Fail) throw CLI::RuntimeError(1);
    });
  }
  {
    auto* cmd = app.add_subcommand("validate", "Check a capture before ranking on it: exit 1 when a hard check fails");
    auto dir = std::make_shared<std::string>();
    cmd->add_option("capture", *dir, "A capture folder")->required()->check(CLI::ExistingDirectory);
    cmd->callback([=] {
      if (printValidation(*dir) == CheckStatus::Fail) throw CLI::RuntimeError(1);
    });
  }
}

}  // namespace arena::cli
