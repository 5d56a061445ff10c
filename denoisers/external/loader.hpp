#pragma once
// Turns a `--denoisers` entry naming an external denoiser into a registry entry:
//   ext:PATH.json       a manifest file
//   ext:DIR             a folder holding manifest.json
//   ext:NAME            NAME.json or NAME/manifest.json in a folder of ARENA_DENOISER_PATH
//                       (colon-separated folders, searched in order)
//   plugin:LIBRARY.so   a C plugin (include/arena_plugin.h)
// A manifest with "library" loads that plugin (with "isolated": true, each instance runs in a
// process of its own, `arena serve`); one with "command" runs a process per sequence and signal
// (process_denoiser.hpp).
#include <filesystem>
#include <string>
#include <vector>

#include "denoisers/denoiser.hpp"

namespace arena {

bool isExternalEntry(const std::string& entry);
DenoiserInfo loadExternalDenoiser(const std::string& entry);

// The program that serves an isolated plugin (`arena serve`): the one set here (the arena command
// line sets its own executable), else $ARENA_EXECUTABLE; throws an Error saying so when neither is.
void setServeExecutable(std::string path);
std::string serveExecutable();

// The manifests found on ARENA_DENOISER_PATH (for `arena denoisers`).
std::vector<std::filesystem::path> manifestsOnSearchPath();

}  // namespace arena
