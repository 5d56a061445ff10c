#pragma once
// Each subcommand of `arena` registers itself on the CLI11 app; main.cpp only dispatches.
#include <CLI/CLI.hpp>

namespace arena::cli {

void addScenesCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addRefineCommand(CLI::App& app);
void addBenchCommand(CLI::App& app);
void addStudyCommand(CLI::App& app);
void addRunCommands(CLI::App& app);
void addReportCommand(CLI::App& app);
void addCaptureCommands(CLI::App& app);  // export, import blender, validate
void addBenchReferenceCommand(CLI::App* bench);  // `arena bench reference`, under `arena bench`

// What a --denoisers list holds (the end of its error when an item is empty).
inline constexpr const char* kDenoiserListExpected =
    "registered names (`arena denoisers`), ext:MANIFEST or plugin:LIBRARY, comma-separated, or "
    "'all'";

}  // namespace arena::cli
