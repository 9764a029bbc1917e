// The 3D-lidar ground calibration (calib/ground/ground.h, ground_session.h,
// cloud_file.h): simulated clouds with known mounts over 20 seeds (16 and 128
// rings, 2 cm range noise, obstacles and the robot's body in view), the grid
// search, a lidar turning on its mount, refusals, KITTI frames, file readers
// and bad input. Tolerances are stated at each check.
#include "calib/ground/ground.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "agvcal/mount_angle_t.hpp"
#include "agvcal/point_cloud_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/ground/ground_session.h"
#include "calib/io/cloud_file.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "calib/sim/simulator.h"

namespace calib {
namespace {

constexpr double kDeg = M_PI / 180.0;
const std::string kSource = AGVCAL_SOURCE_DIR;
const std::string kSimDir = kSource + "/config/sims";
const std::string kKitti = kSource + "/../shared/data/kitti-velodyne-frames";

std::string TempPath(const std::string& name) { return testing::TempDir() + "/ground_test_" + name; }

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// A 40 m x 40 m hall with low pallets (0.15-0.3 m) and pillars 5-12 m around
// the origin: obstacles near the floor in every direction.
std::string ObstacleWorld() {
  const std::string path = TempPath("obstacles.world");
  WriteText(path,
            "wall -20 -20 20 -20 6\nwall 20 -20 20 20 6\nwall 20 20 -20 20 6\nwall -20 20 -20 -20 6\n"
            "box 6 -1 7.2 0.2 0.15\nbox -8 3 -6.8 4.2 0.3\nbox 2 7 3.2 8 0.2\nbox -3 -9 -1.8 -8 0.25\n"
            "box 9 5 10.2 6.2 0.15\nbox -11 -6 -9.8 -4.8 0.2\npillar 5 9 0.3\npillar -7 -7 0.3\n"
            "pillar 11 -4 0.35\n");
  return path;
}

struct Truth {
  double z, pitch, roll;
};

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}


// Simulated clouds (xyz interleaved) and every message, for `config` held still.
struct SimRun {
  std::vector<std::vector<float>> clouds;
  MemorySink sink;
};

// Runs `session` over the simulator's messages through a recording, as `agvcal ground` does.
void Replay(const MemorySink& sink, GroundSession* session) {
  const std::string path = TempPath("session.log");
  {
    LogWriter writer(path);
    for (const LogEvent& e : sink.events) writer.Publish(e.channel, e.timestamp, e.data);
    writer.Close();
  }
  RecordingSource source(path);
  session->Subscribe(&source);
  source.HandleAll();
}

SimRun Simulate(const SimConfig& config, double seconds) {
  SimRun run;
  Simulator sim(config);
  sim.AdvanceTo(config.start_utime + std::llround(seconds * 1e6), &run.sink);
  for (const LogEvent& e : run.sink.events) {
    if (e.channel != kCloudChannel) continue;
    agvcal::point_cloud_t cloud;
    EXPECT_TRUE(Decode(e.data.data(), static_cast<int>(e.data.size()), &cloud));
    std::vector<float> xyz;
    xyz.reserve(3 * cloud.xyz.size());
    for (const auto& p : cloud.xyz) xyz.insert(xyz.end(), {p[0], p[1], p[2]});
    run.clouds.push_back(std::move(xyz));
  }
  return run;
}

// The forklift (nominal z 1.90, pitch 0, roll 0; body box in its robot file)
// with a true mount drawn from `seed`, standing at a random pose in the
// obstacle world; `rings` 16 (+-15 deg) or 128 (+-22.5 deg).
SimConfig SeededConfig(int seed, int rings, Truth* truth) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  truth->z = 1.90 + 0.03 * u(rng);
  truth->pitch = 2.0 * kDeg * u(rng);
  truth->roll = 1.0 * kDeg * u(rng);
  const double x = 2.0 * u(rng), y = 2.0 * u(rng), theta = M_PI * u(rng);
  char yaml[1024];
  std::snprintf(yaml, sizeof yaml, R"(
robot: ../robots/forklift.yaml
seed: %d
world: %s
start: {x: %.4f, y: %.4f, theta: %.4f}
truth:
  lidar3d: {z: %.6f, pitch: %.6f, roll: %.6f, x: 0.05, y: -0.02, yaw: 0.01}
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 0}
  lidar3d: {rate: 10, rings: %d, elevation_min: %.4f, elevation_max: %.4f, points_per_ring: %d,
            range_noise: 0.02, body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]}}
)",
                seed, ObstacleWorld().c_str(), x, y, theta, truth->z, truth->pitch, truth->roll, rings,
                rings == 16 ? -15 * kDeg : -22.5 * kDeg, rings == 16 ? 15 * kDeg : 22.5 * kDeg,
                rings == 16 ? 1800 : 900);
  return ParseSimConfig(yaml, "seeded.yaml", kSimDir);
}

// ---------------------------------------------------------------------------
// 1. Convention

TEST(GroundTest, FloorNormalIsTheThirdRowOfTheSimulatorsMountRotation) {
  for (double pitch : {-0.3, 0.0, 0.035, 0.2})
    for (double roll : {-0.25, -0.012, 0.0, 0.1}) {
      const Eigen::Matrix3d r = (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                    .toRotationMatrix();
      EXPECT_LT((r.row(2).transpose() - FloorNormal(pitch, roll)).norm(), 1e-12);
      double p, q;
      PitchRollOf(3.0 * FloorNormal(pitch, roll), &p, &q);  // any length
      EXPECT_NEAR(p, pitch, 1e-12);
      EXPECT_NEAR(q, roll, 1e-12);
    }
}

// ---------------------------------------------------------------------------
// 2. Simulated clouds over 20 seeds: the targets (z within 5 mm, pitch and
// roll within 0.05 deg) and honest sigmas: the errors divided by their sigma
// have an RMS near 1 (60 values: [0.6, 1.5] holds with margin for a correct
// sigma; a sigma off by 2x either way fails) and none beyond 4.5.

void RunSeeds(int rings, double seconds) {
  std::vector<double> normalized;
  double worst_z = 0, worst_pitch = 0, worst_roll = 0, worst_grid = 0;
  for (int seed = 1; seed <= 20; ++seed) {
    Truth truth;
    const SimConfig config = SeededConfig(seed, rings, &truth);
    const SimRun run = Simulate(config, seconds);
    ASSERT_GE(run.clouds.size(), 2u);
    GroundCalibrator calibrator(*config.robot.lidar3d, GroundOptions{});
    for (const auto& cloud : run.clouds) {
      const FrameFit& fit = calibrator.AddFrame(cloud.data(), cloud.size() / 3);
      EXPECT_TRUE(fit.usable) << "seed " << seed << ": " << fit.problem;
      EXPECT_GT(fit.body_points, 100) << "the body is in view";
      EXPECT_GT(fit.near_obstacles, 0) << "obstacles are in view";
    }
    const GroundResult result = calibrator.Result(true /* grid */);
    const MountEstimate& e = result.lidar3d;
    EXPECT_EQ(e.frames, static_cast<int>(run.clouds.size()));
    const double dz = e.value.z - truth.z, dp = e.value.pitch - truth.pitch, dr = e.value.roll - truth.roll;
    EXPECT_LT(std::abs(dz), 0.005) << "seed " << seed;
    EXPECT_LT(std::abs(dp), 0.05 * kDeg) << "seed " << seed;
    EXPECT_LT(std::abs(dr), 0.05 * kDeg) << "seed " << seed;
    worst_z = std::max(worst_z, std::abs(dz));
    worst_pitch = std::max(worst_pitch, std::abs(dp));
    worst_roll = std::max(worst_roll, std::abs(dr));
    normalized.insert(normalized.end(), {dz / e.std.z, dp / e.std.pitch, dr / e.std.roll});
    // The grid search is accepted with the default 1 cm tolerance and agrees
    // with the fit within its resolution: 1.5 final steps per axis (plus the
    // fit's 4 sigma), as on a coarse grid a step in pitch trades against z.
    ASSERT_TRUE(result.grid.has_value());
    const GridEstimate& g = *result.grid;
    EXPECT_TRUE(g.accepted) << "seed " << seed << ": height error " << g.height_error_m;
    EXPECT_LE(std::abs(g.pose.z - e.value.z), 1.5 * g.step.z + 4 * e.std.z) << "seed " << seed;
    EXPECT_LE(std::abs(g.pose.pitch - e.value.pitch), 1.5 * g.step.pitch + 4 * e.std.pitch) << "seed " << seed;
    EXPECT_LE(std::abs(g.pose.roll - e.value.roll), 1.5 * g.step.roll + 4 * e.std.roll) << "seed " << seed;
    worst_grid = std::max({worst_grid, std::abs(g.pose.z - e.value.z) / g.step.z,
                           std::abs(g.pose.pitch - e.value.pitch) / g.step.pitch,
                           std::abs(g.pose.roll - e.value.roll) / g.step.roll});
  }
  double sum2 = 0, worst = 0;
  for (double v : normalized) sum2 += v * v, worst = std::max(worst, std::abs(v));
  const double rms = std::sqrt(sum2 / normalized.size());
  std::printf("%d rings, 20 seeds: worst |error| z %.3f mm, pitch %.5f deg, roll %.5f deg; "
              "error/sigma RMS %.2f, max %.2f; grid - fit at most %.2f final steps\n",
              rings, 1000 * worst_z, worst_pitch / kDeg, worst_roll / kDeg, rms, worst, worst_grid);
  EXPECT_GT(rms, 0.6);
  EXPECT_LT(rms, 1.5);
  EXPECT_LT(worst, 4.5);
}

TEST(GroundTest, TwentySeeds16RingsMeetTheTargetsWithHonestSigmas) { RunSeeds(16, 0.45); }
TEST(GroundTest, TwentySeeds128RingsMeetTheTargetsWithHonestSigmas) { RunSeeds(128, 0.25); }

// ---------------------------------------------------------------------------
// 3. Refusals

// Clouds of planes: `frames` frames of points on the floor seen from a sensor
// at (z, pitch, roll), a 30 m x 30 m patch, 1 cm noise along the normal.
std::vector<float> PlaneCloud(const Truth& t, int points, uint64_t seed, double noise = 0.01) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-15.0, 15.0);
  std::normal_distribution<double> normal(0.0, noise);
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(t.pitch, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(t.roll, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  std::vector<float> xyz;
  while (static_cast<int>(xyz.size() / 3) < points) {
    const Eigen::Vector3d floor(u(rng), u(rng), normal(rng));
    if (floor.head<2>().norm() < 3.0) continue;  // under and next to the robot: not seen
    const Eigen::Vector3d p = r.transpose() * (floor - Eigen::Vector3d(0, 0, t.z));
    xyz.insert(xyz.end(), {float(p.x()), float(p.y()), float(p.z())});
  }
  return xyz;
}

Mount3d NominalMount() {
  Mount3d m;
  m.z = 1.9;
  return m;
}

std::string Refusal(const std::function<void()>& f) {
  try {
    f();
  } catch (const UnobservableError& e) {
    return e.what();
  }
  return "(no refusal)";
}

TEST(GroundTest, RefusesWhenTheRobotStandsAmongObstacles) {
  // Tall crates close around the robot: the lidar's lowest ring (-15 deg from
  // 1.9 m, floor at 7 m) sees only their sides.
  const std::string world = TempPath("crowded.world");
  WriteText(world,
            "box 2.5 -4 3.5 4 2.5\nbox -4 -4 -3 4 2.5\nbox -3 3 2.5 4 2.5\nbox -3 -4 2.5 -3 2.5\n");
  const SimConfig config = ParseSimConfig(R"(
robot: ../robots/forklift.yaml
world: )" + world + R"(
sensors:
  lidar2d: {rate: 0}
  imu: {rate: 0}
  lidar3d: {rate: 10, rings: 16, points_per_ring: 900, body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]}}
)", "crowded.yaml", kSimDir);
  const SimRun run = Simulate(config, 0.35);
  GroundCalibrator calibrator(*config.robot.lidar3d, GroundOptions{});
  for (const auto& cloud : run.clouds) {
    const FrameFit& fit = calibrator.AddFrame(cloud.data(), cloud.size() / 3);
    EXPECT_FALSE(fit.usable);
    EXPECT_NE(fit.problem.find("too few"), std::string::npos) << fit.problem;
  }
  const std::string why = Refusal([&] { calibrator.Result(false); });
  EXPECT_NE(why.find("floor is not visible enough"), std::string::npos) << why;
  EXPECT_NE(why.find("none of " + std::to_string(run.clouds.size()) + " frames"), std::string::npos)
      << why;
  EXPECT_NE(why.find("not among obstacles"), std::string::npos) << why;  // the remedy
}

TEST(GroundTest, RefusesAFloorThatTiltsBetweenFrames) {
  // The robot drives onto a 1 deg ramp: 6 level frames, then 4 tilted ones.
  GroundCalibrator calibrator(NominalMount(), GroundOptions{});
  for (int k = 0; k < 10; ++k) {
    const Truth t{1.9, k < 6 ? 0.0 : 1.0 * kDeg, 0.0};
    const auto cloud = PlaneCloud(t, 5000, k);
    EXPECT_TRUE(calibrator.AddFrame(cloud.data(), cloud.size() / 3).usable);
  }
  const std::string why = Refusal([&] { calibrator.Result(false); });
  EXPECT_NE(why.find("not one level plane across frames"), std::string::npos) << why;
  EXPECT_NE(why.find("4 of 10 frames"), std::string::npos) << why;
  EXPECT_NE(why.find("slope"), std::string::npos) << why;

  // One bump among 20 frames (5 %, under the 10 % allowed) is left out instead.
  GroundCalibrator bumpy(NominalMount(), GroundOptions{});
  for (int k = 0; k < 20; ++k) {
    const Truth t{1.9, k == 7 ? 0.8 * kDeg : 0.3 * kDeg, -0.2 * kDeg};
    const auto cloud = PlaneCloud(t, 5000, 100 + k);
    bumpy.AddFrame(cloud.data(), cloud.size() / 3);
  }
  const MountEstimate e = bumpy.Estimate();
  EXPECT_EQ(e.frames, 19);
  EXPECT_EQ(e.frames_tilted, 1);
  // 19 x 5000 points with 1 cm noise: sigmas ~0.1 mm, 0.001 deg; 5 sigma.
  EXPECT_NEAR(e.value.z, 1.9, 5 * e.std.z);
  EXPECT_NEAR(e.value.pitch, 0.3 * kDeg, 5 * e.std.pitch);
  EXPECT_NEAR(e.value.roll, -0.2 * kDeg, 5 * e.std.roll);
}

TEST(GroundTest, RefusesAPlatformWithMoreFloorBelowIt) {
  // A large platform 0.25 m above the floor (within the 0.4 m window) holds
  // most points; the floor around it lies below: the plane is not the floor.
  std::vector<float> xyz = PlaneCloud({1.65, 0.0, 0.0}, 6000, 1, 0.005);
  const std::vector<float> floor = PlaneCloud({1.90, 0.0, 0.0}, 2000, 2, 0.005);
  xyz.insert(xyz.end(), floor.begin(), floor.end());
  const FrameFit fit = FitFloor(xyz.data(), xyz.size() / 3, NominalMount(), FloorFitOptions{});
  EXPECT_FALSE(fit.usable);
  EXPECT_NE(fit.problem.find("below the plane"), std::string::npos) << fit.problem;
  EXPECT_NEAR(fit.below_share, 2000.0 / 6000.0, 0.05);
}

TEST(GroundTest, RefusesACloudWithoutFloor) {
  // Only walls (vertical planes around the sensor).
  std::vector<float> xyz;
  for (int i = 0; i < 4000; ++i) {
    const double a = 2 * M_PI * i / 4000, h = -1.5 + 3.0 * ((i * 37) % 100) / 100.0;
    xyz.insert(xyz.end(), {float(8 * std::cos(a)), float(8 * std::sin(a)), float(h)});
  }
  GroundCalibrator calibrator(NominalMount(), GroundOptions{});
  EXPECT_FALSE(calibrator.AddFrame(xyz.data(), xyz.size() / 3).usable);
  const std::string why = Refusal([&] { calibrator.Result(true); });
  EXPECT_NE(why.find("not visible enough"), std::string::npos) << why;
}

// ---------------------------------------------------------------------------
// 4. The grid search

TEST(GroundTest, GridSearchFindsThePlaneWithinItsFinalStep) {
  const Truth t{1.934, 2.3 * kDeg, -0.7 * kDeg};
  const auto xyz = PlaneCloud(t, 20000, 3, 0.003);
  GridSearchOptions options;
  options.tolerance_m = 0.004;  // above the 3 mm noise
  const GridEstimate g = GridSearch(xyz.data(), xyz.size() / 3, {1.90, 0.0, 0.0}, options);
  EXPECT_TRUE(g.accepted);
  EXPECT_GE(g.rounds, 2);  // the first round's 0.5 deg steps leave more than 4 mm RMS
  EXPECT_LE(g.height_error_m, 0.004);
  // Within half the final step plus the noise's pull (20000 points: ~0.05 mm, 0.0005 deg).
  EXPECT_LE(std::abs(g.pose.z - t.z), g.step.z / 2 + 2e-4);
  EXPECT_LE(std::abs(g.pose.pitch - t.pitch), g.step.pitch / 2 + 0.002 * kDeg);
  EXPECT_LE(std::abs(g.pose.roll - t.roll), g.step.roll / 2 + 0.002 * kDeg);
  EXPECT_EQ(g.points, 20000);
}

TEST(GroundTest, GridSearchKeepsTheFirstCandidateOnTies) {
  // Every point at the sensor's origin: the height is z for every pitch and
  // roll, so all (pitch, roll) tie and the first (lowest pitch, then lowest
  // roll) is kept; z = 0.01 is the best z on the grid 0 +- 0.05 (step 0.01)
  // for points at height 0.01 ... i.e. the start's own z.
  const std::vector<float> xyz(3 * 50, 0.0f);
  GridSearchOptions options;
  options.max_rounds = 1;
  const GridEstimate g = GridSearch(xyz.data(), 50, {0.0, 0.0, 0.0}, options);
  EXPECT_NEAR(g.pose.z, 0.0, 1e-12);
  EXPECT_NEAR(g.pose.pitch, -options.pitch_range_rad, 1e-12);
  EXPECT_NEAR(g.pose.roll, -options.roll_range_rad, 1e-12);
  EXPECT_EQ(g.candidates_scored, 11 * 21 * 21);
}

TEST(GroundTest, GridSearchRecentresWhenTheBestLiesOnARangesEdge) {
  const Truth t{1.9, 8.0 * kDeg, 0.0};  // outside the first +-5 deg
  const auto xyz = PlaneCloud(t, 5000, 4, 0.002);
  GridSearchOptions options;
  const GridEstimate g = GridSearch(xyz.data(), xyz.size() / 3, {1.9, 0.0, 0.0}, options);
  EXPECT_TRUE(g.accepted);
  EXPECT_LE(std::abs(g.pose.pitch - t.pitch), g.step.pitch / 2 + 0.002 * kDeg);
}

TEST(GroundTest, GridSearchIsNotAcceptedWhenTheToleranceIsBelowTheNoise) {
  const auto xyz = PlaneCloud({1.9, 0.0, 0.0}, 5000, 5, 0.02);
  GridSearchOptions options;
  options.tolerance_m = 0.005;  // 2 cm noise: the RMS height cannot go below ~2 cm
  options.max_rounds = 4;
  const GridEstimate g = GridSearch(xyz.data(), xyz.size() / 3, {1.9, 0.0, 0.0}, options);
  EXPECT_FALSE(g.accepted);
  EXPECT_EQ(g.rounds, 4);
  EXPECT_GT(g.height_error_m, 0.015);
}

// ---------------------------------------------------------------------------
// 5. A lidar turning on its mount: one estimate per 15 deg sector

const char kTurretRobot[] = R"(name: turret-agv
drive: differential
wheels: {left: l, right: r}
params: {left_radius: 0.1, right_radius: 0.1, track: 0.6}
lidar3d: {channel: CLOUD, z: 1.90, body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]},
          rotation: {channel: LIDAR3D_ANGLE, sector_width: 0.2617993877991494}}
)";

// Floor pose of the turret lidar at `angle` (the simulator's model, simulator.h).
Truth TurretTruth(const Mount3d& mount, const Lidar3dSensorConfig& sensor, double angle) {
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(sensor.turret_axis_pitch, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(sensor.turret_axis_roll, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(angle + mount.yaw, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(mount.pitch, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(mount.roll, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  Truth t{mount.z, 0, 0};
  PitchRollOf(r.row(2).transpose(), &t.pitch, &t.roll);
  return t;
}

SimConfig TurretConfig() {
  WriteText(TempPath("turret_robot.yaml"), kTurretRobot);
  return ParseSimConfig("robot: " + TempPath("turret_robot.yaml") + R"(
world: )" + ObstacleWorld() + R"(
truth:
  lidar3d: {z: 1.912, pitch: 0.035, roll: -0.012}
sensors:
  imu: {rate: 0}
  lidar3d: {rate: 10, rings: 16, points_per_ring: 720,
            body: {min: [-0.6, -0.6, 0.0], max: [1.9, 0.6, 1.6]},
            turret: {rate: 40, speed: 0.2618, start: -3.1, axis_pitch: 0.0105, axis_roll: -0.007}}
)", "turret.yaml", kSimDir);
}

TEST(GroundTest, SimulatorTurretPublishesItsAngleAndTurnsTheCloud) {
  SimConfig config = TurretConfig();
  config.lidar3d.range_noise = 0.0;
  const SimRun run = Simulate(config, 2.0);
  std::vector<agvcal::mount_angle_t> angles;
  for (const LogEvent& e : run.sink.events) {
    if (e.channel != "LIDAR3D_ANGLE") continue;
    agvcal::mount_angle_t m;
    ASSERT_TRUE(Decode(e.data.data(), static_cast<int>(e.data.size()), &m));
    EXPECT_EQ(m.utime, e.timestamp);
    // angle = start + speed t, wrapped to (-pi, pi]
    const double t = (m.utime - config.start_utime) * 1e-6;
    EXPECT_NEAR(std::remainder(m.angle - (-3.1 + 0.2618 * t), 2 * M_PI), 0.0, 1e-9);
    angles.push_back(m);
  }
  EXPECT_NEAR(static_cast<double>(angles.size()), 2.0 * 40, 2);  // 40 Hz
  // Each cloud's floor points lie on the floor (to float precision) under the
  // rotation at the angle published with the same stamp.
  size_t k = 0;
  for (const LogEvent& e : run.sink.events) {
    if (e.channel != kCloudChannel) continue;
    agvcal::point_cloud_t cloud;
    ASSERT_TRUE(Decode(e.data.data(), static_cast<int>(e.data.size()), &cloud));
    while (k < angles.size() && angles[k].utime < cloud.utime) ++k;
    ASSERT_LT(k, angles.size());
    ASSERT_EQ(angles[k].utime, cloud.utime);
    const Truth t = TurretTruth(config.true_lidar3d, config.lidar3d, angles[k].angle);
    const Eigen::Vector3d n = FloorNormal(t.pitch, t.roll);
    int on_floor = 0;
    for (const auto& p : cloud.xyz)
      if (std::abs(n.dot(Eigen::Vector3d(p[0], p[1], p[2])) + t.z) < 1e-4) ++on_floor;
    EXPECT_GT(on_floor, 1000);
  }
  // A turret needs the robot file's rotation (the channel of its angle).
  const std::string e = ErrorOf([] {
    ParseSimConfig("robot: ../robots/forklift.yaml\nsensors:\n  lidar3d: {rate: 10, turret: {rate: 10}}\n",
                   "t.yaml", kSimDir);
  });
  EXPECT_NE(e.find("sensors.lidar3d.turret"), std::string::npos) << e;
  EXPECT_NE(e.find("needs lidar3d.rotation in the robot file"), std::string::npos) << e;
}

TEST(GroundTest, TurningLidarGetsOneEstimatePerSector) {
  const SimConfig config = TurretConfig();
  // 15 deg/s: one revolution in 24 s, about 10 clouds per sector.
  const SimRun run = Simulate(config, 24.5);
  GroundSession session(config.robot, GroundOptions{});
  EXPECT_EQ(session.angle_channel(), "LIDAR3D_ANGLE");
  Replay(run.sink, &session);
  const GroundCalibrator& calibrator = session.calibrator();
  ASSERT_EQ(calibrator.num_sectors(), 24);
  const GroundResult result = calibrator.Result(true);
  ASSERT_EQ(result.sectors.size(), 24u);
  double pitch_min = 1, pitch_max = -1, worst_z = 0, worst_angle = 0;
  std::vector<double> normalized;
  for (const SectorEstimate& s : result.sectors) {
    EXPECT_GE(s.estimate.frames, 8) << "sector " << s.index;
    EXPECT_GE(s.angle_mean, s.angle_min - 1e-9);
    EXPECT_LE(s.angle_mean, s.angle_max + 1e-9);
    // Truth at the sector's mean angle: the pose varies within a sector by up
    // to ~0.1 deg (a 0.7 deg axis tilt over +-7.5 deg), nearly linearly, so
    // the sector's estimate matches the truth at its mean angle: 0.05 deg, 5 mm.
    const Truth t = TurretTruth(config.true_lidar3d, config.lidar3d, s.angle_mean);
    EXPECT_NEAR(s.estimate.value.z, t.z, 0.005) << "sector " << s.index;
    EXPECT_NEAR(s.estimate.value.pitch, t.pitch, 0.05 * kDeg) << "sector " << s.index;
    EXPECT_NEAR(s.estimate.value.roll, t.roll, 0.05 * kDeg) << "sector " << s.index;
    worst_z = std::max(worst_z, std::abs(s.estimate.value.z - t.z));
    worst_angle = std::max({worst_angle, std::abs(s.estimate.value.pitch - t.pitch),
                            std::abs(s.estimate.value.roll - t.roll)});
    normalized.insert(normalized.end(), {(s.estimate.value.z - t.z) / s.estimate.std.z,
                                         (s.estimate.value.pitch - t.pitch) / s.estimate.std.pitch,
                                         (s.estimate.value.roll - t.roll) / s.estimate.std.roll});
    pitch_min = std::min(pitch_min, s.estimate.value.pitch);
    pitch_max = std::max(pitch_max, s.estimate.value.pitch);
  }
  double sum2 = 0;
  for (double v : normalized) sum2 += v * v;
  const double rms = std::sqrt(sum2 / normalized.size());
  std::printf("turret, 24 sectors: worst |error| at the sectors' mean angles z %.3f mm, pitch/roll "
              "%.4f deg, error/sigma RMS %.2f; pitch from %.3f to %.3f deg\n",
              1000 * worst_z, worst_angle / kDeg, rms, pitch_min / kDeg, pitch_max / kDeg);
  // Honest sigmas per sector too (72 values; the angle's trend within a sector is modelled).
  EXPECT_GT(rms, 0.6);
  EXPECT_LT(rms, 1.5);
  // The tilted axis shows: the sensor's pitch sweeps +-0.75 deg around the mount's 2 deg.
  EXPECT_GT(pitch_max - pitch_min, 1.2 * kDeg);
  // lidar3d is the sector holding angle 0 (the robot file's mount).
  const int home = calibrator.HomeSector();
  ASSERT_EQ(home, calibrator.SectorOf(0.0));
  EXPECT_LE(result.sectors[home].angle_min, 0.0);
  EXPECT_GT(result.sectors[home].angle_max, 0.0);
  EXPECT_EQ(result.lidar3d.value.pitch, result.sectors[home].estimate.value.pitch);
  EXPECT_EQ(calibrator.SectorOf(-M_PI), 0);
  EXPECT_EQ(calibrator.SectorOf(M_PI - 1e-9), 23);
  EXPECT_EQ(calibrator.SectorOf(M_PI + 0.1), 0);  // wraps: the range is a full turn
  EXPECT_EQ(calibrator.SectorOf(0.2617993877991494 * 1.5 - M_PI), 1);

  // The live message reports the newest cloud's sector and its estimate.
  const GroundEstimate msg = session.CurrentEstimate();
  EXPECT_EQ(msg.status, "ok");
  EXPECT_EQ(msg.num_sectors, 24);
  EXPECT_EQ(msg.sectors_done, 24);
  EXPECT_EQ(msg.sector, calibrator.SectorOf(msg.angle));

  // The human report (ground --report): the floor-point sample lies on the calibrated floor
  // (RMS height within the simulator's range noise), the page has the per-sector table.
  ASSERT_FALSE(result.floor_points.empty());
  EXPECT_LE(result.floor_points.size() / 3, GroundResult::kReportFloorPoints);
  const Eigen::Vector3d n = FloorNormal(result.lidar3d.value.pitch, result.lidar3d.value.roll);
  double h2 = 0;
  for (size_t i = 0; i < result.floor_points.size(); i += 3) {
    const double h = n.x() * result.floor_points[i] + n.y() * result.floor_points[i + 1] +
                     n.z() * result.floor_points[i + 2] + result.lidar3d.value.z;
    h2 += h * h;
  }
  EXPECT_LT(std::sqrt(h2 / (result.floor_points.size() / 3)), 0.02);
  EXPECT_EQ(result.frame_fits.size(), result.frame_angles.size());
  const std::string dir = testing::TempDir() + "ground_test_report";
  WriteGroundReportDir(config.robot, result, GroundInput{"turret.log", "log", 1, 0}, dir);
  std::ifstream in(dir + "/index.html");
  const std::string page((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(page.find("Per sector of the lidar's rotation"), std::string::npos);
  size_t rows = 0;
  for (size_t at = page.find("<tr><td>"); at != std::string::npos; at = page.find("<tr><td>", at + 1)) ++rows;
  EXPECT_EQ(rows, 3u + 24u);  // the mount's z, pitch, roll and one row per sector
  for (const char* f : {"floor_points.svg", "floor_height_histogram.svg", "frames.svg", "summary.txt"})
    EXPECT_TRUE(std::filesystem::exists(dir + "/" + f)) << f;
  std::filesystem::remove_all(dir);
}

TEST(GroundTest, TurningLidarWithSectorsLeftOutIsRefusedNamingThem) {
  const SimConfig config = TurretConfig();
  const SimRun run = Simulate(config, 8.0);  // a third of a turn
  GroundSession session(config.robot, GroundOptions{});
  Replay(run.sink, &session);
  const std::string why = Refusal([&] { session.calibrator().Result(false); });
  EXPECT_NE(why.find("no estimate for sector"), std::string::npos) << why;
  EXPECT_NE(why.find("of 24"), std::string::npos) << why;
  EXPECT_NE(why.find("turn the lidar through every sector"), std::string::npos) << why;
}

TEST(GroundTest, SessionUsesTheNewestAngleAtOrBeforeEachCloud) {
  const RobotDescription robot = ParseRobot(kTurretRobot, "turret.yaml");
  GroundSession session(robot, GroundOptions{});
  const auto cloud_xyz = PlaneCloud({1.9, 0.0, 0.0}, 3000, 6);
  PointCloud cloud{0, cloud_xyz};
  const agvcal::point_cloud_t message = ToMessage(cloud);
  ASSERT_EQ(message.npoints, 3000);
  ASSERT_EQ(message.xyz[2][1], cloud_xyz[7]);
  ASSERT_EQ(CloudFromMessage(message).xyz, cloud_xyz);
  auto angle = [&](int64_t utime, double a) { session.OnMountAngle(MountAngle{utime, a}); };
  cloud.utime = 1000000;
  EXPECT_EQ(session.OnCloud(cloud), nullptr);  // no angle yet: skipped
  angle(1000000, 0.1);
  angle(1300000, 1.0);  // stamped after the next cloud, arrives before it
  cloud.utime = 1100000;
  ASSERT_NE(session.OnCloud(cloud), nullptr);
  EXPECT_EQ(session.CurrentEstimate().sector, session.calibrator().SectorOf(0.1));
  cloud.utime = 1600000;  // the newest angle at or before is 0.3 s old: over max_age 0.2 s
  EXPECT_EQ(session.OnCloud(cloud), nullptr);
  EXPECT_EQ(session.calibrator().frames_seen(), 3);
}

// ---------------------------------------------------------------------------
// 6. KITTI Velodyne frames (../shared/data): the documented mount is 1.73 m
// above the ground. A frame's floor is the road and its surroundings within
// sight (up to ~70 m), which are not one plane: slopes change, the road has
// camber, sidewalks and verges sit higher. So the fitted height is the mount
// height above that best plane, not above the ground under the car. Stated
// tolerances: the raw frame (road all round the car from 4 m) within 5 cm of
// 1.73 m; the five frames' median within 5 cm; every frame within 20 cm (two
// of the cropped object frames look down a road that falls away ahead).

TEST(GroundTest, KittiFramesGiveTheDocumentedMountHeight) {
  const std::vector<std::string> frames{"raw_frame/000000.bin", "object_reduced/000000.bin",
                                        "object_reduced/000001.bin", "object_reduced/000002.bin",
                                        "object_reduced/000003.bin"};
  if (!std::ifstream(kKitti + "/" + frames[0])) GTEST_SKIP() << "no KITTI frames at " << kKitti;
  const RobotDescription robot = LoadRobotFile(kSource + "/config/robots/kitti_hdl64e.yaml");
  std::vector<double> heights;
  for (const std::string& frame : frames) {
    GroundInput input;
    const GroundResult r = CalibrateGroundFile(robot, GroundOptions{}, kKitti + "/" + frame, false, &input);
    EXPECT_EQ(input.kind, "kitti");
    EXPECT_EQ(r.lidar3d.frames, 1);
    std::printf("KITTI %-26s %6zu points: z %.3f m +- %.1f mm, pitch %+.3f deg, roll %+.3f deg, "
                "floor inliers %.0f %%, floor RMS %.1f cm\n",
                frame.c_str(), input.points, r.lidar3d.value.z, 1000 * r.lidar3d.std.z,
                r.lidar3d.value.pitch / kDeg, r.lidar3d.value.roll / kDeg, 100 * r.lidar3d.inliers,
                100 * r.lidar3d.rms_m);
    EXPECT_NEAR(r.lidar3d.value.z, 1.73, 0.20) << frame;
    heights.push_back(r.lidar3d.value.z);
  }
  EXPECT_NEAR(heights[0], 1.73, 0.05);
  std::vector<double> sorted = heights;
  std::sort(sorted.begin(), sorted.end());
  EXPECT_NEAR(sorted[2], 1.73, 0.05);
}

// ---------------------------------------------------------------------------
// 7. Cloud files: readers and bad input

void WriteBytes(const std::string& path, const std::string& header, const void* data, size_t size) {
  std::ofstream out(path, std::ios::binary);
  out << header;
  out.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
}

TEST(GroundTest, KittiBinIsReadAndATruncatedOneNamesTheByte) {
  const float records[3][4] = {{1, 2, 3, 0.5f}, {4, 5, 6, 0.1f}, {NAN, 0, 0, 0}};
  const std::string path = TempPath("frame.bin");
  WriteBytes(path, "", records, sizeof records);
  const CloudFileData data = ReadCloudFile(path);
  EXPECT_EQ(data.format, "kitti");
  EXPECT_EQ(data.xyz, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(data.dropped, 1u);

  WriteBytes(TempPath("cut.bin"), "", records, sizeof records - 5);
  const std::string cut = ErrorOf([] { ReadCloudFile(TempPath("cut.bin")); });
  EXPECT_NE(cut.find("cut.bin"), std::string::npos) << cut;
  EXPECT_NE(cut.find("byte 32"), std::string::npos) << cut;
  EXPECT_NE(cut.find("truncated record"), std::string::npos) << cut;
  WriteBytes(TempPath("empty.bin"), "", records, 0);
  EXPECT_NE(ErrorOf([] { ReadCloudFile(TempPath("empty.bin")); }).find("empty file"), std::string::npos);
  EXPECT_NE(ErrorOf([] { ReadCloudFile(TempPath("missing.bin")); }).find("missing.bin"), std::string::npos);
  EXPECT_NE(ErrorOf([] { ReadCloudFile(TempPath("cloud.ply")); }).find("unknown point cloud format"),
            std::string::npos);
}

const char kPcdHeader[] =
    "# .PCD v0.7 - Point Cloud Data file format\n"
    "VERSION 0.7\n"
    "FIELDS x y z intensity\n"
    "SIZE 4 4 4 4\n"
    "TYPE F F F F\n"
    "COUNT 1 1 1 1\n"
    "WIDTH 3\n"
    "HEIGHT 1\n"
    "VIEWPOINT 0 0 0 1 0 0 0\n"
    "POINTS 3\n";

TEST(GroundTest, PcdAsciiBinaryAndCompressedAreRead) {
  WriteText(TempPath("a.pcd"), std::string(kPcdHeader) + "DATA ascii\n1 2 3 7\n4 5 6 7\nnan nan nan 0\n");
  const CloudFileData ascii = ReadCloudFile(TempPath("a.pcd"));
  EXPECT_EQ(ascii.xyz, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(ascii.dropped, 1u);

  const float rows[3][4] = {{1, 2, 3, 7}, {4, 5, 6, 7}, {7, 8, 9, 7}};
  WriteBytes(TempPath("b.pcd"), std::string(kPcdHeader) + "DATA binary\n", rows, sizeof rows);
  EXPECT_EQ(ReadCloudFile(TempPath("b.pcd")).xyz, (std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8, 9}));

  // binary_compressed: the fields one after another (x x x y y y z z z i i i),
  // LZF: a literal run of 24 bytes (x, y), then z as 12 literal bytes, then
  // "intensity" (7 7 7) as one literal float and a back reference of 8 bytes.
  std::vector<uint8_t> raw;
  auto put = [&](float v) {
    uint8_t b[4];
    std::memcpy(b, &v, 4);
    raw.insert(raw.end(), b, b + 4);
  };
  for (float v : {1.f, 4.f, 7.f, 2.f, 5.f, 8.f, 3.f, 6.f, 9.f, 7.f}) put(v);
  std::vector<uint8_t> lzf;
  lzf.push_back(23);  // literal run of 24 bytes
  lzf.insert(lzf.end(), raw.begin(), raw.begin() + 24);
  lzf.push_back(15);  // literal run of 16 bytes: z and the first intensity
  lzf.insert(lzf.end(), raw.begin() + 24, raw.begin() + 40);
  lzf.push_back((6 << 5) | 0);  // back reference: length 6 + 2 = 8, offset 0 * 256 + 3 + 1 = 4
  lzf.push_back(3);
  const uint32_t sizes[2] = {static_cast<uint32_t>(lzf.size()), 48};
  std::string blob(reinterpret_cast<const char*>(sizes), 8);
  blob.append(reinterpret_cast<const char*>(lzf.data()), lzf.size());
  WriteBytes(TempPath("c.pcd"), std::string(kPcdHeader) + "DATA binary_compressed\n", blob.data(), blob.size());
  EXPECT_EQ(ReadCloudFile(TempPath("c.pcd")).xyz, (std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8, 9}));

  // A viewpoint is undone: the points come back in the sensor frame.
  std::string moved = kPcdHeader;
  moved.replace(moved.find("VIEWPOINT 0 0 0 1 0 0 0"), 23, "VIEWPOINT 10 0 0 0 0 0 1");  // 180 deg about z
  WriteText(TempPath("v.pcd"), moved + "DATA ascii\n11 2 3 0\n10 0 1 0\n10 0 0 0\n");
  const CloudFileData v = ReadCloudFile(TempPath("v.pcd"));
  ASSERT_EQ(v.xyz.size(), 9u);
  EXPECT_NEAR(v.xyz[0], -1, 1e-6);
  EXPECT_NEAR(v.xyz[1], -2, 1e-6);
  EXPECT_NEAR(v.xyz[2], 3, 1e-6);
}

TEST(GroundTest, MalformedPcdNamesTheFileThePlaceAndTheProblem) {
  struct Case {
    std::string text, place, problem;
  };
  const std::string header = kPcdHeader;
  auto without = [&](const std::string& line) {
    std::string h = header;
    h.erase(h.find(line), line.size() + 1);
    return h;
  };
  std::string no_z = header;
  no_z.replace(no_z.find("FIELDS x y z intensity"), 22, "FIELDS x y q intensity");
  std::string bad_size = header;
  bad_size.replace(bad_size.find("SIZE 4 4 4 4"), 12, "SIZE 4 4 3 4");
  // Found by the fuzzer: a huge COUNT sized a row of 12 GB before reading any data.
  std::string huge_count = header;
  huge_count.replace(huge_count.find("COUNT 1 1 1 1"), 13, "COUNT 1 1555555555 1 1");
  const std::vector<Case> cases{
      {header + "DATA ascii\n1 2 3 7\n4 5 x 7\n7 8 9 7\n", "line 13", "expected 4 numbers per point"},
      {header + "DATA ascii\n1 2 3 7\n4 5 6 7 8\n7 8 9 7\n", "line 13", "more than 4 values"},
      {header + "DATA ascii\n1 2 3 7\n", "line 13", "truncated: 1 of 3 points"},
      {header, "line 10", "header ends without a DATA line"},
      {no_z + "DATA ascii\n", "line 11", "FIELDS lacks x, y or z"},
      {bad_size + "DATA ascii\n", "line 4", "SIZE of z must be 1, 2, 4 or 8"},
      {without("TYPE F F F F") + "DATA ascii\n", "line 10", "header lacks TYPE"},
      {huge_count + "DATA ascii\n1 2 3 7\n", "line 11", "more than the whole file"},
      {header + "DATA lzma\n", "line 11", "DATA must be ascii, binary or binary_compressed"},
      {"hello world\n", "line 1", "unknown header line 'hello'"},
      {header + "DATA binary\n" + std::string(20, '\0'), "byte", "truncated: 3 points of 16 bytes need 48"},
      {header + "DATA binary_compressed\n" + std::string("\x05\0\0\0\x30\0\0\0\x1f\x01\x02\x03\x04", 13),
       "byte", "corrupt compressed data"},
  };
  for (size_t k = 0; k < cases.size(); ++k) {
    const std::string path = TempPath("bad" + std::to_string(k) + ".pcd");
    WriteText(path, cases[k].text);
    const std::string what = ErrorOf([&] { ReadCloudFile(path); });
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_NE(what.find(cases[k].place), std::string::npos) << "case " << k << ": " << what;
    EXPECT_NE(what.find(cases[k].problem), std::string::npos) << "case " << k << ": " << what;
  }
}

// ---------------------------------------------------------------------------
// 8. Robot file, options file, recordings, RESULT.json

TEST(GroundTest, RobotFileCarriesTheBodyBoxAndTheRotationAndChecksThem) {
  const RobotDescription robot = ParseRobot(kTurretRobot, "turret.yaml");
  ASSERT_TRUE(robot.lidar3d && robot.lidar3d->body && robot.lidar3d->rotation);
  EXPECT_EQ(robot.lidar3d->body->min, (std::array<double, 3>{-0.6, -0.6, 0.0}));
  EXPECT_EQ(robot.lidar3d->body->max, (std::array<double, 3>{1.9, 0.6, 1.6}));
  EXPECT_EQ(robot.lidar3d->rotation->channel, "LIDAR3D_ANGLE");
  EXPECT_DOUBLE_EQ(robot.lidar3d->rotation->min, -M_PI);
  const RobotDescription forklift = LoadRobotFile(kSource + "/config/robots/forklift.yaml");
  ASSERT_TRUE(forklift.lidar3d && forklift.lidar3d->body);
  EXPECT_FALSE(forklift.lidar3d->rotation);

  auto error_with = [&](const std::string& from, const std::string& to) {
    std::string text = kTurretRobot;
    text.replace(text.find(from), from.size(), to);
    return ErrorOf([&] { ParseRobot(text, "turret.yaml"); });
  };
  std::string e = error_with("max: [1.9, 0.6, 1.6]", "maxx: [1.9, 0.6, 1.6]");
  EXPECT_NE(e.find("lidar3d.body.maxx"), std::string::npos) << e;
  EXPECT_NE(e.find("line 5"), std::string::npos) << e;
  e = error_with("max: [1.9, 0.6, 1.6]", "max: [1.9, -0.6, 1.6]");
  EXPECT_NE(e.find("max must exceed min on every axis (axis y)"), std::string::npos) << e;
  e = error_with("max: [1.9, 0.6, 1.6]", "max: [1.9, 0.6]");
  EXPECT_NE(e.find("expected [x, y, z]"), std::string::npos) << e;
  e = error_with("sector_width: 0.2617993877991494", "sector_width: -0.1");
  EXPECT_NE(e.find("lidar3d.rotation.sector_width"), std::string::npos) << e;
  e = error_with("rotation: {", "rotation: {sectors: 3, ");
  EXPECT_NE(e.find("lidar3d.rotation.sectors"), std::string::npos) << e;
}

TEST(GroundTest, OptionsFileListsTheDefaultsAndRejectsTypos) {
  const GroundOptions file = LoadGroundOptions(kSource + "/config/ground.yaml");
  const GroundOptions defaults;
  EXPECT_DOUBLE_EQ(file.fit.window_m, defaults.fit.window_m);
  EXPECT_NEAR(file.fit.max_tilt_rad, defaults.fit.max_tilt_rad, 1e-6);
  EXPECT_DOUBLE_EQ(file.fit.min_band_m, defaults.fit.min_band_m);
  EXPECT_DOUBLE_EQ(file.fit.obstacle_cell_m, defaults.fit.obstacle_cell_m);
  EXPECT_EQ(file.fit.min_floor_points, defaults.fit.min_floor_points);
  EXPECT_NEAR(file.frames.max_tilt_rad, defaults.frames.max_tilt_rad, 1e-6);
  EXPECT_NEAR(file.grid.pitch_step_rad, defaults.grid.pitch_step_rad, 1e-6);
  EXPECT_NEAR(file.grid.roll_range_rad, defaults.grid.roll_range_rad, 1e-6);
  EXPECT_DOUBLE_EQ(file.grid.tolerance_m, defaults.grid.tolerance_m);
  EXPECT_EQ(file.grid.max_points, defaults.grid.max_points);

  std::string e = ErrorOf([] { ParseGroundOptions("fit:\n  window_m: 0.3\n  max_tilt: 5\n", "g.yaml"); });
  EXPECT_NE(e.find("g.yaml: line 3"), std::string::npos) << e;
  EXPECT_NE(e.find("fit.max_tilt"), std::string::npos) << e;
  EXPECT_NE(e.find("max_tilt_deg"), std::string::npos) << e;  // did you mean
  e = ErrorOf([] { ParseGroundOptions("grid:\n  pitch: {range_deg: 5, step_deg: 0.0001}\n", "g.yaml"); });
  EXPECT_NE(e.find("candidates per round"), std::string::npos) << e;
}

TEST(GroundTest, RecordingWithoutCloudsOrWithACorruptCloudIsBadInput) {
  const RobotDescription robot = LoadRobotFile(kSource + "/config/robots/forklift.yaml");
  const std::string no_clouds = kSource + "/logs/forklift_demo.log";
  std::string e = ErrorOf([&] { CalibrateGroundFile(robot, GroundOptions{}, no_clouds, false, nullptr); });
  EXPECT_NE(e.find("forklift_demo.log"), std::string::npos) << e;
  EXPECT_NE(e.find("no messages on channel CLOUD"), std::string::npos) << e;

  const std::string corrupt = TempPath("corrupt_cloud.log");
  {
    LogWriter writer(corrupt);
    writer.Publish("CLOUD", 1, std::vector<uint8_t>(40, 0xff));
    writer.Close();
  }
  e = ErrorOf([&] { CalibrateGroundFile(robot, GroundOptions{}, corrupt, false, nullptr); });
  EXPECT_NE(e.find("corrupt_cloud.log"), std::string::npos) << e;
  EXPECT_NE(e.find("event 0"), std::string::npos) << e;
  EXPECT_NE(e.find("does not decode as point_cloud_t"), std::string::npos) << e;

  RobotDescription no_lidar = robot;
  no_lidar.lidar3d.reset();
  e = ErrorOf([&] { CalibrateGroundFile(no_lidar, GroundOptions{}, corrupt, false, nullptr); });
  EXPECT_NE(e.find("has no 3D lidar"), std::string::npos) << e;
}

TEST(GroundTest, ResultJsonHoldsTheSpecKeysAndTheGrid) {
  Truth truth;
  const SimConfig config = SeededConfig(3, 16, &truth);
  const SimRun run = Simulate(config, 0.25);
  const std::string log = TempPath("clouds.log");
  {
    LogWriter writer(log);
    for (const LogEvent& e : run.sink.events) writer.Publish(e.channel, e.timestamp, e.data);
    writer.Close();
  }
  GroundInput input;
  const GroundResult result = CalibrateGroundFile(config.robot, GroundOptions{}, log, true, &input);
  EXPECT_EQ(input.kind, "log");
  EXPECT_EQ(input.clouds, static_cast<int>(run.clouds.size()));
  const auto json = nlohmann::json::parse(GroundResultJson(result, input));
  for (const char* key : {"z", "pitch", "roll"}) {
    EXPECT_TRUE(json["lidar3d"][key]["value"].is_number()) << key;
    EXPECT_GT(json["lidar3d"][key]["std"].get<double>(), 0.0) << key;
  }
  EXPECT_NEAR(json["lidar3d"]["z"]["value"].get<double>(), truth.z, 0.005);
  EXPECT_EQ(json["frames"].get<int>(), static_cast<int>(run.clouds.size()));
  EXPECT_GT(json["inliers"].get<double>(), 0.05);
  EXPECT_LT(json["inliers"].get<double>(), 1.0);
  EXPECT_TRUE(json["grid"]["accepted"].get<bool>());
  EXPECT_FALSE(json.contains("sectors"));  // a fixed lidar
  const std::string text = GroundResultText(result, input);
  EXPECT_NE(text.find("grid search (accepted"), std::string::npos) << text;
}

}  // namespace
}  // namespace calib
