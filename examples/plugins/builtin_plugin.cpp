#include "examples/plugins/builtin_plugin.hpp"

#include <algorithm>
#include <exception>

namespace arena::plugin {

const BuiltinPlugin* BuiltinPlugin::exported_ = nullptr;

namespace {

// Every entry point turns an exception into the ABI's error message.
template <class Body>
int guarded(char* error, size_t errorSize, Body&& body) {
  try {
    body();
    return 0;
  } catch (const std::exception& e) {
    std::snprintf(error, errorSize, "%s", e.what());
    return 1;
  }
}

CameraState cameraOf(const ArenaCamera& a) {
  CameraState c;
  c.eye = {a.eye[0], a.eye[1], a.eye[2]};
  c.forward = {a.forward[0], a.forward[1], a.forward[2]};
  c.right = {a.right[0], a.right[1], a.right[2]};
  c.up = {a.up[0], a.up[1], a.up[2]};
  c.tanHalfFovY = a.tanHalfFovY;
  c.aspect = a.aspect;
  c.width = a.width;
  c.height = a.height;
  return c;
}

// The ABI's planes are laid out like an Image's when plane c is at planes[0] + c * width * height
// (the arena's own harness always hands them over so); then the built-in works on them in place.
template <class Float>
bool laidOutLikeAnImage(Float* const* planes, int width, int height, int channels) {
  const size_t pixels = size_t(width) * size_t(height);
  for (int c = 1; c < channels; ++c)
    if (planes[c] != planes[0] + size_t(c) * pixels) return false;
  return true;
}

// `image` as an owning width x height x channels image, reallocated only when it is not one.
void ensureOwned(Image& image, int width, int height, int channels) {
  if (image.borrowed() || image.width() != width || image.height() != height ||
      image.channels() != channels)
    image = Image(width, height, channels);
}

// An input as an Image: the harness's planes borrowed in place, else copied into `owned`. The C
// ABI's inputs are const; the built-in only reads them (const Image&).
const Image& inputImage(const ArenaImage& view, Image& owned) {
  if (laidOutLikeAnImage(view.planes, view.width, view.height, view.channels)) {
    owned =
        Image::borrow(const_cast<float*>(view.planes[0]), view.width, view.height, view.channels);
  } else {
    ensureOwned(owned, view.width, view.height, view.channels);
    for (int c = 0; c < view.channels; ++c)
      parallelCopy(view.planes[c], owned.pixelCount(), owned.plane(c));
  }
  return owned;
}

// The output as an Image: the harness's planes borrowed, else an image of its own whose result
// denoise() copies back (nothing to copy in: the built-in writes every output pixel).
Image& outputImage(const ArenaMutableImage& view, Image& owned) {
  if (laidOutLikeAnImage(view.planes, view.width, view.height, view.channels))
    owned = Image::borrow(view.planes[0], view.width, view.height, view.channels);
  else
    ensureOwned(owned, view.width, view.height, view.channels);
  return owned;
}

}  // namespace

BuiltinPlugin::BuiltinPlugin(DenoiserInfo info, std::string exportedName)
    : info_(std::move(info)), name_(std::move(exportedName)) {
  for (const ParamSpec& s : info_.schema.specs()) {
    std::vector<const char*> names;
    for (const std::string& c : s.choices) names.push_back(c.c_str());
    choices_.push_back(std::move(names));
  }
  for (size_t i = 0; i < info_.schema.specs().size(); ++i) {
    const ParamSpec& s = info_.schema.specs()[i];
    const ArenaParamType type = s.type == ParamSpec::Type::Bool    ? ARENA_PARAM_BOOL
                                : s.type == ParamSpec::Type::Int   ? ARENA_PARAM_INT
                                : s.type == ParamSpec::Type::Float ? ARENA_PARAM_FLOAT
                                                                   : ARENA_PARAM_CHOICE;
    specs_.push_back({s.name.c_str(), type, s.defaultValue, s.min, s.max, choices_[i].data(),
                      int(choices_[i].size()), s.meaning.c_str()});
  }
  channels_ =
      info_.create(info_.schema.resolve({}, name_), SignalKind::Diffuse)->requiredChannels();
  for (const std::string& c : channels_) channelNames_.push_back(c.c_str());
  plugin_.abiVersion = ARENA_PLUGIN_ABI_VERSION;
  plugin_.name = name_.c_str();
  plugin_.description = info_.description.c_str();
  plugin_.signals =
      info_.signals == SignalMode::Color ? ARENA_SIGNALS_COLOR : ARENA_SIGNALS_DEMODULATED;
  plugin_.params = specs_.data();
  plugin_.paramCount = int(specs_.size());
  plugin_.requiredChannels = channelNames_.data();
  plugin_.requiredChannelCount = int(channelNames_.size());
  plugin_.create = &BuiltinPlugin::create;
  plugin_.setup = &BuiltinPlugin::setup;
  plugin_.reset = &BuiltinPlugin::reset;
  plugin_.denoise = &BuiltinPlugin::denoise;
  plugin_.destroy = &BuiltinPlugin::destroy;
  exported_ = this;
}

void* BuiltinPlugin::create(const ArenaParamValue* values, int count, ArenaSignal signal,
                            char* error, size_t errorSize) {
  auto made = std::make_unique<Instance>();
  const int failed = guarded(error, errorSize, [&] {
    const DenoiserInfo& info = exported_->info_;
    // The harness has range-checked the values against the same schema; rebuild the ParamSet.
    ParamSet params = info.schema.resolve({}, exported_->name_);
    for (int i = 0; i < count; ++i) {
      const ParamSpec* spec = info.schema.find(values[i].name);
      if (!spec) throw Error(std::string("unknown parameter ") + values[i].name);
      switch (spec->type) {
        case ParamSpec::Type::Bool:
          params.set(spec->name, values[i].number != 0);
          break;
        case ParamSpec::Type::Int:
          params.set(spec->name, int(values[i].number));
          break;
        case ParamSpec::Type::Float:
          params.set(spec->name, values[i].number);
          break;
        case ParamSpec::Type::Choice:
          params.set(spec->name, std::string(values[i].choice));
          break;
      }
    }
    const SignalKind kind = signal == ARENA_SIGNAL_SPECULAR ? SignalKind::Specular
                            : signal == ARENA_SIGNAL_COLOR  ? SignalKind::Color
                                                            : SignalKind::Diffuse;
    made->denoiser = info.create(params, kind);
  });
  return failed ? nullptr : made.release();
}

int BuiltinPlugin::setup(void* instance, int width, int height, char* error, size_t errorSize) {
  return guarded(error, errorSize,
                 [&] { static_cast<Instance*>(instance)->denoiser->setup(width, height); });
}

void BuiltinPlugin::reset(void* instance) {
  static_cast<Instance*>(instance)->denoiser->reset();
}

int BuiltinPlugin::denoise(void* instance, const ArenaFrameContext* ctx, const ArenaInputs* inputs,
                           const ArenaMutableImage* output, const ArenaHost* host, char* error,
                           size_t errorSize) {
  return guarded(error, errorSize, [&] {
    Instance& self = *static_cast<Instance*>(instance);
    const Image& signal = inputImage(inputs->signal, self.signal);
    for (int i = 0; i < inputs->layerCount; ++i) {
      const char* name = inputs->layers[i].name;
      if (self.frame.has(name)) {
        inputImage(inputs->layers[i].image, self.frame.get(name));
      } else {
        Image first;
        inputImage(inputs->layers[i].image, first);
        self.frame.set(name, std::move(first));
      }
    }
    Image& result = outputImage(*output, self.output);
    FrameContext c;
    c.frameIndex = ctx->frameIndex;
    c.width = ctx->width;
    c.height = ctx->height;
    c.reset = ctx->reset != 0;
    c.camera = cameraOf(ctx->camera);
    c.previousCamera = cameraOf(ctx->previousCamera);
    self.denoiser->clearPassStats();
    self.denoiser->denoise(c, {signal, self.frame, nullptr}, result);
    // A built-in that assigned its output (rather than writing its planes) left it elsewhere.
    if (result.plane(0) != output->planes[0])
      for (int k = 0; k < std::min(result.channels(), output->channels); ++k)
        parallelCopy(result.plane(k), result.pixelCount(), output->planes[k]);
    if (host && host->reportPass)
      for (const PassStats& p : self.denoiser->lastPasses())
        host->reportPass(host->context, p.name.c_str(), p.milliseconds, p.tapsPerPixel);
  });
}

void BuiltinPlugin::destroy(void* instance) {
  delete static_cast<Instance*>(instance);
}

}  // namespace arena::plugin
