#pragma once
// Re-exposes a built-in Denoise Arena denoiser through the C plugin ABI (include/arena_plugin.h):
// the registry entry's schema, channels and signal mode become the C descriptor, and each ABI
// call forwards to the C++ instance. The C ABI hands over views of the harness's planes and the
// adapter hands them to the built-in as borrowed arena::Images (Image::borrow): the built-in reads
// the signal and layers and writes the output in the harness's own planes, zero copy. (Planes not
// laid out like an Image's are copied; so is an output the built-in assigned instead of writing.)
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "arena_plugin.h"
#include "core/sequence.hpp"
#include "denoisers/common/parallel.hpp"
#include "denoisers/denoiser.hpp"

namespace arena::plugin {

// The C descriptor of `info`, with every string and array it points to kept alive here. One per
// library (the ABI's create() has no context pointer; the entry points find it through a static).
class BuiltinPlugin {
 public:
  BuiltinPlugin(DenoiserInfo info, std::string exportedName);
  const ArenaPlugin* descriptor() const { return &plugin_; }

 private:
  struct Instance {
    std::unique_ptr<Denoiser> denoiser;
    Image signal, output;  // borrowed views of the harness's planes (or copies, see above)
    LayerSet frame;        // the required layers, likewise
  };
  static void* create(const ArenaParamValue* values, int count, ArenaSignal signal, char* error,
                      size_t errorSize);
  static int setup(void* instance, int width, int height, char* error, size_t errorSize);
  static void reset(void* instance);
  static int denoise(void* instance, const ArenaFrameContext* ctx, const ArenaInputs* inputs,
                     const ArenaMutableImage* output, const ArenaHost* host, char* error,
                     size_t errorSize);
  static void destroy(void* instance);

  DenoiserInfo info_;
  std::string name_;
  std::vector<std::vector<const char*>> choices_;
  std::vector<ArenaParamSpec> specs_;
  std::vector<std::string> channels_;
  std::vector<const char*> channelNames_;
  ArenaPlugin plugin_{};
  static const BuiltinPlugin* exported_;
};

}  // namespace arena::plugin
