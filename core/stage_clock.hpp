#pragma once
// Where a command's wall time goes, by stage: the breakdown `arena study` prints (issue 32). Code
// runs under a StageTimer naming its stage; a timer started inside another (a reference rendered
// while a sequence renders, the metrics of a frame inside a denoiser's run) counts for its own
// stage only, and the enclosing one loses that time, so the stages never overlap and sum to at
// most the wall time. Only the thread that starts a timer is timed (the tracer's and the filters'
// worker threads run inside their caller's timer).
#include <array>
#include <string>

#include <nlohmann/json.hpp>

namespace arena {

enum class Stage { Frames, References, Refinement, Loading, Denoisers, Metrics, Statistics, Report };
inline constexpr int kStageCount = 8;
// "frames", "references", ...: the names in printouts and JSON.
const char* stageName(Stage stage);

// The seconds each stage has taken in this process since the last reset.
std::array<double, kStageCount> stageSeconds();
void resetStageClock();
// {"frames": s, ..., "other": total - their sum, "total": total} for a command that took `total` s.
nlohmann::json stageBreakdownJson(double totalSeconds);
// "frames 1m02s, references 6m10s, ..., other 12s": the stages that took any time, then the rest.
std::string stageBreakdownLine(double totalSeconds);

class StageTimer {
 public:
  explicit StageTimer(Stage stage);
  ~StageTimer();
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  Stage stage_;
  double start_ = 0, nested_ = 0;  // seconds on the steady clock; time of timers inside this one
  StageTimer* outer_ = nullptr;
};

}  // namespace arena
