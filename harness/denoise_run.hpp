#pragma once
// Runs one registered denoiser over a cached sequence: one instance per signal (diffuse,
// specular), every input it reads sanitised and counted (sanitizeInputs), outputs remodulated
// (albedo * diffuse + specAlbedo * specular + emission), per-pass timings collected. Set-up and
// allocation happen before the first timed frame; file I/O is never timed.
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/non_finite.hpp"
#include "core/sequence.hpp"
#include "denoisers/denoiser.hpp"

namespace arena {

struct DenoiserRequest {
  std::string name;                           // registry name
  std::map<std::string, std::string> params;  // overrides, without the "name." prefix
  std::string label;                          // how results and charts name this setting
};

// "svgf.sigmaL=4" style assignments, grouped by denoiser; unknown denoiser prefixes are errors.
std::map<std::string, std::map<std::string, std::string>> parseParamAssignments(const std::vector<std::string>& items);
std::string defaultLabel(const DenoiserRequest& r);
// "file:NAME" -> "NAME": a contender whose output frames are stored in a capture (a denoiser that ran
// elsewhere, docs/captures.md); "" for every other entry.
std::string capturedOutputName(const std::string& entry);

struct DenoisedFrame {
  int frame = 0;
  Image color, diffuse, specular;  // remodulated colour and the two filtered signals (a colour
                                   // denoiser leaves diffuse and specular empty)
  double milliseconds = 0;         // the denoiser's time (both signals): the harness's wall clock,
                                   // or what an external process reported (selfTimed)
  double wallMilliseconds = 0;     // the harness's wall clock around the calls, transfer included
  bool selfTimed = false;          // milliseconds were reported by the denoiser itself
  std::vector<PassStats> passes;   // "diffuse/<pass>", "specular/<pass>"
  NonFiniteCounts sanitized;       // NaN/Inf input values replaced by 0, per layer.channel
  double extraRaysPerPixel = 0;    // extra paths read per pixel (low-resolution or gradient samples)
  // The first call of this frame whose own report of its time (a process's computeMs, the sum of
  // its passes) exceeds the harness's wall clock around that call, said in words; empty if none.
  std::string implausibleTime;
  // Every signal's output is the signal the denoiser was given, bit for bit (a demodulated
  // denoiser that passes its inputs through: the remodulated colour differs from the frame's by
  // rounding, so comparing the colours would not see it).
  bool outputIsInput = false;
};

// A report no measurement gives, or "": a time above kMaxFrameMilliseconds (a process's computeMs,
// a pass's ms), or taps or rays per pixel of a pass beyond 1e9 or not finite. The pair (or the
// bench's contender) fails naming it: summed into a summary, one of 1e308 made it inf, and the
// whole run stopped without results (a bad-input trial). `name` is the denoiser as messages name
// it, `where` "the diffuse signal at frame 3".
std::string reportedFault(const std::string& name, const std::string& where,
                          const std::optional<double>& reported,
                          const std::vector<PassStats>& passes, double wall);

// What is wrong with a call's own report of its time (a process's computeMs, the sum of its
// reported passes), or "": no work inside a call can take longer than the call, the harness's
// wall clock `wall` around it (1% and 0.05 ms allowed for two clocks' reading).
std::string implausibleTime(const std::optional<double>& reported,
                            const std::vector<PassStats>& passes, double wall);

// What `sequence` lacks of what the denoiser reads ("svgf needs channel(s) 'meshId' that capture
// ... does not provide ..."), or "": the error DenoiseRun's constructor throws, found without
// setting anything up. A run of every denoiser (--denoisers all) on a capture skips those it names.
std::string lackingInputs(const DenoiserRequest& request, const Sequence& sequence);
// What is wrong with a denoiser requiring `channel` when that is no frame layer at all (a typo:
// no sequence could hold it), naming the layer it likely means; "" for a frame layer.
std::string unknownLayerProblem(const std::string& denoiser, const std::string& channel);

class DenoiseRun {
 public:
  // Resolves parameters (errors list the valid names), checks the sequence has every channel the
  // denoiser declares (else the error lackingInputs gives), creates and sets up both instances.
  DenoiseRun(const DenoiserRequest& request, const Sequence& sequence);
  // The same for a denoiser not in the registry (`info` outlives the run): the harness's own rules
  // tested on a denoiser made to break them.
  DenoiseRun(const DenoiserInfo& info, const DenoiserRequest& request, const Sequence& sequence);
  const ParamSet& params() const { return params_; }
  const DenoiserInfo& info() const { return info_; }
  // What the instances filter: the registered mode, or the colour where a capture has no parts
  // and the denoiser's output is its input (DenoiserInfo::identity: passthrough).
  SignalMode signals() const { return mode_; }
  // The denoiser reads the sequence's low-resolution buffer (it wants it and the sequence has one).
  bool readsLowres() const { return readsLowres_; }
  // The denoiser reads the sequence's A-SVGF gradient samples: re-shaded paths beyond the frame's
  // own, charged one path per valid sample (DenoisedFrame::extraRaysPerPixel).
  bool readsGradients() const { return needsGradients_; }
  // Every frame layer an instance reads (requiredChannels of all of them).
  const std::vector<std::string>& readLayers() const { return readLayers_; }
  // Denoises frames 0..n-1 in order; `frame(t)` supplies the sequence frame's layers.
  void run(const std::function<const LayerSet&(int)>& frame, const std::function<void(const DenoisedFrame&)>& onFrame);
  // After run(): ends the instances' external processes, one line for each that ended badly
  // (ExternalProcessDenoiser::finish); empty for every other denoiser.
  std::vector<std::string> finish();

 private:
  friend std::string lackingInputs(const DenoiserRequest& request, const Sequence& sequence);
  // setUp false: only what the denoiser would read is worked out (lacking_); the instances are
  // created but not set up, and nothing is refused.
  DenoiseRun(const DenoiserInfo& info, const DenoiserRequest& request, const Sequence& sequence,
             bool setUp);
  std::string lacking_;  // what the sequence lacks of what the denoiser reads, or ""
  const Sequence& sequence_;
  DenoiserRequest request_;
  const DenoiserInfo& info_;
  ParamSet params_;
  SignalMode mode_ = SignalMode::Demodulated;
  std::vector<std::pair<SignalKind, std::unique_ptr<Denoiser>>> instances_;  // one per signal
  std::vector<std::string> readLayers_;  // every frame layer a denoiser instance reads
  bool needsGradients_ = false;
  bool readsLowres_ = false;
};

// The one rule for non-finite inputs (docs/metrics.md, "Non-finite inputs"): every NaN/Inf in a
// layer the denoiser reads -- its signal, its guides (normal, depth, motion, position, ...), the
// low-resolution buffer -- becomes 0 before it runs; a gradient sample (A-SVGF) with any non-finite
// field also becomes invalid (valid = 0): a sample that is not a number says nothing about the
// history, and a 0 in its place would fake a full gradient and drop the history.
// Both sanitise in place, add their counts to `counts` under `prefix + channel` ("normal.Y",
// "gradients: gradient.lumNew") and return how many values they replaced. sanitizeInputs touches
// the layers named in `names` only (every layer when empty).
long sanitizeInputs(LayerSet& layers, const std::vector<std::string>& names,
                    const std::vector<LayerSpec>& specs, const std::string& prefix, NonFiniteCounts& counts);
long sanitizeGradientSamples(LayerSet& gradients, NonFiniteCounts& counts);

// The pair's warning for what sanitizeInputs replaced: "N non-finite input values (normal.Y x30,
// ...) were replaced by 0 before the denoiser ran"; empty when nothing was.
std::string sanitizedWarning(const NonFiniteCounts& counts);

// A value no denoiser computes: a quiet NaN with a payload of its own. markUnwritten fills an
// output with it before each call (outside the timed call), so a denoiser that leaves values
// unwritten (a plugin that returns success without writing) is caught instead of being scored, or
// timed, on what the buffer held from the frame before. outputFault is then what is wrong with the
// call's output: "NAME left N of the M values of its diffuse output unwritten at frame T ...",
// "NAME produced a non-finite value on the diffuse signal at frame T", or "" (one pass over a
// finite output: the marker is a NaN). `origin` (DenoiserInfo::origin: the plugin library or the
// manifest; empty for a built-in) follows the name in brackets, as the denoiser's other errors say.
void markUnwritten(Image& output);
// An output of another size than the signal it was given (`input`) is a fault too, named with both
// sizes (the remodulation's later error named neither).
std::string outputFault(const Image& output, const Image& input, const std::string& name,
                        SignalKind kind, int frame, const std::string& origin = "");

// The error for a denoiser (its label) that cannot run without the low-resolution buffer, where
// none is rendered (--lowres-factor 0): `arena run` and `arena bench denoise` refuse it up front.
std::string lowresNeeded(const std::string& label);

}  // namespace arena
