// The simulator against ground truth and physics: determinism, kinematic
// consistency of WHEELS with GROUND_TRUTH under the TRUE parameters, command
// following, the 2D lidar (geometry, true mount, header, noise, per-beam
// timing), every effect of spec/effects.md against its definition, the IMU,
// the 3D lidar, and config errors. Tolerances are stated at each check.
#include "calib/sim/simulator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "agvcal/drive_command_t.hpp"
#include "agvcal/imu_t.hpp"
#include "agvcal/laser_scan_t.hpp"
#include "agvcal/point_cloud_t.hpp"
#include "agvcal/pose2d_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/se2.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "calib/live/sim_run.h"

namespace calib {
namespace {

constexpr int64_t kStart = 1700000000000000;  // default start_utime
constexpr double kDeg = M_PI / 180.0;

const std::string kSimDir = std::string(AGVCAL_SOURCE_DIR) + "/config/sims";

SimConfig Parse(const std::string& yaml) { return ParseSimConfig(yaml, "inline.yaml", kSimDir); }

// A 10 m x 10 m square room centred at the origin (walls at x, y = +-5).
constexpr double kRoomHalf = 5.0;
std::string RoomWorld() {
  // In the test process's own temporary folder (tests/scratch_dir.cc).
  const std::string path = testing::TempDir() + "simulator_test_room.world";
  std::ofstream out(path);
  out << "# 10 m x 10 m room\nwall -5 -5 5 -5\nwall 5 -5 5 5\nwall 5 5 -5 5\nwall -5 5 -5 -5\n";
  return path;
}

// Distance from p along angle a to the room's walls.
double RoomRange(double px, double py, double a) {
  const double c = std::cos(a), s = std::sin(a);
  double t = 1e9;
  if (c > 1e-12) t = std::min(t, (kRoomHalf - px) / c);
  if (c < -1e-12) t = std::min(t, (-kRoomHalf - px) / c);
  if (s > 1e-12) t = std::min(t, (kRoomHalf - py) / s);
  if (s < -1e-12) t = std::min(t, (-kRoomHalf - py) / s);
  return t;
}

template <typename Message>
std::vector<Message> Messages(const MemorySink& sink, const std::string& channel) {
  std::vector<Message> out;
  for (const LogEvent& e : sink.events) {
    if (e.channel != channel) continue;
    Message m;
    EXPECT_TRUE(Decode(e.data.data(), static_cast<int>(e.data.size()), &m)) << channel;
    out.push_back(m);
  }
  return out;
}

std::map<int64_t, Pose2> Truth(const MemorySink& sink) {
  std::map<int64_t, Pose2> out;
  for (const auto& m : Messages<agvcal::pose2d_t>(sink, kGroundTruthChannel))
    out[m.utime] = {m.x, m.y, m.theta};
  return out;
}

// Body twist over each ground-truth interval, keyed by the interval's midpoint (us).
std::map<int64_t, Twist2> TruthTwists(const MemorySink& sink) {
  const auto truth = Truth(sink);
  std::map<int64_t, Twist2> out;
  for (auto it = truth.begin(); std::next(it) != truth.end(); ++it) {
    const auto next = std::next(it);
    const int64_t dt = next->first - it->first;
    out[(it->first + next->first) / 2] = LogTwist(Between(it->second, next->second), dt * 1e-6);
  }
  return out;
}

DriveCommand TwistCommand(double vx, double omega, double timeout_s = 100.0) {
  DriveCommand c;
  c.mode = DriveMode::kTwist;
  c.twist = {vx, 0.0, omega};
  c.timeout_s = timeout_s;
  return c;
}

DriveCommand WheelCommand(std::vector<double> speed, std::vector<double> steer,
                          double timeout_s = 100.0) {
  DriveCommand c;
  c.mode = DriveMode::kWheels;
  c.wheels = {std::move(speed), std::move(steer)};
  c.timeout_s = timeout_s;
  return c;
}

int64_t Us(double seconds) { return std::llround(seconds * 1e6); }

// ---------------------------------------------------------------------------
// 1. Determinism

const char* kForkliftNoisy = R"(
robot: ../robots/forklift.yaml
seed: 7
truth:
  params: {drive_radius: 0.1163, wheelbase: 1.4335, steer_offset: 0.0131}
  lidar2d: {x: 1.6152, y: 0.0123, yaw: -0.0142}
sensors:
  wheels: {tick_noise: 0.3, velocity_noise: 0.01}
  lidar2d: {rate: 20, beams: 360, range_noise: 0.01, dropout: 0.02}
  imu: {rate: 200}
  pose: {rate: 10}
)";

TEST(SimulatorTest, SameSeedGivesIdenticalBytesAndOtherSeedDifferentScans) {
  OfflineRunOptions options;
  options.trajectory = "demo";
  SimConfig config = Parse(kForkliftNoisy);
  MemorySink a, b, c;
  RunOffline(config, options, &a);
  RunOffline(config, options, &b);
  ASSERT_EQ(a.events.size(), b.events.size());
  ASSERT_GT(a.events.size(), 1000u);
  for (size_t i = 0; i < a.events.size(); ++i) {
    ASSERT_EQ(a.events[i].channel, b.events[i].channel) << "event " << i;
    ASSERT_EQ(a.events[i].timestamp, b.events[i].timestamp) << "event " << i;
    ASSERT_EQ(a.events[i].data, b.events[i].data) << "event " << i << " " << a.events[i].channel;
  }

  config.seed = 8;
  RunOffline(config, options, &c);
  std::vector<std::vector<uint8_t>> scans_a, scans_c;
  for (const auto& e : a.events)
    if (e.channel == kScanChannel) scans_a.push_back(e.data);
  for (const auto& e : c.events)
    if (e.channel == kScanChannel) scans_c.push_back(e.data);
  ASSERT_FALSE(scans_a.empty());
  ASSERT_EQ(scans_a.size(), scans_c.size());
  for (size_t i = 0; i < scans_a.size(); ++i) EXPECT_NE(scans_a[i], scans_c[i]) << "scan " << i;
}

// The bundled samples (logs/, scripts/make-samples.sh) are what today's simulator
// makes of config/sims: tests that compare them with their sim config's truth
// would otherwise measure an older simulator. (The dual-steer sample once
// predated the wheels' fighting model: 0.4 mrad per 50 ms of yaw no model had.)
TEST(SimulatorTest, BundledSamplesAreTodaysSimulatorOutput) {
  for (const auto& [sim, log] : std::vector<std::pair<std::string, std::string>>{
           {"forklift", "forklift_demo"}, {"diff_robot", "diff_robot_demo"},
           {"dual_steer_agv", "dual_steer_demo"}}) {
    SCOPED_TRACE(log);
    OfflineRunOptions options;
    options.trajectory = "demo";
    MemorySink simulated;
    RunOffline(LoadSimConfig(kSimDir + "/" + sim + ".yaml"), options, &simulated);
    LogReader reader(std::string(AGVCAL_SOURCE_DIR) + "/logs/" + log + ".log");
    LogEvent e;
    std::size_t i = 0;
    bool same = true;
    for (; same && reader.Next(&e); ++i)
      same = i < simulated.events.size() && e.channel == simulated.events[i].channel &&
             e.timestamp == simulated.events[i].timestamp && e.data == simulated.events[i].data;
    EXPECT_TRUE(same && i == simulated.events.size())
        << "logs/" << log << ".log differs from the simulator's output at event " << i - 1
        << ": run scripts/make-samples.sh";
  }
}

TEST(SimulatorTest, SeedsBeyond32BitsGiveDifferentNoise) {
  // std::seed_seq keeps 32 bits per entry: seeds 1 and 2^32 + 1 must still differ.
  SimConfig config = Parse(kForkliftNoisy);
  MemorySink a, b;
  config.seed = 1;
  Simulator(config).AdvanceTo(kStart + Us(0.1), &a);
  config.seed = (uint64_t{1} << 32) + 1;
  Simulator(config).AdvanceTo(kStart + Us(0.1), &b);
  const auto scans_a = Messages<agvcal::laser_scan_t>(a, kScanChannel);
  const auto scans_b = Messages<agvcal::laser_scan_t>(b, kScanChannel);
  ASSERT_FALSE(scans_a.empty());
  // Compared as bytes: NaN (dropout) never equals itself.
  EXPECT_NE(Encode(scans_a[0]), Encode(scans_b[0]));
}

// ---------------------------------------------------------------------------
// 2. Kinematic consistency: WHEELS integrated with the TRUE parameters follow
// GROUND_TRUTH; with the nominal ones they drift.

struct PathErrors {
  double position_m = 0.0, heading_rad = 0.0, path_length_m = 0.0;
};

PathErrors IntegrateAgainstTruth(const MemorySink& sink, const RobotDescription& robot,
                                 const DriveModel& model) {
  const auto truth = Truth(sink);
  const auto wheels = Messages<agvcal::wheel_state_t>(sink, kWheelsChannel);
  const auto& roles = WheelRoles(robot.drive);
  // Message column of each role.
  std::vector<int> column(roles.size(), -1);
  for (size_t i = 0; i < roles.size(); ++i)
    for (int k = 0; k < wheels.front().num_wheels; ++k)
      if (wheels.front().name[k] == robot.wheel_name(roles[i])) column[i] = k;
  for (int c : column) EXPECT_GE(c, 0);

  PathErrors errors;
  Pose2 pose;
  bool started = false;
  Pose2 previous_truth;
  for (size_t k = 0; k + 1 < wheels.size(); ++k) {
    const auto& w0 = wheels[k];
    const auto& w1 = wheels[k + 1];
    const auto t0 = truth.find(w0.utime), t1 = truth.find(w1.utime);
    EXPECT_TRUE(t0 != truth.end() && t1 != truth.end()) << "no ground truth at " << w0.utime;
    if (t0 == truth.end() || t1 == truth.end()) continue;
    if (!started) {
      pose = t0->second;
      previous_truth = t0->second;
      started = true;
    }
    WheelIncrement inc;
    for (size_t i = 0; i < roles.size(); ++i) {
      inc.rotation.push_back(w1.position[column[i]] - w0.position[column[i]]);
      inc.steer_start.push_back(w0.steer[column[i]]);
      inc.steer_end.push_back(w1.steer[column[i]]);
    }
    pose = Compose(pose, model.Integrate(inc));
    const Pose2& gt = t1->second;
    errors.position_m = std::max(errors.position_m, std::hypot(pose.x - gt.x, pose.y - gt.y));
    errors.heading_rad =
        std::max(errors.heading_rad, std::abs(WrapAngle(pose.theta - gt.theta)));
    errors.path_length_m += std::hypot(gt.x - previous_truth.x, gt.y - previous_truth.y);
    previous_truth = gt;
  }
  return errors;
}

TEST(SimulatorTest, WheelsIntegratedWithTrueParamsFollowGroundTruth) {
  const std::vector<std::string> configs = {
      R"(
robot: ../robots/diff_robot.yaml
truth: {params: {left_radius: 0.07538, right_radius: 0.07471, track: 0.4561}}
)",
      R"(
robot: ../robots/forklift.yaml
truth: {params: {drive_radius: 0.1163, wheelbase: 1.4335, steer_offset: 0.0131}}
)",
      R"(
robot: ../robots/dual_steer_agv.yaml
truth: {params: {a1_radius: 0.1009, a1_steer_offset: -0.0105, b: 1.2082, a2_radius: 0.0994, a: 0.6057}}
)"};
  // Exact encoders apart from 4096-tick quantisation; no lidar or IMU (speed).
  const std::string sensors = R"(
sensors:
  wheels: {rate: 100, ticks_per_rev: 4096, tick_noise: 0, steer_noise: 0}
  lidar2d: {rate: 0}
  imu: {rate: 0}
)";
  for (const std::string& text : configs) {
    const SimConfig config = Parse(text + sensors);
    SCOPED_TRACE(DriveTypeName(config.robot.drive));
    OfflineRunOptions options;
    options.trajectory = "demo";
    MemorySink sink;
    RunOffline(config, options, &sink);
    const auto true_model = MakeDriveModel(config.robot.drive, config.true_params);
    const auto nominal_model = MakeDriveModel(config.robot);
    const PathErrors with_truth = IntegrateAgainstTruth(sink, config.robot, *true_model);
    const PathErrors with_nominal = IntegrateAgainstTruth(sink, config.robot, *nominal_model);
    std::printf("  %-12s path %.2f m; true params: %.2e m %.2e rad; nominal: %.2e m %.2e rad\n",
                DriveTypeName(config.robot.drive), with_truth.path_length_m,
                with_truth.position_m, with_truth.heading_rad, with_nominal.position_m,
                with_nominal.heading_rad);
    EXPECT_GT(with_truth.path_length_m, 3.0);  // the demo moves the robot
    EXPECT_LT(with_truth.position_m, 0.01);
    EXPECT_LT(with_truth.heading_rad, 0.2 * kDeg);
    // The true parameters are the ones driving the robot: nominal values drift
    // clearly more (by at least 5x in position or heading, and by >= 1 cm or 0.2 deg).
    EXPECT_TRUE(with_nominal.position_m > 5 * with_truth.position_m ||
                with_nominal.heading_rad > 5 * with_truth.heading_rad);
    EXPECT_TRUE(with_nominal.position_m > 0.01 || with_nominal.heading_rad > 0.2 * kDeg);
  }
}

// ---------------------------------------------------------------------------
// 3. Commands are followed (differential: the controller uses nominal values,
// the wheels roll with the true ones).

const char* kDiffTruth = R"(
robot: ../robots/diff_robot.yaml
truth: {params: {left_radius: 0.07538, right_radius: 0.07471, track: 0.4561}}
sensors: {lidar2d: {rate: 0}, imu: {rate: 0}}
)";

TEST(SimulatorTest, TwistCommandGivesTrueSpeedFromNominalWheelSpeeds) {
  const SimConfig config = Parse(kDiffTruth);
  const double r_nom = 0.075, track_nom = 0.45;
  const double rl = 0.07538, rr = 0.07471, track = 0.4561;
  for (const auto& [vx, omega] : std::vector<std::pair<double, double>>{{0.4, 0.0}, {0.0, 0.5},
                                                                        {0.3, -0.4}}) {
    SCOPED_TRACE("vx " + std::to_string(vx) + " omega " + std::to_string(omega));
    Simulator sim(config);
    MemorySink sink;
    sim.ApplyCommand(TwistCommand(vx, omega));
    sim.AdvanceTo(kStart + Us(1.0), &sink);
    // The robot's controller: nominal inverse kinematics.
    const double wl = (vx - 0.5 * track_nom * omega) / r_nom;
    const double wr = (vx + 0.5 * track_nom * omega) / r_nom;
    const double vx_true = 0.5 * (rl * wl + rr * wr);
    const double omega_true = (rr * wr - rl * wl) / track;
    int checked = 0;
    for (const auto& [t, twist] : TruthTwists(sink)) {
      if (t < kStart + Us(0.1)) continue;  // steady state
      EXPECT_NEAR(twist.vx, vx_true, 1e-6);
      EXPECT_NEAR(twist.vy, 0.0, 1e-6);
      EXPECT_NEAR(twist.omega, omega_true, 1e-6);
      ++checked;
    }
    EXPECT_GT(checked, 50);
    // And the reported wheel speeds are the commanded ones.
    const auto wheels = Messages<agvcal::wheel_state_t>(sink, kWheelsChannel);
    EXPECT_NEAR(wheels.back().velocity[0], wl, 1e-12);
    EXPECT_NEAR(wheels.back().velocity[1], wr, 1e-12);
  }
}

TEST(SimulatorTest, StaleCommandStopsTheRobot) {
  Simulator sim(Parse(kDiffTruth));
  MemorySink sink;
  sim.ApplyCommand(TwistCommand(0.4, 0.2, 0.2 /* timeout s */));
  sim.AdvanceTo(kStart + Us(1.0), &sink);
  const auto truth = Truth(sink);
  const Pose2 at_100ms = truth.at(kStart + Us(0.10));
  const Pose2 at_190ms = truth.at(kStart + Us(0.19));
  const Pose2 at_210ms = truth.at(kStart + Us(0.21));
  const Pose2 at_end = truth.at(kStart + Us(1.0));
  EXPECT_GT(std::hypot(at_190ms.x - at_100ms.x, at_190ms.y - at_100ms.y), 0.03);  // moving
  EXPECT_EQ(at_210ms.x, at_end.x);  // stopped once the command was stale
  EXPECT_EQ(at_210ms.y, at_end.y);
  EXPECT_EQ(at_210ms.theta, at_end.theta);
  const auto wheels = Messages<agvcal::wheel_state_t>(sink, kWheelsChannel);
  EXPECT_EQ(wheels.back().velocity[0], 0.0);
  EXPECT_EQ(wheels.back().velocity[1], 0.0);
}

// ---------------------------------------------------------------------------
// 4. 2D lidar in the square room.

std::string RoomConfig(const std::string& lidar_sensor, const std::string& extra = "") {
  return "robot: ../robots/diff_robot.yaml\nworld: " + RoomWorld() +
         "\nstart: {x: 1.0, y: -0.5, theta: 0.3}\n"
         "truth: {lidar2d: {x: 0.2123, y: -0.0087, yaw: 0.0191}}\n"
         "sensors: {lidar2d: " + lidar_sensor + ", imu: {rate: 0}}\n" + extra;
}

TEST(SimulatorTest, ScanRangesMatchTheRoomFromTheTrueMount) {
  const SimConfig config =
      Parse(RoomConfig("{rate: 20, beams: 720, range_noise: 0, dropout: 0}"));
  Simulator sim(config);
  MemorySink sink;
  sim.AdvanceTo(kStart + Us(0.5), &sink);
  const auto scans = Messages<agvcal::laser_scan_t>(sink, kScanChannel);
  ASSERT_GE(scans.size(), 9u);
  const Pose2 robot = config.start;
  const Pose2 true_sensor = Compose(robot, {0.2123, -0.0087, 0.0191});
  const Pose2 nominal_sensor = Compose(robot, {0.20, 0.0, 0.0});
  for (size_t k = 0; k < scans.size(); ++k) {
    const auto& scan = scans[k];
    // Header.
    EXPECT_EQ(scan.utime, kStart + static_cast<int64_t>(k) * 50000);
    EXPECT_EQ(scan.angle_min, static_cast<float>(-M_PI));
    EXPECT_EQ(scan.angle_increment, static_cast<float>(2 * M_PI / 720));
    EXPECT_FLOAT_EQ(scan.scan_time, 0.05f);
    EXPECT_FLOAT_EQ(scan.time_increment, 0.05f / 720);
    EXPECT_FLOAT_EQ(scan.range_min, 0.05f);
    EXPECT_FLOAT_EQ(scan.range_max, 30.0f);
    ASSERT_EQ(scan.nranges, 720);
    ASSERT_EQ(scan.ranges.size(), 720u);
    EXPECT_EQ(scan.nintensities, 0);
    double max_error = 0.0, max_nominal_error = 0.0;
    for (int j = 0; j < scan.nranges; ++j) {
      const double a = double(scan.angle_min) + j * double(scan.angle_increment);
      const double expected = RoomRange(true_sensor.x, true_sensor.y, true_sensor.theta + a);
      max_error = std::max(max_error, std::abs(scan.ranges[j] - expected));
      max_nominal_error = std::max(
          max_nominal_error,
          std::abs(scan.ranges[j] - RoomRange(nominal_sensor.x, nominal_sensor.y,
                                              nominal_sensor.theta + a)));
      // The cardinal beams (0, 90, 180, 270 deg in the sensor frame) individually.
      if (j % 180 == 0) {
        EXPECT_NEAR(scan.ranges[j], expected, 1e-4) << "beam " << j;
      }
    }
    EXPECT_LT(max_error, 1e-4) << "scan " << k;
    EXPECT_GT(max_nominal_error, 0.01) << "scan " << k;  // the nominal mount would not fit
  }
}

TEST(SimulatorTest, ScanNoiseAndDropoutHaveTheConfiguredStatistics) {
  const SimConfig config =
      Parse(RoomConfig("{rate: 20, beams: 720, range_noise: 0.01, dropout: 0.1}"));
  Simulator sim(config);
  MemorySink sink;
  sim.AdvanceTo(kStart + Us(1.0), &sink);
  const Pose2 sensor = Compose(config.start, {0.2123, -0.0087, 0.0191});
  double sum = 0.0, sum2 = 0.0;
  int n = 0, dropped = 0, total = 0;
  for (const auto& scan : Messages<agvcal::laser_scan_t>(sink, kScanChannel)) {
    for (int j = 0; j < scan.nranges; ++j) {
      ++total;
      if (std::isnan(scan.ranges[j])) {
        ++dropped;
        continue;
      }
      const double a = double(scan.angle_min) + j * double(scan.angle_increment);
      const double e = scan.ranges[j] - RoomRange(sensor.x, sensor.y, sensor.theta + a);
      sum += e;
      sum2 += e * e;
      ++n;
    }
  }
  ASSERT_GT(total, 10000);
  const double mean = sum / n, std_dev = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.001);
  EXPECT_NEAR(std_dev, 0.01, 0.0015);  // +-15%
  const double fraction = double(dropped) / total;
  EXPECT_NEAR(fraction, 0.1, 0.015);  // > 4 sigma of the binomial
}

// ---------------------------------------------------------------------------
// 5. Per-beam timing: the robot turns in place, the lidar at its centre.

// Turns in place at `omega` with the lidar at the reference point; returns the sink.
MemorySink TurnInPlaceInRoom(const std::string& lidar_sensor, const std::string& effects,
                             double omega, SimConfig* config_out) {
  *config_out = Parse("robot: ../robots/diff_robot.yaml\nworld: " + RoomWorld() +
                      "\nstart: {x: 0.7, y: -1.1, theta: 0.2}\n"
                      "truth: {lidar2d: {x: 0, y: 0, yaw: 0}}\n"
                      "sensors: {lidar2d: " + lidar_sensor + ", imu: {rate: 0}}\n" + effects);
  Simulator sim(*config_out);
  MemorySink sink;
  sim.ApplyCommand(TwistCommand(0.0, omega));
  sim.AdvanceTo(kStart + Us(1.0), &sink);
  return sink;
}

struct TimingErrors {
  double timed = 0.0;   // max |range - analytic| with beam j at utime + j * dt_beam
  double static_ = 0.0; // same with every beam at utime (the pose of the scan's start)
  double first = 0.0, last = 0.0;
  int scans = 0;
};

// Compares each scan (after 0.1 s) with the room seen from the ground-truth
// pose, beam j taken at utime + j * dt_beam.
TimingErrors CheckBeamTiming(const MemorySink& sink, const SimConfig& config, double dt_beam) {
  const auto truth = Truth(sink);
  const double omega = TruthTwists(sink).rbegin()->second.omega;
  TimingErrors e;
  for (const auto& scan : Messages<agvcal::laser_scan_t>(sink, kScanChannel)) {
    if (scan.utime < kStart + Us(0.1)) continue;
    const auto gt = truth.find(scan.utime);
    EXPECT_TRUE(gt != truth.end());
    if (gt == truth.end()) continue;
    const Pose2& p = gt->second;
    EXPECT_NEAR(p.x, config.start.x, 1e-9);  // turning in place
    EXPECT_NEAR(p.y, config.start.y, 1e-9);
    ++e.scans;
    for (int j = 0; j < scan.nranges; ++j) {
      const double a = double(scan.angle_min) + j * double(scan.angle_increment);
      const double timed = RoomRange(p.x, p.y, p.theta + omega * j * dt_beam + a);
      const double err = std::abs(scan.ranges[j] - timed);
      e.timed = std::max(e.timed, err);
      if (j == 0) e.first = std::max(e.first, err);
      if (j == scan.nranges - 1) e.last = std::max(e.last, err);
      e.static_ = std::max(e.static_, std::abs(scan.ranges[j] - RoomRange(p.x, p.y, p.theta + a)));
    }
  }
  return e;
}

TEST(SimulatorTest, EachBeamIsTakenAtItsOwnTime) {
  SimConfig config;
  const MemorySink sink =
      TurnInPlaceInRoom("{rate: 20, beams: 720, range_noise: 0, dropout: 0}", "", 0.8, &config);
  const auto scans = Messages<agvcal::laser_scan_t>(sink, kScanChannel);
  ASSERT_FALSE(scans.empty());
  const double dt_beam = scans[0].time_increment;
  EXPECT_FLOAT_EQ(dt_beam, 0.05f / 720);
  const TimingErrors e = CheckBeamTiming(sink, config, dt_beam);
  EXPECT_GE(e.scans, 15);
  EXPECT_LT(e.first, 1e-3);
  EXPECT_LT(e.last, 1e-3);
  EXPECT_LT(e.timed, 1e-3);
  EXPECT_GT(e.static_, 0.01);  // timing matters at this turn rate
}

// ---------------------------------------------------------------------------
// 6. Effects, each against its definition in spec/effects.md.

TEST(SimulatorTest, TimeOffsetShiftsScanStampsOnly) {
  const std::string base = R"(
robot: ../robots/diff_robot.yaml
truth: {params: {left_radius: 0.07538, right_radius: 0.07471, track: 0.4561}}
sensors: {lidar2d: {rate: 20, beams: 360, range_noise: 0.01}}
)";
  auto run = [](const SimConfig& config) {
    Simulator sim(config);
    MemorySink sink;
    sim.ApplyCommand(TwistCommand(0.3, 0.5));
    sim.AdvanceTo(kStart + Us(2.0), &sink);
    return sink;
  };
  const MemorySink plain = run(Parse(base));
  const MemorySink shifted = run(Parse(base + "effects: {time_offset: {offset_s: 0.02}}\n"));
  const auto a = Messages<agvcal::laser_scan_t>(plain, kScanChannel);
  const auto b = Messages<agvcal::laser_scan_t>(shifted, kScanChannel);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GE(a.size(), 30u);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(b[k].utime, a[k].utime + 20000);  // stamped t, taken at t - offset_s
    EXPECT_EQ(b[k].ranges, a[k].ranges);        // same content
    EXPECT_EQ(b[k].time_increment, a[k].time_increment);
  }
  // Nothing else changes.
  for (const char* channel : {kWheelsChannel, kImuChannel, kGroundTruthChannel}) {
    std::vector<std::vector<uint8_t>> da, db;
    for (const auto& e : plain.events)
      if (e.channel == channel) da.push_back(e.data);
    for (const auto& e : shifted.events)
      if (e.channel == channel) db.push_back(e.data);
    EXPECT_EQ(da, db) << channel;
  }
}

TEST(SimulatorTest, ScanDistortionSpreadsBeamsButDeclaresNoTimeIncrement) {
  // Full circle and a 270 deg scanner: beam j at utime + j * scan_period_s / nranges.
  for (const auto& [fov, beams] : std::vector<std::pair<double, int>>{{2 * M_PI, 720},
                                                                      {1.5 * M_PI, 540}}) {
    SCOPED_TRACE("fov " + std::to_string(fov));
    const double period = 0.03;
    SimConfig config;
    const MemorySink sink = TurnInPlaceInRoom(
        "{rate: 20, beams: " + std::to_string(beams) + ", fov: " + std::to_string(fov) +
            ", range_noise: 0, dropout: 0}",
        "effects: {scan_distortion: {scan_period_s: 0.03}}\n", 0.8, &config);
    const auto scans = Messages<agvcal::laser_scan_t>(sink, kScanChannel);
    ASSERT_FALSE(scans.empty());
    for (const auto& scan : scans) EXPECT_EQ(scan.time_increment, 0.0f);
    const TimingErrors e = CheckBeamTiming(sink, config, period / beams);
    EXPECT_LT(e.timed, 1e-3);
    EXPECT_GT(e.static_, 0.01);
    // Spread over the period, not over scan_time.
    EXPECT_GT(CheckBeamTiming(sink, config, 0.05 / beams).timed, 0.005);
  }
}

// Wheel travel (true radius x encoder rotation, mean of the two wheels) and
// ground-truth travel between two WHEELS samples of a differential drive
// driving straight.
struct Travel {
  double wheels = 0.0, truth = 0.0;
};

Travel StraightTravel(const MemorySink& sink, int64_t from, int64_t to, double radius) {
  const auto truth = Truth(sink);
  std::map<int64_t, agvcal::wheel_state_t> wheels;
  for (const auto& w : Messages<agvcal::wheel_state_t>(sink, kWheelsChannel)) wheels[w.utime] = w;
  const auto& w0 = wheels.at(from);
  const auto& w1 = wheels.at(to);
  Travel t;
  t.wheels = radius * 0.5 * ((w1.position[0] - w0.position[0]) + (w1.position[1] - w0.position[1]));
  t.truth = truth.at(to).x - truth.at(from).x;
  return t;
}

const char* kDiffStraight = R"(
robot: ../robots/diff_robot.yaml
sensors:
  wheels: {ticks_per_rev: 1048576}
  lidar2d: {rate: 0}
  imu: {rate: 0}
)";

TEST(SimulatorTest, LongitudinalSlipLosesDistanceWhileAccelerating) {
  // Ground speed r w (1 - k a): over a ramp from 0 to V the ground falls short
  // of the wheels by k * integral(a v dt) = k V^2 / 2, and gains it back while
  // braking. Commands every 1 ms (smooth) and every 50 ms (the commander's rate).
  const double k = 0.05, accel = 0.5, top = 0.5, radius = 0.075;
  const double expected = k * top * top / 2.0;
  for (const int64_t command_period : {int64_t{1000}, int64_t{50000}}) {
    SCOPED_TRACE("command period " + std::to_string(command_period) + " us");
    Simulator sim(Parse(std::string(kDiffStraight) +
                        "effects: {longitudinal_slip: {slip_per_accel: 0.05}}\n"));
    MemorySink sink;
    const int64_t ramp = Us(top / accel);
    int64_t t = kStart + Us(0.1);
    sim.AdvanceTo(t, &sink);
    const int64_t accel_start = t;
    // Speed after each command step: the ramp's value at the end of the step.
    for (int64_t s = 0; s < ramp; s += command_period) {
      sim.ApplyCommand(TwistCommand(accel * (s + command_period) * 1e-6, 0.0));
      sim.AdvanceTo(t += command_period, &sink);
    }
    sim.AdvanceTo(t += Us(0.5), &sink);  // cruise
    const int64_t cruise_end = t;
    for (int64_t s = 0; s < ramp; s += command_period) {
      sim.ApplyCommand(TwistCommand(top - accel * (s + command_period) * 1e-6, 0.0));
      sim.AdvanceTo(t += command_period, &sink);
    }
    sim.AdvanceTo(t += Us(0.2), &sink);
    const Travel accelerating = StraightTravel(sink, accel_start, cruise_end, radius);
    const Travel whole = StraightTravel(sink, accel_start, t, radius);
    EXPECT_GT(accelerating.wheels, 0.4);
    EXPECT_NEAR(accelerating.wheels - accelerating.truth, expected, 0.02 * expected);
    // Braking gives it back: no net loss over a start-stop run.
    EXPECT_NEAR(whole.wheels - whole.truth, 0.0, 0.02 * expected);
  }
}

TEST(SimulatorTest, LateralSlipSkidsOutwardsInATurn) {
  const double gain = 0.1, vx = 0.4, omega = 0.5;
  Simulator sim(Parse(std::string(kDiffStraight) + "effects: {lateral_slip: {gain: 0.1}}\n"));
  MemorySink sink;
  sim.ApplyCommand(TwistCommand(vx, omega));
  sim.AdvanceTo(kStart + Us(2.0), &sink);
  const double vy = -gain * vx * omega;  // right of a left turn: outwards
  int checked = 0;
  for (const auto& [t, twist] : TruthTwists(sink)) {
    if (t < kStart + Us(0.1)) continue;
    EXPECT_NEAR(twist.vx, vx, 1e-6);
    EXPECT_NEAR(twist.vy, vy, 0.02 * std::abs(vy));
    EXPECT_NEAR(twist.omega, omega, 1e-6);
    // Drift angle between heading and track.
    EXPECT_NEAR(std::atan2(twist.vy, twist.vx), std::atan(-gain * omega), 0.02 * gain * omega);
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

// Tricycle: true steering angle from the ground-truth twist, tan(alpha) = omega L / vx.
const char* kForkliftExact = R"(
robot: ../robots/forklift.yaml
truth: {params: {drive_radius: 0.1163, wheelbase: 1.4335, steer_offset: 0.0131}}
sensors:
  wheels: {steer_noise: 0, steer_resolution: 0}
  lidar2d: {rate: 0}
  imu: {rate: 0}
)";
constexpr double kTrueWheelbase = 1.4335, kTrueSteerOffset = 0.0131;

double TrueSteer(const Twist2& twist) { return std::atan2(twist.omega * kTrueWheelbase, twist.vx); }

TEST(SimulatorTest, SteeringLagDelaysTheWheelBehindTheEncoder) {
  const double tau = 0.2, step = 0.3;
  Simulator sim(Parse(std::string(kForkliftExact) + "effects: {steering_lag: {tau_s: 0.2}}\n"));
  MemorySink sink;
  sim.ApplyCommand(WheelCommand({3.0}, {0.0}));
  const int64_t t_step = kStart + Us(0.5);
  sim.AdvanceTo(t_step, &sink);
  sim.ApplyCommand(WheelCommand({3.0}, {step}));
  sim.AdvanceTo(t_step + Us(1.5), &sink);
  // The encoder jumps (no rate limit); the wheel follows through the lag.
  for (const auto& w : Messages<agvcal::wheel_state_t>(sink, kWheelsChannel)) {
    if (w.utime > t_step) {
      EXPECT_EQ(w.steer[0], step);
    }
  }
  int checked = 0;
  double max_unlagged_error = 0.0;
  for (const auto& [t, twist] : TruthTwists(sink)) {
    if (t < kStart + Us(0.05)) continue;
    const double since = (t - t_step) * 1e-6;
    const double raw = since < 0 ? 0.0 : step * (1.0 - std::exp(-since / tau));
    EXPECT_NEAR(TrueSteer(twist), raw - kTrueSteerOffset, 0.02 * step) << "t " << since;
    if (since > 0) max_unlagged_error = std::max(max_unlagged_error,
                                                 std::abs(TrueSteer(twist) - (step - kTrueSteerOffset)));
    ++checked;
  }
  EXPECT_GT(checked, 150);
  EXPECT_GT(max_unlagged_error, 0.5 * step);  // a lag-free wheel would not fit
}

TEST(SimulatorTest, SteeringBacklashOffsetsByHalfWidthAgainstTheLastMotion) {
  const double width = 0.02;
  Simulator sim(
      Parse(std::string(kForkliftExact) + "effects: {steering_backlash: {width_rad: 0.02}}\n"));
  MemorySink sink;
  int64_t t = kStart;
  auto steer_to = [&](double raw, double hold_s) {
    sim.ApplyCommand(WheelCommand({3.0}, {raw}));
    sim.AdvanceTo(t += Us(hold_s), &sink);
    return t;
  };
  const int64_t before_any = steer_to(0.0, 0.5);  // no steering motion yet: no side of the play
  const int64_t from_below = steer_to(0.2, 0.5);  // 0 -> 0.2: last motion positive
  steer_to(0.4, 0.3);
  const int64_t from_above = steer_to(0.2, 0.5);  // 0.4 -> 0.2: last motion negative
  const auto twists = TruthTwists(sink);
  // Mean true angle over the last 0.3 s of each hold.
  auto mean_steer = [&](int64_t end) {
    double sum = 0.0;
    int n = 0;
    for (const auto& [tm, twist] : twists)
      if (tm > end - Us(0.3) && tm < end) sum += TrueSteer(twist), ++n;
    EXPECT_GT(n, 20);
    return sum / n;
  };
  const double up = mean_steer(from_below), down = mean_steer(from_above);
  EXPECT_NEAR(mean_steer(before_any), -kTrueSteerOffset, 0.02 * width);
  EXPECT_NEAR(up, 0.2 - kTrueSteerOffset - width / 2, 0.02 * width);
  EXPECT_NEAR(down, 0.2 - kTrueSteerOffset + width / 2, 0.02 * width);
  EXPECT_NEAR(down - up, width, 0.02 * width);
}

TEST(SimulatorTest, WheelEccentricityModulatesDistancePerWheelAngle) {
  // Travel s(phi) = r (phi + A (sin(phi - phase) + sin(phase))): modulated
  // within a revolution, 2 pi r per revolution.
  const double amplitude = 0.01, phase = 0.4, radius = 0.075;
  Simulator sim(Parse(std::string(kDiffStraight) +
                      "effects: {wheel_eccentricity: {amplitude: 0.01, phase: 0.4}}\n"));
  MemorySink sink;
  sim.ApplyCommand(TwistCommand(0.3, 0.0));
  sim.AdvanceTo(kStart + Us(4.0), &sink);
  const auto truth = Truth(sink);
  double max_error = 0.0, lo = 1e9, hi = -1e9, max_phi = 0.0;
  std::vector<std::pair<double, double>> travel;  // (phi, s)
  for (const auto& w : Messages<agvcal::wheel_state_t>(sink, kWheelsChannel)) {
    const double phi = w.position[0];
    const double gt = truth.at(w.utime).x;
    const double expected = radius * (phi + amplitude * (std::sin(phi - phase) + std::sin(phase)));
    max_error = std::max(max_error, std::abs(gt - expected));
    lo = std::min(lo, gt - radius * phi);
    hi = std::max(hi, gt - radius * phi);
    max_phi = phi;
    travel.push_back({phi, gt});
  }
  EXPECT_GT(max_phi, 4 * M_PI);  // at least two revolutions
  EXPECT_LT(max_error, 0.03 * radius * amplitude);
  EXPECT_NEAR(hi - lo, 2 * radius * amplitude, 0.05 * radius * amplitude);
  // One whole revolution from any start covers 2 pi r.
  for (size_t i = 0; i < travel.size(); i += 37) {
    const double phi0 = travel[i].first;
    if (phi0 + 2 * M_PI > max_phi) break;
    auto it = std::lower_bound(travel.begin(), travel.end(), phi0 + 2 * M_PI,
                               [](const auto& p, double v) { return p.first < v; });
    // Interpolate s at phi0 + 2 pi.
    const auto& b = *it;
    const auto& a = *(it - 1);
    const double s = a.second + (b.second - a.second) * (phi0 + 2 * M_PI - a.first) / (b.first - a.first);
    EXPECT_NEAR(s - travel[i].second, 2 * M_PI * radius, 0.03 * radius * amplitude);
  }
}

TEST(SimulatorTest, DriveLagIsFirstOrder) {
  const double tau = 0.15, vx = 0.3, r_nom = 0.075;
  Simulator sim(Parse(std::string(kDiffStraight) + "effects: {drive_lag: {tau_s: 0.15}}\n"));
  MemorySink sink;
  const int64_t t_step = kStart + Us(0.2);
  sim.AdvanceTo(t_step, &sink);
  sim.ApplyCommand(TwistCommand(vx, 0.0));
  sim.AdvanceTo(t_step + Us(1.0), &sink);
  const double target = vx / r_nom;
  int checked = 0;
  for (const auto& w : Messages<agvcal::wheel_state_t>(sink, kWheelsChannel)) {
    const double since = (w.utime - t_step) * 1e-6;
    const double expected = since <= 0 ? 0.0 : target * (1.0 - std::exp(-since / tau));
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(w.velocity[i], expected, 0.005 * target) << since;
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

// A lag shorter than the integration step still delays the travel by tau: the wheel turns over
// each step at the lag's mean speed. (With the step's end speed, a 4 ms lag on an 8 ms step
// delayed it by dt e^(-dt/tau) / (1 - e^(-dt/tau)) = 1.25 ms, and the diagnosis found that.)
TEST(SimulatorTest, DriveLagShorterThanThePhysicsStepDelaysTheTravelByTau) {
  const double tau = 0.004, vx = 0.3;
  double travelled[2];
  for (const bool lag : {false, true}) {
    Simulator sim(Parse(std::string(kDiffStraight) + "physics_step: 0.008\n" +
                        (lag ? "effects: {drive_lag: {tau_s: 0.004}}\n" : "")));
    MemorySink sink;
    const int64_t t_step = kStart + Us(0.2);  // on the 8 ms grid
    sim.AdvanceTo(t_step, &sink);
    sim.ApplyCommand(TwistCommand(vx, 0.0));
    sim.AdvanceTo(t_step + Us(0.4), &sink);
    travelled[lag] = sim.true_pose().x;
  }
  const double speed = travelled[0] / 0.4;  // the true speed (true radii, nominal commands)
  EXPECT_NEAR((travelled[0] - travelled[1]) / speed, tau, 0.02 * tau);
}

// commands.between: ramp: the setpoint moves linearly from the one in force to the new
// command over one command period (1 / commands.rate), then holds; hold steps at once.
TEST(SimulatorTest, RampedSetpointReachesTheCommandOverOneCommandPeriod) {
  const double vx = 0.3, r_nom = 0.075, target = vx / r_nom;
  for (const bool ramp : {false, true}) {
    SCOPED_TRACE(ramp ? "ramp" : "hold");
    Simulator sim(Parse(std::string(kDiffStraight) + "commands: {rate: 25, between: " + (ramp ? "ramp" : "hold") +
                        "}\n"));
    EXPECT_EQ(sim.config().command_rate_hz, 25.0);
    MemorySink sink;
    const int64_t t_step = kStart + Us(0.2);
    sim.AdvanceTo(t_step, &sink);
    sim.ApplyCommand(TwistCommand(vx, 0.0));
    sim.AdvanceTo(t_step + Us(0.2), &sink);
    int checked = 0;
    for (const auto& w : Messages<agvcal::wheel_state_t>(sink, kWheelsChannel)) {
      const double since = (w.utime - t_step) * 1e-6;
      // A sample at a step's end reports the speed held over that step: the ramp at the step's
      // middle (half the 1 ms step earlier).
      const double expected = since <= 0 ? 0.0 : ramp ? target * std::min(1.0, (since - 0.0005) / 0.04) : target;
      for (int i = 0; i < 2; ++i) EXPECT_NEAR(w.velocity[i], expected, 1e-9 + 0.001 * target) << since;
      ++checked;
    }
    EXPECT_GT(checked, 30);
  }
}

// physics_step: the integration step; sensors sample at most once per step, at its end.
TEST(SimulatorTest, PhysicsStepSetsTheSampleGrid) {
  Simulator sim(Parse(std::string(kDiffStraight) + "physics_step: 0.007\n"));
  MemorySink sink;
  sim.ApplyCommand(TwistCommand(0.3, 0.0));
  sim.AdvanceTo(kStart + Us(1.0), &sink);
  const auto wheels = Messages<agvcal::wheel_state_t>(sink, kWheelsChannel);
  ASSERT_GT(wheels.size(), 50u);
  for (const auto& w : wheels) EXPECT_EQ((w.utime - kStart) % 7000, 0) << w.utime - kStart;
  // 100 Hz wheels on a 7 ms grid: every 7 or 14 ms, 100 a second on average.
  EXPECT_NEAR(double(wheels.size()), 100.0, 2.0);
  EXPECT_NEAR(sim.true_pose().x, 0.3 * 1.0, 0.02);
}

// region: longitudinal slip acts only while the reference point is inside the box.
TEST(SimulatorTest, LongitudinalSlipOnlyInsideItsRegion) {
  const double k = 0.05, accel = 0.5, top = 0.5, radius = 0.075;
  for (const bool inside : {true, false}) {
    SCOPED_TRACE(inside ? "inside" : "outside");
    Simulator sim(Parse(std::string(kDiffStraight) + "effects: {longitudinal_slip: {slip_per_accel: 0.05, region: " +
                        (inside ? "[-1, -1, 3, 1]" : "[2, -1, 5, 1]") + "}}\n"));
    MemorySink sink;
    int64_t t = kStart + Us(0.1);
    sim.AdvanceTo(t, &sink);
    const int64_t start = t;
    for (int64_t s = 0; s < Us(top / accel); s += 1000) {
      sim.ApplyCommand(TwistCommand(accel * (s + 1000) * 1e-6, 0.0));
      sim.AdvanceTo(t += 1000, &sink);
    }
    sim.AdvanceTo(t += Us(0.5), &sink);
    const Travel travel = StraightTravel(sink, start, t, radius);
    EXPECT_NEAR(travel.wheels - travel.truth, inside ? k * top * top / 2.0 : 0.0, 0.02 * k * top * top / 2.0);
  }
}

TEST(SimulatorTest, SteeringRateLimitRampsTheEncoderReading) {
  const double rate = 0.5, target = 0.4;
  Simulator sim(
      Parse(std::string(kForkliftExact) + "effects: {steering_rate_limit: {rate_rad_s: 0.5}}\n"));
  MemorySink sink;
  const int64_t t_step = kStart + Us(0.1);
  sim.AdvanceTo(t_step, &sink);
  sim.ApplyCommand(WheelCommand({0.0}, {target}));
  sim.AdvanceTo(t_step + Us(1.5), &sink);
  int checked = 0;
  for (const auto& w : Messages<agvcal::wheel_state_t>(sink, kWheelsChannel)) {
    const double since = std::max(0.0, (w.utime - t_step) * 1e-6);
    EXPECT_NEAR(w.steer[0], std::min(target, rate * since), 1e-9) << since;
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

// ---------------------------------------------------------------------------
// 7. IMU

const char* kDiffImu = R"(
robot: ../robots/diff_robot.yaml
truth: {params: {left_radius: 0.075, right_radius: 0.075, track: 0.4561}}
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 200, gyro_noise_density: 8.7e-5, gyro_bias: 0.0017, accel_noise_density: 0.002}
)";

struct ImuStats {
  Eigen::Vector3d gyro_mean = Eigen::Vector3d::Zero(), accel_mean = Eigen::Vector3d::Zero();
  double gyro_z_std = 0.0;
  int n = 0;
};

ImuStats ImuStatsBetween(const MemorySink& sink, int64_t from, int64_t to) {
  ImuStats s;
  double sum2 = 0.0;
  for (const auto& m : Messages<agvcal::imu_t>(sink, kImuChannel)) {
    if (m.utime < from || m.utime > to) continue;
    s.gyro_mean += Eigen::Vector3d(m.angular_velocity);
    s.accel_mean += Eigen::Vector3d(m.linear_acceleration);
    sum2 += m.angular_velocity[2] * m.angular_velocity[2];
    ++s.n;
  }
  s.gyro_mean /= s.n;
  s.accel_mean /= s.n;
  s.gyro_z_std = std::sqrt(sum2 / s.n - s.gyro_mean.z() * s.gyro_mean.z());
  return s;
}

TEST(SimulatorTest, ImuAtStandstillShowsBiasAndGravity) {
  Simulator sim(Parse(kDiffImu));
  MemorySink sink;
  sim.AdvanceTo(kStart + Us(5.0), &sink);
  const ImuStats s = ImuStatsBetween(sink, kStart, kStart + Us(5.0));
  ASSERT_GE(s.n, 999);
  const double gyro_sigma = 8.7e-5 * std::sqrt(200.0);
  const double accel_sigma = 0.002 * std::sqrt(200.0);
  const double gyro_tol = 3 * gyro_sigma / std::sqrt(s.n), accel_tol = 3 * accel_sigma / std::sqrt(s.n);
  EXPECT_NEAR(s.gyro_mean.z(), 0.0017, gyro_tol);
  EXPECT_NEAR(s.gyro_mean.x(), 0.0, gyro_tol);
  EXPECT_NEAR(s.gyro_mean.y(), 0.0, gyro_tol);
  EXPECT_NEAR(s.gyro_z_std, gyro_sigma, 0.1 * gyro_sigma);
  EXPECT_NEAR(s.accel_mean.z(), 9.80665, accel_tol);
  EXPECT_NEAR(s.accel_mean.x(), 0.0, accel_tol);
  EXPECT_NEAR(s.accel_mean.y(), 0.0, accel_tol);
}

TEST(SimulatorTest, ImuGyroMeasuresTheTrueTurnRate) {
  Simulator sim(Parse(kDiffImu));
  MemorySink sink;
  sim.ApplyCommand(TwistCommand(0.0, 0.5));
  sim.AdvanceTo(kStart + Us(3.0), &sink);
  const double omega_true = TruthTwists(sink).rbegin()->second.omega;
  EXPECT_NEAR(omega_true, 0.5 * 0.45 / 0.4561, 1e-9);  // the true track
  const ImuStats s = ImuStatsBetween(sink, kStart + Us(0.1), kStart + Us(3.0));
  const double gyro_tol = 3 * 8.7e-5 * std::sqrt(200.0) / std::sqrt(s.n);
  EXPECT_NEAR(s.gyro_mean.z(), omega_true + 0.0017, gyro_tol);
}

TEST(SimulatorTest, ImuMountYawRotatesTheAcceleration) {
  const double yaw = 0.3;
  const std::string exact = R"(
robot: ../robots/diff_robot.yaml
truth: {imu: {yaw: 0.3}}
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 200, gyro_noise_density: 0, gyro_bias: 0, accel_noise_density: 0}
)";
  // Constant arc: centripetal v * omega to the left of the body.
  {
    Simulator sim(Parse(exact));
    MemorySink sink;
    const double vx = 0.4, omega = 0.5;
    sim.ApplyCommand(TwistCommand(vx, omega));
    sim.AdvanceTo(kStart + Us(2.0), &sink);
    const double a = vx * omega;
    int checked = 0;
    for (const auto& m : Messages<agvcal::imu_t>(sink, kImuChannel)) {
      if (m.utime < kStart + Us(0.1)) continue;
      // Body (0, a) in the sensor frame rotated by yaw: R(-yaw) (0, a).
      EXPECT_NEAR(m.linear_acceleration[0], a * std::sin(yaw), 0.01 * a);
      EXPECT_NEAR(m.linear_acceleration[1], a * std::cos(yaw), 0.01 * a);
      EXPECT_NEAR(m.linear_acceleration[2], 9.80665, 1e-12);
      EXPECT_NEAR(m.angular_velocity[2], omega, 1e-9);
      ++checked;
    }
    EXPECT_GT(checked, 300);
  }
  // Straight acceleration at 0.5 m/s^2 (commands every 1 ms).
  {
    Simulator sim(Parse(exact));
    MemorySink sink;
    const double accel = 0.5;
    int64_t t = kStart;
    for (int k = 1; k <= 800; ++k) {
      sim.ApplyCommand(TwistCommand(accel * k * 1e-3, 0.0));
      sim.AdvanceTo(t += 1000, &sink);
    }
    int checked = 0;
    for (const auto& m : Messages<agvcal::imu_t>(sink, kImuChannel)) {
      if (m.utime < kStart + Us(0.02)) continue;
      EXPECT_NEAR(m.linear_acceleration[0], accel * std::cos(yaw), 0.01 * accel);
      EXPECT_NEAR(m.linear_acceleration[1], -accel * std::sin(yaw), 0.01 * accel);
      ++checked;
    }
    EXPECT_GT(checked, 100);
  }
}

// ---------------------------------------------------------------------------
// 8. 3D lidar

TEST(SimulatorTest, CloudPointsLieOnTheFloorAndBodyThroughTheTrueMount) {
  const SimConfig config = Parse(R"(
robot: ../robots/forklift.yaml
truth:
  lidar3d: {x: 0.3, y: -0.1, z: 1.912, pitch: 0.035, roll: -0.012, yaw: 0.2}
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 0}
  lidar3d: {rate: 10, rings: 16, points_per_ring: 900, range_noise: 0,
            body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]}}
)");
  Simulator sim(config);
  MemorySink sink;
  sim.AdvanceTo(kStart + Us(0.15), &sink);
  const auto clouds = Messages<agvcal::point_cloud_t>(sink, kCloudChannel);
  ASSERT_EQ(clouds.size(), 2u);
  auto rotation = [](double yaw, double pitch, double roll) {
    return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
            Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
        .toRotationMatrix();
  };
  const Eigen::Matrix3d R = rotation(0.2, 0.035, -0.012);
  const Eigen::Vector3d t(0.3, -0.1, 1.912);
  const Eigen::Matrix3d R_nominal = rotation(0.0, 0.0, 0.0);
  const Eigen::Vector3d t_nominal(0.0, 0.0, 1.90);
  for (const auto& cloud : clouds) {
    ASSERT_EQ(cloud.npoints, static_cast<int32_t>(cloud.xyz.size()));
    ASSERT_EQ(cloud.nring, cloud.npoints);
    ASSERT_EQ(cloud.ring.size(), cloud.xyz.size());
    EXPECT_EQ(cloud.nintensity, 0);
    EXPECT_GT(cloud.npoints, 16 * 900 / 2);
    int floor = 0, body = 0;
    double max_floor_error = 0.0, max_nominal_floor_error = 0.0;
    for (int i = 0; i < cloud.npoints; ++i) {
      const int ring = cloud.ring[i];
      ASSERT_GE(ring, 0);
      ASSERT_LT(ring, 16);
      const Eigen::Vector3d p_sensor(cloud.xyz[i][0], cloud.xyz[i][1], cloud.xyz[i][2]);
      // Each point at its ring's elevation.
      const double elevation = -15 * kDeg + ring * 30 * kDeg / 15;
      EXPECT_NEAR(std::atan2(p_sensor.z(), p_sensor.head<2>().norm()), elevation, 1e-5);
      const Eigen::Vector3d p = R * p_sensor + t;
      // Low points within the warehouse's free area (|x| < 10, |y| < 9 around the
      // robot at the origin) are floor; beyond it they may be the foot of a wall.
      if (p.z() < 0.05 && p.head<2>().norm() < 8.5) {
        ++floor;
        max_floor_error = std::max(max_floor_error, std::abs(p.z()));
        max_nominal_floor_error =
            std::max(max_nominal_floor_error, std::abs((R_nominal * p_sensor + t_nominal).z()));
      }
      // On the body box's top face.
      if (std::abs(p.z() - 1.6) < 1e-4 && p.x() > -0.6 - 1e-4 && p.x() < 1.9 + 1e-4 &&
          std::abs(p.y()) < 0.6 + 1e-4)
        ++body;
      // Nothing inside the body.
      const bool inside = p.x() > -0.6 + 1e-3 && p.x() < 1.9 - 1e-3 && std::abs(p.y()) < 0.6 - 1e-3 &&
                          p.z() > 1e-3 && p.z() < 1.6 - 1e-3;
      EXPECT_FALSE(inside) << p.transpose();
    }
    EXPECT_GT(floor, 1000);
    EXPECT_GT(body, 100);
    EXPECT_LT(max_floor_error, 1e-4);
    EXPECT_GT(max_nominal_floor_error, 0.05);  // the nominal mount would not fit
  }
}

// ---------------------------------------------------------------------------
// 9. Config errors

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(SimulatorTest, ConfigErrorsNameLineAndProblem) {
  const std::string typo = ErrorOf([] {
    Parse("robot: ../robots/diff_robot.yaml\n"
          "effects:\n"
          "  time_ofset: {offset_s: 0.02}\n");
  });
  EXPECT_NE(typo.find("line 3"), std::string::npos) << typo;
  EXPECT_NE(typo.find("did you mean time_offset"), std::string::npos) << typo;

  const std::string steering = ErrorOf([] {
    Parse("robot: ../robots/diff_robot.yaml\n"
          "effects: {steering_lag: {tau_s: 0.1}}\n");
  });
  EXPECT_NE(steering.find("line 2"), std::string::npos) << steering;
  EXPECT_NE(steering.find("no steering"), std::string::npos) << steering;

  // A bad world is reported while reading the config, at the world key.
  for (const char* world : {"/nonexistent/room.world", "warehous", "missing.world"}) {
    const std::string at_parse = ErrorOf(
        [&] { Parse(std::string("robot: ../robots/diff_robot.yaml\nworld: ") + world + "\n"); });
    EXPECT_NE(at_parse.find("line 2"), std::string::npos) << at_parse;
    EXPECT_NE(at_parse.find("world"), std::string::npos) << at_parse;
  }

  const std::string wheel = ErrorOf([] {
    Parse("robot: ../robots/forklift.yaml\n"
          "effects: {wheel_eccentricity: {amplitude: 0.01, wheel: left}}\n");
  });
  EXPECT_NE(wheel.find("no wheel role 'left'"), std::string::npos) << wheel;

  // Steering effects share one wheel selection: conflicting ones are an error.
  const std::string conflict = ErrorOf([] {
    Parse("robot: ../robots/dual_steer_agv.yaml\n"
          "effects:\n"
          "  steering_lag: {tau_s: 0.1, wheel: a1}\n"
          "  steering_backlash: {width_rad: 0.01}\n");
  });
  EXPECT_NE(conflict.find("line "), std::string::npos) << conflict;
  EXPECT_NE(conflict.find("wheel"), std::string::npos) << conflict;

  const std::string dropout = ErrorOf([] {
    Parse("robot: ../robots/diff_robot.yaml\nsensors: {lidar2d: {dropout: 1.5}}\n");
  });
  EXPECT_NE(dropout.find("dropout"), std::string::npos) << dropout;

  const std::string beams = ErrorOf([] {
    Parse("robot: ../robots/diff_robot.yaml\nsensors: {lidar2d: {beams: 0.5}}\n");
  });
  EXPECT_NE(beams.find("whole number"), std::string::npos) << beams;

  // Found by the fuzzer: a seed beyond uint64 was converted with undefined behaviour.
  const std::string seed = ErrorOf([] { Parse("robot: ../robots/diff_robot.yaml\nseed: 2.2e46\n"); });
  EXPECT_NE(seed.find("a seed is a whole number from 0 to 2^53"), std::string::npos) << seed;

  const std::string rate = ErrorOf([] {
    Parse("robot: ../robots/diff_robot.yaml\nsensors: {imu: {rate: 2000}}\n");
  });
  EXPECT_NE(rate.find("physics rate"), std::string::npos) << rate;

  const std::string spread = ErrorOf([] {
    Parse("robot: ../robots/diff_robot.yaml\nsensors: {lidar2d: {rate: 20}}\n"
          "effects: {scan_distortion: {scan_period_s: 0.1}}\n");
  });
  EXPECT_NE(spread.find("time between scans"), std::string::npos) << spread;
}

TEST(SimulatorTest, RegionCommandsAndPhysicsStepErrors) {
  const std::string bad = ErrorOf([] {
    Parse("robot: ../robots/diff_robot.yaml\n"
          "effects: {lateral_slip: {gain: 0.1, region: [3, 0, 1, 2]}}\n");
  });
  EXPECT_NE(bad.find("x0 < x1"), std::string::npos) << bad;
  const std::string between = ErrorOf([] { Parse("robot: ../robots/diff_robot.yaml\ncommands: {between: ramps}\n"); });
  EXPECT_NE(between.find("hold, ramp or continuous"), std::string::npos) << between;
  const std::string step = ErrorOf([] {
    Parse("robot: ../robots/diff_robot.yaml\nphysics_step: 0.01\nsensors: {wheels: {rate: 200}}\n");
  });
  EXPECT_NE(step.find("physics rate"), std::string::npos) << step;
}

TEST(SimulatorTest, RelativeWorldFileResolvesAgainstTheConfigDirectory) {
  const std::filesystem::path world = RoomWorld();
  const SimConfig config = ParseSimConfig(std::string("robot: ") + AGVCAL_SOURCE_DIR +
                                              "/config/robots/diff_robot.yaml\n"
                                              "world: " + world.filename().string() + "\n",
                                          "inline.yaml", world.parent_path().string());
  Simulator sim(config);  // finds the room, not a file in the working directory
  MemorySink sink;
  sim.AdvanceTo(kStart + Us(0.06), &sink);
  const auto scans = Messages<agvcal::laser_scan_t>(sink, kScanChannel);
  ASSERT_FALSE(scans.empty());
  // Beam 360 looks along +x from the lidar at (0.2, 0): the wall at x = 5.
  EXPECT_NEAR(scans[0].ranges[360], 4.8, 0.05);
}

}  // namespace
}  // namespace calib

namespace calib {
namespace {

// Each wheel sample's count step less the mean of its neighbours, RMS in ticks, over a wheel
// moving steadily (the unevenness of the counts).
double CountUnevenness(const MemorySink& sink, int ticks_per_rev) {
  std::vector<double> ticks;
  for (const auto& m : Messages<agvcal::wheel_state_t>(sink, kWheelsChannel))
    ticks.push_back(m.position[0] / (2 * M_PI / ticks_per_rev));
  double ss = 0;
  int count = 0;
  for (std::size_t i = 1; i + 2 < ticks.size(); ++i) {
    const double before = ticks[i] - ticks[i - 1], step = ticks[i + 1] - ticks[i], after = ticks[i + 2] - ticks[i + 1];
    if (before * after <= 0 || std::abs(before) + std::abs(after) < 4) continue;
    ss += std::pow(step - 0.5 * (before + after), 2), ++count;
  }
  EXPECT_GT(count, 100);
  return std::sqrt(ss / std::max(count, 1));
}

// wheels.count_jitter: counts read off their stamps step unevenly (a plain quantiser's steps
// differ from their neighbours' mean by well under a tick); 0 changes nothing.
TEST(SimulatorTest, CountJitterMakesTheCountsStepUnevenly) {
  OfflineRunOptions options;
  options.trajectory = "demo";
  const std::string base = "robot: ../robots/forklift.yaml\nsensors:\n  wheels: {rate: 20, ticks_per_rev: 1600";
  MemorySink plain, uneven;
  RunOffline(Parse(base + "}\n"), options, &plain);
  RunOffline(Parse(base + ", count_jitter: 0.3}\n"), options, &uneven);
  EXPECT_LT(CountUnevenness(plain, 1600), 0.75);
  EXPECT_GT(CountUnevenness(uneven, 1600), 3.0);
  EXPECT_THROW(Parse(base + ", count_jitter: 0.6}\n"), InputError);
}

// commands.between continuous: the controller follows the commander's setpoint every physics
// step, so between two DRIVE_CMD messages the wheel's setpoint moves (held, it would not); the
// messages keep their rate.
TEST(SimulatorTest, ContinuousSetpointIsSampledByTheCommands) {
  OfflineRunOptions options;
  options.trajectory = "demo";
  const std::string base = "robot: ../robots/diff_robot.yaml\ncommands: {rate: 10, between: ";
  MemorySink held, continuous;
  RunOffline(Parse(base + "hold}\n"), options, &held);
  RunOffline(Parse(base + "continuous}\n"), options, &continuous);
  EXPECT_EQ(Parse(base + "continuous}\n").command_between, CommandsBetween::kContinuous);
  EXPECT_THROW(Parse(base + "smooth}\n"), InputError);
  const auto held_cmds = Messages<agvcal::drive_command_t>(held, kDriveCmdChannel);
  const auto cont_cmds = Messages<agvcal::drive_command_t>(continuous, kDriveCmdChannel);
  EXPECT_NEAR(double(cont_cmds.size()), double(held_cmds.size()), 0.01 * held_cmds.size());
  // Wheel speeds (no lag, no noise: the setpoint itself) that differ within one command period
  // while the commanded speed changes.
  auto changes_between_commands = [](const MemorySink& sink) {
    const auto wheels = Messages<agvcal::wheel_state_t>(sink, kWheelsChannel);
    const auto cmds = Messages<agvcal::drive_command_t>(sink, kDriveCmdChannel);
    int changes = 0;
    std::size_t c = 0;
    for (std::size_t i = 1; i < wheels.size(); ++i) {
      // A sample shows the last command stamped before it.
      while (c < cmds.size() && cmds[c].utime < wheels[i - 1].utime) ++c;
      const bool same_command = c >= cmds.size() || cmds[c].utime >= wheels[i].utime;
      if (same_command && std::abs(wheels[i].velocity[0] - wheels[i - 1].velocity[0]) > 1e-6) ++changes;
    }
    return changes;
  };
  EXPECT_GT(changes_between_commands(continuous), 100);
  EXPECT_LT(changes_between_commands(held), changes_between_commands(continuous) / 10);
}

}  // namespace
}  // namespace calib
