#include "core/json_reader.hpp"

#include <cctype>
#include <cmath>
#include <limits>
#include <map>

#include "core/atomic_file.hpp"
#include "core/error.hpp"
#include "core/text.hpp"

namespace arena {

using nlohmann::json;

JsonReader::JsonReader(const json& node, std::string file, std::string path)
    : node_(node), file_(std::move(file)), path_(std::move(path)) {
  if (!node_.is_object())
    throw Error(file_ + ": " + path_ + ": expected an object, got " + jsonTypeName(node_));
}

std::string jsonTypeName(const json& j) {
  if (j.is_null()) return "null";
  if (j.is_boolean()) return "a boolean";
  if (j.is_number()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_array()) return "an array";
  return "an object";
}

namespace {

// The deepest nesting of arrays and objects in `text`, outside strings; stops counting at `limit`
// and returns the byte offset where it was exceeded (or npos).
size_t firstTooDeep(const std::string& text, int limit) {
  int depth = 0;
  bool inString = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (inString) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        inString = false;
    } else if (c == '"') {
      inString = true;
    } else if (c == '[' || c == '{') {
      if (++depth > limit) return i;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return std::string::npos;
}

// nlohmann's DOM parser, plus a check nlohmann does not make: a key given twice in one object.
// nlohmann keeps one of the two silently, so a scene with "frames" twice would render whichever
// it kept; here it is an error naming the object's JSON path and both members' positions.
class DuplicateKeyCheckingParser : public nlohmann::detail::json_sax_dom_parser<json> {
  using Base = nlohmann::detail::json_sax_dom_parser<json>;

 public:
  DuplicateKeyCheckingParser(json& result, std::string file) : Base(result), file_(std::move(file)) {}

  bool start_object(std::size_t n) {
    enterValue();
    scopes_.push_back({true, {}, "", 0});
    return Base::start_object(n);
  }
  bool key(std::string& k) {
    Scope& s = scopes_.back();
    ++s.members;
    if (auto it = s.keys.find(k); it != s.keys.end())
      throw Error(file_ + ": " + path() + ": key \"" + k + "\" is given twice (members " +
                  std::to_string(it->second) + " and " + std::to_string(s.members) +
                  " of this object); JSON keeps only one, so remove or rename the other");
    s.keys.emplace(k, s.members);
    s.key = k;
    return Base::key(k);
  }
  bool end_object() {
    scopes_.pop_back();
    return Base::end_object();
  }
  bool start_array(std::size_t n) {
    enterValue();
    scopes_.push_back({false, {}, "", 0});
    return Base::start_array(n);
  }
  bool end_array() {
    scopes_.pop_back();
    return Base::end_array();
  }
  bool null() { return enterValue(), Base::null(); }
  bool boolean(bool v) { return enterValue(), Base::boolean(v); }
  bool number_integer(json::number_integer_t v) { return enterValue(), Base::number_integer(v); }
  bool number_unsigned(json::number_unsigned_t v) { return enterValue(), Base::number_unsigned(v); }
  bool number_float(json::number_float_t v, const std::string& s) {
    enterValue();
    // "1e-400" is not zero, but reads as 0 (below the smallest double): a value the user wrote
    // would be replaced by one they did not, and a range check would then report "got 0".
    if (v == 0 && s.find_first_of("123456789") < s.find_first_of("eE"))
      throw Error(
          file_ + ": " + path(scopes_.size()) + ": " + s +
          " is too small to be stored as a number (it would read as 0); write 0 if 0 is meant");
    return Base::number_float(v, s);
  }
  bool string(std::string& v) { return enterValue(), Base::string(v); }
  // A number beyond the double range (1e999) is named where it is, as a value too small is.
  template <class Exception>
  bool parse_error(std::size_t position, const std::string& token, const Exception& ex) {
    if (ex.id == 406) {
      enterValue();
      throw Error(file_ + ": " + path(scopes_.size()) + ": " + token +
                  " is too large to be stored as a number (beyond 1.8e308)");
    }
    return Base::parse_error(position, token, ex);
  }

 private:
  struct Scope {
    bool object;
    std::map<std::string, int> keys;  // key -> its member number (1-based)
    std::string key;                  // the member being read
    int members;                      // objects: keys seen; arrays: elements started
  };
  // A value starts: in an array it is the next element.
  void enterValue() {
    if (!scopes_.empty() && !scopes_.back().object) ++scopes_.back().members;
  }
  // The JSON path of the innermost object, as JsonReader names paths ($.camera.keys[0]).
  std::string path() const { return path(scopes_.empty() ? 0 : scopes_.size() - 1); }
  // With `depth` scopes: the value being read (all of them) rather than its object.
  std::string path(size_t depth) const {
    std::string p = "$";
    for (size_t i = 0; i < depth && i < scopes_.size(); ++i)
      p += scopes_[i].object ? "." + scopes_[i].key : "[" + std::to_string(scopes_[i].members - 1) + "]";
    return p;
  }

  std::string file_;
  std::vector<Scope> scopes_;
};

}  // namespace

json parseJsonText(const std::string& text, const std::string& file) {
  size_t deep = firstTooDeep(text, kMaxJsonDepth);
  if (deep != std::string::npos)
    throw Error(file + ": JSON nested deeper than " + std::to_string(kMaxJsonDepth) +
                " levels (at byte " + std::to_string(deep) +
                "); arena documents nest a few levels");
  try {
    json result;
    DuplicateKeyCheckingParser parser(result, file);
    json::sax_parse(text, &parser);
    return result;
  } catch (const json::parse_error& e) {
    throw Error(file + ": malformed JSON (byte " + std::to_string(e.byte) + "): " + e.what());
  } catch (const json::exception& e) {  // e.g. a number beyond double range (out_of_range.406)
    throw Error(file + ": unreadable JSON value: " + e.what());
  }
}

json parseJsonFile(const std::string& file) {
  return parseJsonText(readText(file), file);
}

std::string JsonReader::where(const std::string& key) const {
  return file_ + ": " + path_ + "." + key;
}

void JsonReader::fail(const std::string& key, const std::string& expected) const {
  throw Error(where(key) + ": " + expected);
}

std::string JsonReader::misspelling(const std::string& key) const {
  // A member not read yet, close to the missing key: the user most likely meant it ("camra" for
  // "camera").
  std::vector<std::string> unread;
  for (auto it = node_.begin(); it != node_.end(); ++it)
    if (!read_.count(it.key())) unread.push_back(it.key());
  const std::string best = closestName(key, unread);
  return best.empty() ? ""
                      : " (the object has \"" + best + "\": a misspelling of \"" + key + "\"?)";
}

bool JsonReader::has(const std::string& key) const {
  if (node_.contains(key)) return true;
  missing_.insert(key);
  return false;
}

const json& JsonReader::member(const std::string& key, const char* expected) {
  if (!node_.contains(key))
    fail(key, std::string("missing; expected ") + expected + misspelling(key));
  read_.insert(key);
  return node_.at(key);
}

JsonReader JsonReader::child(const std::string& key) {
  const json& j = member(key, "an object");
  if (!j.is_object()) fail(key, "expected an object, got " + jsonTypeName(j));
  return JsonReader(j, file_, path_ + "." + key);
}

std::optional<JsonReader> JsonReader::optionalChild(const std::string& key) {
  if (!has(key)) return std::nullopt;
  return child(key);
}

std::vector<JsonReader> JsonReader::requiredArray(const std::string& key) {
  const json& j = member(key, "an array of objects");
  if (!j.is_array()) fail(key, "expected an array of objects, got " + jsonTypeName(j));
  std::vector<JsonReader> out;
  for (size_t i = 0; i < j.size(); ++i) {
    std::string p = path_ + "." + key + "[" + std::to_string(i) + "]";
    if (!j[i].is_object())
      throw Error(file_ + ": " + p + ": expected an object, got " + jsonTypeName(j[i]));
    out.emplace_back(j[i], file_, p);
  }
  return out;
}

std::vector<JsonReader> JsonReader::optionalArray(const std::string& key) {
  if (!has(key)) return {};
  return requiredArray(key);
}

std::vector<std::string> JsonReader::memberNames() {
  std::vector<std::string> names;
  for (auto it = node_.begin(); it != node_.end(); ++it) names.push_back(it.key());
  return names;
}

double JsonReader::number(const std::string& key) {
  const json& j = member(key, "a number");
  if (!j.is_number()) fail(key, "expected a number, got " + jsonTypeName(j));
  double v = j.get<double>();
  if (!std::isfinite(v)) fail(key, "expected a finite number");
  return v;
}

double JsonReader::number(const std::string& key, double fallback) {
  return has(key) ? number(key) : fallback;
}

int JsonReader::integerIn(const std::string& key, long long lo, long long hi) {
  const json& j = member(key, "an integer");
  if (!j.is_number_integer()) fail(key, "expected an integer, got " + jsonTypeName(j));
  const std::string range =
      "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  // Compare in the type nlohmann stored, before any narrowing conversion.
  if (j.is_number_unsigned()) {
    unsigned long long v = j.get<unsigned long long>();
    if (hi < 0 || v > static_cast<unsigned long long>(hi) ||
        (lo > 0 && v < static_cast<unsigned long long>(lo)))
      fail(key, "expected " + range + ", got " + std::to_string(v));
    return int(v);
  }
  long long v = j.get<long long>();
  if (v < lo || v > hi) fail(key, "expected " + range + ", got " + std::to_string(v));
  return int(v);
}

int JsonReader::integerIn(const std::string& key, int fallback, long long lo, long long hi) {
  return has(key) ? integerIn(key, lo, hi) : fallback;
}

bool JsonReader::boolean(const std::string& key, bool fallback) {
  if (!has(key)) return fallback;
  const json& j = member(key, "a boolean");
  if (!j.is_boolean()) fail(key, "expected a boolean (true/false), got " + jsonTypeName(j));
  return j.get<bool>();
}

std::string JsonReader::string(const std::string& key) {
  const json& j = member(key, "a string");
  if (!j.is_string()) fail(key, "expected a string, got " + jsonTypeName(j));
  return j.get<std::string>();
}

std::string JsonReader::string(const std::string& key, const std::string& fallback) {
  return has(key) ? string(key) : fallback;
}

std::vector<double> JsonReader::numbers(const std::string& key, size_t count) {
  const json& j = member(key, "an array of numbers");
  std::string expected = "expected an array of " + std::to_string(count) + " numbers";
  if (!j.is_array()) fail(key, expected + ", got " + jsonTypeName(j));
  if (j.size() != count) fail(key, expected + ", got an array of " + std::to_string(j.size()));
  std::vector<double> out;
  for (const json& e : j) {
    if (!e.is_number() || !std::isfinite(e.get<double>())) fail(key, expected);
    out.push_back(e.get<double>());
  }
  return out;
}

double JsonReader::numberOrNull(const std::string& key) {
  const json& j = member(key, "a number or null");
  if (j.is_null()) return std::numeric_limits<double>::quiet_NaN();
  if (!j.is_number()) fail(key, "expected a number or null, got " + jsonTypeName(j));
  return j.get<double>();
}

std::vector<std::string> JsonReader::strings(const std::string& key) {
  const json& j = member(key, "an array of strings");
  if (!j.is_array()) fail(key, "expected an array of strings, got " + jsonTypeName(j));
  std::vector<std::string> out;
  for (size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_string())
      fail(key + "[" + std::to_string(i) + "]", "expected a string, got " + jsonTypeName(j[i]));
    out.push_back(j[i].get<std::string>());
  }
  return out;
}

glm::vec3 JsonReader::vec3(const std::string& key) {
  auto v = numbers(key, 3);
  for (double x : v)
    if (std::abs(x) > double(std::numeric_limits<float>::max()))
      fail(key, "expected values that fit a float (|v| <= 3.4e38), got " + std::to_string(x));
  return glm::vec3(float(v[0]), float(v[1]), float(v[2]));
}

glm::vec3 JsonReader::vec3(const std::string& key, glm::vec3 fallback) {
  return has(key) ? vec3(key) : fallback;
}

void JsonReader::rejectUnread() const {
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    if (read_.count(it.key())) continue;
    // The names this reader asked for and did not find: an unknown field close to one of them
    // is most likely it misspelt.
    const std::string meant = closestName(it.key(), {missing_.begin(), missing_.end()});
    throw Error(where(it.key()) + ": unknown field" +
                (meant.empty()
                     ? std::string(" (check the spelling; unknown fields are errors)")
                     : ": a misspelling of \"" + meant + "\"? (unknown fields are errors)"));
  }
}

std::string jsonText(const nlohmann::json& j, int indent) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string quotedText(const std::string& text) {
  return jsonText(nlohmann::json(text));
}

}  // namespace arena
