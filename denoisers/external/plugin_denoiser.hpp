#pragma once
// The host side of include/arena_plugin.h: loads a plugin library with dlopen, checks its ABI
// version, turns its C descriptor into a registry entry (the same typed schema, channels and
// signal mode as a built-in) and wraps each instance as a Denoiser. The images handed over are
// views of the harness's own planes (zero copy); the call is timed like any built-in's.
#include <filesystem>

#include "denoisers/denoiser.hpp"

namespace arena {

// Throws an Error naming the library when it cannot be loaded, lacks the entry point, was built
// for another ABI version or describes itself inconsistently.
DenoiserInfo loadPluginDenoiser(const std::filesystem::path& library);

}  // namespace arena
