#pragma once
// Wheel odometry and gyro fused by a Kalman filter (docs/imu.md), with the
// noise of the calibration (robot file imu: gyro_bias, gyro_scale,
// time_offset, gyro_noise, wheel_noise; params from `agvcal solve --source imu`).
//
// The heading filter's state is [theta, beta, e]: the heading, the gyro's bias
// left after the calibrated one (rad/s), and the wheels' accumulated heading
// error (slip, residual calibration error; rad). Between two wheel samples the
// gyro predicts: theta += (G - gyro_bias dt) / gyro_scale - beta dt, with
// variance gyro_noise^2 dt / gyro_scale^2; beta walks slowly; e walks with the
// wheel travel d (variance wheel_noise^2 d). The wheels' cumulative heading
// (r_R phi_R - r_L phi_L) / track measures theta + e, with the variance of the
// encoder quantisation. At rest the wheels hold still, so beta is learnt.
// Position: the wheels' arc length along the chord of the fused heading change.
//
// Policy for short motions (a motion runs from rest to rest): kFilter uses the
// filter throughout; kAverageShort (the method we support) takes the mean of
// the gyro's and the wheels' heading increments while the motion's wheel travel
// is below `short_motion_m` (one wheel circumference by default) and the
// filter's beyond it. The comparison is in docs/imu.md; kFilter is the default.
//
// Deterministic replay: a wheel sample is processed once the IMU samples cover
// it (stamp >= its utime + time_offset), so the output depends only on the
// order of messages within each channel, live or offline.

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/calibrate/imu_calibration.h"
#include "calib/core/robot.h"
#include "calib/core/se2.h"
#include "calib/core/sensor_data.h"
#include "calib/core/wheel_track.h"

namespace calib {

enum class FusionPolicy { kFilter, kAverageShort };

struct FusedOdometryOptions {
  FusionPolicy policy = FusionPolicy::kFilter;
  double short_motion_m = 0.0;  // kAverageShort threshold; 0 = one wheel circumference
  double bias_walk = 1e-5;      // rad/s/sqrt(s): how fast the gyro bias may drift
  double standstill_s = 0.2;    // no encoder change for this long ends a motion
  double max_imu_wait_s = 0.5;  // wheels this far ahead of the IMU are processed without gyro
};

struct FusedPose {
  int64_t utime = 0;
  Pose2 pose;              // reference point in the odometry frame (start = origin)
  double heading_std = 0;  // rad, the filter's
  double gyro_bias = 0;    // rad/s, calibrated + learnt
};

// The gyro angle (rad) over (t0, t1] (us) from samples sorted by utime, each the
// mean rate since the previous sample; the span before the first sample counts
// at the first sample's rate.
double IntegrateGyro(const std::deque<ImuSample>& samples, double t0, double t1);

// A fused pose as published (pose2d_t on ODOM_FUSED, calib/io/messages.h): theta
// wrapped, the heading variance in cov[8], the rest of cov zero (not estimated).
StampedPose ToStampedPose(const FusedPose& pose);

// Feeds a recording's WHEELS and IMU (robot file's channel) in log order, as the
// live process receives them; the poses in order. Throws InputError for an
// unreadable log or message.
std::vector<FusedPose> FuseLog(const RobotDescription& robot, const std::string& log_path,
                               const FusedOdometryOptions& options);

class FusedOdometry {
 public:
  // `robot` must be a differential drive with an imu block.
  explicit FusedOdometry(const RobotDescription& robot, FusedOdometryOptions options = {});

  void AddImu(const ImuSample& sample);       // out-of-order or repeated stamps are dropped
  void AddWheels(const WheelSample& sample);  // idem
  // Processes what the IMU does not cover yet (end of a recording).
  void Finish();
  // Poses of the wheel samples processed since the last call.
  std::vector<FusedPose> TakePoses();

  const FusedPose& latest() const { return latest_; }

 private:
  void Process(bool flush);
  void Step(const WheelSample& sample, bool with_gyro);

  RobotDescription robot_;
  FusedOdometryOptions options_;
  double rL_, rR_, track_, short_m_;
  ImuMount imu_;
  std::deque<ImuSample> gyro_;
  std::deque<WheelSample> pending_;
  std::vector<FusedPose> out_;
  bool started_ = false;
  WheelSample last_;
  int64_t last_move_utime_ = 0;
  double motion_travel_ = 0.0;
  double tick_[2] = {0.0, 0.0};
  Eigen::Vector3d x_ = Eigen::Vector3d::Zero();  // theta, beta, e
  Eigen::Matrix3d P_ = Eigen::Matrix3d::Zero();
  double wheel_heading_ = 0.0;   // cumulative, calibrated model
  double output_heading_ = 0.0;  // theta as published (differs under kAverageShort)
  FusedPose latest_;
  int64_t last_imu_utime_ = 0;
};

}  // namespace calib
