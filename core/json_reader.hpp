#pragma once
// Strict JSON reading for configuration files (scenes, run configs): every access knows its JSON
// path, wrong types and missing keys are errors naming the file and path, and keys that nobody
// read are errors too (pbrt's ReportUnused) -- a typo must not silently fall back to a default.
#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace arena {

class JsonReader {
 public:
  static constexpr long long kIntMin = -2147483648LL, kIntMax = 2147483647LL;

  JsonReader(const nlohmann::json& node, std::string file, std::string path = "$");

  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  const nlohmann::json& node() const { return node_; }
  bool has(const std::string& key) const;

  // Object members; `required*` throws if absent, `optional*` returns the fallback.
  JsonReader child(const std::string& key);
  std::optional<JsonReader> optionalChild(const std::string& key);
  std::vector<JsonReader> requiredArray(const std::string& key);
  std::vector<JsonReader> optionalArray(const std::string& key);
  std::vector<std::string> memberNames();  // marks nothing as read

  double number(const std::string& key);
  double number(const std::string& key, double fallback);
  // Integers must be written as integers and lie in [lo, hi] (by default the int range): a value
  // that would wrap (frames 4294967300) is an error naming it, never a silently different number.
  int integer(const std::string& key) { return integerIn(key, kIntMin, kIntMax); }
  int integer(const std::string& key, int fallback) {
    return integerIn(key, fallback, kIntMin, kIntMax);
  }
  int integerIn(const std::string& key, long long lo, long long hi);
  int integerIn(const std::string& key, int fallback, long long lo, long long hi);
  bool boolean(const std::string& key, bool fallback);
  std::string string(const std::string& key);
  std::string string(const std::string& key, const std::string& fallback);
  // Three numbers that fit a float (1e39 would become +Inf in the tracer).
  glm::vec3 vec3(const std::string& key);
  glm::vec3 vec3(const std::string& key, glm::vec3 fallback);
  std::vector<double> numbers(const std::string& key, size_t count);
  // A number, or null for a value that was not defined (NaN then); results documents write NaN so.
  double numberOrNull(const std::string& key);
  std::vector<std::string> strings(const std::string& key);
  // The member as it stands (marked read), for values a caller checks itself.
  const nlohmann::json& value(const std::string& key) { return member(key, "a value"); }

  // Throws for every member of this object that no accessor read.
  void rejectUnread() const;
  [[noreturn]] void fail(const std::string& key, const std::string& expected) const;

 private:
  const nlohmann::json& member(const std::string& key, const char* expected);
  std::string where(const std::string& key) const;
  // " (the object has "camra": a misspelling of "camera"?)" when an unread member is within two
  // edits of a missing key; empty otherwise.
  std::string misspelling(const std::string& key) const;

  const nlohmann::json& node_;
  std::string file_;
  std::string path_;
  std::set<std::string> read_;
  // The keys looked up and not found: names this object's reader knows, which rejectUnread offers
  // for an unknown field that is one of them misspelt (a document without mistakes adds none).
  mutable std::set<std::string> missing_;
};

std::string jsonTypeName(const nlohmann::json& j);
// Configuration and results documents nest a handful of levels; anything deeper than this is
// rejected before parsing, so no later recursive walk (dump, hash, destructor) can exhaust the
// stack.
constexpr int kMaxJsonDepth = 64;
// Parses `text` (read from `file`, named in errors); malformed or too deeply nested text is an
// Error.
nlohmann::json parseJsonText(const std::string& text, const std::string& file);
nlohmann::json parseJsonFile(const std::string& file);
// The text of `j` as dump(indent) writes it, a byte that is not UTF-8 in any string written as
// U+FFFD: a file name, EXR channel or process message of another encoding, quoted in a result,
// must not stop the writing of what was measured (dump() throws on it).
std::string jsonText(const nlohmann::json& j, int indent = -1);
// `text` quoted as JSON writes a string ("a\nb", U+FFFD for a byte that is not UTF-8): a name or
// file's bytes in a message that a terminal shows as written.
std::string quotedText(const std::string& text);

}  // namespace arena
