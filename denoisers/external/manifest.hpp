#pragma once
// The manifest that declares an external denoiser (docs/external-denoisers.md): a small JSON file
// naming the denoiser, how to start it (a command speaking the frame protocol, or a C plugin
// library), the sequence layers it reads, its typed parameter schema (the same ParamSchema as the
// built-ins, so unknown and out-of-range values are errors and results record the values) and
// which signal one instance filters. Every mistake is an Error naming the file and the field.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "denoisers/denoiser.hpp"

namespace arena {

struct ExternalManifest {
  std::filesystem::path file;  // the manifest itself; relative paths start at its folder
  std::string name, description;
  std::vector<std::string> command;  // argv; run in the manifest's folder (empty for a library)
  std::filesystem::path library;     // a C plugin (include/arena_plugin.h) instead of a command
  // The plugin runs in a process of its own (`arena serve plugin:LIBRARY`, speaking the frame
  // protocol), so that a crash or a hang past timeoutSeconds fails only its pair.
  bool isolated = false;
  SignalMode signals = SignalMode::Demodulated;
  std::vector<std::string> channels;  // sequence layers sent with the signal, in this order
  ParamSchema schema;
  double timeoutSeconds = 30;  // per answer (ready, each frame); then the process is killed

  std::filesystem::path folder() const { return file.parent_path(); }
};

// Reads and validates a manifest file.
ExternalManifest readManifest(const std::filesystem::path& file);
// The same from its JSON (`file`: where relative paths start; `where`: how errors name it).
ExternalManifest manifestFromJson(const nlohmann::json& j, const std::filesystem::path& file,
                                  const std::string& where);
// A parameter as a manifest declares it (the inverse of reading one): `arena serve --describe`.
nlohmann::json paramSpecJson(const ParamSpec& spec);

// Registry names become CLI prefixes ("NAME.param=value"): letters, digits, '_' and '-' only.
// Throws naming `where` otherwise.
void checkDenoiserName(const std::string& name, const std::string& where);

// The frame layer's spec (channel suffixes) by name; throws naming `where` for an unknown layer.
const LayerSpec& frameLayerSpec(const std::string& name, const std::string& where);

}  // namespace arena
