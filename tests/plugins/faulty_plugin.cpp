// A plugin that misbehaves (tests/external_test.cpp). Built twice: with FAULTY_PLUGIN_BAD_PARAMS
// its schema has an int parameter of default 2.5 (refused at load); without, it loads and its
// denoise() misbehaves as the environment variable ARENA_FAULTY_PLUGIN says, read per frame:
//   unterminated  fails, filling the whole error buffer without a terminator, ending in bytes
//                 that are not UTF-8
//   bad-pass      reports a pass with a NaN time and succeeds
//   slow-pass     reports a pass of 1e9 ms (longer than the call) and succeeds
//   unwritten     succeeds without writing its output
//   partial       writes only the output's first plane and succeeds
//   segfault      writes through a null pointer (a real fault, not a raised signal)
//   hang          never returns (sleeps; only an isolated plugin's process can be ended)
//   exit          calls exit(3), as a library that gives up on a driver error might
//   echo          returns the signal it was given, unchanged (an input wired in as the output)
//   reset-check   fails unless reset() was called exactly before the frames whose context says
//                 reset, after the first (a camera cut), as the harness calls it
// Otherwise it writes zeros and succeeds. The FAULTY_PLUGIN_BAD_PARAMS build reads
// ARENA_FAULTY_DESCRIPTOR when loaded: "negative-count" declares paramCount -2 with no array,
// "crash" writes through a null pointer inside arena_plugin(), "hang" never returns from it,
// "null-reset" gives no reset entry point, "duplicate-channel" requires depth twice.
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <thread>

#include "arena_plugin.h"

namespace {

// A real fault, on purpose: a write through a null pointer the compiler cannot see (volatile).
// UBSan (scripts/sanitize.sh) would stop the process first with a report of its own, so it is
// told not to check here: the tests check what arena says of a plugin's SIGSEGV.
__attribute__((no_sanitize("undefined"))) void faultOnPurpose() {
  volatile std::uintptr_t address = 0;
  *reinterpret_cast<volatile int*>(address) = 1;
}

struct Instance {
  bool resetSinceLastFrame = false;
};

void* create(const ArenaParamValue*, int, ArenaSignal, char*, size_t) {
  return new Instance;
}
int setup(void*, int, int, char*, size_t) {
  return 0;
}
void reset(void* instance) {
  static_cast<Instance*>(instance)->resetSinceLastFrame = true;
}
int denoise(void* instance, const ArenaFrameContext* ctx, const ArenaInputs* inputs,
            const ArenaMutableImage* output, const ArenaHost* host, char* error, size_t errorSize) {
  const char* mode = std::getenv("ARENA_FAULTY_PLUGIN");
  const std::string_view m = mode ? mode : "";
  Instance& self = *static_cast<Instance*>(instance);
  const bool wasReset = self.resetSinceLastFrame;
  self.resetSinceLastFrame = false;
  if (m == "reset-check" && wasReset != (ctx->reset && ctx->frameIndex > 0)) {
    std::snprintf(error, errorSize, "frame %d: reset() %s (the context says reset = %d)",
                  ctx->frameIndex, wasReset ? "was called" : "was not called", ctx->reset);
    return 1;
  }
  if (m == "unterminated") {
    std::memset(error, 'e', errorSize);
    error[errorSize - 2] = char(0xff);
    error[errorSize - 1] = char(0x80);
    return 1;
  }
  if (m == "bad-pass" && host && host->reportPass)
    host->reportPass(host->context, "blur", NAN, 1.0);
  if (m == "slow-pass" && host && host->reportPass)
    host->reportPass(host->context, "blur", 1e9, 1.0);
  if (m == "unwritten") return 0;
  if (m == "exit") std::exit(3);
  if (m == "hang")
    for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
  if (m == "segfault") faultOnPurpose();
  if (m == "echo") {
    for (int c = 0; c < output->channels; ++c)
      std::memcpy(output->planes[c], inputs->signal.planes[c],
                  sizeof(float) * size_t(output->width) * size_t(output->height));
    return 0;
  }
  const int planes = m == "partial" ? 1 : output->channels;
  for (int c = 0; c < planes; ++c)
    std::memset(output->planes[c], 0,
                sizeof(float) * size_t(output->width) * size_t(output->height));
  return 0;
}
void destroy(void* instance) {
  delete static_cast<Instance*>(instance);
}

}  // namespace

extern "C" ARENA_PLUGIN_EXPORT const ArenaPlugin* arena_plugin(void) {
#ifdef FAULTY_PLUGIN_BAD_PARAMS
  static const ArenaParamSpec params[] = {
      {"k", ARENA_PARAM_INT, 2.5, 0.5, 7.9, nullptr, 0, "taps"}};
  static const char* name = "faulty-params";
#else
  static const ArenaParamSpec* params = nullptr;
  static const char* name = "faulty";
#endif
  static ArenaPlugin plugin{};
  plugin.abiVersion = ARENA_PLUGIN_ABI_VERSION;
  plugin.name = name;
  plugin.description = "misbehaves for the tests";
  plugin.signals = ARENA_SIGNALS_DEMODULATED;
  plugin.params = params;
  plugin.paramCount = params ? 1 : 0;
#ifdef FAULTY_PLUGIN_BAD_PARAMS
  if (const char* d = std::getenv("ARENA_FAULTY_DESCRIPTOR"); d && std::string_view(d) == "crash")
    faultOnPurpose();
  if (const char* d = std::getenv("ARENA_FAULTY_DESCRIPTOR"); d && std::string_view(d) == "hang")
    for (;;) std::this_thread::sleep_for(std::chrono::seconds(1));
  if (const char* d = std::getenv("ARENA_FAULTY_DESCRIPTOR");
      d && std::string_view(d) == "negative-count") {
    plugin.params = nullptr;
    plugin.paramCount = -2;
  }
#endif
  plugin.create = create;
  plugin.setup = setup;
  plugin.reset = reset;
  plugin.denoise = denoise;
  plugin.destroy = destroy;
  plugin.requiredChannels = nullptr;
  plugin.requiredChannelCount = 0;
#ifdef FAULTY_PLUGIN_BAD_PARAMS
  if (const char* d = std::getenv("ARENA_FAULTY_DESCRIPTOR");
      d && std::string_view(d) == "null-reset")
    plugin.reset = nullptr;
  static const char* twice[] = {"depth", "normal", "depth"};
  if (const char* d = std::getenv("ARENA_FAULTY_DESCRIPTOR");
      d && std::string_view(d) == "duplicate-channel") {
    plugin.requiredChannels = twice;
    plugin.requiredChannelCount = 3;
  }
#endif
  return &plugin;
}
