#include "denoisers/external/manifest.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/sequence.hpp"
#include "core/text.hpp"

namespace arena {

namespace fs = std::filesystem;

void checkDenoiserName(const std::string& name, const std::string& where) {
  bool ok = !name.empty();
  for (char c : name)
    ok = ok && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-');
  if (!ok)
    throw Error(where + ": name '" + name +
                "' must be non-empty and use only letters, digits, '_' and '-' (it prefixes "
                "--param NAME.parameter=value)");
}

const LayerSpec& frameLayerSpec(const std::string& name, const std::string& where) {
  for (const LayerSpec& spec : channels::frameLayers())
    if (spec.name == name) return spec;
  std::vector<std::string> names;  // each once: "color" has two specs (its plain R, G, B alias)
  for (const LayerSpec& spec : channels::frameLayers())
    if (std::find(names.begin(), names.end(), spec.name) == names.end()) names.push_back(spec.name);
  std::string known;
  for (const std::string& n : names) known += " " + n;
  const std::string likely = closestName(name, names);
  throw Error(where + ": unknown layer '" + name + "'" +
              (likely.empty() ? "" : " ('" + likely + "'?)") +
              "; the sequence layers are:" + known);
}

namespace {

std::vector<std::string> stringArray(JsonReader& r, const std::string& key, bool required) {
  if (!r.has(key)) {
    if (required) r.fail(key, "missing; expected an array of strings");
    return {};
  }
  const nlohmann::json& j = r.node()[key];
  if (!j.is_array()) r.fail(key, "expected an array of strings, got " + jsonTypeName(j));
  std::vector<std::string> out;
  for (size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_string())
      r.fail(key + "[" + std::to_string(i) + "]", "expected a string, got " + jsonTypeName(j[i]));
    out.push_back(j[i].get<std::string>());
  }
  return out;
}

// Unknown fields are errors (a typo must not silently fall back to a default). JsonReader's own
// check cannot see arrays of strings as read, so the manifest lists its fields here.
// `kind` names the manifest ("a process's manifest"), `other` the other kind's fields, so that a
// reader who took the wrong kind sees both.
void rejectUnknownFields(JsonReader& r, const std::vector<std::string>& known,
                         const std::string& kind = "", const std::string& other = "") {
  for (const std::string& key : r.memberNames())
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      std::string list;
      for (const std::string& k : known) list += " " + k;
      r.fail(key,
             "unknown field (check the spelling; " +
                 (kind.empty() ? "the fields are" + list : kind + " has" + list + "; " + other) +
                 ")");
    }
}

ParamSpec readParamSpec(JsonReader& p) {
  const std::string name = p.string("name");
  const std::string type = p.string("type");
  const std::string meaning = p.string("meaning", "");
  ParamSpec spec;
  if (type == "bool") {
    spec = ParamSpec::boolean(name, p.boolean("default", false), meaning);
  } else if (type == "int" || type == "float") {
    const double min = p.number("min"), max = p.number("max");
    const double def = p.number("default");
    if (min > max) {
      std::ostringstream text;
      text << "must not exceed max (" << min << " > " << max << ")";
      p.fail("min", text.str());
    }
    if (def < min || def > max) {
      std::ostringstream text;
      text << "must lie in [min, max] (" << def << " outside [" << min << ", " << max << "])";
      p.fail("default", text.str());
    }
    if (type == "int") {
      // Each named: a whole number within a 32-bit int (3e9 was blamed on the default, and a
      // cast of it to int is undefined).
      for (const auto& [field, value] :
           {std::pair{"default", def}, std::pair{"min", min}, std::pair{"max", max}})
        if (value != std::floor(value) || value < double(INT32_MIN) || value > double(INT32_MAX)) {
          std::ostringstream text;
          text << "an int parameter's " << field << " must be a whole number from " << INT32_MIN
               << " to " << INT32_MAX << ", got " << shortestText(value);
          p.fail(field, text.str());
        }
      spec = ParamSpec::integer(name, int(def), int(min), int(max), meaning);
    } else {
      spec = ParamSpec::real(name, def, min, max, meaning);
    }
  } else if (type == "choice") {
    std::vector<std::string> choices = stringArray(p, "choices", true);
    const std::string def = p.string("default");
    if (std::find(choices.begin(), choices.end(), def) == choices.end())
      p.fail("default", "must be one of the choices");
    spec = ParamSpec::choice(name, def, std::move(choices), meaning);
  } else {
    p.fail("type", "expected one of bool, int, float, choice; got '" + type + "'");
  }
  if (!ParamSpec::validName(name))
    p.fail("name", "must be non-empty without '=', ',', '[', ']' or spaces");
  rejectUnknownFields(p, {"name", "type", "default", "min", "max", "choices", "meaning"});
  return spec;
}

double readTimeout(JsonReader& r) {
  const double seconds = r.number("timeoutSeconds", 30.0);
  // At most a day: a longer wait is no timeout (and past ~292 years its deadline overflowed).
  if (!(seconds > 0 && seconds <= 86400))
    r.fail("timeoutSeconds", "expected a positive number of seconds, at most 86400 (a day)");
  return seconds;
}

}  // namespace

nlohmann::json paramSpecJson(const ParamSpec& spec) {
  nlohmann::json j = {{"name", spec.name}};
  switch (spec.type) {
    case ParamSpec::Type::Bool:
      j["type"] = "bool";
      j["default"] = spec.defaultValue != 0;
      break;
    case ParamSpec::Type::Int:
    case ParamSpec::Type::Float:
      j["type"] = spec.type == ParamSpec::Type::Int ? "int" : "float";
      j["default"] = spec.defaultValue;
      j["min"] = spec.min;
      j["max"] = spec.max;
      break;
    case ParamSpec::Type::Choice:
      j["type"] = "choice";
      j["choices"] = spec.choices;
      j["default"] = spec.choices.at(size_t(spec.defaultValue));
      break;
  }
  if (!spec.meaning.empty()) j["meaning"] = spec.meaning;
  return j;
}

ExternalManifest readManifest(const fs::path& file) {
  if (!fs::is_regular_file(file))
    throw Error(file.string() +
                ": no such manifest file (expected a JSON manifest, see "
                "docs/external-denoisers.md)");
  nlohmann::json j;
  try {
    j = parseJsonFile(file.string());
  } catch (const Error& e) {
    // ext: given the program itself rather than its manifest (a script, a binary): said as such.
    // A manifest with a typo (it starts as JSON does) keeps the parser's message alone.
    std::string head(64, '\0');
    std::ifstream in(file, std::ios::binary);
    in.read(head.data(), std::streamsize(head.size()));
    head.resize(size_t(in.gcount()));
    const size_t first = head.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && head[first] == '{') throw;
    throw Error(std::string(e.what()) +
                " (ext: names the denoiser's JSON manifest, which names the program to run; see "
                "docs/external-denoisers.md)");
  }

  return manifestFromJson(j, file, file.string());
}

ExternalManifest manifestFromJson(const nlohmann::json& j, const fs::path& file,
                                  const std::string& where) {
  if (!j.is_object()) throw Error(where + ": expected a JSON object, got " + jsonTypeName(j));
  JsonReader r(j, where);
  ExternalManifest m;
  m.file = fs::absolute(file).lexically_normal();
  m.name = r.string("name");
  checkDenoiserName(m.name, where + ": $.name");
  m.description = r.string("description", "");
  const bool hasCommand = r.has("command"), hasLibrary = r.has("library");
  if (hasCommand == hasLibrary)
    r.fail("command",
           "give exactly one of \"command\" (an external process) and \"library\" (a C "
           "plugin)");
  if (hasLibrary) {
    m.library = r.string("library");
    if (m.library.is_relative()) m.library = m.folder() / m.library;
    m.isolated = r.boolean("isolated", false);
    if (r.has("timeoutSeconds") && !m.isolated)
      r.fail("timeoutSeconds",
             "a plugin inside arena's process has no timeout; with \"isolated\": true it runs in "
             "a process of its own, which is killed after timeoutSeconds");
    m.timeoutSeconds = readTimeout(r);
    // The rest (signals, channels, parameters) is in the library.
    rejectUnknownFields(r, {"name", "description", "library", "isolated", "timeoutSeconds"},
                        "a plugin's manifest",
                        "a process's has command signals channels parameters instead of library "
                        "isolated");
    return m;
  }
  if (r.has("isolated"))
    r.fail("isolated",
           "applies to a \"library\" (a plugin); a \"command\" already runs in a process of "
           "its own");
  m.command = stringArray(r, "command", true);
  if (m.command.empty() || m.command[0].empty()) r.fail("command", "must name a program to start");
  const std::string signals = r.string("signals");
  if (signals == "demodulated")
    m.signals = SignalMode::Demodulated;
  else if (signals == "color")
    m.signals = SignalMode::Color;
  else
    r.fail("signals",
           "expected \"demodulated\" (one process per diffuse and specular signal, "
           "remodulated by the harness) or \"color\" (one process on the colour)");
  m.channels = stringArray(r, "channels", false);
  for (size_t i = 0; i < m.channels.size(); ++i) {
    const std::string at = where + ": $.channels[" + std::to_string(i) + "]";
    frameLayerSpec(m.channels[i], at);
    // Twice, its planes would be sent twice under the same names: a process that maps planes by
    // name keeps one and loses the other's place.
    for (size_t k = 0; k < i; ++k)
      if (m.channels[k] == m.channels[i])
        throw Error(at + ": '" + m.channels[i] + "' is already $.channels[" + std::to_string(k) +
                    "]; name each layer once");
  }
  std::vector<ParamSpec> specs;
  for (JsonReader& p : r.optionalArray("parameters")) {
    specs.push_back(readParamSpec(p));
    for (size_t k = 0; k + 1 < specs.size(); ++k)
      if (specs[k].name == specs.back().name)
        p.fail("name", "'" + specs.back().name + "' given twice");
  }
  m.schema = ParamSchema(std::move(specs));
  m.timeoutSeconds = readTimeout(r);
  rejectUnknownFields(
      r, {"name", "description", "command", "signals", "channels", "parameters", "timeoutSeconds"},
      "a process's manifest",
      "a plugin's has library isolated instead of command signals channels parameters");
  return m;
}

}  // namespace arena
