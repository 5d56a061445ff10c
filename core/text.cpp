#include "core/text.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <system_error>
#include <vector>

namespace arena {

namespace {

constexpr std::string_view kReplacement = "\xEF\xBF\xBD";  // U+FFFD

// The length of the well-formed sequence starting at text[i] (RFC 3629's table), 0 if none.
size_t sequenceLength(std::string_view text, size_t i) {
  const auto byte = [&](size_t k) { return uint8_t(text[k]); };
  const uint8_t b = byte(i);
  if (b < 0x80) return 1;
  size_t n = 0;
  uint8_t lo = 0x80, hi = 0xBF;  // the range of the second byte
  if (b >= 0xC2 && b <= 0xDF) {
    n = 2;
  } else if (b >= 0xE0 && b <= 0xEF) {
    n = 3;
    if (b == 0xE0) lo = 0xA0;  // no overlong forms
    if (b == 0xED) hi = 0x9F;  // no surrogates
  } else if (b >= 0xF0 && b <= 0xF4) {
    n = 4;
    if (b == 0xF0) lo = 0x90;  // no overlong forms
    if (b == 0xF4) hi = 0x8F;  // nothing beyond U+10FFFF
  } else {
    return 0;
  }
  if (i + n > text.size()) return 0;
  if (byte(i + 1) < lo || byte(i + 1) > hi) return 0;
  for (size_t k = 2; k < n; ++k)
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  return n;
}

}  // namespace

std::string validUtf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size();) {
    const size_t n = text[i] == '\0' ? 0 : sequenceLength(text, i);
    if (n == 0) {
      out += kReplacement;
      ++i;
    } else {
      out.append(text.substr(i, n));
      i += n;
    }
  }
  return out;
}

std::string shortestText(double x) {
  char buf[64];
  if (x == 0) x = 0.0;  // -0 compares equal to 0, and is written as it
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x);
  return ec == std::errc() ? std::string(buf, end) : std::to_string(x);
}

std::string utf8Excerpt(std::string_view text, size_t maxBytes, bool fromEnd) {
  if (text.size() <= maxBytes) return validUtf8(text);
  size_t begin = fromEnd ? text.size() - maxBytes : 0, end = fromEnd ? text.size() : maxBytes;
  // Move the cut off a continuation byte (10xxxxxx), at most three bytes: a character is whole or
  // left out (what is malformed anyway becomes U+FFFD).
  const auto continuation = [&](size_t k) {
    return k < text.size() && (uint8_t(text[k]) & 0xC0) == 0x80;
  };
  if (fromEnd)
    for (int k = 0; k < 3 && continuation(begin); ++k) ++begin;
  else
    for (int k = 0; k < 3 && continuation(end); ++k) --end;
  return validUtf8(text.substr(begin, end - begin));
}

size_t editDistance(std::string_view a, std::string_view b) {
  // Three rows of the table: row[j] is the distance from a's first i characters to b's first j;
  // a swap reads the row two back.
  std::vector<size_t> before(b.size() + 1), previous(b.size() + 1), row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    before.swap(previous);
    previous.swap(row);
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      row[j] = std::min(
          {previous[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1), previous[j] + 1, row[j - 1] + 1});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        row[j] = std::min(row[j], before[j - 2] + 1);
    }
  }
  return row[b.size()];
}

size_t displayWidth(std::string_view text) {
  size_t n = 0;
  for (const char c : text) n += (uint8_t(c) & 0xC0) != 0x80;
  return n;
}

std::string paddedText(std::string_view text, size_t width) {
  std::string out(text);
  const size_t w = displayWidth(text);
  if (w < width) out.append(width - w, ' ');
  return out;
}

std::string shellWord(const std::string& word) {
  static const std::string plain =
      "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-./:=,+@%";
  if (!word.empty() && word.find_first_not_of(plain) == std::string::npos) return word;
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

std::string trimmed(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t"), last = text.find_last_not_of(" \t");
  return first == std::string::npos ? "" : text.substr(first, last - first + 1);
}

std::string closestName(const std::string& name, const std::vector<std::string>& names) {
  auto lower = [](std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
  };
  const size_t limit = name.size() <= 2 ? 0 : name.size() <= 4 ? 1 : 2;
  std::string best;
  size_t bestDistance = limit + 1;
  for (const std::string& n : names) {
    const size_t d = editDistance(lower(n), lower(name));
    if (d < bestDistance) best = n, bestDistance = d;
  }
  return best;
}

}  // namespace arena
