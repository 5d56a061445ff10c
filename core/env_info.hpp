#pragma once
// The machine and build a measurement was taken on: CPU model, cores, load average at the start
// (null where unknown), compiler, flags, and the
// commit the binary was built from ("<hash>-dirty" when tracked files had uncommitted changes).
#include <nlohmann/json.hpp>
#include <string>

namespace arena {
nlohmann::json environmentInfo();
// Now, as an ISO 8601 UTC timestamp (2026-11-25T22:10:08Z): when a result was created.
std::string utcTimestamp();
// Whether `text` is such a timestamp: the form above exactly, a date that exists and a time of day.
// Runs are ordered by it (the history, the gate's previous run), so another form would misorder
// them.
bool isUtcTimestamp(const std::string& text);
}
