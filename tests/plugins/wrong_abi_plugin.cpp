// A plugin built for another ABI version (tests/external_test.cpp): the harness must refuse it
// before touching any other field.
#include "arena_plugin.h"

extern "C" ARENA_PLUGIN_EXPORT const ArenaPlugin* arena_plugin(void) {
  static ArenaPlugin plugin{};
  plugin.abiVersion = ARENA_PLUGIN_ABI_VERSION + 998u;
  plugin.name = "from-the-future";
  return &plugin;
}
