#include "harness/denoiser_server.hpp"

#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "core/sequence.hpp"
#include "core/text.hpp"
#include "denoisers/denoiser.hpp"
#include "denoisers/external/manifest.hpp"
#include "denoisers/external/plugin_denoiser.hpp"
#include "denoisers/external/process_denoiser.hpp"
#include "harness/denoise_run.hpp"

namespace arena {

static_assert(std::endian::native == std::endian::little,
              "the frame protocol sends float32 planes little-endian, as they lie in memory");

namespace {

using nlohmann::json;

constexpr int kMaxSide = 1 << 15;

// Blocking reads and writes on the two descriptors (the harness drives its end with deadlines).
class Wire {
 public:
  Wire(int in, int out) : in_(in), out_(out) {}

  // One header line without its '\n'; false when the input ended before any byte of it.
  bool readLine(std::string& line) {
    line.clear();
    for (;;) {
      if (const size_t nl = buffer_.find('\n'); nl != std::string::npos) {
        line = buffer_.substr(0, nl);
        buffer_.erase(0, nl + 1);
        return true;
      }
      if (buffer_.size() > kMaxProtocolHeaderBytes)
        throw Error("a header line longer than 1 MiB (expected one JSON line)");
      if (!fill()) {
        if (buffer_.empty()) return false;
        throw Error("the input ended inside a header line: " + utf8Excerpt(buffer_, 200, false));
      }
    }
  }
  void read(void* data, size_t bytes) {
    char* to = static_cast<char*>(data);
    const size_t buffered = std::min(bytes, buffer_.size());
    std::memcpy(to, buffer_.data(), buffered);
    buffer_.erase(0, buffered);
    for (size_t got = buffered; got < bytes;) {
      const ssize_t n = ::read(in_, to + got, bytes - got);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw Error(std::string("cannot read its input: ") + std::strerror(errno));
      if (n == 0)
        throw Error("the input ended after " + std::to_string(got) + " of its " +
                    std::to_string(bytes) + " bytes");
      got += size_t(n);
    }
  }
  void write(const void* data, size_t bytes) {
    const char* from = static_cast<const char*>(data);
    for (size_t put = 0; put < bytes;) {
      const ssize_t n = ::write(out_, from + put, bytes - put);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) throw Error(std::string("cannot write the answer: ") + std::strerror(errno));
      put += size_t(n);
    }
  }
  void writeLine(const json& header) {
    const std::string line = jsonText(header) + "\n";
    write(line.data(), line.size());
  }

 private:
  bool fill() {
    char chunk[65536];
    for (;;) {
      const ssize_t n = ::read(in_, chunk, sizeof chunk);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw Error(std::string("cannot read its input: ") + std::strerror(errno));
      if (n == 0) return false;
      buffer_.append(chunk, size_t(n));
      return true;
    }
  }

  int in_, out_;
  std::string buffer_;
};

json parseHeader(const std::string& line, const std::string& type) {
  json header;
  try {
    header = json::parse(line);
  } catch (const std::exception&) {
    throw Error("expected a JSON '" + type + "' line, got: " + utf8Excerpt(line, 200, false));
  }
  if (!header.is_object() || !header.contains("type") || header["type"] != type)
    throw Error("expected a header with \"type\": \"" + type +
                "\", got: " + utf8Excerpt(line, 200, false));
  return header;
}

int intField(const json& header, const char* key, int min, int max) {
  if (!header.contains(key) || !header[key].is_number_integer() || header[key].get<long>() < min ||
      header[key].get<long>() > max)
    throw Error(std::string("the '") + header.value("type", "?") + "' header needs an integer \"" +
                key + "\" in [" + std::to_string(min) + ", " + std::to_string(max) +
                "], got: " + (header.contains(key) ? header[key].dump() : "nothing"));
  return header[key].get<int>();
}

// A parameter's value as the text --param would give (ParamSchema::resolve checks it).
std::string paramText(const json& value, const std::string& name) {
  if (value.is_boolean()) return value.get<bool>() ? "true" : "false";
  if (value.is_string()) return value.get<std::string>();
  if (value.is_number()) return value.dump();  // integers as such, doubles the shortest round trip
  throw Error("setup: parameter '" + name + "' is " + jsonTypeName(value) +
              "; expected a boolean, a number or a choice's name");
}

// Where each layer the denoiser reads lies in the frame's planes.
struct PlaneMap {
  std::vector<std::string> layers;          // the layers the denoiser reads, in declaration order
  std::vector<std::vector<size_t>> planes;  // per layer, its channels' indices in the frame
};

PlaneMap mapPlanes(const std::vector<std::string>& sent, const std::vector<std::string>& reads,
                   const std::string& denoiser) {
  const char* signal[] = {"signal.R", "signal.G", "signal.B"};
  for (size_t c = 0; c < 3; ++c)
    if (sent.size() <= c || sent[c] != signal[c])
      throw Error("setup: \"planes\" must begin with signal.R, signal.G, signal.B; got " +
                  (sent.size() > c ? "'" + sent[c] + "'" : std::string("nothing")) + " at index " +
                  std::to_string(c));
  PlaneMap map;
  for (const std::string& layer : reads) {
    const LayerSpec& spec = frameLayerSpec(layer, denoiser + " reads");
    std::vector<size_t> at;
    for (int c = 0; c < spec.channels(); ++c) {
      const std::string name = spec.channelName(c);
      const auto it = std::find(sent.begin(), sent.end(), name);
      if (it == sent.end())
        throw Error("setup: " + denoiser + " reads the layer '" + layer +
                    "', but \"planes\" has no '" + name +
                    "' (declare the layer in the manifest's \"channels\")");
      at.push_back(size_t(it - sent.begin()));
    }
    map.layers.push_back(layer);
    map.planes.push_back(std::move(at));
  }
  return map;
}

// A manifest's process already speaks the protocol: serving it again would only add a hop.
const std::string& servable(const std::string& entry) {
  if (entry.rfind("ext:", 0) == 0)
    throw Error("'" + entry +
                "': serve takes plugin:LIBRARY or a built-in's name; an ext: manifest names a "
                "program that speaks the frame protocol itself");
  // The registry's own error would offer ext: and names on ARENA_DENOISER_PATH, which serve takes
  // neither of.
  if (entry.rfind("plugin:", 0) != 0 && !DenoiserRegistry::instance().has(entry)) {
    std::string known;
    for (const std::string& name : DenoiserRegistry::instance().names())
      known += (known.empty() ? "" : ", ") + name;
    throw Error("unknown denoiser '" + entry +
                "'; serve takes plugin:LIBRARY or a built-in: " + known);
  }
  return entry;
}

class Server {
 public:
  Server(const std::string& entry, Wire& wire)
      : info_(DenoiserRegistry::instance().find(DenoiserRegistry::resolve(servable(entry)))),
        wire_(wire) {}

  void setup(const json& s) {
    const int protocol = intField(s, "protocol", 0, 1 << 30);
    if (protocol != kExternalProtocolVersion)
      throw Error("setup: protocol " + std::to_string(protocol) + "; this arena speaks version " +
                  std::to_string(kExternalProtocolVersion));
    width_ = intField(s, "width", 1, kMaxSide);
    height_ = intField(s, "height", 1, kMaxSide);
    const std::string signal = s.value("signal", "");
    if (signal == "diffuse" || signal == "specular") {
      kind_ = signal == "diffuse" ? SignalKind::Diffuse : SignalKind::Specular;
      if (info_.signals != SignalMode::Demodulated)
        throw Error("setup: signal '" + signal + "', but " + info_.name +
                    " filters the colour (its manifest must say \"signals\": \"color\")");
    } else if (signal == "color") {
      kind_ = SignalKind::Color;
      if (info_.signals != SignalMode::Color)
        throw Error("setup: signal 'color', but " + info_.name +
                    " filters the demodulated diffuse and specular signals (its manifest must say "
                    "\"signals\": \"demodulated\")");
    } else {
      throw Error("setup: \"signal\" must be diffuse, specular or color; got " +
                  (s.contains("signal") ? s["signal"].dump() : std::string("nothing")));
    }
    if (!s.contains("planes") || !s["planes"].is_array())
      throw Error("setup: expected \"planes\", an array of plane names");
    for (const json& p : s["planes"]) {
      if (!p.is_string()) throw Error("setup: \"planes\" holds " + p.dump() + ", not a name");
      if (std::find(sent_.begin(), sent_.end(), p.get<std::string>()) != sent_.end())
        throw Error("setup: \"planes\" names '" + p.get<std::string>() +
                    "' twice (each plane once, as a manifest names each layer once)");
      sent_.push_back(p.get<std::string>());
    }
    std::map<std::string, std::string> overrides;
    if (s.contains("params")) {
      if (!s["params"].is_object()) throw Error("setup: \"params\" must be an object");
      for (const auto& [name, value] : s["params"].items())
        overrides[name] = paramText(value, name);
    }
    const ParamSet params = info_.schema.resolve(overrides, info_.name);
    denoiser_ = info_.create(params, kind_);
    if (denoiser_->needsGradients())
      throw Error(info_.name +
                  " reads A-SVGF's gradient samples, which the frame protocol does not carry; it "
                  "runs only inside arena");
    if (denoiser_->needsLowres())
      throw Error(info_.name +
                  " needs the sequence's low-resolution buffer, which the frame protocol does not "
                  "carry; it runs only inside arena");
    map_ = mapPlanes(sent_, denoiser_->requiredChannels(), info_.name);
    denoiser_->setup(width_, height_);
    output_ = Image(width_, height_, 3);
    signal_ = Image(width_, height_, 3);
    for (size_t i = 0; i < map_.layers.size(); ++i)
      frame_.set(map_.layers[i], Image(width_, height_, int(map_.planes[i].size())));
    wire_.writeLine({{"type", "ready"}});
  }

  void frame(const json& f) {
    const int t = intField(f, "frame", 0, 1 << 30);
    const size_t planeBytes = size_t(width_) * size_t(height_) * sizeof(float);
    if (!f.contains("bytes") || !f["bytes"].is_number_unsigned() ||
        f["bytes"].get<size_t>() != planeBytes * sent_.size())
      throw Error("frame " + std::to_string(t) + ": \"bytes\" must be " +
                  std::to_string(planeBytes * sent_.size()) + " (" + std::to_string(sent_.size()) +
                  " planes of " + std::to_string(width_) + "x" + std::to_string(height_) +
                  " floats), got " +
                  (f.contains("bytes") ? f["bytes"].dump() : std::string("nothing")));
    if (!f.contains("reset") || !f["reset"].is_boolean())
      throw Error("frame " + std::to_string(t) + ": expected a boolean \"reset\"");
    FrameContext ctx;
    ctx.frameIndex = t;
    ctx.width = width_;
    ctx.height = height_;
    ctx.reset = f["reset"].get<bool>();
    for (const char* key : {"camera", "previousCamera"}) {
      CameraState& camera = std::string(key) == "camera" ? ctx.camera : ctx.previousCamera;
      try {
        camera = cameraFromJson(f.contains(key) ? f[key] : json());
      } catch (const Error& e) {
        throw Error("frame " + std::to_string(t) + ": \"" + key + "\": " + e.what());
      }
      // The plugin derives its aspect and pixel mapping from it: the frame's size or an error.
      if (camera.width != width_ || camera.height != height_)
        throw Error("frame " + std::to_string(t) + ": \"" + key + "\" is " +
                    std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                    "; the frames are " + std::to_string(width_) + "x" + std::to_string(height_));
    }
    // Every plane read, in the order sent; those the denoiser does not read are read and dropped.
    std::vector<float*> into(sent_.size(), nullptr);
    for (int c = 0; c < 3; ++c) into[size_t(c)] = signal_.plane(c);
    for (size_t i = 0; i < map_.layers.size(); ++i)
      for (size_t c = 0; c < map_.planes[i].size(); ++c)
        into[map_.planes[i][c]] = frame_.get(map_.layers[i]).plane(int(c));
    scratch_.resize(size_t(width_) * size_t(height_));
    for (size_t i = 0; i < into.size(); ++i) try {
        wire_.read(into[i] ? into[i] : scratch_.data(), planeBytes);
      } catch (const Error& e) {
        throw Error("frame " + std::to_string(t) + ": plane '" + sent_[i] + "' (" +
                    std::to_string(i + 1) + " of " + std::to_string(into.size()) +
                    "): " + e.what());
      }
    // The harness replaces non-finite inputs by 0 before sending: one here is the sender's, and
    // would otherwise come back as the denoiser's non-finite output.
    for (size_t i = 0; i < into.size(); ++i)
      if (into[i]) {
        const size_t bad = size_t(std::count_if(into[i], into[i] + size_t(width_) * size_t(height_),
                                                [](float v) { return !std::isfinite(v); }));
        if (bad > 0)
          throw Error("frame " + std::to_string(t) + ": its input plane '" + sent_[i] + "' holds " +
                      std::to_string(bad) +
                      " non-finite value(s); the protocol's planes are finite (the harness "
                      "replaces NaN/Inf by 0 before sending)");
      }
    // As DenoiseRun: reset() at a cut after the first frame, the context saying reset on both.
    if (ctx.reset && started_) denoiser_->reset();
    started_ = true;
    const DenoiserInputs in{signal_, frame_, nullptr, nullptr};
    denoiser_->clearPassStats();
    markUnwritten(output_);
    const auto start = std::chrono::steady_clock::now();
    denoiser_->denoise(ctx, in, output_);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (const std::string fault = outputFault(output_, signal_, info_.name, kind_, t, info_.origin);
        !fault.empty())
      throw Error(fault);
    json passes = json::array();
    for (const PassStats& p : denoiser_->lastPasses()) {
      json pass = {{"name", p.name}, {"ms", p.milliseconds}};
      if (std::isfinite(p.tapsPerPixel) && p.tapsPerPixel >= 0)
        pass["tapsPerPixel"] = p.tapsPerPixel;
      passes.push_back(std::move(pass));
    }
    wire_.writeLine({{"type", "result"},
                     {"frame", t},
                     {"width", width_},
                     {"height", height_},
                     {"channels", 3},
                     // A served denoiser that measures itself (an external process served again)
                     // keeps its own clock.
                     {"computeMs", denoiser_->reportedMilliseconds().value_or(ms)},
                     {"passes", std::move(passes)}});
    for (int c = 0; c < 3; ++c) wire_.write(output_.plane(c), planeBytes);
  }

 private:
  const DenoiserInfo& info_;
  Wire& wire_;
  SignalKind kind_ = SignalKind::Diffuse;
  int width_ = 0, height_ = 0;
  std::vector<std::string> sent_;
  PlaneMap map_;
  std::unique_ptr<Denoiser> denoiser_;
  Image signal_, output_;
  LayerSet frame_;
  std::vector<float> scratch_;
  bool started_ = false;
};

}  // namespace

int describeDenoiser(const std::string& entry, int outFd) {
  try {
    json d;
    std::vector<std::string> channels;
    DenoiserInfo info;
    if (entry.rfind("plugin:", 0) == 0) {
      info = loadPluginDenoiser(entry.substr(7), &channels);
    } else {
      info = DenoiserRegistry::instance().find(DenoiserRegistry::resolve(servable(entry)));
      channels =
          info.create(info.schema.resolve({}, info.name),
                      info.signals == SignalMode::Color ? SignalKind::Color : SignalKind::Diffuse)
              ->requiredChannels();
    }
    d["name"] = info.name;
    d["description"] = info.description;
    d["signals"] = info.signals == SignalMode::Color ? "color" : "demodulated";
    d["channels"] = channels;
    d["parameters"] = json::array();
    for (const ParamSpec& spec : info.schema.specs())
      d["parameters"].push_back(paramSpecJson(spec));
    Wire(-1, outFd).writeLine(d);
    return 0;
  } catch (const Error& e) {
    std::cerr << "arena serve: " << e.what() << "\n";
    return 2;
  }
}

int serveDenoiser(const std::string& entry, int inFd, int outFd) {
  Wire wire(inFd, outFd);
  std::unique_ptr<Server> server;
  try {
    server = std::make_unique<Server>(entry, wire);
  } catch (const Error& e) {
    std::cerr << "arena serve: " << e.what() << "\n";
    return 2;
  }
  try {
    std::string line;
    if (!wire.readLine(line)) throw Error("the input ended before the setup line");
    server->setup(parseHeader(line, "setup"));
    while (wire.readLine(line)) server->frame(parseHeader(line, "frame"));
    return 0;
  } catch (const std::exception& e) {
    // Said once: in the answer, which the harness quotes, or on stderr when it cannot be sent.
    const std::string message = validUtf8(e.what());
    try {
      wire.writeLine({{"type", "error"}, {"message", message}});
    } catch (const Error&) {
      std::cerr << "arena serve: " << message << "\n";
    }
    return 1;
  }
}

}  // namespace arena
