// The plausible size of each diagnosis candidate comes from the recording and the robot file
// (diagnose/diagnose_plausible.h), not from fixed sizes: on a simulated pose-source tricycle the
// time offset's is the range searched (up to 2 s), the slip's the reciprocal of the recording's
// hard rim accelerations, the steering play's the steering travel the recording shows. Before,
// they were 0.05 s, 0.1 s^2/m and 0.05 rad whatever the recording.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/diagnose/diagnose.h"
#include "calib/sim/simulator.h"
#include "diagnose/diagnose_candidates.h"
#include "diagnose/diagnose_fit.h"
#include "sim_log.h"

namespace calib::diag {
namespace {

using test_support::SimLog;
using test_support::Source;

// The forklift (a tricycle) with a pose source instead of its lidar: read without scan matching.
SimConfig PoseForklift() {
  SimConfig config = LoadSimConfig(Source("config/sims/forklift.yaml"));
  config.robot.pose = Mount2d{"POSE", 0.0, 0.0, 0.0};
  config.true_pose = Mount2d{"POSE", 0.3, -0.1, 0.0};
  config.pose.rate_hz = 20.0;
  config.pose.noise_xy = 0.001;
  config.pose.noise_theta = 0.001;
  config.lidar2d.rate_hz = 0.0;
  config.imu.rate_hz = 0.0;
  return config;
}

const Candidate& Named(const std::vector<Candidate>& cands, const std::string& name) {
  const auto it = std::find_if(cands.begin(), cands.end(), [&](const Candidate& c) { return c.name == name; });
  EXPECT_NE(it, cands.end()) << name;
  return *it;
}

TEST(DiagnosePlausible, SizesComeFromTheRecording) {
  const SimConfig config = PoseForklift();
  const SimLog log(config);
  const DiagnoseData data = ReadDiagnoseData(config.robot, log.path(), nullptr);
  ASSERT_EQ(data.source, MotionSource::kPose);
  const std::vector<Candidate> cands = Candidates(config.robot, data, kWidestTimeOffsetS);

  // The offset: anything within the range searched.
  EXPECT_EQ(Named(cands, "time_offset").plausible, kWidestTimeOffsetS);

  // The slip: between the reciprocals of the largest and the median rim acceleration.
  const Track tr = MakeTrack(config.robot, data.wheels);
  const double r = config.robot.params.at("drive_radius");
  const std::size_t k = std::size_t(tr.speed_window.k);
  std::vector<double> accel;
  for (std::size_t i = k; i + k < tr.size(); ++i)
    accel.push_back(std::abs(r * (tr.speed[i + k][0] - tr.speed[i - k][0]) / ((tr.utime(i + k) - tr.utime(i - k)) * 1e-6)));
  std::sort(accel.begin(), accel.end());
  const double slip = Named(cands, "longitudinal_slip").plausible;
  EXPECT_GT(slip, 1.0 / accel.back());
  EXPECT_LT(slip, 1.0 / accel[accel.size() / 2]);

  // The steering play and travel offset: the steering travel of the recording.
  double lo = INFINITY, hi = -INFINITY;
  for (std::size_t i = 0; i < tr.size(); ++i) lo = std::min(lo, tr.steer(i, 0)), hi = std::max(hi, tr.steer(i, 0));
  EXPECT_GT(hi - lo, 0.1);
  EXPECT_DOUBLE_EQ(Named(cands, "steering_backlash").plausible, hi - lo);
  EXPECT_DOUBLE_EQ(Named(cands, "travel_direction_offset").plausible, hi - lo);

  // The lateral skid: at most the forward speed at the recording's fast turns (finite, and above
  // the reciprocal of its fastest turn).
  const double lateral = Named(cands, "lateral_slip").plausible;
  double fastest = 0;
  for (const SensorMotion& m : data.motions)
    fastest = std::max(fastest, std::abs(m.delta.theta) / ((m.utime_end - m.utime_start) * 1e-6));
  EXPECT_TRUE(std::isfinite(lateral));
  EXPECT_GE(lateral, 1.0 / fastest);
}

}  // namespace
}  // namespace calib::diag
