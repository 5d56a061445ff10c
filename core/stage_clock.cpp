#include "core/stage_clock.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace arena {

namespace {

// Nanoseconds per stage: atomics, so timers on different threads (a sharded render) may add at once.
std::array<std::atomic<long long>, kStageCount>& totals() {
  static std::array<std::atomic<long long>, kStageCount> t{};
  return t;
}

thread_local StageTimer* innermost = nullptr;

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string clockText(double s) {
  char buf[32];
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%.1fs", s);
  else
    std::snprintf(buf, sizeof buf, "%dm%02ds", int(s / 60), int(std::lround(s)) % 60);
  return buf;
}

}  // namespace

const char* stageName(Stage stage) {
  static const char* const names[kStageCount] = {"frames",  "references", "refinement", "loading",
                                                 "denoisers", "metrics",  "statistics", "report"};
  return names[int(stage)];
}

std::array<double, kStageCount> stageSeconds() {
  std::array<double, kStageCount> out{};
  for (int i = 0; i < kStageCount; ++i) out[size_t(i)] = double(totals()[size_t(i)].load()) * 1e-9;
  return out;
}

void resetStageClock() {
  for (auto& t : totals()) t.store(0);
}

nlohmann::json stageBreakdownJson(double totalSeconds) {
  nlohmann::json out = nlohmann::json::object();
  double sum = 0;
  const auto seconds = stageSeconds();
  for (int i = 0; i < kStageCount; ++i) {
    out[stageName(Stage(i))] = seconds[size_t(i)];
    sum += seconds[size_t(i)];
  }
  out["other"] = std::max(0.0, totalSeconds - sum);
  out["total"] = totalSeconds;
  return out;
}

std::string stageBreakdownLine(double totalSeconds) {
  std::string line;
  double sum = 0;
  const auto seconds = stageSeconds();
  for (int i = 0; i < kStageCount; ++i) {
    sum += seconds[size_t(i)];
    if (seconds[size_t(i)] >= 0.05) line += (line.empty() ? "" : ", ") + std::string(stageName(Stage(i))) + " " + clockText(seconds[size_t(i)]);
  }
  line += (line.empty() ? "" : ", ") + std::string("other ") + clockText(std::max(0.0, totalSeconds - sum));
  return line;
}

StageTimer::StageTimer(Stage stage) : stage_(stage), start_(now()), outer_(innermost) { innermost = this; }

StageTimer::~StageTimer() {
  const double elapsed = now() - start_;
  innermost = outer_;
  if (outer_) outer_->nested_ += elapsed;
  const double own = std::max(0.0, elapsed - nested_);
  totals()[size_t(stage_)].fetch_add(static_cast<long long>(own * 1e9));
}

}  // namespace arena
