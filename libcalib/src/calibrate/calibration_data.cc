#include "calib/calibrate/calibration_data.h"

#include <cmath>

#include <Eigen/Dense>

#include "calib/io/message_source.h"

namespace calib {

void CalibrationData::AddWheels(const WheelSample& sample) {
  if (!wheels_.Append(sample)) ++dropped_wheels_;
}

void CalibrationData::AddPose(const StampedPose& message) {
  const bool finite = std::isfinite(message.x) && std::isfinite(message.y) && std::isfinite(message.theta);
  if (!finite || (last_pose_ && message.utime <= last_pose_->utime)) {
    ++dropped_poses_;
    return;
  }
  if (std::optional<SensorMotion> motion = pose_intervals_.Add(message)) motions_.push_back(*motion);
  last_pose_ = message;
}

void CalibrationData::AddMotion(const SensorMotion& motion) { motions_.push_back(motion); }

void CalibrationData::AddImu(const ImuSample& sample) { imu_.push_back(sample); }

void CalibrationData::AddDropped(const std::string& note) {
  ++dropped_input_;
  if (drop_notes_.size() < MessageSource::kMaxDropNotes) drop_notes_.push_back(note);
}

std::optional<SensorMotion> PoseIntervals::Add(const StampedPose& pose) {
  if (!start_) {
    start_ = pose;
    return std::nullopt;
  }
  if (pose.utime - start_->utime < std::llround(kMinPoseIntervalS * 1e6)) return std::nullopt;
  const SensorMotion motion = MotionBetweenPoses(*start_, pose);
  start_ = pose;
  return motion;
}

SensorMotion MotionBetweenPoses(const StampedPose& from, const StampedPose& to) {
  SensorMotion m;
  m.utime_start = from.utime;
  m.utime_end = to.utime;
  m.delta = Between({from.x, from.y, from.theta}, {to.x, to.y, to.theta});
  m.inlier_fraction = 1.0;
  const Eigen::Matrix3d c0 = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(from.cov.data());
  const Eigen::Matrix3d c1 = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(to.cov.data());
  Eigen::Matrix3d sum = c0 + c1;
  if (!sum.allFinite() || sum.diagonal().minCoeff() <= 0.0) {
    sum = Eigen::Vector3d(1e-4, 1e-4, std::pow(0.5 * M_PI / 180.0, 2)).asDiagonal();
  }
  // Both poses' errors, in the world frame, carried into the first pose's frame.
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  rotation.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(from.theta).toRotationMatrix().transpose();
  m.covariance = rotation * sum * rotation.transpose();
  return m;
}

}  // namespace calib
