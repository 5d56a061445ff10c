#include "denoisers/params.hpp"

#include <charconv>
#include <cmath>
#include <regex>
#include <sstream>

#include "core/error.hpp"
#include "core/text.hpp"

namespace arena {

ParamSpec ParamSpec::boolean(std::string name, bool def, std::string meaning) {
  return {std::move(name), Type::Bool, def ? 1.0 : 0.0, 0, 1, {}, std::move(meaning)};
}
ParamSpec ParamSpec::integer(std::string name, int def, int min, int max, std::string meaning) {
  return {std::move(name), Type::Int, double(def), double(min), double(max), {}, std::move(meaning)};
}
ParamSpec ParamSpec::real(std::string name, double def, double min, double max, std::string meaning) {
  return {std::move(name), Type::Float, def, min, max, {}, std::move(meaning)};
}
ParamSpec ParamSpec::choice(std::string name, std::string def, std::vector<std::string> choices, std::string meaning) {
  double index = -1;  // not among the choices: problem() says so
  for (size_t i = 0; i < choices.size(); ++i)
    if (choices[i] == def) index = double(i);
  return {std::move(name), Type::Choice, index, 0, 0, std::move(choices), std::move(meaning)};
}

static std::string formatNumber(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

bool ParamSpec::validName(const std::string& name) {
  return !name.empty() && name.find_first_of("=,[] ") == std::string::npos;
}

std::string ParamSpec::problem() const {
  if (!validName(name))
    return "'" + name + "': a name must be non-empty without '=', ',', '[', ']' or spaces";
  if (meaning.empty()) return "'" + name + "': no meaning (arena denoisers lists it)";
  if (type == Type::Choice && !(defaultValue >= 0 && defaultValue < double(choices.size())))
    return "'" + name + "': its default is not one of its choices";
  if (type != Type::Int && type != Type::Float) return "";
  const std::string range = "[" + formatNumber(min) + ", " + formatNumber(max) + "]";
  if (!std::isfinite(min) || !std::isfinite(max))
    return "'" + name + "': its range " + range +
           " is not finite (a range bounds what a run or a sweep may pass: give the largest value "
           "that makes sense)";
  if (!(min <= max)) return "'" + name + "': its range " + range + " is inverted (min > max)";
  if (!(defaultValue >= min && defaultValue <= max))
    return "'" + name + "': its default " + formatNumber(defaultValue) +
           " lies outside its range " + range;
  return "";
}

std::string ParamSpec::describe() const {
  std::string out = name + " (";
  switch (type) {
    case Type::Bool:
      out += "bool, default " + std::string(defaultValue != 0 ? "true" : "false");
      break;
    case Type::Int:
    case Type::Float:
      out += std::string(type == Type::Int ? "int" : "float") + ", default " + formatNumber(defaultValue) +
             ", range [" + formatNumber(min) + ", " + formatNumber(max) + "]";
      break;
    case Type::Choice: {
      out += "one of";
      for (auto& c : choices) out += " " + c;
      out += ", default " + choices[size_t(defaultValue)];
      break;
    }
  }
  return out + ")" + (meaning.empty() ? "" : ": " + meaning);  // a manifest may give none
}

const ParamSet::Value& ParamSet::find(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end()) throw Error("parameter '" + name + "' is not in this parameter set");
  return it->second;
}
bool ParamSet::getBool(const std::string& name) const { return std::get<bool>(find(name)); }
int ParamSet::getInt(const std::string& name) const { return std::get<int>(find(name)); }
float ParamSet::getFloat(const std::string& name) const { return float(std::get<double>(find(name))); }
const std::string& ParamSet::getChoice(const std::string& name) const { return std::get<std::string>(find(name)); }

std::string ParamSet::text(const Value& v) {
  if (const bool* b = std::get_if<bool>(&v)) return *b ? "true" : "false";
  if (const int* i = std::get_if<int>(&v)) return std::to_string(*i);
  if (const double* d = std::get_if<double>(&v)) return shortestText(*d);
  return std::get<std::string>(v);
}

nlohmann::json ParamSet::toJson() const {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : values_) std::visit([&j, &key = k](const auto& x) { j[key] = x; }, v);
  return j;
}

const ParamSpec* ParamSchema::find(const std::string& name) const {
  for (const ParamSpec& s : specs_)
    if (s.name == name) return &s;
  return nullptr;
}

namespace {
// The float `v` is read as, written back as the shortest decimal that reads as that float.
double asReadFloat(double v) {
  const float f = float(v);
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, f);
  double shortest = 0;  // from_chars: no locale can read "0.3" as 0
  if (ec != std::errc() || std::from_chars(buf, end, shortest).ec != std::errc() ||
      float(shortest) != f)
    return double(f);
  return shortest;
}
}  // namespace

ParamSet ParamSchema::resolve(const std::map<std::string, std::string>& overrides, const std::string& owner) const {
  ParamSet out;
  for (const ParamSpec& s : specs_) {
    switch (s.type) {
      case ParamSpec::Type::Bool: out.set(s.name, s.defaultValue != 0); break;
      case ParamSpec::Type::Int: out.set(s.name, int(s.defaultValue)); break;
      case ParamSpec::Type::Float:
        out.set(s.name, floats_ ? asReadFloat(s.defaultValue) : s.defaultValue);
        break;
      case ParamSpec::Type::Choice: out.set(s.name, s.choices[size_t(s.defaultValue)]); break;
    }
  }
  for (const auto& override : overrides) {
    const std::string &name = override.first,
                      &text = override.second;  // the lambda below reads them
    const ParamSpec* s = find(name);
    if (!s) {
      std::string valid;
      std::vector<std::string> names;
      for (const ParamSpec& p : specs_) {
        valid += "\n  " + owner + "." + p.describe();
        names.push_back(p.name);
      }
      if (specs_.empty()) valid = " (none: it has no parameters)";
      const std::string meant = closestName(name, names);
      throw Error(owner + ": unknown parameter '" + name + "'" +
                  (meant.empty() ? "" : " (did you mean '" + meant + "'?)") +
                  "; valid parameters:" + valid);
    }
    auto bad = [&](const std::string& expected) {
      throw Error(owner + "." + name + "=" + text + ": expected " + expected + " (" + s->describe() + ")");
    };
    switch (s->type) {
      case ParamSpec::Type::Bool:
        if (text == "true" || text == "1" || text == "on") out.set(name, true);
        else if (text == "false" || text == "0" || text == "off") out.set(name, false);
        else
          bad("true or false in lower case (or 1/0, on/off)");
        break;
      case ParamSpec::Type::Int:
      case ParamSpec::Type::Float: {
        // Decimal notation only: std::stod would also take "0x10" (as 16), " 8" and "inf", so a
        // slip in a sweep would run a value nobody wrote.
        static const std::regex decimal(R"([+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?)");
        if (!std::regex_match(text, decimal))
          bad(s->type == ParamSpec::Type::Int
                  ? "an integer in decimal notation, e.g. 8 or 1e2"
                  : "a number in decimal notation, e.g. 8, 0.5 or 1e-3");
        size_t used = 0;
        double v = 0;
        try {
          v = std::stod(text, &used);
        } catch (...) {
          used = 0;
        }
        // stod throws out_of_range for a value beyond a double's range, either way (1e400, and
        // 1e-400, which would round to 0): neither is the number written.
        if (used != text.size() || !std::isfinite(v))
          bad("a finite number within a double's range (about 1e-308 to 1e308 in magnitude, or 0)");
        if (s->type == ParamSpec::Type::Int && v != std::floor(v)) bad("an integer");
        if (v < s->min || v > s->max)
          bad("a value in [" + formatNumber(s->min) + ", " + formatNumber(s->max) + "]");
        // Read as a float, a value beyond its range would be an infinity nobody wrote.
        if (s->type == ParamSpec::Type::Float && floats_ && !std::isfinite(float(v)))
          bad("a number within a float's range (about 3.4e38 in magnitude), which this parameter "
              "is read as");
        // ...and one too small for a float would be a 0 nobody wrote (1e-300 ran as 0 unwarned).
        if (s->type == ParamSpec::Type::Float && floats_ && v != 0 && float(v) == 0.0f)
          bad("0 or a number at least about 1.4e-45 in magnitude (the smallest a float holds), "
              "which this parameter is read as");
        if (s->type == ParamSpec::Type::Int) out.set(name, int(v));
        else
          out.set(name, floats_ ? asReadFloat(v) : v);
        break;
      }
      case ParamSpec::Type::Choice: {
        bool ok = false;
        for (auto& c : s->choices) ok = ok || c == text;
        if (!ok) bad("one of the listed choices");
        out.set(name, text);
        break;
      }
    }
  }
  return out;
}

}  // namespace arena
