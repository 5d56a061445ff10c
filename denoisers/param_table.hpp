#pragma once
#include <algorithm>
#include <functional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/error.hpp"
#include "denoisers/params.hpp"

namespace arena {

// A denoiser's parameters declared once (NRD: field, default and `[range] - meaning` on one line;
// pbrt: GetOneInt("maxdepth", 5) where the value is used). Each line names the parameter, binds it
// to the settings field it sets and gives its default, range and meaning (svgf.cpp):
//
//   using S = SvgfSettings;
//   ParamTable<S>()
//       .integer("iterations", &S::iterations, 5, 0, 10, "à-trous iterations (SVGF paper 5, ...)")
//       .include(atrousKernelParams(), &S::atrous)  // a shared block: "kernel"
//       .choice("youngColor", &S::youngColor, "accumulated",
//               {{"spatial", YoungColor::Spatial}, {"accumulated", YoungColor::Accumulated}},
//               "...")
//       .real("sigmaZ", member(&S::atrous, &AtrousSettings::edges, &EdgeStoppingSettings::sigmaZ),
//             1.0, 0.0, 1e6, "depth stopping sigma_z, SVGF eq. 3 (paper 1)")
//       .fixed([](S& s) { s.atrous.edges.normalForm = NormalWeightForm::CosinePower; })
//       .check([](const S& s, const std::string& owner) { /* feedbackTap <= iterations */ });
//
// The schema (what `arena denoisers` lists and --param/sweeps validate) and the settings a run uses
// both come from the table, so a name, a default or a field cannot drift between them. A field is
// a data-member pointer or a callable returning a reference to it (member() for nested fields).
// The table is the only default: settings() starts from a value-initialised Settings{} and sets
// every bound field, so a bound field declares no initialiser of its own (a shared block's field
// that one denoiser binds and another does not is set by the other's fixed() or by the code that
// builds the block). selfCheck() verifies the bindings themselves (no bound field has an
// initialiser, each parameter reaches its own field and no other, each field holds its default)
// and runs whenever the schema is built, so a binding slip fails every test that touches the
// registry.
template <class Settings>
class ParamTable {
 public:
  struct Binding {
    ParamSpec spec;
    std::function<void(const ParamSet&, Settings&)> apply;     // the resolved value -> field
    std::function<ParamSet::Value(const Settings&)> readBack;  // field -> value (self-check)
    std::function<bool(const Settings&)> blank;  // the field holds its type's zero (self-check)
  };
  using Check = std::function<void(const Settings&, const std::string& owner)>;
  // The type of the field that `Field` (a member pointer or a callable) selects.
  template <class Field>
  using FieldType = std::remove_cvref_t<std::invoke_result_t<Field, Settings&>>;

  ParamTable& boolean(std::string name, auto field, bool def, std::string meaning) {
    return bind(
        ParamSpec::boolean(std::move(name), def, std::move(meaning)), field,
        [](const ParamSet& p, const std::string& n) { return p.getBool(n); },
        [](auto v) -> ParamSet::Value { return bool(v); });
  }
  // An int parameter; the field may be wider or a float (e.g. a history cap used as 1/h).
  ParamTable& integer(std::string name, auto field, int def, int min, int max,
                      std::string meaning) {
    return bind(
        ParamSpec::integer(std::move(name), def, min, max, std::move(meaning)), field,
        [](const ParamSet& p, const std::string& n) { return p.getInt(n); },
        [](auto v) -> ParamSet::Value { return int(v); });
  }
  // A real parameter, read as a float (ParamSet::getFloat) whatever the field's type.
  ParamTable& real(std::string name, auto field, double def, double min, double max,
                   std::string meaning) {
    return bind(
        ParamSpec::real(std::move(name), def, min, max, std::move(meaning)), field,
        [](const ParamSet& p, const std::string& n) { return p.getFloat(n); },
        [](auto v) -> ParamSet::Value { return double(float(v)); });
  }
  // A choice: each listed name maps to the field's value (an enum, a bool, a channel name).
  template <class Field>
  ParamTable& choice(std::string name, Field field, std::string def,
                     std::vector<std::pair<std::string, FieldType<Field>>> options,
                     std::string meaning) {
    std::vector<std::string> names;
    for (const auto& option : options) names.push_back(option.first);
    if (std::find(names.begin(), names.end(), def) == names.end())
      throw Error("parameter table: '" + name + "' defaults to '" + def +
                  "', not one of its choices");
    Binding b{ParamSpec::choice(name, def, std::move(names), std::move(meaning)), {}, {}, {}};
    b.apply = [name, field, options](const ParamSet& p, Settings& s) {
      const std::string& chosen = p.getChoice(name);
      for (const auto& [optionName, value] : options)
        if (optionName == chosen) std::invoke(field, s) = value;
    };
    b.readBack = [field, options](const Settings& s) -> ParamSet::Value {
      for (const auto& [optionName, value] : options)
        if (std::invoke(field, const_cast<Settings&>(s)) == value) return optionName;
      return std::string("?");
    };
    b.blank = blankTest(field);
    bindings_.push_back(std::move(b));
    return *this;
  }
  // Another table's parameters (a shared block: reprojection, footprint, ...), bound to the part
  // of these settings that `part` selects (a member pointer or a callable), its checks included.
  template <class Part>
  ParamTable& include(const ParamTable<Part>& table, auto part) {
    for (const auto& inner : table.bindings()) {
      auto apply = inner.apply;
      auto readBack = inner.readBack;
      auto blank = inner.blank;
      bindings_.push_back(
          {inner.spec,
           [apply, part](const ParamSet& p, Settings& s) { apply(p, std::invoke(part, s)); },
           [readBack, part](const Settings& s) {
             return readBack(std::invoke(part, const_cast<Settings&>(s)));
           },
           [blank, part](const Settings& s) {
             return blank(std::invoke(part, const_cast<Settings&>(s)));
           }});
    }
    for (const auto& set : table.fixedSettings())
      fixed_.push_back([set, part](Settings& s) { set(std::invoke(part, s)); });
    for (const auto& check : table.checks())
      checks_.push_back([check, part](const Settings& s, const std::string& owner) {
        check(std::invoke(part, const_cast<Settings&>(s)), owner);
      });
    return *this;
  }
  // A variant that reuses a parameter adds what the value means to it (A-SVGF's base alpha).
  ParamTable& extendMeaning(const std::string& name, const std::string& addition) {
    for (Binding& b : bindings_)
      if (b.spec.name == name) {
        b.spec.meaning += addition;
        return *this;
      }
    throw Error("parameter table: no parameter '" + name + "' to extend");
  }
  // A rule across parameters; throws an Error that names `owner` (the denoiser).
  ParamTable& check(Check rule) {
    checks_.push_back(std::move(rule));
    return *this;
  }
  // What the variant fixes rather than exposes (SVGF's cosine-power normal term), set after the
  // parameters; kept beside them so that settings() is the whole story.
  ParamTable& fixed(std::function<void(Settings&)> set) {
    fixed_.push_back(std::move(set));
    return *this;
  }

  const std::vector<Binding>& bindings() const { return bindings_; }
  const std::vector<Check>& checks() const { return checks_; }
  const std::vector<std::function<void(Settings&)>>& fixedSettings() const { return fixed_; }
  std::vector<ParamSpec> specs() const {
    std::vector<ParamSpec> out;
    for (const Binding& b : bindings_) out.push_back(b.spec);
    return out;
  }
  // The schema, after the self-check (throws an Error naming the first binding that is wrong).
  ParamSchema schema() const {
    const std::vector<std::string> problems = selfCheck();
    if (!problems.empty()) throw Error("parameter table: " + problems.front());
    return ParamSchema(specs());
  }
  // Settings{} with every parameter's resolved value and the fixed settings set, then the
  // cross-parameter checks.
  Settings settings(const ParamSet& params, const std::string& owner) const {
    Settings s = unchecked(params);
    for (const Check& rule : checks_) rule(s, owner);
    return s;
  }
  Settings defaults(const std::string& owner = "defaults") const {
    return settings(ParamSchema(specs()).resolve({}, owner), owner);
  }

  // What is wrong with the bindings, one line each: duplicate names, a bound field that declares
  // an initialiser of its own (a second default that the table hides but a caller building the
  // struct by hand would get), a default that does not read back from its field, or a parameter
  // whose change moves another parameter's field (two names on one field) or not its own.
  std::vector<std::string> selfCheck() const {
    std::vector<std::string> problems;
    const ParamSchema schema(specs());
    for (const Binding& b : bindings_)
      if (const std::string problem = b.spec.problem(); !problem.empty())
        problems.push_back(problem);
    for (size_t i = 0; i < bindings_.size(); ++i)
      for (size_t j = 0; j < i; ++j)
        if (bindings_[i].spec.name == bindings_[j].spec.name)
          problems.push_back("'" + bindings_[i].spec.name + "' is declared twice");
    // The checks below resolve the declarations: with these wrong they would read nonsense (a
    // name declared int and then real reads one value as the other).
    if (!problems.empty()) return problems;
    const Settings blank{};
    for (const Binding& b : bindings_)
      if (!b.blank(blank))
        problems.push_back("'" + b.spec.name +
                           "': its field declares an initialiser; the table's default is the only "
                           "one (remove it from the struct)");
    const ParamSet defaultSet = schema.resolve({}, "table");
    const Settings defaultSettings = unchecked(defaultSet);
    auto expect = [](const ParamSpec& spec, const ParamSet::Value& v) -> ParamSet::Value {
      if (spec.type == ParamSpec::Type::Float) return double(float(std::get<double>(v)));
      return v;
    };
    for (const Binding& b : bindings_)
      if (b.readBack(defaultSettings) != expect(b.spec, defaultSet.values().at(b.spec.name)))
        problems.push_back("'" + b.spec.name + "': its field does not hold its default");
    for (const Binding& changed : bindings_) {
      const std::string other = otherValue(changed.spec);
      if (other.empty()) continue;
      const ParamSet set = schema.resolve({{changed.spec.name, other}}, "table");
      const Settings s = unchecked(set);
      for (const Binding& b : bindings_) {
        const ParamSet::Value want = expect(b.spec, set.values().at(b.spec.name));
        if (b.readBack(s) != want)
          problems.push_back("setting '" + changed.spec.name + "' to " + other +
                             (&b == &changed ? " does not reach its field"
                                             : " changes the field of '" + b.spec.name + "'"));
      }
    }
    return problems;
  }

 private:
  template <class Get, class ToValue>
  ParamTable& bind(ParamSpec spec, auto field, Get get, ToValue toValue) {
    const std::string name = spec.name;
    bindings_.push_back({std::move(spec),
                         [name, field, get](const ParamSet& p, Settings& s) {
                           auto& target = std::invoke(field, s);
                           target =
                               static_cast<std::remove_reference_t<decltype(target)>>(get(p, name));
                         },
                         [field, toValue](const Settings& s) {
                           return toValue(std::invoke(field, const_cast<Settings&>(s)));
                         },
                         blankTest(field)});
    return *this;
  }
  // Whether the field is its type's zero: in Settings{}, a field with an initialiser of its own
  // (a second default beside the table's) is not.
  template <class Field>
  static std::function<bool(const Settings&)> blankTest(Field field) {
    return [field](const Settings& s) {
      return std::invoke(field, const_cast<Settings&>(s)) == FieldType<Field>{};
    };
  }
  Settings unchecked(const ParamSet& params) const {
    Settings s{};
    for (const Binding& b : bindings_) b.apply(params, s);
    for (const auto& set : fixed_) set(s);
    return s;
  }
  // A valid value other than the default, as --param text ("" when there is none).
  static std::string otherValue(const ParamSpec& spec) {
    switch (spec.type) {
      case ParamSpec::Type::Bool:
        return spec.defaultValue != 0 ? "false" : "true";
      case ParamSpec::Type::Choice:
        return spec.choices.size() < 2 ? "" : spec.choices[spec.defaultValue == 0 ? 1 : 0];
      case ParamSpec::Type::Int:
      case ParamSpec::Type::Float: {
        double v = spec.defaultValue + 1 <= spec.max   ? spec.defaultValue + 1
                   : spec.defaultValue - 1 >= spec.min ? spec.defaultValue - 1
                                                       : (spec.min + spec.max) / 2;
        if (spec.type == ParamSpec::Type::Int) v = double(int(v));
        if (v == spec.defaultValue) return "";
        std::ostringstream text;
        text.precision(17);
        text << v;
        return text.str();
      }
    }
    return "";
  }

  std::vector<Binding> bindings_;
  std::vector<Check> checks_;
  std::vector<std::function<void(Settings&)>> fixed_;
};

// A member of a member, for binding nested fields: member(&S::atrous, &AtrousSettings::edges,
// &EdgeStoppingSettings::sigmaL) sets s.atrous.edges.sigmaL.
template <class First, class... Rest>
auto member(First first, Rest... rest) {
  return [=](auto& s) -> auto& {
    if constexpr (sizeof...(Rest) == 0)
      return s.*first;
    else
      return member(rest...)(s.*first);
  };
}

}  // namespace arena
