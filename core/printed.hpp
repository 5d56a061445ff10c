#pragma once
// printf into a std::string, for the benchmarks' progress lines (any length: the buffer is sized
// by a first, measuring call).
#include <cstdio>
#include <string>

namespace arena {

template <class... Args>
std::string printed(const char* format, Args... args) {
  const int length = std::snprintf(nullptr, 0, format, args...);
  if (length <= 0) return {};
  std::string text(size_t(length) + 1, '\0');
  std::snprintf(text.data(), text.size(), format, args...);
  text.resize(size_t(length));
  return text;
}

}  // namespace arena
