#include <algorithm>

#include "core/error.hpp"
#include "denoisers/denoiser.hpp"
#include "denoisers/variants.hpp"

namespace arena {

const char* signalName(SignalKind kind) { return kind == SignalKind::Diffuse ? "diffuse" : "specular"; }

const DenoiserRegistry& DenoiserRegistry::instance() {
  // Explicit list (static-initialiser registration is dropped by the linker in static libraries).
  static const DenoiserRegistry registry = [] {
    DenoiserRegistry r;
    for (auto& info : builtinDenoisers()) r.add(std::move(info));
    return r;
  }();
  return registry;
}

void DenoiserRegistry::add(DenoiserInfo info) {
  if (std::any_of(infos_.begin(), infos_.end(), [&](auto& i) { return i.name == info.name; }))
    throw Error("denoiser '" + info.name + "' registered twice");
  infos_.push_back(std::move(info));
}

const DenoiserInfo& DenoiserRegistry::find(const std::string& name) const {
  for (const DenoiserInfo& i : infos_)
    if (i.name == name) return i;
  std::string known;
  for (const DenoiserInfo& i : infos_) known += (known.empty() ? "" : ", ") + i.name;
  throw Error("unknown denoiser '" + name + "'; registered: " + known);
}

std::vector<std::string> DenoiserRegistry::names() const {
  std::vector<std::string> out;
  for (const DenoiserInfo& i : infos_) out.push_back(i.name);
  return out;
}

}  // namespace arena
