// The solver against the simulator's truth, with an external pose source as
// the sensor (scan matching is tested on its own and end to end in solve tests).

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "calib/calibration.h"
#include "calib/calibration_data.h"
#include "calib/errors.h"
#include "calib/messages.h"
#include "calib/sim_run.h"
#include "calib/simulator.h"

namespace calib {
namespace {

std::string Source(const std::string& relative) {
  return std::string(AGVCAL_SOURCE_DIR) + "/" + relative;
}

// A simulation with a tracked point mounted off the reference point, its nominal mount at 0.
SimConfig PoseSim(const std::string& name, uint64_t seed) {
  SimConfig config = LoadSimConfig(Source("config/sims/" + name + ".yaml"));
  config.seed = seed;
  config.robot.pose = Mount2d{"POSE", 0.0, 0.0, 0.0};
  config.true_pose = Mount2d{"POSE", 0.21, -0.13, 0.035};
  config.pose.rate_hz = 20.0;
  config.pose.noise_xy = 0.0005;
  config.pose.noise_theta = 0.0005;
  config.lidar2d.rate_hz = 0.0;  // not needed here; keeps the run fast
  config.imu.rate_hz = 0.0;
  return config;
}

CalibrationData Collect(const MemorySink& sink, const RobotDescription& robot) {
  CalibrationData data(robot);
  for (const LogEvent& e : sink.events) {
    if (e.channel == kWheelsChannel) {
      agvcal::wheel_state_t m;
      EXPECT_TRUE(Decode(e.data.data(), int(e.data.size()), &m));
      data.AddWheels(m, "sim");
    } else if (e.channel == kPoseChannel) {
      agvcal::pose2d_t m;
      EXPECT_TRUE(Decode(e.data.data(), int(e.data.size()), &m));
      data.AddPose(m);
    }
  }
  return data;
}

struct Case {
  std::string sim;
  std::string trajectory;
};

class PoseCalibration : public ::testing::TestWithParam<Case> {};

TEST_P(PoseCalibration, RecoversTruthWithHonestSigmas) {
  const Case c = GetParam();
  const SimConfig config = PoseSim(c.sim, 7);
  MemorySink sink;
  OfflineRunOptions run;
  run.trajectory = c.trajectory;
  RunOffline(config, run, &sink);
  const CalibrationData data = Collect(sink, config.robot);
  const CalibrationResult r = Calibrate(config.robot, data.wheels(), data.motions(),
                                        MotionSource::kPose, CalibrationOptions{}, "sim");
  for (const auto& [name, e] : r.params) {
    const double truth = config.true_params.at(name);
    const bool angle = name.find("offset") != std::string::npos;
    // Radii 0.05 %, lengths 0.1 %, steering offsets 0.05 deg (issue 3 targets).
    const double tol = angle ? 0.05 * M_PI / 180 : (name.find("radius") != std::string::npos ? 5e-4 : 1e-3) * std::abs(truth);
    EXPECT_NEAR(e.value, truth, tol) << name << " nominal " << e.nominal << " std " << e.std;
    EXPECT_LT(std::abs(e.value - truth), 4.0 * e.std + 1e-12) << name << " sigma not honest";
  }
  EXPECT_NEAR(r.mount_x.value, 0.21, 0.003);
  EXPECT_NEAR(r.mount_y.value, -0.13, 0.003);
  EXPECT_NEAR(r.mount_yaw.value, 0.035, 0.05 * M_PI / 180);
  EXPECT_LT(r.residual.outliers, r.residual.intervals / 50);
}

INSTANTIATE_TEST_SUITE_P(DriveTypes, PoseCalibration,
                         ::testing::Values(Case{"diff_robot", "default"}, Case{"forklift", "default"}),
                         [](const auto& info) { return info.param.sim; });

TEST(Calibration, StraightOnlyIsRefusedNamingTheParameters) {
  const SimConfig config = PoseSim("forklift", 3);
  MemorySink sink;
  OfflineRunOptions run;
  run.trajectory = "straight";
  RunOffline(config, run, &sink);
  const CalibrationData data = Collect(sink, config.robot);
  try {
    Calibrate(config.robot, data.wheels(), data.motions(), MotionSource::kPose, CalibrationOptions{}, "sim");
    FAIL() << "a straight-only recording must be refused";
  } catch (const UnobservableError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("wheelbase"), std::string::npos) << what;
    EXPECT_NE(e.remedy().find("steering angles"), std::string::npos) << e.remedy();
  }
}

}  // namespace
}  // namespace calib
