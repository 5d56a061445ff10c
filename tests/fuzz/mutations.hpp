#pragma once
// Deterministic mutations for the importers' always-on fuzz tests (tests/*_fuzz_test.cpp): a JSON
// value replaced, a member deleted or an element repeated; a text line's number replaced, the line
// deleted or repeated; bytes replaced, inserted or deleted, or the file cut short. The same seed
// gives the same mutants on every run.
#include <cctype>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace arena::fuzz {

// Numbers that broke importers before: float overflow, NaN and infinity spelled out, wrapping
// and negative indices, zero.
inline const std::vector<std::string> kNastyNumbers = {"nan",  "-nan", "inf",        "1e39",        "-1e39",
                                                "1e30", "0",    "-0",         "-1",          "-2",
                                                "65536", "4294967295", "4294967296", "-2147483649", "1e-45",
                                                "999999999", ""};

inline nlohmann::json nastyJson(std::mt19937& rng) {
  static const std::vector<nlohmann::json> values = {0, -1, 1, 3, 4294967295LL, 4294967296LL, 1e39, -1e39, 1e30, 1e-45,
                                           -0.0, "", "a.bin", "data:,", "/dev/zero", true, nullptr,
                                           nlohmann::json::array(), nlohmann::json::object(), nlohmann::json::array({0, 0, 0}),
                                           nlohmann::json::array({1e39, 0, 0}), nlohmann::json::array({0, 0, 0, 0}),
                                           nlohmann::json::array({1, 2})};
  return values[std::uniform_int_distribution<size_t>(0, values.size() - 1)(rng)];
}

inline void collectPointers(const nlohmann::json& j, const nlohmann::json::json_pointer& at, std::vector<nlohmann::json::json_pointer>& out) {
  out.push_back(at);
  if (j.is_object())
    for (auto& [k, v] : j.items()) collectPointers(v, at / k, out);
  else if (j.is_array())
    for (size_t i = 0; i < j.size(); ++i) collectPointers(j[i], at / i, out);
}

// A glTF document with one value replaced, a member deleted or an array element repeated.
inline std::string mutateJson(const std::string& text, std::mt19937& rng) {
  nlohmann::json doc = nlohmann::json::parse(text);
  std::vector<nlohmann::json::json_pointer> pointers;
  collectPointers(doc, nlohmann::json::json_pointer(), pointers);
  const nlohmann::json::json_pointer p = pointers[std::uniform_int_distribution<size_t>(1, pointers.size() - 1)(rng)];
  nlohmann::json& parent = doc[p.parent_pointer()];
  switch (std::uniform_int_distribution<int>(0, 3)(rng)) {
    case 0:
      if (parent.is_object())
        parent.erase(p.back());
      else if (!parent.empty())
        parent.erase(parent.begin());
      break;
    case 1:
      if (parent.is_array() && !parent.empty()) parent.push_back(parent.front());
      break;
    default:
      doc[p] = nastyJson(rng);
  }
  return doc.dump();
}

// A text file (OBJ, MTL) with one number replaced, a line deleted or repeated.
inline std::string mutateLines(const std::string& text, std::mt19937& rng) {
  std::vector<std::string> lines;
  for (size_t at = 0; at < text.size();) {
    const size_t end = text.find('\n', at);
    lines.push_back(text.substr(at, end == std::string::npos ? std::string::npos : end - at));
    at = end == std::string::npos ? text.size() : end + 1;
  }
  if (lines.empty()) return text;
  const size_t l = std::uniform_int_distribution<size_t>(0, lines.size() - 1)(rng);
  switch (std::uniform_int_distribution<int>(0, 3)(rng)) {
    case 0:
      lines.erase(lines.begin() + std::ptrdiff_t(l));
      break;
    case 1:
      lines.insert(lines.begin() + std::ptrdiff_t(l), lines[l]);
      break;
    default: {  // a number (or an index in "1/2/3") of the line
      std::string& line = lines[l];
      std::vector<std::pair<size_t, size_t>> numbers;
      for (size_t i = 0; i < line.size();) {
        if (std::isdigit(static_cast<unsigned char>(line[i])) || line[i] == '-' || line[i] == '.') {
          size_t j = i;
          while (j < line.size() && (std::isalnum(static_cast<unsigned char>(line[j])) || line[j] == '.' ||
                                     line[j] == '-' || line[j] == '+'))
            ++j;
          numbers.push_back({i, j - i});
          i = j;
        } else {
          ++i;
        }
      }
      if (numbers.empty()) break;
      const auto [at, length] = numbers[std::uniform_int_distribution<size_t>(0, numbers.size() - 1)(rng)];
      line.replace(at, length,
                   kNastyNumbers[std::uniform_int_distribution<size_t>(0, kNastyNumbers.size() - 1)(rng)]);
    }
  }
  std::string out;
  for (const std::string& line : lines) out += line + "\n";
  return out;
}

// 1-4 bytes replaced, inserted or deleted, or the file cut short.
inline std::string mutateBytes(std::string bytes, std::mt19937& rng) {
  if (bytes.empty()) return bytes;
  if (std::uniform_int_distribution<int>(0, 4)(rng) == 0)
    return bytes.substr(0, std::uniform_int_distribution<size_t>(0, bytes.size() - 1)(rng));
  const int edits = std::uniform_int_distribution<int>(1, 4)(rng);
  for (int e = 0; e < edits && !bytes.empty(); ++e) {
    const size_t at = std::uniform_int_distribution<size_t>(0, bytes.size() - 1)(rng);
    const char c = char(std::uniform_int_distribution<int>(0, 255)(rng));
    switch (std::uniform_int_distribution<int>(0, 2)(rng)) {
      case 0:
        bytes[at] = c;
        break;
      case 1:
        bytes.insert(at, 1, c);
        break;
      default:
        bytes.erase(at, 1);
    }
  }
  return bytes;
}

}  // namespace arena::fuzz
