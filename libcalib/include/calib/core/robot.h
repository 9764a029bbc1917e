#pragma once
// The robot description of spec/robot.md: drive type, wheel names, nominal
// parameters, sensor mounts and motion limits, read from YAML and validated.

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace calib {

enum class DriveType { kDifferential, kTricycle, kDualSteer };

// "differential", "tricycle", "dual_steer".
const char* DriveTypeName(DriveType type);

// Wheel roles of a drive type, in the fixed order used by libcalib
// (differential: left, right; tricycle: drive; dual_steer: a1, a2).
const std::vector<std::string>& WheelRoles(DriveType type);

// Parameter names of a drive type, as in spec/robot.md, in a fixed order.
const std::vector<std::string>& ParamNames(DriveType type);

// Name of the rolling-radius parameter of a wheel role ("left" -> "left_radius",
// "drive" -> "drive_radius", "a1" -> "a1_radius", ...).
std::string RadiusParamName(const std::string& role);

// Name of the steering-offset parameter of a wheel role ("drive" ->
// "steer_offset", "a1" -> "a1_steer_offset"); empty for a wheel whose raw
// steering reading needs no offset (a2) or that does not steer.
std::string SteerOffsetParamName(const std::string& role);

// Mount of a planar sensor (2D lidar, tracked point of an external pose source)
// in the robot frame: m, m, rad.
struct Mount2d {
  std::string channel;
  double x = 0.0, y = 0.0, yaw = 0.0;
};

// Axis-aligned box in the robot frame, m: the part of the robot a 3D lidar sees
// (robot file: lidar3d.body: {min: [x, y, z], max: [x, y, z]}).
struct BodyBox {
  std::array<double, 3> min{}, max{};
};

// A 3D lidar that turns on its mount (a turret): the angle it stands at comes on
// `channel` as agvcal::mount_angle_t, and its floor pose is calibrated per
// sector of `sector_width` over [min, max] (robot file: lidar3d.rotation).
struct MountRotation {
  std::string channel = "LIDAR3D_ANGLE";
  double min = -3.14159265358979323846, max = 3.14159265358979323846;  // rad
  double sector_width = 15.0 * 3.14159265358979323846 / 180.0;          // rad
  double max_age_s = 0.2;  // an angle older than this (robot clock) is not used for a cloud
};

// Mount of a 3D lidar: z, pitch, roll relative to the floor; x, y, yaw in the robot frame.
// Orientation of the sensor in the robot frame: R = Rz(yaw) Ry(pitch) Rx(roll).
struct Mount3d {
  std::string channel = "CLOUD";
  double x = 0.0, y = 0.0, z = 0.0, roll = 0.0, pitch = 0.0, yaw = 0.0;
  std::optional<BodyBox> body;          // points inside are the robot itself
  std::optional<MountRotation> rotation;
};

// An IMU (robot file imu:). `yaw` is the sensor's mount yaw in the robot frame
// (spec/robot.md); the other keys are optional and written by `agvcal solve
// --source imu` (docs/imu.md): the gyro model measured_rate = gyro_scale *
// true_rate + gyro_bias, a gyro sample stamped t taken at wheel-clock time
// t - time_offset, and the noise the fused odometry uses.
struct ImuMount {
  std::string channel = "IMU";
  double yaw = 0.0;
  double gyro_bias = 0.0;           // rad/s about z
  double gyro_scale = 1.0;
  double time_offset = 0.0;         // s
  double gyro_noise = 8.7e-5;       // rad/s/sqrt(Hz), white noise density of the z rate
  double wheel_noise = 1e-3;        // rad/sqrt(m): wheel heading error growth per metre of wheel travel
  std::optional<double> distance;   // m: measured length of a calibration run's first straight
};

// Motion limits the commander must respect.
struct Limits {
  double max_speed = 0.5;       // m/s at the reference point (and at each wheel's contact point)
  double max_omega = 0.5;       // rad/s
  double max_accel = 0.5;       // m/s^2
  double max_steer = 1.3;       // rad, true steering angle
  double max_steer_rate = 1.0;  // rad/s
};

// What the robot's controller does with its setpoint between DRIVE_CMD messages: holds each
// command until the next, ramps from the setpoint in force to the new command over one command
// period, or follows a setpoint that changes continuously, of which the messages are samples.
enum class CommandsBetween { kHold, kRamp, kContinuous };

// "hold", "ramp", "continuous" (the robot file's and the simulation config's words).
const char* CommandsBetweenName(CommandsBetween between);
// The value named `word`, or none.
std::optional<CommandsBetween> CommandsBetweenNamed(const std::string& word);
// The robot's ROS topics (robot file `ros:`, docs/ros.md): which topic of a bag is which
// sensor, for `agvcal import rosbag2|rosbag`. An empty topic is not imported.
struct RosTopics {
  bool header_stamps = true;                          // false: the bag's record times
  std::string joint_states;                           // sensor_msgs/JointState -> WHEELS
  std::map<std::string, std::string> wheel_joints;    // wheel role -> joint (drive rotation)
  std::map<std::string, std::string> steering_joints; // wheel role -> joint (raw steering angle)
  std::string scan;                                   // sensor_msgs/LaserScan -> lidar2d channel
  std::string imu;                                    // sensor_msgs/Imu -> imu channel
  std::string odom;                                   // nav_msgs/Odometry -> pose channel
  bool odom_as_wheels = false;                        // odom -> WHEELS instead (the drive's own odometry)
  std::string cmd_vel;                                // geometry_msgs/Twist(Stamped) -> DRIVE_CMD
  std::string tf_static = "/tf_static";               // tf2_msgs/TFMessage: nominal mounts, noted
  std::string base_frame = "base_link";               // the robot frame's name in tf
};

struct RobotDescription {
  std::string name;
  DriveType drive = DriveType::kDifferential;
  std::map<std::string, std::string> wheels;  // role -> name used in wheel_state_t.name
  std::map<std::string, double> params;       // the drive type's ParamNames(), all present
  std::optional<Mount2d> lidar2d;
  std::optional<Mount3d> lidar3d;
  std::optional<ImuMount> imu;
  std::optional<Mount2d> pose;                // external pose source
  Limits limits;
  std::optional<CommandsBetween> commands_between;  // commands.between; absent: chosen from the data
  std::optional<RosTopics> ros;
  std::string source_file;                    // where it was read from (for messages)

  double param(const std::string& key) const;  // throws std::out_of_range naming the key
  const std::string& wheel_name(const std::string& role) const;
};

// Reads and validates a robot file. Throws InputError naming the file, the line
// and the key for a YAML syntax error, an unknown key (a typo), a missing key,
// a wrong type or an implausible value.
RobotDescription LoadRobotFile(const std::string& path);

// Same, from YAML text; `origin` names the text in error messages.
RobotDescription ParseRobot(const std::string& yaml_text, const std::string& origin);

}  // namespace calib
