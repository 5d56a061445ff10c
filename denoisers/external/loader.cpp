#include "denoisers/external/loader.hpp"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>

#include "core/error.hpp"
#include "core/text.hpp"
#include "denoisers/external/manifest.hpp"
#include "denoisers/external/plugin_denoiser.hpp"
#include "denoisers/external/process_denoiser.hpp"
#include "denoisers/external/subprocess.hpp"

namespace arena {

namespace fs = std::filesystem;

namespace {

constexpr const char* kManifestPrefix = "ext:";
constexpr const char* kPluginPrefix = "plugin:";

std::vector<fs::path> searchPath() {
  std::vector<fs::path> dirs;
  const char* env = std::getenv("ARENA_DENOISER_PATH");
  std::stringstream in(env ? env : "");
  for (std::string dir; std::getline(in, dir, ':');)
    if (!dir.empty()) dirs.push_back(dir);
  return dirs;
}

fs::path findManifest(const std::string& what) {
  const fs::path p(what);
  if (fs::is_regular_file(p)) return p;
  if (fs::is_regular_file(p / "manifest.json")) return p / "manifest.json";
  // A folder without a manifest (say ./mine while ARENA_DENOISER_PATH holds mine/) is not the
  // denoiser: a plain name goes on to the search path.
  const bool isName = what.find('/') == std::string::npos && p.extension() != ".json";
  std::string message = "ext:" + what + ": no manifest there";
  if (isName) {
    std::string tried;
    for (const fs::path& dir : searchPath())
      for (const fs::path& candidate : {dir / (what + ".json"), dir / what / "manifest.json"}) {
        if (fs::is_regular_file(candidate)) return candidate;
        tried += ' ';
        tried += candidate.string();
      }
    message +=
        tried.empty() ? " (and ARENA_DENOISER_PATH is empty)" : "; searched ARENA_DENOISER_PATH:";
    message += tried;
  }
  message +=
      "; expected a manifest file, a folder with manifest.json, or a name on ARENA_DENOISER_PATH";
  throw Error(message);
}

DenoiserInfo processDenoiserInfo(ExternalManifest manifest) {
  auto shared = std::make_shared<const ExternalManifest>(std::move(manifest));
  DenoiserInfo info;
  info.name = shared->name;
  info.description = shared->description;
  info.schema = shared->schema;
  info.signals = shared->signals;
  info.origin = "external process " + shared->file.string();
  info.create = [shared](const ParamSet& params, SignalKind kind) {
    return std::make_unique<ExternalProcessDenoiser>(shared, params, kind);
  };
  return info;
}

constexpr double kLoadSeconds = 10;

std::string& serveExecutablePath() {
  static std::string path;
  return path;
}

// An isolated plugin: never loaded in this process. `arena serve --describe plugin:LIBRARY` loads
// it in a process of its own and says what it is (a crash or a hang there refuses the manifest
// before anything runs, and arena goes on); its instances are made by `arena serve plugin:LIBRARY`,
// one process per sequence and signal, which speak the frame protocol.
DenoiserInfo isolatedPluginInfo(const ExternalManifest& manifest) {
  const std::string library = fs::absolute(manifest.library).lexically_normal().string();
  const std::vector<std::string> command = {serveExecutable(), "serve", "plugin:" + library};
  const std::string where = manifest.file.string() + ": $.library: " + library;
  auto fail = [&](const std::string& what, Subprocess& p) {
    throw Error(validUtf8(where + ": loading it in its isolated process (arena serve --describe) " +
                          what + p.howItEnded(std::chrono::milliseconds(500))));
  };
  nlohmann::json described;
  {
    std::vector<std::string> describe = command;
    describe.insert(describe.begin() + 2, "--describe");
    Subprocess process(describe, manifest.folder());
    std::string line;
    // Loading (a process started, a library and its driver loaded) gets at least kLoadSeconds: a
    // per-frame timeout tuned tight must not refuse a library that loads slowly on a busy machine.
    const double seconds = std::max(manifest.timeoutSeconds, kLoadSeconds);
    try {
      line = process.readLine(kMaxProtocolHeaderBytes,
                              std::chrono::steady_clock::now() +
                                  std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(seconds)));
    } catch (const Subprocess::TimedOut&) {
      fail("gave no description within " + std::to_string(int(seconds)) +
               " s (timeoutSeconds, at least " + std::to_string(int(kLoadSeconds)) +
               " s for loading: a hang while loading?)",
           process);
    } catch (const Error& e) {
      fail(std::string("failed (") + e.what() + ")", process);
    }
    try {
      described = nlohmann::json::parse(line);
    } catch (const std::exception&) {
      fail("answered what is not a JSON description: " + line.substr(0, 200), process);
    }
  }
  described["command"] = command;  // read as the process manifest it becomes
  ExternalManifest m = manifestFromJson(described, manifest.file, where + " (its description)");
  if (m.name != manifest.name)
    throw Error(manifest.file.string() + ": $.name '" + manifest.name +
                "' differs from the name '" + m.name + "' that the library " + library +
                " gives itself");
  m.file = manifest.file;
  m.library = manifest.library;
  m.isolated = true;
  m.timeoutSeconds = manifest.timeoutSeconds;
  if (!manifest.description.empty()) m.description = manifest.description;
  const std::string origin =
      "isolated plugin " + library + " (manifest " + manifest.file.string() + ")";
  DenoiserInfo info = processDenoiserInfo(std::move(m));
  info.origin = origin;
  return info;
}

}  // namespace

void setServeExecutable(std::string path) {
  serveExecutablePath() = std::move(path);
}

std::string serveExecutable() {
  if (!serveExecutablePath().empty()) return serveExecutablePath();
  // Absolute: the process starts in its manifest's folder.
  if (const char* env = std::getenv("ARENA_EXECUTABLE"); env && *env)
    return fs::absolute(env).lexically_normal().string();
  throw Error(
      "an isolated plugin runs in `arena serve`, but this program does not know where the arena "
      "executable is (set ARENA_EXECUTABLE to its path)");
}

bool isExternalEntry(const std::string& entry) {
  return entry.rfind(kManifestPrefix, 0) == 0 || entry.rfind(kPluginPrefix, 0) == 0;
}

DenoiserInfo loadExternalDenoiser(const std::string& entry) {
  if (entry.rfind(kPluginPrefix, 0) == 0)
    return loadPluginDenoiser(entry.substr(std::strlen(kPluginPrefix)));
  if (entry.rfind(kManifestPrefix, 0) != 0)
    throw Error("'" + entry +
                "' is not an external denoiser (expected ext:MANIFEST or plugin:LIBRARY)");
  ExternalManifest manifest =
      readManifest(findManifest(entry.substr(std::strlen(kManifestPrefix))));
  if (manifest.library.empty()) return processDenoiserInfo(std::move(manifest));
  if (manifest.isolated) return isolatedPluginInfo(manifest);
  DenoiserInfo info;
  try {
    info = loadPluginDenoiser(manifest.library);
  } catch (const Error& e) {  // the library's own errors name it; the manifest that named it too
    throw Error(manifest.file.string() + ": $.library: " + e.what());
  }
  if (info.name != manifest.name)
    throw Error(manifest.file.string() + ": $.name '" + manifest.name +
                "' differs from the name '" + info.name + "' that the library " +
                manifest.library.string() + " gives itself");
  if (!manifest.description.empty()) info.description = manifest.description;
  return info;
}

std::vector<fs::path> manifestsOnSearchPath() {
  std::vector<fs::path> found;
  for (const fs::path& dir : searchPath()) {  // in the path's order: the first folder wins a name
    if (!fs::is_directory(dir)) continue;
    std::vector<fs::path> inDir;
    for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
      if (e.is_regular_file() && e.path().extension() == ".json") inDir.push_back(e.path());
      if (e.is_directory() && fs::is_regular_file(e.path() / "manifest.json"))
        inDir.push_back(e.path() / "manifest.json");
    }
    std::sort(inDir.begin(), inDir.end());
    found.insert(found.end(), inDir.begin(), inDir.end());
  }
  return found;
}

}  // namespace arena
