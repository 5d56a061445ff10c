#include <algorithm>

#include "core/error.hpp"
#include "core/text.hpp"
#include "denoisers/denoiser.hpp"
#include "denoisers/external/loader.hpp"
#include "denoisers/variants.hpp"

namespace arena {

const char* signalName(SignalKind kind) {
  switch (kind) {
    case SignalKind::Diffuse:
      return "diffuse";
    case SignalKind::Specular:
      return "specular";
    case SignalKind::Color:
      return "color";
  }
  return "?";
}

namespace {
DenoiserRegistry& globalRegistry() {
  // Explicit list (static-initialiser registration is dropped by the linker in static libraries).
  static DenoiserRegistry registry = [] {
    DenoiserRegistry r;
    for (auto& info : builtinDenoisers()) r.add(std::move(info));
    return r;
  }();
  return registry;
}
}  // namespace

const DenoiserRegistry& DenoiserRegistry::instance() {
  return globalRegistry();
}

std::string DenoiserRegistry::resolve(const std::string& entry) {
  if (!isExternalEntry(entry)) {
    instance().find(entry);  // throws, listing the registered names
    return entry;
  }
  DenoiserInfo info = loadExternalDenoiser(entry);
  DenoiserRegistry& registry = globalRegistry();
  for (const DenoiserInfo& known : registry.infos_)
    if (known.name == info.name) {
      if (known.origin == info.origin) return info.name;  // loaded before
      throw Error(entry + ": its name '" + info.name + "' is already taken by " +
                  (known.origin.empty() ? "a built-in denoiser" : known.origin) +
                  (info.origin.find("plugin ") != std::string::npos
                       ? "; a plugin's name is its library's (a manifest cannot rename it): give "
                         "one of the two only, or rebuild one library under another name"
                       : "; rename it in its manifest"));
    }
  std::string name = info.name;
  registry.add(std::move(info));
  return name;
}

void DenoiserRegistry::add(DenoiserInfo info) {
  if (std::any_of(infos_.begin(), infos_.end(), [&](auto& i) { return i.name == info.name; }))
    throw Error("denoiser '" + info.name + "' registered twice");
  if (info.origin.empty()) info.schema.readsFloatsAsFloat();  // built-ins: ParamSet::getFloat
  infos_.push_back(std::move(info));
}

const DenoiserInfo& DenoiserRegistry::find(const std::string& name) const {
  for (const DenoiserInfo& i : infos_)
    if (i.name == name) return i;
  std::string known;
  for (const DenoiserInfo& i : infos_) known += (known.empty() ? "" : ", ") + i.name;
  // A label (svgf[sigmaL=2]) names a result, not a denoiser: say how a variant is asked for.
  if (const size_t bracket = name.find('[');
      bracket != std::string::npos && bracket > 0 && name.back() == ']')
    throw Error("'" + name +
                "' is a label (a denoiser and its settings, as results name them), not a "
                "denoiser: run " +
                name.substr(0, bracket) + " with --param " + name.substr(0, bracket) +
                ".NAME=VALUE, or compare settings side by side with arena sweep --denoiser " +
                name.substr(0, bracket) + " --grid 'NAME=[A,B]'");
  const std::string likely = closestName(name, names());
  // A denoiser of one's own is not registered by its name alone: say how it is named.
  throw Error("unknown denoiser '" + name + "'" +
              (likely.empty() ? "" : " (did you mean '" + likely + "'?)") +
              "; registered: " + known +
              " (an external one is named ext:MANIFEST.json or plugin:LIBRARY.so, or by its name "
              "once its manifest's folder is on ARENA_DENOISER_PATH; docs/external-denoisers.md)");
}

bool DenoiserRegistry::has(const std::string& name) const {
  return std::any_of(infos_.begin(), infos_.end(),
                     [&](const DenoiserInfo& i) { return i.name == name; });
}

std::vector<std::string> DenoiserRegistry::names() const {
  std::vector<std::string> out;
  for (const DenoiserInfo& i : infos_) out.push_back(i.name);
  return out;
}

}  // namespace arena
