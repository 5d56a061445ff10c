#pragma once
// A rendered sequence as the cache stores it and every downstream stage reads it: one
// multi-channel EXR per frame, A-SVGF gradient samples per frame at stratum resolution, one EXR
// per distinct reference, and sequence.json (scene, settings, frame -> reference map, events,
// cameras). The channel layout is defined here once, for the writer (tracer) and the readers.
#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/camera.hpp"
#include "core/exr_io.hpp"

namespace arena {

// A frame's time above this (1e9 ms, 11.6 days) is no measurement but a timer's garbage: refused
// where a time enters (a stored output's milliseconds, a process's or plugin's report), as a
// 1e308 ms summed into a run's mean time made it inf and stopped the whole run.
inline constexpr double kMaxFrameMilliseconds = 1e9;

namespace channels {
// Per-frame layers (noise-free G-buffer of the primary hit through the pixel centre + 1-spp signals).
const std::vector<LayerSpec>& frameLayers();
// Reference layers: converged means and the per-pixel variance of each mean.
const std::vector<LayerSpec>& referenceLayers();
// Gradient samples (A-SVGF), one texel per 3x3 stratum.
const std::vector<LayerSpec>& gradientLayers();
// Optional low-resolution, many-sample buffer (CAPCOM 2023 "disocclusion rays", slides 19-21): one
// texel per factor x factor block, shaded lowresSpp times at its anchor pixel (lowresAnchor).
const std::vector<LayerSpec>& lowresLayers();
// Frame layers a real-time engine would not have (the tracer's noise-free extras), with what each
// is: a denoiser reading one is not on equal terms, and its results say so.
const std::map<std::string, std::string>& oracleLayers();
}  // namespace channels

// The full-resolution pixel whose primary hit a low-resolution texel shades: the block's centre
// pixel, clamped to the image. Writer and readers share it, so the texel's G-buffer is the frame's.
inline int lowresAnchor(int texel, int factor, int size) {
  const int p = texel * factor + factor / 2;
  return p < size ? p : size - 1;
}
inline int lowresSize(int size, int factor) { return (size + factor - 1) / factor; }

constexpr int kGradientStratum = 3;
constexpr int kSequenceFormatVersion = 1;

// What a scripted event does (a scene's "events"; the ghosting windows and cut analysis of
// docs/metrics.md follow from it). Written in files by its name (eventKindName).
enum class EventKind { LightOff, LightOn, LightChange, ObjectMoves, CameraCut };
const char* eventKindName(EventKind kind);
// The kind named `name`, or nullopt (callers say where the name came from).
std::optional<EventKind> eventKindFromName(std::string_view name);
// "light_off, light_on, ...": the valid names, for error messages.
std::string eventKindNames();
// The kind names one by one, in that order (for a misspelling's nearest name).
std::vector<std::string> eventKindNameList();

struct SequenceEvent {
  int frame = 0;
  EventKind kind = EventKind::LightOff;
  std::string what;  // the light or object concerned (may be empty)
  // The mesh id (the meshId layer's value) of the object an object_moves event concerns, written
  // by the tracer; -1 for other kinds or when the event names no object.
  int meshId = -1;
};

struct SequenceInfo {
  std::string scene, purpose, hash;
  int width = 0, height = 0, frames = 0;
  std::vector<int> referenceOfFrame;   // frame -> reference index
  std::vector<int> referenceSpp;       // per reference: samples actually used
  std::vector<double> referenceEstimatedRelMse;  // per reference: its own estimated relMSE (0: unknown)
  std::vector<bool> referenceCapped;   // per reference: stopped at the sample cap above its target
  std::vector<CameraState> cameras;    // per frame
  std::vector<SequenceEvent> events;
  nlohmann::json settings;             // what produced the pixels (preset, spp, bounces, ...)
  // Paths per second of the low-resolution buffer's render, measured on the machine that rendered
  // it (0: unknown or no buffer). Timing metadata, not pixels: it is not part of the hash.
  double lowresPathsPerSecond = 0;
  // Paths per second of the 1-spp frames' render (gradient samples included), measured likewise:
  // the rate at which A-SVGF's re-shaded gradient samples are charged.
  double inputPathsPerSecond = 0;
  // "tracer" (this project's cache) or "capture" (core/capture.hpp). A capture gives only some
  // frame layers (`layers`; empty means every frame layer) and no gradient samples.
  std::string source = "tracer";
  std::vector<std::string> layers;
  bool hasGradients = true;
  bool hasReference = true;  // false: a capture without one (rankings use no-reference metrics)
  // The frame layers a denoiser may read from this sequence.
  std::vector<std::string> availableLayers() const;

  // The low-resolution buffer's block size and samples per texel; 0 when the sequence has none.
  int lowresFactor() const { return settings.value("lowresFactor", 0); }
  int lowresSpp() const { return settings.value("lowresSpp", 0); }
  // Whether a frame t >= firstFrame uses reference r (frames before a warm-up are not summarised).
  bool referenceUsedFrom(int r, int firstFrame) const {
    const auto from = referenceOfFrame.begin() + std::clamp(firstFrame, 0, int(referenceOfFrame.size()));
    return std::find(from, referenceOfFrame.end(), r) != referenceOfFrame.end();
  }

  nlohmann::json toJson() const;
  static SequenceInfo fromJson(const nlohmann::json& j, const std::string& file);
};

nlohmann::json cameraToJson(const CameraState& c);
// "frame_0007.exr": the numbered file names of sequences and captures (prefix, index, digits).
std::string numberedFileName(const char* prefix, int n, int digits);
CameraState cameraFromJson(const nlohmann::json& j);

struct CaptureDescription;

class Sequence {
 public:
  // Opens a complete cached sequence, or a capture (a folder with capture.json, core/capture.hpp);
  // throws naming the directory when it is missing/incomplete.
  static Sequence open(const std::filesystem::path& dir);
  bool isCapture() const { return capture_ != nullptr; }
  const CaptureDescription& capture() const;  // only when isCapture()

  const SequenceInfo& info() const { return info_; }
  const std::filesystem::path& dir() const { return dir_; }

  LayerSet frame(int t) const;
  LayerSet reference(int t) const;  // the reference of frame t
  LayerSet referenceByIndex(int r) const;
  LayerSet gradients(int t) const;  // frame t >= 1
  LayerSet lowres(int t) const;     // only when info().lowresFactor() > 0

  static std::filesystem::path framePath(const std::filesystem::path& dir, int t);
  static std::filesystem::path referencePath(const std::filesystem::path& dir, int r);
  static std::filesystem::path gradientPath(const std::filesystem::path& dir, int t);
  static std::filesystem::path lowresPath(const std::filesystem::path& dir, int t);

 private:
  std::filesystem::path dir_;
  SequenceInfo info_;
  std::shared_ptr<const CaptureDescription> capture_;
};

}  // namespace arena
