#pragma once
// One exception type for every user-facing failure: the message names the file, field or channel
// and what was expected, so the CLI can print it as is.
#include <stdexcept>
#include <string>

namespace arena {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace arena
