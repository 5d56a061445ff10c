#pragma once
// The machine and build a measurement was taken on: CPU model, cores, compiler, flags, git commit.
#include <nlohmann/json.hpp>

namespace arena {
nlohmann::json environmentInfo();
}
