// The diagnosis's wheel speeds (diagnose_fit.cc MakeTrack, ChooseSpeedWindow) come from a window
// suited to the encoder: a central difference over about +-50 ms for an even one; for an encoder
// whose counter is updated at another rate than it is read, so that the readings step unevenly
// (37 38 75 38 ... ticks at a constant speed), the least-squares slope over a window wide enough
// for a speed error of 1.5 %. Before, such speeds were central differences over a window for a
// 10 % error, and the slip fitted through them came out at a fifth to a half of the truth.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "calib/core/kinematics.h"
#include "calib/core/wheel_track.h"
#include "calib/sim/simulator.h"
#include "diagnose/diagnose_model.h"
#include "sim_log.h"

namespace calib::diag {
namespace {

using test_support::Source;

// A tricycle's drive wheel turning at `speed` rad/s, read at `read_hz` from a counter of
// `ticks_per_rev` updated at `update_hz`.
WheelTrack Readings(double speed, double read_hz, double update_hz, double ticks_per_rev, double seconds) {
  WheelTrack track;
  const double tick = 2 * M_PI / ticks_per_rev;
  for (int i = 0; i < int(seconds * read_hz); ++i) {
    const double t = i / read_hz;
    const double updated = std::floor(t * update_hz + 1e-9) / update_hz;  // (1e-9: i / rate * rate is not always i)
    track.Append({int64_t(std::llround(t * 1e6)), {tick * std::floor(speed * updated / tick)}, {0.0}});
  }
  return track;
}

// RMS error of the track's speeds (away from the ends) as a share of the true speed.
double RelativeSpeedError(const Track& tr, double speed) {
  double sum = 0;
  int n = 0;
  for (std::size_t i = 20; i + 20 < tr.size(); ++i, ++n) sum += std::pow(tr.speed[i][0] - speed, 2);
  return std::sqrt(sum / n) / speed;
}

TEST(DiagnoseSpeeds, UnevenlySteppingEncoderAveragedOverAWiderWindow) {
  const RobotDescription robot = LoadSimConfig(Source("config/sims/forklift.yaml")).robot;
  ASSERT_EQ(WheelRoles(robot.drive).size(), 1u);
  for (double update_hz : {24.0, 26.0, 29.0}) {
    const WheelTrack wheels = Readings(3.5, 20.0, update_hz, 1600, 60.0);
    const Track tr = MakeTrack(robot, wheels);
    EXPECT_GT(tr.speed_window.k, 1) << update_hz << " Hz";
    EXPECT_LT(RelativeSpeedError(tr, 3.5), 0.1) << update_hz << " Hz, +-" << tr.speed_window.k << " samples";
  }
}

// A wheel whose speed swings between 0 and 2 A rad/s with period `period` s (the positions of
// A (t - sin(w t) / w)), read at 20 Hz from a 1600-tick counter updated at `update_hz`.
WheelTrack SwingReadings(double amplitude, double period, double update_hz) {
  WheelTrack track;
  const double tick = 2 * M_PI / 1600, w = 2 * M_PI / period;
  for (int i = 0; i < 120 * 20; ++i) {
    const double t = i / 20.0;
    const double updated = std::floor(t * update_hz + 1e-9) / update_hz;
    const double angle = amplitude * (updated - std::sin(w * updated) / w);
    track.Append({int64_t(std::llround(t * 1e6)), {tick * std::floor(angle / tick)}, {0.0}});
  }
  return track;
}

// The slip's model (diagnose_model.h) loses k r (v_end^2 - v_start^2) / 2 over an interval. A true
// slip acts on the true speeds; fitted through the track's speeds over 0.2 s intervals (the pose
// intervals of the tricycle recordings), the estimate is the true slip times this ratio.
double SlipRecovered(const Track& tr, double amplitude, double period) {
  const double w = 2 * M_PI / period;
  auto true_speed = [&](std::size_t i) { return amplitude * (1 - std::cos(w * tr.utime(i) * 1e-6)); };
  double cross = 0, own = 0;
  for (std::size_t i = 20; i + 24 < tr.size(); i += 4) {
    const double model = (std::pow(tr.speed[i + 4][0], 2) - std::pow(tr.speed[i][0], 2)) / 2;
    const double truth = (std::pow(true_speed(i + 4), 2) - std::pow(true_speed(i), 2)) / 2;
    cross += model * truth, own += model * model;
  }
  return cross / own;
}

// Errors in the speeds are errors in the slip's regressor, and they attenuate its fit: with the
// central difference over +-2 samples (the window for a 10 % speed error) the slip came out at
// 0.46-0.56 of the truth for a 4 s speed swing, 0.18-0.33 for an 8 s one.
TEST(DiagnoseSpeeds, SlipRegressorOfAnUnevenlySteppingEncoderIsNotAttenuated) {
  const RobotDescription robot = LoadSimConfig(Source("config/sims/forklift.yaml")).robot;
  for (double period : {4.0, 8.0}) {
    for (double update_hz : {24.0, 26.0, 29.0}) {
      const WheelTrack wheels = SwingReadings(2.0, period, update_hz);
      const Track tr = MakeTrack(robot, wheels);
      const double recovered = SlipRecovered(tr, 2.0, period);
      EXPECT_NEAR(recovered, 1.0, 0.1) << period << " s swing, " << update_hz << " Hz, +-" << tr.speed_window.k
                                       << " samples";
    }
    // A counter read as it counts: the central difference, and the slip whole already.
    const WheelTrack even = SwingReadings(2.0, period, 20.0);
    const Track tr = MakeTrack(robot, even);
    EXPECT_FALSE(tr.speed_window.least_squares);
    EXPECT_NEAR(SlipRecovered(tr, 2.0, period), 1.0, 0.02) << period << " s swing, even";
  }
}

TEST(DiagnoseSpeeds, EvenEncoderKeepsFiftyMilliseconds) {
  const RobotDescription robot = LoadSimConfig(Source("config/sims/forklift.yaml")).robot;
  // Counter read as it counts, 4096 ticks a turn: the speeds over +-50 ms, 5 samples at 100 Hz.
  // (The track reads the wheel samples in place: they outlive it.)
  const WheelTrack fine_wheels = Readings(3.5, 100.0, 100.0, 4096, 30.0);
  const Track fine = MakeTrack(robot, fine_wheels);
  EXPECT_EQ(fine.speed_window.k, 5);
  EXPECT_FALSE(fine.speed_window.least_squares);
  EXPECT_LT(RelativeSpeedError(fine, 3.5), 0.01);
  const WheelTrack slow_wheels = Readings(3.5, 20.0, 20.0, 1600, 30.0);
  const Track slow = MakeTrack(robot, slow_wheels);
  EXPECT_EQ(slow.speed_window.k, 1);
}

}  // namespace
}  // namespace calib::diag
