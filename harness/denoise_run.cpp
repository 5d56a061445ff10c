#include "harness/denoise_run.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>

#include "core/error.hpp"
#include "core/sequence.hpp"
#include "core/text.hpp"
#include "denoisers/common/remodulation.hpp"
#include "denoisers/external/process_denoiser.hpp"

namespace arena {

namespace {

// A denoiser's error that a layer is missing, where the frame holds it but the denoiser did not
// declare it (so was not handed it): says so. Empty for any other error.
std::string undeclaredRead(const std::string& message, const LayerSet& frame,
                           const LayerSet& handed, const std::string& denoiser) {
  for (const auto& [name, image] : frame.all())
    if (!handed.has(name) && message.find("missing channel '" + name + "'") != std::string::npos)
      return message + ": " + denoiser + " reads layer '" + name +
             "', which the frame holds but it does not declare (requiredChannels()); a denoiser is "
             "handed only the layers it declares, as a plugin is sent them, so that every "
             "contender "
             "reads the same information (docs/extending.md)";
  return {};
}

// The unwritten-value marker (markUnwritten).
constexpr uint32_t kUnwrittenBits = 0x7fc0dea1u;

}  // namespace

std::string reportedFault(const std::string& name, const std::string& where,
                          const std::optional<double>& reported,
                          const std::vector<PassStats>& passes, double wall) {
  const std::string call = ", in a call of " + shortestText(wall) + " ms";
  if (reported && !(*reported <= kMaxFrameMilliseconds))
    return name + " reported a time of " + shortestText(*reported) + " ms on " + where +
           " (computeMs)" + call + "; expected at most 1e9 ms";
  for (const PassStats& p : passes) {
    if (!(p.milliseconds <= kMaxFrameMilliseconds))
      return name + " reported its pass '" + p.name + "' at " + shortestText(p.milliseconds) +
             " ms on " + where + call + "; expected at most 1e9 ms";
    for (const auto& [what, value] :
         {std::pair{"taps", p.tapsPerPixel}, std::pair{"rays", p.raysPerPixel}}) {
      if (std::isnan(value) && std::string(what) == "taps") continue;  // a process may not say
      if (!(value >= 0 && value <= 1e9))
        return name + " reported its pass '" + p.name + "' at " + shortestText(value) + " " + what +
               " per pixel on " + where + "; expected 0 to 1e9";
    }
  }
  return "";
}

std::string implausibleTime(const std::optional<double>& reported,
                            const std::vector<PassStats>& passes, double wall) {
  const double limit = wall * 1.01 + 0.05;
  char buf[160];
  if (reported && *reported > limit) {
    std::snprintf(buf, sizeof buf, "computeMs %.4g ms in a call of %.4g ms", *reported, wall);
    return buf;
  }
  double sum = 0;
  for (const PassStats& p : passes) sum += p.milliseconds;
  if (sum > limit) {
    std::snprintf(buf, sizeof buf, "passes of %.4g ms in all in a call of %.4g ms", sum, wall);
    return buf;
  }
  return "";
}

void markUnwritten(Image& output) {
  for (int c = 0; c < output.channels(); ++c)
    std::fill(output.planeSpan(c).begin(), output.planeSpan(c).end(),
              std::bit_cast<float>(kUnwrittenBits));
}

std::string outputFault(const Image& output, const Image& input, const std::string& denoiser,
                        SignalKind kind, int frame, const std::string& origin) {
  const std::string name = origin.empty() ? denoiser : denoiser + " (" + origin + ")";
  if (output.width() != input.width() || output.height() != input.height() ||
      output.channels() != 3)
    return name + " returned a " + std::to_string(output.width()) + "x" +
           std::to_string(output.height()) + "x" + std::to_string(output.channels()) +
           " output on the " + signalName(kind) + " signal at frame " + std::to_string(frame) +
           "; expected " + std::to_string(input.width()) + "x" + std::to_string(input.height()) +
           "x3, the signal's size (write into the output image given, or one of its size)";
  if (nonFiniteValues(output) == 0) return "";
  size_t n = 0;
  for (int c = 0; c < output.channels(); ++c)
    for (const float v : output.planeSpan(c)) n += std::bit_cast<uint32_t>(v) == kUnwrittenBits;
  if (n == 0)
    return name + " produced a non-finite value on the " + signalName(kind) + " signal at frame " +
           std::to_string(frame);
  return name + " left " + std::to_string(n) + " of the " +
         std::to_string(output.pixelCount() * size_t(output.channels())) + " values of its " +
         signalName(kind) + " output unwritten at frame " + std::to_string(frame) +
         " (every value of the output image must be written on every frame)";
}

std::string lowresNeeded(const std::string& label) {
  return "--lowres-factor 0: " + label +
         " needs the sequence's low-resolution buffer; expected --lowres-factor >= 2 (e.g. 8, with "
         "--lowres-spp 16), or parameters that do not need it (`arena denoisers` lists them)";
}

std::map<std::string, std::map<std::string, std::string>> parseParamAssignments(const std::vector<std::string>& items) {
  std::map<std::string, std::map<std::string, std::string>> out;
  const auto& registry = DenoiserRegistry::instance();
  for (const std::string& item : items) {
    size_t eq = item.find('='), dot = item.find('.');
    if (eq == std::string::npos || dot == std::string::npos || dot > eq)
      throw Error("--param '" + item + "': expected DENOISER.NAME=VALUE, e.g. svgf.sigmaL=4");
    // "svgf.sigmaL=8,svgf.alpha=0.1" would read "8,svgf.alpha=0.1" as sigmaL's value.
    if (const size_t comma = item.find(',', eq);
        comma != std::string::npos && item.find('=', comma) != std::string::npos)
      throw Error("--param '" + item +
                  "': one assignment per --param; give each its own (--param " +
                  item.substr(0, comma) + " --param " + item.substr(comma + 1) + ")");
    std::string denoiser = item.substr(0, dot);
    registry.find(denoiser);  // throws, listing the registered names
    const std::string name = item.substr(dot + 1, eq - dot - 1);
    auto [it, inserted] = out[denoiser].emplace(name, item.substr(eq + 1));
    if (!inserted)
      throw Error("--param '" + item + "': " + denoiser + "." + name + " is already set to '" + it->second +
                  "' (give each parameter once)");
  }
  return out;
}

std::string defaultLabel(const DenoiserRequest& r) {
  if (r.params.empty()) return r.name;
  // The values as the schema reads them ("2.0" and "2" are one contender), where the denoiser is
  // registered (a label is also asked of entries that are not, e.g. a capture's stored outputs).
  std::optional<ParamSet> resolved;
  if (DenoiserRegistry::instance().has(r.name))
    resolved = DenoiserRegistry::instance().find(r.name).schema.resolve(r.params, r.name);
  std::string s = r.name + "[";
  bool first = true;
  for (const auto& [k, v] : r.params) {
    s += (first ? "" : ",") + k + "=" + (resolved ? resolved->text(k) : v);
    first = false;
  }
  return s + "]";
}

long sanitizeInputs(LayerSet& layers, const std::vector<std::string>& names,
                    const std::vector<LayerSpec>& specs, const std::string& prefix, NonFiniteCounts& counts) {
  if (countNonFinite(layers, specs, prefix, counts, names) == 0) return 0;
  long replaced = 0;
  for (auto& [name, image] : layers.all())
    if (names.empty() || std::find(names.begin(), names.end(), name) != names.end())
      replaced += replaceNonFinite(layers.get(name));
  return replaced;
}

long sanitizeGradientSamples(LayerSet& gradients, NonFiniteCounts& counts) {
  const std::vector<LayerSpec>& specs = channels::gradientLayers();
  if (countNonFinite(gradients, specs, "gradients: ", counts) == 0) return 0;
  long replaced = 0;
  for (const LayerSpec& spec : specs) {
    if (!gradients.has(spec.name)) continue;
    Image& samples = gradients.get(spec.name);
    const auto valid = std::find(spec.suffixes.begin(), spec.suffixes.end(), "valid");
    if (valid != spec.suffixes.end() && int(valid - spec.suffixes.begin()) < samples.channels())
      invalidateNonFinitePixels(samples, int(valid - spec.suffixes.begin()));
    replaced += replaceNonFinite(samples);
  }
  return replaced;
}

std::string sanitizedWarning(const NonFiniteCounts& counts) {
  if (counts.empty()) return "";
  return std::to_string(totalNonFinite(counts)) + " non-finite input values (" + describeNonFinite(counts) +
         ") were replaced by 0 before the denoiser ran; its results may differ from those on clean inputs";
}

std::string capturedOutputName(const std::string& entry) {
  return entry.rfind("file:", 0) == 0 ? entry.substr(5) : std::string();
}

std::string unknownLayerProblem(const std::string& denoiser, const std::string& channel) {
  std::vector<std::string> layerNames;
  for (const LayerSpec& spec : channels::frameLayers()) layerNames.push_back(spec.name);
  if (std::find(layerNames.begin(), layerNames.end(), channel) != layerNames.end()) return "";
  std::string all;
  for (const std::string& n : layerNames) all += (all.empty() ? "" : ", ") + n;
  const std::string likely = closestName(channel, layerNames);
  return denoiser + " requires channel '" + channel + "', which is no frame layer" +
         (likely.empty() ? "" : " (did you mean '" + likely + "'?)") + "; the layers: " + all +
         " (core/sequence.hpp)";
}

std::string lackingInputs(const DenoiserRequest& request, const Sequence& sequence) {
  return DenoiseRun(DenoiserRegistry::instance().find(request.name), request, sequence, false)
      .lacking_;
}

DenoiseRun::DenoiseRun(const DenoiserRequest& request, const Sequence& sequence)
    : DenoiseRun(DenoiserRegistry::instance().find(request.name), request, sequence, true) {}

DenoiseRun::DenoiseRun(const DenoiserInfo& info, const DenoiserRequest& request,
                       const Sequence& sequence)
    : DenoiseRun(info, request, sequence, true) {}

DenoiseRun::DenoiseRun(const DenoiserInfo& info, const DenoiserRequest& request,
                       const Sequence& sequence, bool setUp)
    : sequence_(sequence), request_(request), info_(info) {
  params_ = info_.schema.resolve(request.params, request.name);
  // A denoiser whose output is its input (passthrough) runs on the colour: its output is then the
  // noisy input itself, bit for bit (remodulated signals differ from an engine's colour by
  // rounding, so a stored copy of the input did not read as identical to it), and a capture of the
  // colour alone, with no signals to demodulate, has it too. Any other denoiser needs the parts
  // and says so below.
  mode_ = info_.signals;
  if (mode_ == SignalMode::Demodulated && info_.identity) {
    const std::vector<std::string> known = sequence.info().availableLayers();
    if (std::find(known.begin(), known.end(), "color") != known.end()) mode_ = SignalMode::Color;
  }
  if (mode_ == SignalMode::Color) {
    instances_.emplace_back(SignalKind::Color, info_.create(params_, SignalKind::Color));
  } else {
    instances_.emplace_back(SignalKind::Diffuse, info_.create(params_, SignalKind::Diffuse));
    instances_.emplace_back(SignalKind::Specular, info_.create(params_, SignalKind::Specular));
  }
  Denoiser& first = *instances_.front().second;
  // What the instances read of a frame: their signals and every channel either declares (the
  // specular instance may need more than the diffuse one, e.g. roughness).
  for (auto& [kind, d] : instances_) {
    std::vector<std::string> layers = d->requiredChannels();
    layers.insert(layers.begin(), signalName(kind));
    for (const std::string& c : layers)
      if (std::find(readLayers_.begin(), readLayers_.end(), c) == readLayers_.end()) readLayers_.push_back(c);
  }
  std::vector<std::string> missing;
  const std::vector<std::string> known = sequence.info().availableLayers();
  std::vector<std::string> needed = readLayers_;
  if (mode_ == SignalMode::Demodulated)  // remodulation reads these
    for (const char* c : {"albedo", "specAlbedo", "emission"}) needed.push_back(c);
  for (const std::string& c : needed)
    if (std::find(known.begin(), known.end(), c) == known.end() &&
        std::find(missing.begin(), missing.end(), c) == missing.end())
      missing.push_back(c);
  // A name that is no frame layer at all (a denoiser's typo, `normals`): no sequence could hold
  // it, and re-rendering would not help.
  for (const std::string& c : missing)
    if (lacking_.empty()) lacking_ = unknownLayerProblem(request.name, c);
  if (!missing.empty() && lacking_.empty()) {
    std::string list;
    for (auto& m : missing) list += " '" + m + "'";
    lacking_ = request.name + " needs channel(s)" + list + " that " +
               (sequence.isCapture() ? "capture " : "sequence ") + sequence.dir().string() +
               " does not provide" +
               (sequence.isCapture() ? " (docs/captures.md lists the layers and their meaning)"
                                     : " (re-render it with a tracer that writes them)");
  }
  needsGradients_ = first.needsGradients();
  if (needsGradients_ && !sequence.info().hasGradients && lacking_.empty())
    lacking_ = request.name +
               " needs gradient samples (frame t re-shaded with frame t-1's random numbers" +
               (sequence.isCapture()
                    ? std::string(": a capture's gradients_NNNN.exr files, docs/captures.md")
                    : std::string(": the 'gradient' layer")) +
               ") that " + sequence.dir().string() + " does not provide";
  readsLowres_ = first.wantsLowres() && sequence.info().lowresFactor() > 0;
  if (!setUp) return;
  if (!lacking_.empty()) throw Error(lacking_);
  for (auto& [kind, d] : instances_) d->setup(sequence.info().width, sequence.info().height);
}

std::vector<std::string> DenoiseRun::finish() {
  std::vector<std::string> out;
  for (auto& [kind, instance] : instances_)
    if (auto* process = dynamic_cast<ExternalProcessDenoiser*>(instance.get()))
      if (std::string ended = process->finish(); !ended.empty()) out.push_back(std::move(ended));
  return out;
}

void DenoiseRun::run(const std::function<const LayerSet&(int)>& frameOf,
                     const std::function<void(const DenoisedFrame&)>& onFrame) {
  const SequenceInfo& info = sequence_.info();
  const int w = info.width, h = info.height;
  const bool colorOnly = mode_ == SignalMode::Color;
  DenoisedFrame out;
  if (!colorOnly) {
    out.diffuse = Image(w, h, 3);
    out.specular = Image(w, h, 3);
  }
  out.color = Image(w, h, 3);
  // What a denoiser is handed of a frame: the layers it declares (its signals and
  // requiredChannels()) and no other, as a plugin or a process is sent, so that every contender
  // reads the same information and an undeclared read (an oracle layer, say) fails instead of
  // ranking unlabelled. The frame is shared with the evaluation (and other pairs): its planes are
  // borrowed, and copied only when a layer the denoiser reads holds a NaN/Inf to sanitise.
  LayerSet frame, sanitized;  // `sanitized` owns the copies, its buffers reused frame to frame
  for (int t = 0; t < info.frames; ++t) {
    const LayerSet& cached = frameOf(t);
    for (const std::string& c : readLayers_) cached.get(c, sequence_.dir().string() + " frame " + std::to_string(t));
    out.sanitized.clear();
    const bool sanitize =
        countNonFinite(cached, channels::frameLayers(), "", out.sanitized, readLayers_) > 0;
    for (const std::string& name : readLayers_) {
      const Image& layer = cached.get(name);
      const Image* source = &layer;
      if (sanitize) {
        sanitized.copyIn(name, layer);
        replaceNonFinite(sanitized.get(name));
        source = &sanitized.get(name);
      }
      frame.set(name, Image::borrow(const_cast<float*>(source->raw().data()), source->width(),
                                    source->height(), source->channels()));
    }
    LayerSet gradients;
    if (needsGradients_ && t > 0) {
      gradients = sequence_.gradients(t);
      sanitizeGradientSamples(gradients, out.sanitized);
    }
    LayerSet lowresLayers;
    if (readsLowres_) {
      lowresLayers = sequence_.lowres(t);
      sanitizeInputs(lowresLayers, {}, channels::lowresLayers(), "lowres: ", out.sanitized);
    }
    const LowresInputs lowres{lowresLayers, info.lowresFactor(), info.lowresSpp()};
    FrameContext ctx;
    ctx.frameIndex = t;
    ctx.width = w;
    ctx.height = h;
    ctx.camera = info.cameras[size_t(t)];
    ctx.previousCamera = info.cameras[size_t(std::max(t - 1, 0))];
    ctx.reset = t == 0;
    for (const SequenceEvent& e : info.events) ctx.reset = ctx.reset || (e.kind == EventKind::CameraCut && e.frame == t);
    if (ctx.reset && t > 0)
      for (auto& [kind, d] : instances_) d->reset();
    out.frame = t;
    out.passes.clear();
    out.milliseconds = 0;
    out.wallMilliseconds = 0;
    out.selfTimed = false;
    out.extraRaysPerPixel = 0;
    out.implausibleTime.clear();
    out.outputIsInput = true;
    for (auto& [kind, instance] : instances_) {
      Denoiser& d = *instance;
      Image& result = kind == SignalKind::Color ? out.color : kind == SignalKind::Diffuse ? out.diffuse : out.specular;
      DenoiserInputs in{frame.get(signalName(kind)), frame, needsGradients_ && t > 0 ? &gradients : nullptr,
                        readsLowres_ ? &lowres : nullptr};
      d.clearPassStats();
      markUnwritten(result);
      auto start = std::chrono::steady_clock::now();
      try {
        d.denoise(ctx, in, result);
      } catch (const Error& e) {
        if (const std::string named = undeclaredRead(e.what(), cached, frame, request_.name);
            !named.empty())
          throw Error(named);
        throw;
      }
      const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      const std::optional<double> reported = d.reportedMilliseconds();
      // A reported time or count beyond any frame's is the denoiser's fault, not a number to
      // average.
      if (const std::string fault = reportedFault(
              info_.origin.empty() ? request_.name : request_.name + " (" + info_.origin + ")",
              std::string("the ") + signalName(kind) + " signal at frame " + std::to_string(t),
              reported, d.lastPasses(), wall);
          !fault.empty())
        throw Error(fault);
      out.wallMilliseconds += wall;
      out.milliseconds += reported.value_or(wall);
      out.selfTimed = reported.has_value();
      if (const std::string wrong = implausibleTime(reported, d.lastPasses(), wall);
          !wrong.empty() && out.implausibleTime.empty())
        out.implausibleTime = std::string(signalName(kind)) + ": " + wrong;
      if (const std::string fault =
              outputFault(result, in.signal, request_.name, kind, t, info_.origin);
          !fault.empty())
        throw Error(fault);
      out.outputIsInput =
          out.outputIsInput && in.signal.sameShape(result) &&
          std::equal(in.signal.raw().begin(), in.signal.raw().end(), result.raw().begin());
      for (PassStats p : d.lastPasses()) {
        p.name = std::string(signalName(kind)) + "/" + p.name;
        out.extraRaysPerPixel += p.raysPerPixel;
        out.passes.push_back(p);
      }
    }
    // A-SVGF's gradient samples: each valid one is a path re-shaded at this frame (paper §3.1-3.3),
    // read by both signals' instances but traced once. (The tracer also re-shades the old sample
    // to know its luminance; a real-time implementation keeps that value, so it is not charged.)
    // At a cut the history they would correct is gone: none are traced there, none charged.
    if (needsGradients_ && t > 0 && !ctx.reset) {
      const double valid = double(nonZeroPixels(gradients.get("gradient"), 4));
      out.extraRaysPerPixel += valid / (double(w) * double(h));
    }
    if (colorOnly) {  // the denoiser's output is the final colour: nothing to remodulate
      onFrame(out);
      continue;
    }
    // Remodulation reads the cache's own layers: a non-finite one fails the pair below, it is not
    // an input of the denoiser to sanitise.
    remodulate(cached.get("albedo"), out.diffuse, cached.get("specAlbedo"), out.specular, cached.get("emission"),
               out.color);
    // The filtered signals are finite (checked above), so a non-finite colour comes from the cache's
    // remodulation layers: fail the pair naming them rather than score NaN as a perfect frame.
    if (const long bad = nonFiniteValues(out.color)) {
      std::string layers;
      for (const char* name : {"albedo", "specAlbedo", "emission"})
        if (const long n = nonFiniteValues(cached.get(name)))
          layers += std::string(layers.empty() ? "" : ", ") + name + " x" + std::to_string(n);
      throw Error("frame " + std::to_string(t) + ": the remodulated colour has " + std::to_string(bad) +
                  " non-finite values (non-finite input layers: " + (layers.empty() ? "none; overflow" : layers) + ")");
    }
    onFrame(out);
  }
}

}  // namespace arena
