// core/stage_clock: nested timers count for their own stage only, and the stages sum to the time
// the outermost timer ran.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "core/stage_clock.hpp"

namespace arena {
namespace {

TEST(StageClock, NestedTimersCountOnlyForTheirOwnStage) {
  resetStageClock();
  const auto t0 = std::chrono::steady_clock::now();
  {
    StageTimer frames(Stage::Frames);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    {
      StageTimer references(Stage::References);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto s = stageSeconds();
  const double frames = s[size_t(Stage::Frames)], references = s[size_t(Stage::References)];
  EXPECT_GE(references, 0.020);
  EXPECT_GE(frames, 0.010);
  // The outer stage lost the inner one's time: together they are the outer timer's wall time.
  EXPECT_LE(frames + references, wall + 1e-6);
  EXPECT_GE(frames + references, wall - 0.005);
  for (Stage other : {Stage::Refinement, Stage::Loading, Stage::Denoisers, Stage::Metrics, Stage::Statistics, Stage::Report})
    EXPECT_EQ(s[size_t(other)], 0.0) << stageName(other);
  const nlohmann::json j = stageBreakdownJson(wall + 1.0);
  EXPECT_NEAR(j["other"].get<double>(), 1.0, 0.006);
  EXPECT_EQ(j["total"].get<double>(), wall + 1.0);
  const std::string line = stageBreakdownLine(wall + 1.0);
  EXPECT_EQ(line.find("frames"), std::string::npos) << "under 0.05 s, not listed: " << line;
  EXPECT_NE(line.find("other 1.0s"), std::string::npos) << line;
  resetStageClock();
  EXPECT_EQ(stageSeconds()[size_t(Stage::References)], 0.0);
}

}  // namespace
}  // namespace arena
