#pragma once
// Captures: sequences this project did not render (an engine's frames, Blender's, or our own
// exported with `arena export`), in the documented capture format (docs/captures.md, version
// kCaptureFormatVersion): a folder with capture.json and one OpenEXR file per frame whose layers
// carry the names of core/sequence.hpp's frame layers, optional references and optional outputs of
// denoisers that ran elsewhere. Sequence::open reads a capture as it reads a cached sequence; what
// a capture lacks is absent (never invented), and what is derived is said (CaptureDescription).
#include <array>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/camera.hpp"
#include "core/exr_io.hpp"
#include "core/sequence.hpp"

namespace arena {

constexpr int kCaptureFormatVersion = 1;
constexpr const char* kCaptureFormatName = "denoise-arena-capture";

// Output frames of a denoiser that ran elsewhere (`--denoisers file:NAME`): outputs/NAME/frame_NNNN.exr
// with an RGB colour layer, and optionally its per-frame time as the capture's device measured it.
struct CaptureOutput {
  std::string name;
  std::filesystem::path dir;
  std::vector<double> milliseconds;  // per frame; empty: not recorded
  std::string device;                // what measured milliseconds (e.g. "RTX 4080, GPU timestamps")
  // What is wrong with the times as given (a time of 0 or below, no device, a device without
  // times), or "": it fails this output's `file:` pair and its validation, not the capture.
  std::string timingProblem;
};

struct CaptureDescription {
  std::filesystem::path dir;
  SequenceInfo info;  // scene (the capture's name), size, frames, cameras, events, references
  // Per-frame layers the files hold (the same set in every frame; checked on open).
  std::vector<std::string> layers;
  // Layers made from others when the files lack them: "color" (albedo*diffuse + specAlbedo*specular
  // + emission), "position" (view depth + camera), "emission" (zero). meshId is filled with 0 for
  // the metrics' disocclusion tests only; no denoiser is given an invented meshId.
  std::vector<std::string> derived;
  // Channels of frame 0 that no layer names (a typo such as "motoin.X"): ignored, and the
  // validation warns about them.
  std::vector<std::string> unknownChannels;
  std::vector<std::array<double, 2>> jitter;  // per frame, pixels; zeros when not given
  std::vector<double> deltaTime;              // per frame, seconds
  double exposure = 1.0;
  bool reverseZ = false;
  double nearPlane = 0, farPlane = 0;
  std::string units = "m";
  bool referenceHasVariance = false, referenceHasHalf = false;
  std::map<std::string, CaptureOutput> outputs;
  nlohmann::json source;  // who wrote it (free-form: engine, Blender version, arena export)

  const CaptureOutput& output(const std::string& name) const;  // Error listing the names
};

// The file a capture's frame, reference or denoiser output lives in.
std::filesystem::path captureFramePath(const std::filesystem::path& dir, int t);
std::filesystem::path captureReferencePath(const std::filesystem::path& dir, int r);
// Optional: A-SVGF's gradient samples of frame t >= 1 (core/sequence.hpp gradientLayers()), which
// only a renderer that re-shades frame t with frame t-1's random numbers can write.
std::filesystem::path captureGradientPath(const std::filesystem::path& dir, int t);
std::filesystem::path captureOutputPath(const CaptureOutput& output, int t);

bool isCapture(const std::filesystem::path& dir);
// A capture's name, a scene file's or a denoiser output's key: one folder name (non-empty, UTF-8,
// no spaces, slashes or control characters, not . or ..).
bool isPlainName(const std::string& name);
// Where `dir` is what Blender's render script writes (cameras.json and noisy/), not a capture:
// "DIR: not a capture (...) but a Blender render (...); import it first: arena import blender DIR
// --out CAPTURE"; else "".
std::string blenderRenderText(const std::filesystem::path& dir);
// What a folder holds of EXR files, for an error about a frame file that is not there: frames
// numbered from 1 (Blender's default) or with another width of number are the usual slip, and
// the first names say which. "; the folder holds a, b, c, ..." or "; the folder holds no .exr
// file" (a folder that is not there: the same).
std::string exrFilesHeld(const std::filesystem::path& dir);
// Parses and checks capture.json and the first frame's and references' channel lists; every
// error names the file and the field or channel and what was expected.
CaptureDescription readCaptureDescription(const std::filesystem::path& dir);
// What a capture's pixels are, as checksums of its files' bytes (a run records them; `arena
// compare` refuses runs of other inputs and warns of other references): `inputs` covers the
// frames (and gradient samples) with capture.json's description of them (everything but its
// `reference`, `outputs`, `source` and `purpose`), `references` the reference files with the
// `reference` entry (empty without references). The stored outputs are contenders, not the
// sequence: not covered. Reads every frame and reference once.
struct CaptureContent {
  std::string inputs, references;
};
CaptureContent captureContent(const CaptureDescription& capture);
// Frame t with the internal layer names, derived layers filled in (see CaptureDescription::derived).
LayerSet readCaptureFrame(const CaptureDescription& capture, int t);
// Reference r: color, with colorVar (zeros when the capture gives no variance: then
// referenceHasVariance is false and every reader says the noise floor is unknown) and colorHalf
// when given.
LayerSet readCaptureReference(const CaptureDescription& capture, int r);
// One stored output frame as a run reads it (`name` names the output in errors): its colour at
// width x height (checked before its pixels are read), every value finite; an Error naming the
// file otherwise. readCaptureOutput reads a capture's through it, `arena export --output` too.
Image readOutputFrame(const std::filesystem::path& file, const std::string& name, int width,
                      int height);
// Entries of the capture's folder its description does not cover (a frame beyond `frames`, a
// reference no frame names, notes), sorted: never read.
std::vector<std::string> undescribedEntries(const CaptureDescription& capture);
// Folders in outputs/ that capture.json does not declare, sorted: never scored.
std::vector<std::string> undeclaredOutputs(const CaptureDescription& capture);
// A denoiser output's colour at frame t.
Image readCaptureOutput(const CaptureDescription& capture, const std::string& name, int t);

// The camera of a capture frame from its view (world -> camera, camera looking down -Z, y up) and
// projection (OpenGL clip space) matrices, column-major as in glm; `position` (the eye) when given
// is used as is (it must agree with the view matrix). Errors name `where`.
CameraState cameraFromMatrices(const std::vector<double>& view, const std::vector<double>& projection,
                               const std::vector<double>* position, int width, int height, const std::string& where);
// The capture.json camera entry of a CameraState: view rows are the camera's own axes, so reading
// it back gives the same floats (the round trip is exact).
nlohmann::json captureCameraJson(const CameraState& camera);

// Writes a capture folder: every file goes to a temporary sibling folder, and commit() writes
// capture.json and renames the folder into place; a writer destroyed before commit() removes it,
// so nothing half-written is left behind. Frame layers are written under their own names.
class CaptureWriter {
 public:
  explicit CaptureWriter(std::filesystem::path out);  // Error when `out` exists
  ~CaptureWriter();
  CaptureWriter(const CaptureWriter&) = delete;
  CaptureWriter& operator=(const CaptureWriter&) = delete;
  // The frame's layers among the capture frame layers (core/sequence.hpp names).
  void frame(int t, const LayerSet& layers);
  // color, and colorVar / colorHalf when present.
  void reference(int r, const LayerSet& layers);
  void gradients(int t, const LayerSet& layers);
  void output(const std::string& name, int t, const Image& color);
  void commit(const nlohmann::json& description);

 private:
  std::filesystem::path out_, tmp_;
  bool committed_ = false;
};

// Writes a sequence as a capture (`arena export`): frames, references (color, colorVar, colorHalf),
// cameras and events; the outputs of `outputs` (name -> directory of frame_NNNN.exr with a colour
// layer, as `arena run --keep-frames all` writes them) are copied in as file: contenders. The folder
// is written to a temporary sibling and renamed: nothing half-written is left behind.
void exportCapture(const Sequence& sequence, const std::filesystem::path& out,
                   const std::map<std::string, std::filesystem::path>& outputs = {});

}  // namespace arena
