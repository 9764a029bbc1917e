#include "calib/calibrate/fused_odometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

#include "calib/core/errors.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"

namespace calib {

double IntegrateGyro(const std::deque<ImuSample>& samples, double t0, double t1) {
  if (samples.empty() || t1 <= t0) return 0.0;
  auto it = std::upper_bound(samples.begin(), samples.end(), t0,
                             [](double t, const ImuSample& s) { return t < double(s.utime); });
  double angle = 0.0;
  for (; it != samples.end(); ++it) {
    const double start = it == samples.begin() ? -std::numeric_limits<double>::infinity()
                                               : double((it - 1)->utime);
    if (start >= t1) break;
    const double a = std::max(start, t0), b = std::min(double(it->utime), t1);
    if (b > a) angle += it->rate * (b - a) * 1e-6;
  }
  // Beyond the newest sample: at its rate.
  if (t1 > double(samples.back().utime))
    angle += samples.back().rate * (t1 - std::max(t0, double(samples.back().utime))) * 1e-6;
  return angle;
}

FusedOdometry::FusedOdometry(const RobotDescription& robot, FusedOdometryOptions options)
    : robot_(robot), options_(options) {
  if (robot_.drive != DriveType::kDifferential)
    throw InputError(robot_.source_file, "drive", "fused odometry is for differential drives");
  if (!robot_.imu) throw InputError(robot_.source_file, "imu", "no IMU in the robot file");
  imu_ = *robot_.imu;
  rL_ = robot_.param("left_radius");
  rR_ = robot_.param("right_radius");
  track_ = robot_.param("track");
  short_m_ = options_.short_motion_m > 0 ? options_.short_motion_m : M_PI * (rL_ + rR_);
  P_(1, 1) = 1e-4 * 1e-4;
}

void FusedOdometry::AddImu(const ImuSample& sample) {
  if (!gyro_.empty() && sample.utime <= gyro_.back().utime) return;
  if (!std::isfinite(sample.rate)) return;
  gyro_.push_back(sample);
  last_imu_utime_ = sample.utime;
  Process(false);
}

void FusedOdometry::AddWheels(const WheelSample& sample) {
  const int64_t newest = !pending_.empty() ? pending_.back().utime : (started_ ? last_.utime : INT64_MIN);
  if (sample.utime <= newest || sample.position.size() != 2) return;
  pending_.push_back(sample);
  Process(false);
}

void FusedOdometry::Finish() { Process(true); }

std::vector<FusedPose> FusedOdometry::TakePoses() {
  std::vector<FusedPose> out;
  out.swap(out_);
  return out;
}

void FusedOdometry::Process(bool flush) {
  const double offset_us = imu_.time_offset * 1e6;
  while (!pending_.empty()) {
    const WheelSample& s = pending_.front();
    const bool covered = !gyro_.empty() && double(last_imu_utime_) >= double(s.utime) + offset_us;
    const bool give_up = double(pending_.back().utime - s.utime) > options_.max_imu_wait_s * 1e6;
    if (!covered && !flush && !give_up && started_) break;
    Step(s, covered || (!gyro_.empty() && flush));
    pending_.pop_front();
  }
  // Keep a second of gyro history behind the wheels.
  const double keep = double(last_.utime) + offset_us - 1e6;
  while (gyro_.size() > 2 && double(gyro_[1].utime) < keep) gyro_.pop_front();
}

void FusedOdometry::Step(const WheelSample& sample, bool with_gyro) {
  if (!started_) {
    started_ = true;
    last_ = sample;
    last_move_utime_ = sample.utime;
    latest_ = FusedPose{sample.utime, Pose2{}, 0.0, imu_.gyro_bias};
    out_.push_back(latest_);
    return;
  }
  const double dt = (sample.utime - last_.utime) * 1e-6;
  const double dphiL = sample.position[0] - last_.position[0];
  const double dphiR = sample.position[1] - last_.position[1];
  for (int w = 0; w < 2; ++w) {
    const double d = std::abs(w == 0 ? dphiL : dphiR);
    if (d > 1e-12 && (tick_[w] == 0.0 || d < tick_[w])) tick_[w] = d;
  }
  const double dsL = rL_ * dphiL, dsR = rR_ * dphiR;
  const double ds = 0.5 * (dsL + dsR), travel = 0.5 * (std::abs(dsL) + std::abs(dsR));
  const double dtheta_w = (dsR - dsL) / track_;
  const bool moved = dphiL != 0.0 || dphiR != 0.0;
  if (moved) {
    if ((last_.utime - last_move_utime_) * 1e-6 >= options_.standstill_s) motion_travel_ = 0.0;
    motion_travel_ += travel;
    last_move_utime_ = sample.utime;
  }

  // Predict with the gyro (or, without gyro data, with the wheels and a wide variance).
  const double offset_us = imu_.time_offset * 1e6;
  double dtheta_g = dtheta_w, q_theta = 1e-4 * dt;
  if (with_gyro) {
    const double raw = IntegrateGyro(gyro_, last_.utime + offset_us, sample.utime + offset_us);
    dtheta_g = (raw - imu_.gyro_bias * dt) / imu_.gyro_scale;
    q_theta = imu_.gyro_noise * imu_.gyro_noise * dt / (imu_.gyro_scale * imu_.gyro_scale);
  }
  const double theta_before = x_(0);
  const double gyro_increment = dtheta_g - x_(1) * dt;
  x_(0) += gyro_increment;
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F(0, 1) = -dt;
  P_ = F * P_ * F.transpose();
  P_(0, 0) += q_theta;
  P_(1, 1) += options_.bias_walk * options_.bias_walk * dt;
  P_(2, 2) += imu_.wheel_noise * imu_.wheel_noise * travel;

  // Update with the wheels' cumulative heading, which measures theta + e.
  wheel_heading_ += dtheta_w;
  const double q = (tick_[0] * tick_[0] * rL_ * rL_ + tick_[1] * tick_[1] * rR_ * rR_) /
                   (12.0 * track_ * track_);
  const Eigen::RowVector3d H(1.0, 0.0, 1.0);
  const double S = (H * P_ * H.transpose())(0, 0) + std::max(q, 1e-12);
  const Eigen::Vector3d K = P_ * H.transpose() / S;
  x_ += K * (wheel_heading_ - x_(0) - x_(2));
  const Eigen::Matrix3d IKH = Eigen::Matrix3d::Identity() - K * H;
  P_ = IKH * P_ * IKH.transpose() + K * std::max(q, 1e-12) * K.transpose();

  double increment = x_(0) - theta_before;
  if (options_.policy == FusionPolicy::kAverageShort && moved && motion_travel_ <= short_m_)
    increment = 0.5 * (gyro_increment + dtheta_w);
  const double h0 = output_heading_;
  output_heading_ += increment;
  const double chord = std::abs(increment) < 1e-9 ? ds : ds * std::sin(0.5 * increment) / (0.5 * increment);
  Pose2& pose = latest_.pose;
  pose.x += chord * std::cos(h0 + 0.5 * increment);
  pose.y += chord * std::sin(h0 + 0.5 * increment);
  pose.theta = output_heading_;
  latest_.utime = sample.utime;
  latest_.heading_std = std::sqrt(P_(0, 0));
  latest_.gyro_bias = imu_.gyro_bias + x_(1);
  out_.push_back(latest_);
  last_ = sample;
}

StampedPose ToStampedPose(const FusedPose& pose) {
  StampedPose stamped;
  stamped.utime = pose.utime;
  stamped.x = pose.pose.x;
  stamped.y = pose.pose.y;
  stamped.theta = WrapAngle(pose.pose.theta);
  stamped.cov[8] = pose.heading_std * pose.heading_std;
  return stamped;
}

std::vector<FusedPose> FuseLog(const RobotDescription& robot, const std::string& log_path,
                               const FusedOdometryOptions& options) {
  FusedOdometry fused(robot, options);
  std::vector<FusedPose> poses;
  auto take_poses = [&]() {
    for (const FusedPose& p : fused.TakePoses()) poses.push_back(p);
  };
  RecordingSource source(log_path);
  SubscribeWheels(&source, robot, [&](const WheelSample& sample) {
    fused.AddWheels(sample);
    take_poses();
  });
  SubscribeImu(&source, ImuChannel(robot), [&](const ImuSample& sample) {
    fused.AddImu(sample);
    take_poses();
  });
  source.HandleAll();
  fused.Finish();
  take_poses();
  return poses;
}

}  // namespace calib
