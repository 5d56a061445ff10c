#pragma once
// The host side of include/arena_plugin.h: loads a plugin library with dlopen, checks its ABI
// version, turns its C descriptor into a registry entry (the same typed schema, channels and
// signal mode as a built-in) and wraps each instance as a Denoiser. The images handed over are
// views of the harness's own planes (zero copy); the call is timed like any built-in's.
#include <filesystem>
#include <string>
#include <vector>

#include "denoisers/denoiser.hpp"

namespace arena {

// Throws an Error naming the library when it cannot be loaded, lacks the entry point, was built
// for another ABI version or describes itself inconsistently. `channels`, when given, receives
// the layers the plugin reads (its requiredChannels), known without making an instance.
DenoiserInfo loadPluginDenoiser(const std::filesystem::path& library,
                                std::vector<std::string>* channels = nullptr);

// What a plugin's crash note (core/crash_note.hpp) says the crash costs, after "...; ". By default
// that arena stops and writes no results; `arena serve`, the process of its own that an isolated
// plugin runs in, says that the harness fails that pair alone.
void setPluginCrashConsequence(std::string text);

}  // namespace arena
