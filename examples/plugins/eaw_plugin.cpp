// The built-in `eaw` (Dammertz et al. 2010) as a C plugin named `eaw-plugin`: the same code behind
// include/arena_plugin.h, to show that a plugin's output and timing match the built-in's
// (tests/external_test.cpp; `arena bench denoise --denoisers eaw --plugin ...`).
#include "denoisers/variants.hpp"
#include "examples/plugins/builtin_plugin.hpp"

extern "C" ARENA_PLUGIN_EXPORT const ArenaPlugin* arena_plugin(void) {
  static const arena::plugin::BuiltinPlugin exported(arena::eawInfo(), "eaw-plugin");
  return exported.descriptor();
}
