#pragma once
// Turns a `--denoisers` entry naming an external denoiser into a registry entry:
//   ext:PATH.json       a manifest file
//   ext:DIR             a folder holding manifest.json
//   ext:NAME            NAME.json or NAME/manifest.json in a folder of ARENA_DENOISER_PATH
//                       (colon-separated folders, searched in order)
//   plugin:LIBRARY.so   a C plugin (include/arena_plugin.h)
// A manifest with "library" loads that plugin; one with "command" runs a process per sequence
// and signal (process_denoiser.hpp).
#include <filesystem>
#include <string>
#include <vector>

#include "denoisers/denoiser.hpp"

namespace arena {

bool isExternalEntry(const std::string& entry);
DenoiserInfo loadExternalDenoiser(const std::string& entry);

// The manifests found on ARENA_DENOISER_PATH (for `arena denoisers`).
std::vector<std::filesystem::path> manifestsOnSearchPath();

}  // namespace arena
