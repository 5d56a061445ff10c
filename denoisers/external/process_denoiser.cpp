#include "denoisers/external/process_denoiser.hpp"

#include <bit>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/json_reader.hpp"
#include "core/sequence.hpp"
#include "core/text.hpp"

namespace arena {

static_assert(std::endian::native == std::endian::little,
              "the frame protocol sends float32 planes little-endian, as they lie in memory");

namespace {

std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g s", s);
  return buf;
}

}  // namespace

ExternalProcessDenoiser::ExternalProcessDenoiser(std::shared_ptr<const ExternalManifest> manifest,
                                                 const ParamSet& params, SignalKind kind)
    : manifest_(std::move(manifest)), params_(params.toJson()), kind_(kind) {
  const char* suffixes[] = {"R", "G", "B"};
  for (const char* s : suffixes) planeNames_.push_back(std::string("signal.") + s);
  for (const std::string& layer : manifest_->channels) {
    const LayerSpec& spec = frameLayerSpec(layer, manifest_->file.string());
    for (int c = 0; c < spec.channels(); ++c) planeNames_.push_back(spec.channelName(c));
  }
}

ExternalProcessDenoiser::~ExternalProcessDenoiser() = default;  // Subprocess ends the process

std::chrono::steady_clock::time_point ExternalProcessDenoiser::deadline() const {
  return std::chrono::steady_clock::now() +
         std::chrono::duration_cast<std::chrono::steady_clock::duration>(
             std::chrono::duration<double>(manifest_->timeoutSeconds));
}

void ExternalProcessDenoiser::fail(const std::string& what) {
  std::string message = manifest_->name + " (" + signalName(kind_) + " process, " +
                        manifest_->file.string() + "): " + (stage_.empty() ? "" : stage_ + ": ") +
                        what;
  if (process_) {
    message += process_->howItEnded(std::chrono::milliseconds(200));
    process_.reset();
  }
  throw Error(validUtf8(message));  // its words are the process's, in whatever bytes it wrote
}

std::string ExternalProcessDenoiser::finish() {
  if (!process_) return "";
  const std::string status = process_->endInput(std::chrono::milliseconds(1000));
  // Output beyond its last answer (a goodbye print): harmless now, but the same print between
  // frames would have failed a pair, so it is said.
  std::string excerpt;
  const size_t unread = status == "still running" ? 0 : process_->unreadOutput(excerpt);
  // Quoted on one line: a newline in it would break the warning that quotes it.
  std::string quoted;
  for (const char ch : utf8Excerpt(excerpt, 64, false))
    quoted += ch == '\n' ? std::string("\\n") : std::string(1, ch);
  const std::string stray =
      unread == 0
          ? ""
          : "wrote " + std::to_string(unread) + " byte(s) to its output after its last answer (\"" +
                quoted + "\"): its output carries only answers; write anything else to stderr";
  if (status == "exited with status 0") {
    if (stray.empty()) return "";
    process_.reset();
    return validUtf8(std::string("the ") + signalName(kind_) + " process (" +
                     manifest_->file.string() + ") " + stray);
  }
  if (status == "still running") {
    // Killed now (its destructor would wait another second), and said: every pair of this
    // contender, each signal, pays the second, which the user can save.
    process_->kill();
    process_.reset();
    // An isolated plugin's host exits as soon as the plugin's destroy() returns.
    if (manifest_->isolated)
      return std::string("the ") + signalName(kind_) + " instance of the isolated plugin (" +
             manifest_->file.string() +
             ") did not end within 1 s of its last frame (its destroy() did not return) and its "
             "process was killed (each pair paid that second)";
    return std::string("the ") + signalName(kind_) + " process (" + manifest_->file.string() +
           ") was still running 1 s after its input ended and was killed (exit when stdin closes: "
           "each process that does not costs every pair a second)";
  }
  const std::string tail = process_->stderrTail();
  process_.reset();
  return validUtf8(std::string("the ") + signalName(kind_) + " process (" +
                   manifest_->file.string() + ") " + status + " after its last frame" +
                   (stray.empty() ? "" : "; it " + stray) +
                   (tail.empty() ? "; its stderr was empty" : "; the end of its stderr:\n" + tail));
}

nlohmann::json ExternalProcessDenoiser::readHeader(const std::string& expectedType) {
  std::string line;
  try {
    line = process_->readLine(kMaxProtocolHeaderBytes, deadline());
  } catch (const Subprocess::TimedOut&) {
    fail("no " + expectedType +
         " header within timeoutSeconds = " + seconds(manifest_->timeoutSeconds) + " (a hang?)");
  } catch (const Error& e) {
    fail(std::string("expected a '") + expectedType + "' header line, but " + e.what());
  }
  nlohmann::json header;
  try {
    if (nlohmann::json::accept(line)) {
      // A key given twice ("computeMs": 0.5, "computeMs": 1e9) is refused, not read as the last.
      try {
        header = parseJsonText(line, "its '" + expectedType + "' header");
      } catch (const Error& e) {
        fail(e.what());
      }
    } else {
      header = nlohmann::json::parse(line);  // throws: the message below
    }
  } catch (const nlohmann::json::exception& e) {
    // A number beyond the double range (1e999) is named with its place, as in any JSON file.
    if (e.id == 406) try {
        static_cast<void>(parseJsonText(line, "its '" + expectedType + "' header"));
      } catch (const Error& placed) {
        fail(placed.what());
      }
    // Bytes before a header that parses (a line ending in {"type": ...}): perhaps the previous
    // answer's, more than its planes, or a print to stdout; said, since the error otherwise falls
    // on the frame after. (Stray float data holding a newline byte ends the line before any
    // header: then only the line is quoted.)
    const size_t brace = line.find("{\"type\"");
    const bool stray =
        brace != std::string::npos && brace > 0 && nlohmann::json::accept(line.substr(brace));
    fail("expected a JSON '" + expectedType +
         "' header line, got: " + utf8Excerpt(line, 200, false) +
         (stray ? " (" + std::to_string(brace) +
                      " stray byte(s) before the header: did the answer before send more than "
                      "its 3 planes, or the program print to stdout?)"
                : ""));
  }
  const std::string type =
      header.is_object() && header.contains("type") && header["type"].is_string()
          ? header["type"].get<std::string>()
          : "";
  if (type == "error")
    fail("it reported an error: " +
         (header.contains("message") && header["message"].is_string()
              ? header["message"].get<std::string>()
              : "(no message string; the header was " + utf8Excerpt(line, 200, false) + ")"));
  if (type != expectedType)
    fail("expected a header with \"type\": \"" + expectedType +
         "\", got: " + utf8Excerpt(line, 200, false));
  return header;
}

void ExternalProcessDenoiser::setup(int width, int height) {
  process_.reset();  // a second setup() starts afresh
  stage_ = "setup";
  width_ = width;
  height_ = height;
  try {
    process_ = std::make_unique<Subprocess>(manifest_->command, manifest_->folder());
  } catch (const Error& e) {
    fail(e.what());
  }
  const nlohmann::json setup = {{"type", "setup"},
                                {"protocol", kExternalProtocolVersion},
                                {"denoiser", manifest_->name},
                                {"signal", signalName(kind_)},
                                {"width", width},
                                {"height", height},
                                {"planes", planeNames_},
                                {"params", params_}};
  const std::string line = jsonText(setup) + "\n";
  try {
    process_->write(line.data(), line.size(), deadline());
  } catch (const Error& e) {
    fail(std::string("while sending the setup header: ") + e.what());
  }
  readHeader("ready");
  pendingReset_ = false;
}

void ExternalProcessDenoiser::denoise(const FrameContext& ctx, const DenoiserInputs& in,
                                      Image& output) {
  stage_ = "frame " + std::to_string(ctx.frameIndex);
  if (!process_)
    fail("the process is not running (a previous frame failed, or setup() was not called)");
  computeMs_.reset();
  std::vector<const float*> planes;
  for (int c = 0; c < 3; ++c) planes.push_back(in.signal.plane(c));
  for (const std::string& layer : manifest_->channels) {
    const Image& image =
        in.frame.get(layer, manifest_->name + " frame " + std::to_string(ctx.frameIndex));
    for (int c = 0; c < image.channels(); ++c) planes.push_back(image.plane(c));
  }
  if (planes.size() != planeNames_.size())
    fail("it has " + std::to_string(planes.size()) + " planes where the setup announced " +
         std::to_string(planeNames_.size()));
  const size_t planeBytes = size_t(width_) * size_t(height_) * sizeof(float);
  const nlohmann::json header = {{"type", "frame"},
                                 {"frame", ctx.frameIndex},
                                 {"reset", ctx.reset || pendingReset_},
                                 {"camera", cameraToJson(ctx.camera)},
                                 {"previousCamera", cameraToJson(ctx.previousCamera)},
                                 {"bytes", planeBytes * planes.size()}};
  pendingReset_ = false;
  const std::string line = jsonText(header) + "\n";
  const auto sendBy = deadline();
  try {
    process_->write(line.data(), line.size(), sendBy);
    for (const float* p : planes) process_->write(p, planeBytes, sendBy);
  } catch (const Subprocess::TimedOut&) {
    fail("could not be sent within timeoutSeconds = " + seconds(manifest_->timeoutSeconds) +
         " (it stopped reading its input)");
  } catch (const Error& e) {
    fail(e.what());
  }
  const nlohmann::json result = readHeader("result");
  auto number = [&](const char* key) -> double {
    if (!result.contains(key) || !result[key].is_number())
      fail(std::string("the result header needs a number \"") + key +
           "\", got: " + result.dump().substr(0, 200));
    return result[key].get<double>();
  };
  if (number("frame") != ctx.frameIndex)
    fail("answered frame " + result["frame"].dump() + " when frame " +
         std::to_string(ctx.frameIndex) + " was sent");
  const double w = number("width"), h = number("height"), channels = number("channels");
  if (w != width_ || h != height_ || channels != 3)
    fail("sent a " + result["width"].dump() + "x" + result["height"].dump() + "x" +
         result["channels"].dump() + " result; expected " + std::to_string(width_) + "x" +
         std::to_string(height_) + "x3 (RGB planes)");
  const double ms = number("computeMs");
  if (!std::isfinite(ms) || ms < 0) fail("computeMs must be a finite number >= 0");
  try {
    const auto readBy = deadline();
    for (int c = 0; c < 3; ++c) process_->read(output.plane(c), planeBytes, readBy);
  } catch (const Subprocess::TimedOut&) {
    fail("its planes did not arrive within timeoutSeconds = " + seconds(manifest_->timeoutSeconds) +
         " (fewer bytes than 3 x " + std::to_string(planeBytes) + "?)");
  } catch (const Error& e) {
    fail(std::string(e.what()) + " (expected 3 planes of " + std::to_string(planeBytes) +
         " bytes after the result header)");
  }
  passes_.clear();
  if (result.contains("passes")) {
    if (!result["passes"].is_array())
      fail("\"passes\" must be an array of {name, ms[, tapsPerPixel]}");
    for (const nlohmann::json& p : result["passes"]) {
      const auto nonNegative = [&](const char* key) {
        return p.contains(key) && p[key].is_number() && p[key].get<double>() >= 0;
      };
      if (!p.is_object() || !p.contains("name") || !p["name"].is_string() || !nonNegative("ms") ||
          (p.contains("tapsPerPixel") && !nonNegative("tapsPerPixel")))
        fail(
            "each entry of \"passes\" needs a string \"name\", a number \"ms\" >= 0 and "
            "optionally "
            "a number \"tapsPerPixel\" >= 0, got: " +
            p.dump());
      // Taps not reported are unknown (NaN), not 0: the results leave them out.
      passes_.push_back({p["name"].get<std::string>(), p["ms"].get<double>(),
                         p.value("tapsPerPixel", std::numeric_limits<double>::quiet_NaN())});
    }
  }
  // A non-finite output value fails the pair in DenoiseRun, as for every denoiser; found here,
  // the error also names the manifest and quotes the end of the process's stderr, where its own
  // prints are.
  size_t nonFinite = 0, first = 0;
  int firstPlane = 0;
  for (int c = 0; c < 3; ++c) {
    const float* p = output.plane(c);
    for (size_t i = 0; i < size_t(width_) * size_t(height_); ++i)
      if (!std::isfinite(p[i]) && nonFinite++ == 0) first = i, firstPlane = c;
  }
  if (nonFinite > 0) {
    char where[160];
    std::snprintf(where, sizeof where, "%g at x %zu, y %zu of its %s plane",
                  double(output.plane(firstPlane)[first]), first % size_t(width_),
                  first / size_t(width_),
                  firstPlane == 0   ? "R"
                  : firstPlane == 1 ? "G"
                                    : "B");
    fail("sent " + std::to_string(nonFinite) + " non-finite value(s) in its result (the first " +
         where + "); every output value must be a finite number");
  }
  computeMs_ = ms;
}

}  // namespace arena
