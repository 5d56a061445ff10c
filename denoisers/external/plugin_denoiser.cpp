#include "denoisers/external/plugin_denoiser.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "arena_plugin.h"
#include "core/crash_note.hpp"
#include "core/error.hpp"
#include "core/text.hpp"
#include "denoisers/external/manifest.hpp"

namespace arena {

namespace fs = std::filesystem;

namespace {

constexpr size_t kErrorBytes = 1024;

ArenaImage viewOf(const Image& image) {
  ArenaImage v{image.width(), image.height(), image.channels(), {}};
  for (int c = 0; c < std::min(image.channels(), ARENA_MAX_CHANNELS); ++c)
    v.planes[c] = image.plane(c);
  return v;
}

ArenaCamera cameraOf(const CameraState& c) {
  ArenaCamera a{};
  for (int k = 0; k < 3; ++k) {
    a.eye[k] = c.eye[k];
    a.forward[k] = c.forward[k];
    a.right[k] = c.right[k];
    a.up[k] = c.up[k];
  }
  a.tanHalfFovY = c.tanHalfFovY;
  a.aspect = c.aspect;
  a.width = c.width;
  a.height = c.height;
  const glm::mat4 view = c.view(), projection = c.projection();
  for (int column = 0; column < 4; ++column)
    for (int row = 0; row < 4; ++row) {
      a.view[column * 4 + row] = view[column][row];
      a.projection[column * 4 + row] = projection[column][row];
    }
  return a;
}

std::string& crashConsequence() {
  static std::string text =
      "arena stops here and writes no results (a plugin runs inside arena's process: isolate it, "
      "docs/external-denoisers.md, to keep a crash to its own pair)";
  return text;
}

ArenaSignal signalOf(SignalKind kind) {
  switch (kind) {
    case SignalKind::Diffuse:
      return ARENA_SIGNAL_DIFFUSE;
    case SignalKind::Specular:
      return ARENA_SIGNAL_SPECULAR;
    case SignalKind::Color:
      return ARENA_SIGNAL_COLOR;
  }
  return ARENA_SIGNAL_DIFFUSE;
}

// One instance of a plugin behind the Denoiser interface.
class PluginDenoiser final : public Denoiser {
 public:
  PluginDenoiser(const ArenaPlugin* plugin, std::string library, const ParamSchema& schema,
                 const ParamSet& params, SignalKind kind)
      : plugin_(plugin), library_(std::move(library)), signal_(signalName(kind)) {
    // The resolved values, in schema order; the strings live in `choices_` for create().
    std::vector<ArenaParamValue> values;
    for (const ParamSpec& spec : schema.specs()) {
      ArenaParamValue v{spec.name.c_str(), 0.0, nullptr};
      switch (spec.type) {
        case ParamSpec::Type::Bool:
          v.number = params.getBool(spec.name) ? 1.0 : 0.0;
          break;
        case ParamSpec::Type::Int:
          v.number = params.getInt(spec.name);
          break;
        case ParamSpec::Type::Float:
          v.number = std::get<double>(params.values().at(spec.name));
          break;
        case ParamSpec::Type::Choice:
          v.choice = params.getChoice(spec.name).c_str();
          break;
      }
      values.push_back(v);
    }
    char error[kErrorBytes] = "";
    {
      const CrashNote note = crashNote("create");
      instance_ =
          plugin_->create(values.data(), int(values.size()), signalOf(kind), error, sizeof error);
    }
    if (!instance_) fail("create", error);
    for (int i = 0; i < plugin_->requiredChannelCount; ++i)
      channels_.push_back(plugin_->requiredChannels[i]);
  }
  ~PluginDenoiser() override {
    if (!instance_) return;
    const CrashNote note = crashNote("destroy");
    plugin_->destroy(instance_);
  }

  std::vector<std::string> requiredChannels() const override { return channels_; }

  void setup(int width, int height) override {
    char error[kErrorBytes] = "";
    int status = 0;
    {
      const CrashNote note = crashNote("setup");
      status = plugin_->setup(instance_, width, height, error, sizeof error);
    }
    if (status != 0) fail("setup", error);
  }

  void reset() override {
    const CrashNote note = crashNote("reset");
    plugin_->reset(instance_);
  }

  void denoise(const FrameContext& ctx, const DenoiserInputs& in, Image& output) override {
    ArenaFrameContext c{ctx.frameIndex,       ctx.width,
                        ctx.height,           ctx.reset ? 1 : 0,
                        cameraOf(ctx.camera), cameraOf(ctx.previousCamera)};
    layers_.clear();
    for (const std::string& name : channels_)
      layers_.push_back({name.c_str(), viewOf(in.frame.get(name, library_))});
    ArenaInputs inputs{viewOf(in.signal), layers_.data(), int(layers_.size())};
    ArenaMutableImage out{output.width(), output.height(), output.channels(), {}};
    for (int k = 0; k < std::min(output.channels(), ARENA_MAX_CHANNELS); ++k)
      out.planes[k] = output.plane(k);
    ArenaHost host{this, &PluginDenoiser::reportPass};
    char error[kErrorBytes] = "";
    badPass_.clear();
    int status = 0;
    {
      const CrashNote note = crashNote("denoise of frame " + std::to_string(ctx.frameIndex));
      status = plugin_->denoise(instance_, &c, &inputs, &out, &host, error, sizeof error);
    }
    if (status != 0) fail("denoise (frame " + std::to_string(ctx.frameIndex) + ")", error);
    // reportPass cannot throw through the plugin's C frames: what it refused fails the pair here.
    if (!badPass_.empty())
      throw Error(std::string(plugin_->name) + " (plugin " + library_ + "): frame " +
                  std::to_string(ctx.frameIndex) + ": reportPass " + badPass_);
  }

 private:
  static void reportPass(void* context, const char* name, double milliseconds,
                         double tapsPerPixel) {
    auto* self = static_cast<PluginDenoiser*>(context);
    const std::string pass = name ? validUtf8(name) : "?";
    if (!(milliseconds >= 0 && std::isfinite(milliseconds) && tapsPerPixel >= 0 &&
          std::isfinite(tapsPerPixel))) {
      if (self->badPass_.empty())
        self->badPass_ = "'" + pass + "': milliseconds " + std::to_string(milliseconds) +
                         ", tapsPerPixel " + std::to_string(tapsPerPixel) +
                         " (expected finite numbers >= 0)";
      return;
    }
    self->passes_.push_back({pass, milliseconds, tapsPerPixel});
  }
  // What a fatal signal in the plugin's `entry` says (core/crash_note.hpp): the plugin, the call,
  // the pair the harness was running, and that the run is lost with it.
  // The parts that do not change are composed once (a denoise call is timed): the pair's note is
  // in force when the instance is made.
  CrashNote crashNote(const std::string& entry) const {
    return CrashNote(noteHead_ + entry + noteTail_);
  }
  // `error` is the plugin's buffer: terminated here (the ABI promises only its first errorSize
  // bytes), its bytes made valid text.
  [[noreturn]] void fail(const std::string& entry, char* error) const {
    error[kErrorBytes - 1] = '\0';
    throw Error(std::string(plugin_->name) + " (plugin " + library_ + ", " + signal_ +
                " signal): " + entry +
                " failed: " + (error[0] ? validUtf8(error) : "(no message)"));
  }

  const ArenaPlugin* plugin_;
  std::string library_;
  std::string signal_;  // "diffuse", "specular" or "color": which instance failed
  // crashNote's fixed parts (declared after plugin_ and library_, which they read).
  const std::string noteHead_ = "in plugin " + std::string(plugin_->name) + "'s ";
  const std::string noteTail_ = " (" + library_ + ")" +
                                (outerCrashNote().empty() ? "" : " " + outerCrashNote()) + "; " +
                                crashConsequence();
  void* instance_ = nullptr;
  std::vector<std::string> channels_;
  std::vector<ArenaLayer> layers_;
  std::string badPass_;  // the first pass report refused in this frame (reportPass)
};

ParamSchema schemaOf(const ArenaPlugin& p, const std::string& where) {
  std::vector<ParamSpec> specs;
  // A negative count is no count (a plugin with one loaded and ran as if it declared nothing).
  for (const auto& [field, count] : {std::pair{"paramCount", p.paramCount},
                                     std::pair{"requiredChannelCount", p.requiredChannelCount}})
    if (count < 0)
      throw Error(where + ": " + field + " " + std::to_string(count) + " (expected a count >= 0)");
  // Counts with no array behind them would be read through a null pointer.
  if (p.paramCount > 0 && !p.params)
    throw Error(where + ": paramCount " + std::to_string(p.paramCount) + " but params is NULL");
  if (p.requiredChannelCount > 0 && !p.requiredChannels)
    throw Error(where + ": requiredChannelCount " + std::to_string(p.requiredChannelCount) +
                " but requiredChannels is NULL");
  for (int i = 0; i < p.requiredChannelCount; ++i)
    if (!p.requiredChannels[i])
      throw Error(where + ": requiredChannels[" + std::to_string(i) + "] is NULL");
  for (int i = 0; i < p.paramCount; ++i) {
    const ArenaParamSpec& s = p.params[i];
    const std::string at = where + ": parameter " + std::to_string(i);
    if (!s.name || !*s.name) throw Error(at + " has no name");
    const std::string meaning = s.meaning ? s.meaning : "";
    switch (s.type) {
      case ARENA_PARAM_BOOL:
        specs.push_back(ParamSpec::boolean(s.name, s.defaultValue != 0, meaning));
        break;
      case ARENA_PARAM_INT:
        // Whole numbers within int, as a manifest's int parameter: 2.5 is not silently 2.
        for (const double v : {s.defaultValue, s.min, s.max})
          if (!(v == std::floor(v) && v >= -2147483648.0 && v <= 2147483647.0))
            throw Error(at + " (" + s.name +
                        "): an int parameter's default, min and max must be whole numbers within "
                        "int, got " +
                        std::to_string(v));
        specs.push_back(
            ParamSpec::integer(s.name, int(s.defaultValue), int(s.min), int(s.max), meaning));
        break;
      case ARENA_PARAM_FLOAT:
        specs.push_back(ParamSpec::real(s.name, s.defaultValue, s.min, s.max, meaning));
        break;
      case ARENA_PARAM_CHOICE: {
        std::vector<std::string> choices;
        if (s.choiceCount > 0 && !s.choices)
          throw Error(at + " (" + s.name + "): choiceCount > 0 but choices is NULL");
        for (int k = 0; k < s.choiceCount; ++k) {
          if (!s.choices[k])
            throw Error(at + " (" + s.name + "): choices[" + std::to_string(k) + "] is NULL");
          choices.push_back(s.choices[k]);
        }
        const int def = int(s.defaultValue);
        if (choices.empty() || def < 0 || def >= int(choices.size()))
          throw Error(at + " (" + s.name +
                      "): a choice needs choices and a default index among them");
        // The default by name, taken before the choices move into the spec (argument order is
        // unspecified: indexing the moved-from vector crashed here).
        std::string defaultChoice = choices[size_t(def)];
        specs.push_back(
            ParamSpec::choice(s.name, std::move(defaultChoice), std::move(choices), meaning));
        break;
      }
      default:
        throw Error(at + " (" + s.name + "): unknown type " + std::to_string(int(s.type)));
    }
    if ((s.type == ARENA_PARAM_INT || s.type == ARENA_PARAM_FLOAT) &&
        !(s.min <= s.defaultValue && s.defaultValue <= s.max))
      throw Error(at + " (" + s.name + "): default outside [min, max]");
  }
  return ParamSchema(std::move(specs));
}

}  // namespace

void setPluginCrashConsequence(std::string text) {
  crashConsequence() = std::move(text);
}

DenoiserInfo loadPluginDenoiser(const fs::path& libraryPath, std::vector<std::string>* channels) {
  if (libraryPath.empty()) throw Error("plugin: needs a library's path (plugin:./libmine.so)");
  // Named absolute in every message (and the origin), as the run that reads it may run elsewhere.
  const std::string library = fs::absolute(libraryPath).lexically_normal().string();
  if (!fs::exists(libraryPath))
    throw Error(
        libraryPath.string() + ": no such plugin library (looked for " + library +
        (libraryPath.is_relative() ? ": a relative path is taken from the current directory" : "") +
        ")");
  // Loading runs the library's own code (static constructors, arena_plugin()) in this process: a
  // fault there is named before the process dies of it.
  const CrashNote loading("while loading plugin library " + library +
                          " (its static constructors or arena_plugin()); " + crashConsequence());
  // Never unloaded: instances and thread-local state may outlive any registry entry.
  void* handle = dlopen(fs::absolute(libraryPath).c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) throw Error(library + ": cannot load the plugin: " + dlerror());
  auto entry = reinterpret_cast<ArenaPluginEntryPoint>(dlsym(handle, ARENA_PLUGIN_ENTRY_POINT));
  if (!entry)
    throw Error(library + ": no '" ARENA_PLUGIN_ENTRY_POINT
                          "' symbol; a plugin exports "
                          "`const ArenaPlugin* arena_plugin(void)` (include/arena_plugin.h)");
  const ArenaPlugin* plugin = entry();
  if (!plugin) throw Error(library + ": arena_plugin() returned NULL");
  if (plugin->abiVersion != ARENA_PLUGIN_ABI_VERSION)
    throw Error(library + ": built against plugin ABI version " +
                std::to_string(plugin->abiVersion) + ", but this arena speaks version " +
                std::to_string(ARENA_PLUGIN_ABI_VERSION) +
                "; rebuild the plugin against this arena's include/arena_plugin.h");
  for (const auto& [field, given] :
       {std::pair{"name", plugin->name != nullptr}, std::pair{"create", plugin->create != nullptr},
        std::pair{"setup", plugin->setup != nullptr}, std::pair{"reset", plugin->reset != nullptr},
        std::pair{"denoise", plugin->denoise != nullptr},
        std::pair{"destroy", plugin->destroy != nullptr}})
    if (!given)
      throw Error(library + ": its ArenaPlugin's " + field +
                  " is NULL (a name and the entry points create, setup, reset, denoise and "
                  "destroy are all required)");
  checkDenoiserName(plugin->name, library);
  if (plugin->signals != ARENA_SIGNALS_DEMODULATED && plugin->signals != ARENA_SIGNALS_COLOR)
    throw Error(library + ": signals must be ARENA_SIGNALS_DEMODULATED or ARENA_SIGNALS_COLOR");
  for (int i = 0; i < plugin->requiredChannelCount; ++i) {
    const std::string at = library + ": requiredChannels[" + std::to_string(i) + "]";
    const std::string name = plugin->requiredChannels[i] ? plugin->requiredChannels[i] : "";
    frameLayerSpec(name, at);
    // As a manifest's channels: a layer named twice would be handed over twice under one name.
    for (int k = 0; k < i; ++k)
      if (name == plugin->requiredChannels[k])
        throw Error(at + ": '" + name + "' is already requiredChannels[" + std::to_string(k) +
                    "]; name each layer once");
  }
  DenoiserInfo info;
  info.name = plugin->name;
  info.description = plugin->description ? plugin->description : "";
  info.schema = schemaOf(*plugin, library);
  info.signals =
      plugin->signals == ARENA_SIGNALS_COLOR ? SignalMode::Color : SignalMode::Demodulated;
  info.origin = "plugin " + library;
  if (channels)
    channels->assign(plugin->requiredChannels,
                     plugin->requiredChannels + plugin->requiredChannelCount);
  info.create = [plugin, library, schema = info.schema](const ParamSet& params, SignalKind kind) {
    return std::make_unique<PluginDenoiser>(plugin, library, schema, params, kind);
  };
  return info;
}

}  // namespace arena
