// WheelSampleGate (core/wheel_track.h): a physically impossible wheel jump or a lone
// wrong stamp is dropped alone and said; clean samples pass unchanged and in order.
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "calib/core/robot.h"
#include "calib/core/wheel_track.h"

namespace calib {
namespace {

RobotDescription Forklift() {
  return ParseRobot(
      "name: f\ndrive: tricycle\nwheels: {drive: drive}\n"
      "params: {drive_radius: 0.115, wheelbase: 1.42, steer_offset: 0.0}\n"
      "limits: {max_speed: 0.6, max_omega: 0.6, max_accel: 0.5, max_steer: 1.3, max_steer_rate: 1.0}\n",
      "test");
}

// 100 Hz at 0.5 m/s: 4.35 rad/s of the drive wheel.
std::vector<WheelSample> Clean(int n) {
  std::vector<WheelSample> samples;
  for (int i = 0; i < n; ++i) samples.push_back({1000000 + i * 10000, {i * 0.0435}, {0.1}});
  return samples;
}

struct GateRun {
  std::vector<int64_t> passed;  // stamps
  std::vector<std::string> drops;
};

GateRun Feed(const std::vector<WheelSample>& samples) {
  GateRun run;
  WheelSampleGate gate(Forklift(), [&](const std::string& origin, const std::string& problem) {
    run.drops.push_back(origin + ": " + problem);
  });
  for (std::size_t i = 0; i < samples.size(); ++i)
    for (const WheelSample& s : gate.Add(samples[i], "event " + std::to_string(i)))
      run.passed.push_back(s.utime);
  for (const WheelSample& s : gate.Finish()) run.passed.push_back(s.utime);
  EXPECT_EQ(gate.dropped(), int64_t(run.drops.size()));
  return run;
}

TEST(WheelGate, CleanSamplesPassUnchanged) {
  const std::vector<WheelSample> samples = Clean(300);
  const GateRun run = Feed(samples);
  ASSERT_EQ(run.passed.size(), samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) EXPECT_EQ(run.passed[i], samples[i].utime);
  EXPECT_TRUE(run.drops.empty());
}

TEST(WheelGate, PositionJumpIsDroppedAloneAndNamed) {
  for (double jump : {100.0, 1000.0, -100.0}) {
    std::vector<WheelSample> samples = Clean(300);
    samples[150].position[0] += jump;
    const GateRun run = Feed(samples);
    EXPECT_EQ(run.passed.size(), samples.size() - 1);
    ASSERT_EQ(run.drops.size(), 1u);
    EXPECT_NE(run.drops[0].find("event 150: wheel 'drive' position jumps"), std::string::npos) << run.drops[0];
    EXPECT_NE(run.drops[0].find("limits.max_speed"), std::string::npos) << run.drops[0];
  }
}

TEST(WheelGate, LoneLateStampIsDroppedAloneNotItsSuccessors) {
  std::vector<WheelSample> samples = Clean(1000);
  samples[200].utime += int64_t(1) << 23;  // one flipped bit: +8.4 s
  const GateRun run = Feed(samples);
  EXPECT_EQ(run.passed.size(), samples.size() - 1);
  ASSERT_EQ(run.drops.size(), 1u);
  EXPECT_NE(run.drops[0].find("event 200: stamp 8.39"), std::string::npos) << run.drops[0];
}

TEST(WheelGate, LoneEarlyStampAndRepeatsAreDroppedAlone) {
  std::vector<WheelSample> samples = Clean(300);
  samples[100].utime -= int64_t(1) << 23;
  samples[200].utime = samples[199].utime;
  const GateRun run = Feed(samples);
  EXPECT_EQ(run.passed.size(), samples.size() - 2);
  EXPECT_EQ(run.drops.size(), 2u);
}

TEST(WheelGate, RealGapPassesEverySample) {
  std::vector<WheelSample> samples = Clean(300);
  for (std::size_t i = 150; i < samples.size(); ++i) samples[i].utime += 5000000;  // a 5 s pause
  GateRun run = Feed(samples);
  EXPECT_EQ(run.passed.size(), samples.size());
  EXPECT_TRUE(run.drops.empty());
  samples.resize(151);  // the sample after the gap is the last: Finish passes it
  run = Feed(samples);
  EXPECT_EQ(run.passed.size(), samples.size());
}

}  // namespace
}  // namespace calib
