#pragma once
// Runs one registered denoiser over a cached sequence: one instance per signal (diffuse,
// specular), inputs sanitised (NaN/Inf -> 0, counted), outputs remodulated
// (albedo * diffuse + specAlbedo * specular + emission), per-pass timings collected. Set-up and
// allocation happen before the first timed frame; file I/O is never timed.
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

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

struct DenoisedFrame {
  int frame = 0;
  Image color, diffuse, specular;  // remodulated colour and the two filtered signals (a colour
                                   // denoiser leaves diffuse and specular empty)
  double milliseconds = 0;         // the denoiser's time (both signals): the harness's wall clock,
                                   // or what an external process reported (selfTimed)
  double wallMilliseconds = 0;     // the harness's wall clock around the calls, transfer included
  bool selfTimed = false;          // milliseconds were reported by the denoiser itself
  std::vector<PassStats> passes;   // "diffuse/<pass>", "specular/<pass>"
  long sanitized = 0;              // NaN/Inf input values replaced by 0
  double extraRaysPerPixel = 0;    // low-resolution paths read per pixel (both signals' passes)
};

class DenoiseRun {
 public:
  // Resolves parameters (errors list the valid names), checks the sequence has every channel the
  // denoiser declares, creates and sets up both instances.
  DenoiseRun(const DenoiserRequest& request, const Sequence& sequence);
  const ParamSet& params() const { return params_; }
  const DenoiserInfo& info() const { return info_; }
  // The denoiser reads the sequence's low-resolution buffer (it wants it and the sequence has one).
  bool readsLowres() const { return readsLowres_; }
  // Denoises frames 0..n-1 in order; `frame(t)` supplies the sequence frame's layers.
  void run(const std::function<const LayerSet&(int)>& frame, const std::function<void(const DenoisedFrame&)>& onFrame);

 private:
  const Sequence& sequence_;
  DenoiserRequest request_;
  const DenoiserInfo& info_;
  ParamSet params_;
  std::vector<std::pair<SignalKind, std::unique_ptr<Denoiser>>> instances_;  // one per signal
  bool needsGradients_ = false;
  bool readsLowres_ = false;
};

// Replaces NaN/Inf by 0 in place; returns how many were replaced.
long sanitize(Image& image);

}  // namespace arena
