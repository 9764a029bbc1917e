#pragma once
// Conversions between the messages of spec/messages.md (generated from
// lcmtypes/) and libcalib's plain data, and encoding helpers. No bus here.

#include <cstdint>
#include <exception>
#include <string>
#include <vector>

#include "agvcal/drive_command_t.hpp"
#include "agvcal/imu_t.hpp"
#include "agvcal/laser_scan_t.hpp"
#include "agvcal/mount_angle_t.hpp"
#include "agvcal/point_cloud_t.hpp"
#include "agvcal/pose2d_t.hpp"
#include "agvcal/scan_match_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/core/drive_command.h"
#include "calib/core/laser_scan.h"
#include "calib/core/robot.h"
#include "calib/core/sensor_data.h"
#include "calib/core/sensor_motion.h"
#include "calib/core/wheel_track.h"
#include "calib/io/message_layout.h"

namespace calib {

// Channel names of spec/messages.md and the internal ones.
inline constexpr const char* kWheelsChannel = "WHEELS";
inline constexpr const char* kScanChannel = "SCAN";
inline constexpr const char* kCloudChannel = "CLOUD";
inline constexpr const char* kImuChannel = "IMU";
inline constexpr const char* kDriveCmdChannel = "DRIVE_CMD";
inline constexpr const char* kPoseChannel = "POSE";
inline constexpr const char* kGroundTruthChannel = "GROUND_TRUTH";
inline constexpr const char* kHeartbeatChannel = "HEARTBEAT";
inline constexpr const char* kCommanderStatusChannel = "COMMANDER_STATUS";
inline constexpr const char* kCalibEstimateChannel = "CALIB_ESTIMATE";
inline constexpr const char* kCalibResidualsChannel = "CALIB_RESIDUALS";
inline constexpr const char* kScanMatchChannel = "SCAN_MATCH";
inline constexpr const char* kGroundEstimateChannel = "GROUND_ESTIMATE";
// Wheel odometry fused with the gyro (agvcal-fusion), pose2d_t.
inline constexpr const char* kOdomFusedChannel = "ODOM_FUSED";
// Default channel of a turret-mounted 3D lidar's angle (robot file lidar3d.rotation.channel).
inline constexpr const char* kMountAngleChannel = "LIDAR3D_ANGLE";
// The operator's stop (agvcal::operator_stop_t): the commander holds the robot until released.
inline constexpr const char* kStopChannel = "STOP";

// The channels of a robot's sensors: the robot file's, else the default above.
std::string ScanChannel(const RobotDescription& robot);  // lidar2d
std::string PoseChannel(const RobotDescription& robot);  // pose
std::string ImuChannel(const RobotDescription& robot);   // imu

// The sample of a wheel_state_t in the robot's role order. Throws InputError
// (origin = e.g. "log.lcm: event 1234") when a wheel of the robot is missing or
// a reading is not finite.
WheelSample WheelSampleFromMessage(const agvcal::wheel_state_t& message,
                                   const RobotDescription& robot, const std::string& origin);

// The message of a sample, wheels named as in the robot file: the inverse of
// WheelSampleFromMessage. `velocity` (rad/s, role order) may be empty: NaN, not reported.
agvcal::wheel_state_t WheelStateMessage(const WheelSample& sample, const RobotDescription& robot,
                                        const std::vector<double>& velocity = {});

// The scan of a message. Throws InputError (file = `origin`, e.g. "log.lcm:
// event 1234") when nranges or nintensities disagree with the arrays, an
// angle or time field is not finite, angle_increment is 0 with more than one
// beam, time_increment or scan_time is negative, the beams span more than
// kMaxScanDuration (time_increment in the wrong unit), or the range interval
// is empty or not a number.
LaserScan LaserScanFromMessage(const agvcal::laser_scan_t& message, const std::string& origin);

// The sample of an imu_t message; throws InputError (origin = e.g. "log: event
// 12") when a reading is not finite.
ImuSample ImuSampleFromMessage(const agvcal::imu_t& message, const std::string& origin);

// A pose2d_t (POSE, ODOM_FUSED) and back, field for field (not validated: the
// consumers drop non-finite poses).
StampedPose PoseFromMessage(const agvcal::pose2d_t& message);
agvcal::pose2d_t ToMessage(const StampedPose& pose);

// A point_cloud_t (CLOUD) and back: the first npoints points (interleaved xyz).
PointCloud CloudFromMessage(const agvcal::point_cloud_t& message);
agvcal::point_cloud_t ToMessage(const PointCloud& cloud);

// A mount_angle_t (lidar3d.rotation.channel).
MountAngle MountAngleFromMessage(const agvcal::mount_angle_t& message);

// A command for the robot's wheels, named as in the robot file.
agvcal::drive_command_t ToMessage(const DriveCommand& command, const RobotDescription& robot,
                                  int64_t seq);

// The command in WheelRoles() order; throws InputError if a wheel of the
// robot is missing from a mode-1 command (`origin` names the source).
DriveCommand FromMessage(const agvcal::drive_command_t& message, const RobotDescription& robot,
                         const std::string& origin);

// Why a converted command cannot have been meant for this robot, or "" when it can: a setpoint
// or timeout that is not finite, a speed more than kCommandLimitFactor times the robot file's
// limits allow (limits.max_speed, / the wheel's radius for a wheel speed; limits.max_omega), a
// true steering angle beyond kCommandLimitFactor x limits.max_steer (at most pi). A command the
// robot would clamp passes; a flipped bit or a driver's NaN does not. SubscribeDriveCommands
// drops such a command and names it (as the wheel gate does a wheel sample).
inline constexpr double kCommandLimitFactor = 10.0;
std::string DriveCommandProblem(const DriveCommand& command, const RobotDescription& robot);

// A scan-matcher result (channel SCAN_MATCH) and back. FromMessage throws
// InputError (`origin` names the source) for a non-finite number or
// utime_end <= utime_start.
agvcal::scan_match_t ToMessage(const SensorMotion& motion);
SensorMotion FromMessage(const agvcal::scan_match_t& message, const std::string& origin);

// Encodes any lcm-gen message into bytes.
template <typename Message>
std::vector<uint8_t> Encode(const Message& message) {
  std::vector<uint8_t> bytes(message.getEncodedSize());
  message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

// Decodes bytes into a message; false if they are not a valid `Message`, and then
// `why` (when given) says what is wrong. Every length is checked against the bytes
// first (message_layout.h), so a corrupt one never reaches lcm-gen's allocation;
// its decoders can also throw on corrupt lengths, e.g. of a string.
template <typename Message>
bool Decode(const void* data, int size, Message* message, std::string* why = nullptr) {
  if (size < 0) {
    if (why) *why = "a negative size";
    return false;
  }
  const std::string bad =
      CheckEncodedLengths(Message::getTypeName(), static_cast<const uint8_t*>(data), static_cast<size_t>(size));
  if (!bad.empty()) {
    if (why) *why = bad;
    return false;
  }
  try {
    if (message->decode(data, 0, size) == size) return true;
  } catch (const std::exception&) {
  }
  if (why) *why = "its bytes do not decode";
  return false;
}

}  // namespace calib
