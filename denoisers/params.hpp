#pragma once
// Typed parameter schemas (pbrt's ParameterDictionary, NRD's commented settings): every tunable of
// a denoiser has a name, type, default, valid range and a one-line meaning. Unknown names and
// out-of-range values are errors that list what is valid -- a typo in a sweep must not silently
// benchmark the defaults. The resolved set is recorded with every result.
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <variant>
#include <vector>

namespace arena {

struct ParamSpec {
  enum class Type { Bool, Int, Float, Choice };
  std::string name;     // "iterations", "edge.depth", "sigmaL"
  Type type = Type::Float;
  double defaultValue = 0;  // Bool: 0/1; Choice: index into choices
  double min = 0, max = 0;  // inclusive range for Int/Float
  std::vector<std::string> choices;
  std::string meaning;  // one line, with the source of the default ("SVGF paper", "Falcor")

  static ParamSpec boolean(std::string name, bool def, std::string meaning);
  static ParamSpec integer(std::string name, int def, int min, int max, std::string meaning);
  static ParamSpec real(std::string name, double def, double min, double max, std::string meaning);
  static ParamSpec choice(std::string name, std::string def, std::vector<std::string> choices, std::string meaning);
  // What is wrong with the declaration itself, "" when nothing: a name that is empty or holds
  // '=', ',', '[', ']' or a space (a label or --param could not be read back), no meaning, a
  // range whose min exceeds its max, or a default outside its range (which --param would refuse
  // when typed, yet every run would use unasked).
  std::string problem() const;
  // Whether `name` can name a parameter: non-empty, without '=', ',', '[', ']' or spaces (a label
  // `svgf[sigmaL=4]` and `--param svgf.sigmaL=4` must read back).
  static bool validName(const std::string& name);
  std::string describe() const;  // "iterations (int, default 5, range [1, 8]): meaning"
};

class ParamSet {
 public:
  using Value = std::variant<bool, int, double, std::string>;
  bool getBool(const std::string& name) const;
  int getInt(const std::string& name) const;
  float getFloat(const std::string& name) const;
  const std::string& getChoice(const std::string& name) const;
  void set(const std::string& name, Value v) { values_[name] = std::move(v); }
  const std::map<std::string, Value>& values() const { return values_; }
  nlohmann::json toJson() const;
  // One text per setting, whatever was typed: "true"/"false", "3", the shortest decimal that reads
  // back as the double ("2" for 2.0, "0.05"; -0 as "0"), a choice as itself. Labels are built from
  // it, so "2.0" and "2" (or "on" and "true") name one contender across runs.
  static std::string text(const Value& v);
  std::string text(const std::string& name) const { return text(find(name)); }

 private:
  const Value& find(const std::string& name) const;
  std::map<std::string, Value> values_;
};

class ParamSchema {
 public:
  ParamSchema() = default;
  explicit ParamSchema(std::vector<ParamSpec> specs) : specs_(std::move(specs)) {}
  const std::vector<ParamSpec>& specs() const { return specs_; }
  const ParamSpec* find(const std::string& name) const;
  // Defaults overridden by `overrides` (name -> text value, as from `--param svgf.sigmaL=4` or
  // JSON). `owner` names the denoiser in error messages.
  ParamSet resolve(const std::map<std::string, std::string>& overrides, const std::string& owner) const;
  // A built-in reads its float parameters as `float`: each resolved value is then the shortest
  // decimal of the float it reads (0.30000001 resolves to 0.3, the float both read as), so that
  // labels, recorded parameters and compare's matching say what ran. External denoisers read
  // doubles, and keep every digit.
  void readsFloatsAsFloat() { floats_ = true; }
  bool floatsAsFloat() const { return floats_; }

 private:
  std::vector<ParamSpec> specs_;
  bool floats_ = false;
};

}  // namespace arena
