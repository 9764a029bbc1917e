// scripts/inject_effect.py against the diagnosis's own model (diagnose/diagnose_model.h and the
// speeds and steering directions of diagnose_fit.cc MakeTrack): on simulated recordings, the
// injected wheel stream, read back and seen through the diagnosis's Track, reproduces the
// recorded one by the model's formula for the effect, to rounding, at every encoder sample.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "calib/core/robot.h"
#include "calib/core/wheel_track.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "calib/live/sim_run.h"
#include "calib/sim/simulator.h"
#include "diagnose/diagnose_fit.h"
#include "diagnose/diagnose_model.h"
#include "sim_log.h"

namespace calib::diag {
namespace {

using test_support::Source;

// A drive's default route with only its encoders (and the steering reading) recorded.
std::string WheelsOnlyLog(const std::string& drive, const std::string& path) {
  SimConfig config = LoadSimConfig(Source("config/sims/" + drive + ".yaml"));
  config.lidar2d.rate_hz = 0.0;
  config.imu.rate_hz = 0.0;
  config.pose.rate_hz = 0.0;
  config.ground_truth_rate_hz = 0.0;
  LogWriter writer(path);
  RunOffline(config, OfflineRunOptions{}, &writer);
  writer.Close();
  return path;
}

WheelTrack ReadWheels(const RobotDescription& robot, const std::string& path) {
  WheelTrack track;
  LogReader reader(path);
  LogEvent e;
  while (reader.Next(&e)) {
    if (e.channel != kWheelsChannel) continue;
    agvcal::wheel_state_t m;
    EXPECT_TRUE(Decode(e.data.data(), int(e.data.size()), &m));
    track.Append(WheelSampleFromMessage(m, robot, path));
  }
  return track;
}

// Runs the injector; its exit status.
int Inject(const std::string& in, const std::string& out, const std::string& robot, const std::string& args) {
  const std::string command =
      "python3 " + Source("scripts/inject_effect.py") + " " + in + " " + out + " " + robot + " " + args;
  return std::system(command.c_str());
}

struct Streams {
  RobotDescription robot;
  WheelTrack recorded, injected;
};

Streams Injected(const std::string& drive, const std::string& args) {
  const std::string robot_path = Source("config/robots/" + drive + ".yaml");
  const std::string in = WheelsOnlyLog(drive, testing::TempDir() + drive + ".log");
  const std::string out = testing::TempDir() + drive + "_injected.log";
  EXPECT_EQ(Inject(in, out, robot_path, args), 0);
  Streams s{LoadRobotFile(robot_path), {}, {}};
  s.recorded = ReadWheels(s.robot, in);
  s.injected = ReadWheels(s.robot, out);
  EXPECT_GT(s.recorded.size(), 1000u);
  EXPECT_EQ(s.recorded.size(), s.injected.size());
  return s;
}

// The largest distance (rad) the slip model loses on the injected stream between sample 0 and any
// other, and the largest difference of the injected stream less that loss from the recorded one.
std::pair<double, double> SlipLostAndError(const Streams& s, const Track& tr, double slip, double radius) {
  double largest_change = 0, largest_error = 0;
  for (int w = 0; w < tr.wheels; ++w) {
    for (std::size_t i = 1; i < tr.size(); ++i) {
      // diagnose_model.h: rotation -= slip * r * (spd_n^2 - spd_c^2) / 2 over samples 0 .. i.
      const double lost = slip * radius * (tr.speed[i][w] * tr.speed[i][w] - tr.speed[0][w] * tr.speed[0][w]) / 2;
      const double ground = tr.pos(i, w) - tr.pos(0, w) - lost;
      const double recorded = s.recorded.position(i, w) - s.recorded.position(0, w);
      largest_error = std::max(largest_error, std::abs(ground - recorded));
      largest_change = std::max(largest_change, std::abs(lost));
    }
  }
  return {largest_change, largest_error};
}

TEST(InjectEffect, SlipIsTheModelsDistanceLostToRounding) {
  const Streams s = Injected("diff_robot", "slip 0.05 0.1,0.1");
  const Track tr = MakeTrack(s.robot, s.injected);
  const auto [largest_change, largest_error] = SlipLostAndError(s, tr, 0.05, 0.1);
  EXPECT_GT(largest_change, 1e-3);  // the slip changed the stream
  EXPECT_LT(largest_error, 1e-9);
}

// A tricycle's drive encoder whose 1600-tick counter is updated at 26 Hz and read at 20 Hz, its
// speed swinging between 0 and 4 rad/s: the readings step unevenly, and the diagnosis's speeds
// are least-squares slopes over a wider window (diagnose_fit.cc ChooseSpeedWindow).
TEST(InjectEffect, SlipIsTheModelsDistanceLostOnUnevenSteps) {
  const std::string robot_path = Source("config/robots/forklift.yaml");
  const RobotDescription robot = LoadRobotFile(robot_path);
  const std::string in = testing::TempDir() + "uneven.log", out = testing::TempDir() + "uneven_injected.log";
  {
    LogWriter writer(in);
    const double tick = 2 * M_PI / 1600, w = 2 * M_PI / 4.0;
    for (int i = 0; i < 60 * 20; ++i) {
      const double updated = std::floor(i / 20.0 * 26.0 + 1e-9) / 26.0;
      const double angle = 2.0 * (updated - std::sin(w * updated) / w);
      const int64_t utime = 1000000 + int64_t(i) * 50000;
      writer.Publish(kWheelsChannel, utime,
                     Encode(WheelStateMessage({utime, {tick * std::floor(angle / tick)}, {0.1}}, robot)));
    }
    writer.Close();
  }
  ASSERT_EQ(Inject(in, out, robot_path, "slip 0.5 0.2"), 0);
  const Streams s{robot, ReadWheels(robot, in), ReadWheels(robot, out)};
  const Track tr = MakeTrack(s.robot, s.injected);
  EXPECT_TRUE(tr.speed_window.least_squares);
  EXPECT_GT(tr.speed_window.k, 2);
  const auto [largest_change, largest_error] = SlipLostAndError(s, tr, 0.5, 0.2);
  EXPECT_GT(largest_change, 0.1);
  EXPECT_LT(largest_error, 1e-9);
}

TEST(InjectEffect, EccentricityIsTheModelsTermToRounding) {
  const double amplitude = 0.02, phase = 0.7;
  const Streams s = Injected("diff_robot", "eccentricity left 0.02 0.7");
  const Track tr = MakeTrack(s.robot, s.injected);
  const double c = amplitude * std::cos(phase), sn = amplitude * std::sin(phase);
  double largest_error = 0, largest_change = 0;
  for (std::size_t i = 1; i < tr.size(); ++i) {
    // diagnose_model.h: rotation += c (sin pos_n - sin pos_c) - s (cos pos_n - cos pos_c).
    const double p0 = tr.pos(0, 0), p = tr.pos(i, 0);
    const double term = c * (std::sin(p) - std::sin(p0)) - sn * (std::cos(p) - std::cos(p0));
    const double recorded = s.recorded.position(i, 0) - s.recorded.position(0, 0);
    largest_error = std::max(largest_error, std::abs(p - p0 + term - recorded));
    largest_change = std::max(largest_change, std::abs(term));
    EXPECT_EQ(s.injected.position(i, 1), s.recorded.position(i, 1));  // the other wheel untouched
  }
  EXPECT_GT(largest_change, 0.01);
  EXPECT_LT(largest_error, 1e-9);
}

TEST(InjectEffect, BacklashIsTheModelsPlayToRounding) {
  const double width = 0.03;
  const Streams s = Injected("forklift", "backlash drive 0.03");
  const Track tr = MakeTrack(s.robot, s.injected);
  int reversals = 0;
  for (std::size_t i = 0; i < tr.size(); ++i) {
    // diagnose_model.h: true angle = reading - steer_sign * width / 2, the sign from the injected reading.
    EXPECT_NEAR(tr.steer(i, 0) - tr.steer_sign[i][0] * width / 2, s.recorded.steer(i, 0), 1e-12) << i;
    reversals += i > 0 && tr.steer_sign[i][0] != tr.steer_sign[i - 1][0];
  }
  EXPECT_GT(reversals, 2);
}

TEST(InjectEffect, OffsetMovesEveryStampOnTheChannel) {
  const Streams s = Injected("diff_robot", "offset WHEELS -0.123");
  for (std::size_t i = 0; i < s.recorded.size(); ++i) {
    EXPECT_EQ(s.injected.utime(i), s.recorded.utime(i) - 123000);
    EXPECT_EQ(s.injected.position(i, 0), s.recorded.position(i, 0));
  }
}

TEST(InjectEffect, UnrealisableSizeIsRefused) {
  const std::string robot_path = Source("config/robots/diff_robot.yaml");
  const std::string in = WheelsOnlyLog("diff_robot", testing::TempDir() + "refused.log");
  EXPECT_EQ(WEXITSTATUS(Inject(in, testing::TempDir() + "refused_out.log", robot_path, "eccentricity left 1.2 0")), 3);
}

}  // namespace
}  // namespace calib::diag
