#pragma once
// Gathers what the calibration needs from a stream of messages: the encoder
// track and the sensor motions. The live solver feeds it from the bus and
// `agvcal solve` from a log (both through calib/io/message_source.h), so both
// see the same data and give the same numbers. Samples whose stamps go
// backwards or repeat are dropped and counted.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/core/robot.h"
#include "calib/core/sensor_data.h"
#include "calib/core/sensor_motion.h"
#include "calib/core/wheel_track.h"

namespace calib {

// An external pose stream joined into motions that span at least kMinPoseIntervalS.
// Why: a pose source's stamps and the encoders' are never exactly simultaneous, so
// each motion's encoder increment carries an error proportional to the speed, which
// biases a least-squares scale towards zero, the less the longer the motion
// (figures: docs/calibration.md, "External poses are joined into intervals").
inline constexpr double kMinPoseIntervalS = 0.2;

class PoseIntervals {
 public:
  // The motion since the last one ended, once it spans kMinPoseIntervalS (the
  // first pose only starts one). The caller drops non-finite and repeated stamps.
  std::optional<SensorMotion> Add(const StampedPose& pose);

 private:
  std::optional<StampedPose> start_;
};

class CalibrationData {
 public:
  explicit CalibrationData(const RobotDescription& robot) : robot_(robot) {}

  void AddWheels(const WheelSample& sample);
  // An external pose (PoseIntervals turns the stream into SensorMotions); one not finite
  // or not newer than the last is dropped and counted.
  void AddPose(const StampedPose& pose);
  // A scan-matched (or otherwise measured) sensor motion.
  void AddMotion(const SensorMotion& motion);
  // An IMU sample (the IMU-referenced calibration).
  void AddImu(const ImuSample& sample);
  // A message the source left out (MessageSource::Drop), counted with its note.
  void AddDropped(const std::string& note);

  const WheelTrack& wheels() const { return wheels_; }
  const std::vector<SensorMotion>& motions() const { return motions_; }
  const std::vector<ImuSample>& imu() const { return imu_; }
  int64_t dropped_wheels() const { return dropped_wheels_; }
  int64_t dropped_poses() const { return dropped_poses_; }
  int64_t dropped_input() const { return dropped_input_; }
  const std::vector<std::string>& drop_notes() const { return drop_notes_; }

 private:
  const RobotDescription& robot_;
  WheelTrack wheels_;
  std::vector<SensorMotion> motions_;
  std::vector<ImuSample> imu_;
  std::optional<StampedPose> last_pose_;
  PoseIntervals pose_intervals_;
  int64_t dropped_wheels_ = 0, dropped_poses_ = 0, dropped_input_ = 0;
  std::vector<std::string> drop_notes_;  // the first MessageSource::kMaxDropNotes
};

// The motion between two poses of an external source, with its covariance in
// the first pose's frame (from the poses' own covariances, or 1 cm / 0.5 deg
// when they are not given: the solver rescales it from the residuals).
SensorMotion MotionBetweenPoses(const StampedPose& from, const StampedPose& to);

}  // namespace calib
