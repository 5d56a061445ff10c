#include "core/json_reader.hpp"

#include <cmath>

#include "core/atomic_file.hpp"
#include "core/error.hpp"

namespace arena {

using nlohmann::json;

JsonReader::JsonReader(const json& node, std::string file, std::string path)
    : node_(node), file_(std::move(file)), path_(std::move(path)) {
  if (!node_.is_object()) throw Error(file_ + ": " + path_ + ": expected an object, got " + jsonTypeName(node_));
}

std::string jsonTypeName(const json& j) {
  if (j.is_null()) return "null";
  if (j.is_boolean()) return "a boolean";
  if (j.is_number()) return "a number";
  if (j.is_string()) return "a string";
  if (j.is_array()) return "an array";
  return "an object";
}

json parseJsonFile(const std::string& file) {
  std::string text = readText(file);
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    throw Error(file + ": malformed JSON (byte " + std::to_string(e.byte) + "): " + e.what());
  }
}

std::string JsonReader::where(const std::string& key) const { return file_ + ": " + path_ + "." + key; }

void JsonReader::fail(const std::string& key, const std::string& expected) const {
  throw Error(where(key) + ": " + expected);
}

bool JsonReader::has(const std::string& key) const { return node_.contains(key); }

const json& JsonReader::member(const std::string& key, const char* expected) {
  if (!node_.contains(key)) fail(key, std::string("missing; expected ") + expected);
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
    if (!j[i].is_object()) throw Error(file_ + ": " + p + ": expected an object, got " + jsonTypeName(j[i]));
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

int JsonReader::integer(const std::string& key) {
  const json& j = member(key, "an integer");
  if (!j.is_number_integer()) fail(key, "expected an integer, got " + jsonTypeName(j));
  return j.get<int>();
}

int JsonReader::integer(const std::string& key, int fallback) { return has(key) ? integer(key) : fallback; }

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
  if (!j.is_array() || j.size() != count) fail(key, expected + ", got " + jsonTypeName(j));
  std::vector<double> out;
  for (const json& e : j) {
    if (!e.is_number() || !std::isfinite(e.get<double>())) fail(key, expected);
    out.push_back(e.get<double>());
  }
  return out;
}

glm::vec3 JsonReader::vec3(const std::string& key) {
  auto v = numbers(key, 3);
  return glm::vec3(float(v[0]), float(v[1]), float(v[2]));
}

glm::vec3 JsonReader::vec3(const std::string& key, glm::vec3 fallback) {
  return has(key) ? vec3(key) : fallback;
}

void JsonReader::rejectUnread() const {
  for (auto it = node_.begin(); it != node_.end(); ++it) {
    if (!read_.count(it.key()))
      throw Error(where(it.key()) + ": unknown field (check the spelling; unknown fields are errors)");
  }
}

}  // namespace arena
