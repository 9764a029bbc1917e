// The diagnosis's wheel speeds (diagnose_fit.cc MakeTrack) come from central differences over a
// window suited to the encoder: about +-50 ms for an even one; wider for an encoder whose counter
// is updated at another rate than it is read, so that the readings step unevenly (37 38 75 38 ...
// ticks at a constant speed). Before, the window was +-50 ms whatever the readings: at 20 Hz the
// speeds of such an encoder were off by about 20 % at every sample, and with them the slip's
// regressor and the intervals set aside.

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
    EXPECT_GT(tr.smooth_k, 1) << update_hz << " Hz";
    EXPECT_LT(RelativeSpeedError(tr, 3.5), 0.1) << update_hz << " Hz, +-" << tr.smooth_k << " samples";
  }
}

TEST(DiagnoseSpeeds, EvenEncoderKeepsFiftyMilliseconds) {
  const RobotDescription robot = LoadSimConfig(Source("config/sims/forklift.yaml")).robot;
  // Counter read as it counts, 4096 ticks a turn: the speeds over +-50 ms, 5 samples at 100 Hz.
  // (The track reads the wheel samples in place: they outlive it.)
  const WheelTrack fine_wheels = Readings(3.5, 100.0, 100.0, 4096, 30.0);
  const Track fine = MakeTrack(robot, fine_wheels);
  EXPECT_EQ(fine.smooth_k, 5);
  EXPECT_LT(RelativeSpeedError(fine, 3.5), 0.01);
  const WheelTrack slow_wheels = Readings(3.5, 20.0, 20.0, 1600, 30.0);
  const Track slow = MakeTrack(robot, slow_wheels);
  EXPECT_EQ(slow.smooth_k, 1);
}

}  // namespace
}  // namespace calib::diag
