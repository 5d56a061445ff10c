#pragma once
// Checked before ranked: the validation of a capture (core/capture.hpp) before any denoiser runs on
// it. Most "denoiser bugs" in engines are integration bugs -- motion vectors with a flipped sign, a
// NaN in a guide buffer -- so every capture is measured against what its own data implies, and
// each check reports its measured value, its thresholds and a verdict:
//   pass; warn (soft: the run goes on, the warning is in results.json and on the report page);
//   fail (hard: the capture is refused with the check's name and numbers).
// docs/captures.md lists the checks and their thresholds.
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "core/capture.hpp"
#include "core/image.hpp"
#include "core/sequence.hpp"
#include "metrics/evaluator.hpp"

namespace arena {

enum class CheckStatus { Pass, Warn, Fail };
const char* checkStatusName(CheckStatus s);

struct CaptureCheck {
  std::string name;       // "motion.consistency"
  double value = 0;       // what was measured
  double warnAbove = 0;   // value > warnAbove: warn
  double failAbove = 0;   // value > failAbove: fail (infinity: a soft check)
  std::string unit;       // "share of pixels", "px", ...
  std::string detail;     // what it means, or what was found (e.g. "sign flipped")
  CheckStatus status = CheckStatus::Pass;
};

struct CaptureValidation {
  std::vector<CaptureCheck> checks;
  CheckStatus status() const;
  nlohmann::json toJson() const;
  // "motion.consistency 0.93 > 0.25 (share of pixels off by more than 1 px): sign flipped; ..."
  std::string failures() const;
  std::vector<std::string> warnings() const;
};

// Motion vectors against the motion the depth and the two cameras imply (NRD's validation view):
// the share of surface pixels whose stored motion is off by more than `tolerancePx`, the mean
// error, and which convention slip explains them best (sign, axes, scale, next frame, units).
// Frame pairs across a camera cut are skipped. Exposed for tests.
struct MotionConsistency {
  double offShare = 0, meanErrorPx = 0;
  long pixels = 0;
  std::string explanation;  // empty, or e.g. "sign flipped" when another convention fits far better
  double explainedShare = 0;
  // The frame with the largest share off (-1: none checked), and that share: one frame written
  // with another convention, or for another camera, hides in the sequence's share.
  int worstFrame = -1;
  double worstFrameShare = 0;
  // Empty, or what the depth layer looks like where another reading of it fits the stored motion
  // far better ("in millimetres (1000x the scene's units)", "a depth-buffer value ..."), with the
  // share of the pixels it decides that fit it. Needs correct motion and a moving camera.
  std::string depthExplanation;
  double depthExplainedShare = 0;
  bool depthWithinUnit = true;  // every checked depth lies in (0, 1]: a depth buffer's range
  // Pixels whose expected motion (4 px or more) could tell the conventions apart: where none
  // could, `explanation` stays empty for want of motion, not because none fits.
  long conventionPixels = 0;
};
// The readings of a depth layer tried against the motion: a unit slip, and, where the capture
// records its near and far planes, a depth buffer's value (standard or reversed) linearised.
struct DepthReading {
  std::string name;
  // The view depth the layer's value z means at a pixel whose ray makes an angle with the
  // camera's forward axis of cosine `cosine` (a ray distance is z x cosine there).
  std::function<float(float z, float cosine)> toViewDepth;
};
std::vector<DepthReading> depthReadings(double nearPlane, double farPlane);
// Pixels of the meshes in `movingMeshes` (object_moves events' meshId) are not static: skipped.
MotionConsistency checkMotion(const std::vector<LayerSet>& frames,
                              const std::vector<CameraState>& cameras,
                              const std::vector<int>& cutFrames, double tolerancePx = 1.0,
                              const std::set<int>& movingMeshes = {},
                              const std::vector<DepthReading>& readings = {});

// Stored world positions against depth and camera, per surface pixel: the share whose view depth
// is off by more than 1% of the depth layer's or that project more than 2 px from their pixel's
// centre, and the median ratio of their view depth to the depth layer's (1000: millimetres).
struct PositionConsistency {
  double offShare = 0, medianDepthRatio = 1;
  long pixels = 0;
};
PositionConsistency checkPositions(const std::vector<LayerSet>& frames,
                                   const std::vector<CameraState>& cameras);

// The stored outputs of denoisers that ran elsewhere (`--denoisers file:NAME`), as a run would read
// them: per output, the frames missing, unreadable, of another size or with non-finite values
// (fail: that contender's pair would fail); folders in outputs/ the description does not declare
// (warn). Apart from validateCapture: a bad stored output fails its own pair, not the capture.
// `references`: the capture's references as read for evaluation (an output equal to its frame's
// reference warns); empty when it has none.
CaptureValidation validateCaptureOutputs(const CaptureDescription& capture,
                                         const std::vector<LayerSet>& references);

// Whether an input colour equals a reference value for value on its finite values (at least one;
// a NaN or Inf, which the denoisers read as 0, is not compared): the input then scores a perfect 0
// against it, or nearly.
bool inputEqualsReference(const Image& input, const Image& reference);

// Whether an image holds any nonzero finite value: a reference without one is black (validate's
// reference.blackFrames, a run's refusal).
bool hasSignal(const Image& image);

// Every check of a sequence read for evaluation (frames, references) and its description.
CaptureValidation validateCapture(const Sequence& sequence, const EvaluationInput& input);

}  // namespace arena
