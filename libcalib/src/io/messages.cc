#include "calib/io/messages.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "calib/core/errors.h"
#include "calib/core/units.h"

namespace calib {

std::string ScanChannel(const RobotDescription& robot) {
  return robot.lidar2d ? robot.lidar2d->channel : kScanChannel;
}

std::string PoseChannel(const RobotDescription& robot) {
  return robot.pose ? robot.pose->channel : kPoseChannel;
}

std::string ImuChannel(const RobotDescription& robot) {
  return robot.imu ? robot.imu->channel : kImuChannel;
}

WheelSample WheelSampleFromMessage(const agvcal::wheel_state_t& message,
                                   const RobotDescription& robot, const std::string& origin) {
  WheelSample sample;
  sample.utime = message.utime;
  for (const std::string& role : WheelRoles(robot.drive)) {
    const std::string& name = robot.wheel_name(role);
    int index = -1;
    for (int i = 0; i < message.num_wheels; ++i) {
      if (message.name[i] == name) index = i;
    }
    if (index < 0) {
      throw InputError(origin, "wheel_state_t",
                       "no wheel named '" + name + "' (role " + role + " in " +
                           robot.source_file + ")");
    }
    const double position = message.position[index];
    const double steer = message.steer[index];
    if (!std::isfinite(position) || !std::isfinite(steer)) {
      throw InputError(origin, "wheel '" + name + "'", "position or steer is not finite");
    }
    sample.position.push_back(position);
    sample.steer.push_back(steer);
  }
  return sample;
}

agvcal::wheel_state_t WheelStateMessage(const WheelSample& sample, const RobotDescription& robot,
                                        const std::vector<double>& velocity) {
  const std::vector<std::string>& roles = WheelRoles(robot.drive);
  agvcal::wheel_state_t msg{};
  msg.utime = sample.utime;
  msg.num_wheels = static_cast<int32_t>(roles.size());
  for (std::size_t i = 0; i < roles.size(); ++i) {
    msg.name.push_back(robot.wheel_name(roles[i]));
    msg.position.push_back(sample.position.at(i));
    msg.velocity.push_back(velocity.empty() ? std::nan("") : velocity.at(i));
    msg.steer.push_back(i < sample.steer.size() ? sample.steer[i] : 0.0);
  }
  return msg;
}

LaserScan LaserScanFromMessage(const agvcal::laser_scan_t& message, const std::string& origin) {
  const std::string place = "laser_scan_t utime " + std::to_string(message.utime);
  auto fail = [&](const std::string& problem) { throw InputError(origin, place, problem); };
  if (message.nranges < 0 || static_cast<size_t>(message.nranges) != message.ranges.size())
    fail("nranges " + std::to_string(message.nranges) + " but " +
         std::to_string(message.ranges.size()) + " ranges");
  if (message.nintensities != 0 && message.nintensities != message.nranges)
    fail("nintensities " + std::to_string(message.nintensities) + ", expected 0 or nranges " +
         std::to_string(message.nranges));
  if (message.intensities.size() != static_cast<size_t>(std::max(message.nintensities, 0)))
    fail("nintensities " + std::to_string(message.nintensities) + " but " +
         std::to_string(message.intensities.size()) + " intensities");
  const std::pair<const char*, float> fields[] = {{"angle_min", message.angle_min},
                                                  {"angle_increment", message.angle_increment},
                                                  {"time_increment", message.time_increment},
                                                  {"scan_time", message.scan_time}};
  for (const auto& [name, value] : fields)
    if (!std::isfinite(value)) fail(std::string(name) + " is not finite");
  if (message.angle_increment == 0.0f && message.nranges > 1) fail("angle_increment is 0");
  if (message.time_increment < 0.0f) fail("time_increment is negative");
  if (message.scan_time < 0.0f) fail("scan_time is negative");
  if (double(message.time_increment) * std::max(message.nranges - 1, 0) > kMaxScanDuration)
    fail("beams span " + std::to_string(double(message.time_increment) * (message.nranges - 1)) +
         " s (time_increment " + std::to_string(message.time_increment) + " s per beam)");
  if (!(message.range_min >= 0.0f) || !(message.range_max > message.range_min))
    fail("range interval [" + std::to_string(message.range_min) + ", " +
         std::to_string(message.range_max) + "] is empty or not a number");

  LaserScan scan;
  scan.utime = message.utime;
  scan.angle_min = message.angle_min;
  scan.angle_increment = message.angle_increment;
  scan.time_increment = message.time_increment;
  scan.scan_time = message.scan_time;
  scan.range_min = message.range_min;
  scan.range_max = message.range_max;
  scan.ranges = message.ranges;
  return scan;
}

ImuSample ImuSampleFromMessage(const agvcal::imu_t& message, const std::string& origin) {
  ImuSample s;
  s.utime = message.utime;
  s.rate = message.angular_velocity[2];
  s.accel_x = message.linear_acceleration[0];
  s.accel_y = message.linear_acceleration[1];
  if (!std::isfinite(s.rate) || !std::isfinite(s.accel_x) || !std::isfinite(s.accel_y))
    throw InputError(origin, "imu_t", "angular_velocity or linear_acceleration is not finite");
  return s;
}

StampedPose PoseFromMessage(const agvcal::pose2d_t& message) {
  StampedPose pose;
  pose.utime = message.utime;
  pose.x = message.x;
  pose.y = message.y;
  pose.theta = message.theta;
  std::copy(std::begin(message.cov), std::end(message.cov), pose.cov.begin());
  return pose;
}

agvcal::pose2d_t ToMessage(const StampedPose& pose) {
  agvcal::pose2d_t m{};
  m.utime = pose.utime;
  m.x = pose.x;
  m.y = pose.y;
  m.theta = pose.theta;
  std::copy(pose.cov.begin(), pose.cov.end(), m.cov);
  return m;
}

PointCloud CloudFromMessage(const agvcal::point_cloud_t& message) {
  PointCloud cloud;
  cloud.utime = message.utime;
  const size_t n = std::min(message.xyz.size(), static_cast<size_t>(std::max(message.npoints, 0)));
  cloud.xyz.reserve(3 * n);
  for (size_t i = 0; i < n; ++i) {
    const auto& p = message.xyz[i];
    if (p.size() < 3) continue;
    cloud.xyz.insert(cloud.xyz.end(), {p[0], p[1], p[2]});
  }
  return cloud;
}

agvcal::point_cloud_t ToMessage(const PointCloud& cloud) {
  agvcal::point_cloud_t msg{};
  msg.utime = cloud.utime;
  msg.npoints = static_cast<int32_t>(cloud.xyz.size() / 3);
  msg.xyz.reserve(cloud.xyz.size() / 3);
  for (size_t i = 0; i + 2 < cloud.xyz.size(); i += 3)
    msg.xyz.push_back({cloud.xyz[i], cloud.xyz[i + 1], cloud.xyz[i + 2]});
  return msg;
}

MountAngle MountAngleFromMessage(const agvcal::mount_angle_t& message) {
  MountAngle angle;
  angle.utime = message.utime;
  angle.angle = message.angle;
  return angle;
}

agvcal::drive_command_t ToMessage(const DriveCommand& command, const RobotDescription& robot,
                                  int64_t seq) {
  agvcal::drive_command_t msg{};
  msg.utime = command.utime;
  msg.seq = seq;
  msg.mode = static_cast<int8_t>(command.mode);
  msg.vx = command.twist.vx;
  msg.vy = command.twist.vy;
  msg.omega = command.twist.omega;
  msg.timeout = command.timeout_s;
  msg.num_wheels = 0;
  if (command.mode == DriveMode::kWheels) {
    const auto& roles = WheelRoles(robot.drive);
    for (size_t i = 0; i < roles.size(); ++i) {
      msg.name.push_back(robot.wheel_name(roles[i]));
      msg.wheel_speed.push_back(command.wheels.speed.at(i));
      msg.steer.push_back(command.wheels.steer.at(i));
    }
    msg.num_wheels = static_cast<int32_t>(roles.size());
  }
  return msg;
}

DriveCommand FromMessage(const agvcal::drive_command_t& message, const RobotDescription& robot,
                         const std::string& origin) {
  DriveCommand cmd;
  cmd.utime = message.utime;
  cmd.timeout_s = message.timeout;
  switch (message.mode) {
    case agvcal::drive_command_t::MODE_TWIST:
      cmd.mode = DriveMode::kTwist;
      cmd.twist = {message.vx, message.vy, message.omega};
      break;
    case agvcal::drive_command_t::MODE_WHEELS: {
      cmd.mode = DriveMode::kWheels;
      const auto& roles = WheelRoles(robot.drive);
      for (const auto& role : roles) {
        const std::string& name = robot.wheel_name(role);
        int found = -1;
        for (int i = 0; i < message.num_wheels; ++i)
          if (message.name[i] == name) found = i;
        if (found < 0)
          throw InputError(origin, "DRIVE_CMD seq " + std::to_string(message.seq),
                           "no setpoint for wheel '" + name + "'");
        cmd.wheels.speed.push_back(message.wheel_speed[found]);
        cmd.wheels.steer.push_back(message.steer[found]);
      }
      break;
    }
    default:
      cmd.mode = DriveMode::kStop;
  }
  return cmd;
}

namespace {

// The robot-file parameter holding `role`'s steering offset (tricycle: steer_offset; dual steer:
// a1_steer_offset, a2 has none): 0 for a role without one.
double SteerOffset(const RobotDescription& robot, const std::string& role) {
  for (const std::string& name : {role + "_steer_offset", std::string("steer_offset")}) {
    const auto it = robot.params.find(name);
    if (it != robot.params.end()) return it->second;
  }
  return 0.0;
}

}  // namespace

std::string DriveCommandProblem(const DriveCommand& command, const RobotDescription& robot) {
  const double f = kCommandLimitFactor;
  const Limits& limits = robot.limits;
  if (!std::isfinite(command.timeout_s)) return Formatted("timeout %g s is not finite: dropped", command.timeout_s);
  if (command.mode == DriveMode::kTwist) {
    const Twist2& t = command.twist;
    for (const auto& [name, value] : {std::pair<const char*, double>{"vx", t.vx}, {"vy", t.vy}}) {
      if (!(std::abs(value) <= f * limits.max_speed))
        return Formatted("twist %s = %g m/s, more than %g m/s (%g x limits.max_speed): dropped", name, value,
                         f * limits.max_speed, f);
    }
    if (!(std::abs(t.omega) <= f * limits.max_omega))
      return Formatted("twist omega = %g rad/s, more than %g rad/s (%g x limits.max_omega): dropped", t.omega,
                       f * limits.max_omega, f);
  }
  if (command.mode != DriveMode::kWheels) return "";
  const std::vector<std::string>& roles = WheelRoles(robot.drive);
  const bool steered = robot.drive != DriveType::kDifferential;
  const double kPi = 3.14159265358979323846;
  for (std::size_t i = 0; i < roles.size() && i < command.wheels.speed.size(); ++i) {
    const std::string& name = robot.wheel_name(roles[i]);
    const double max_rate = f * limits.max_speed / robot.param(RadiusParamName(roles[i]));
    const double speed = command.wheels.speed[i];
    if (!(std::abs(speed) <= max_rate))
      return Formatted("wheel '%s' speed setpoint %g rad/s, more than %g rad/s (%g x limits.max_speed / radius): "
                       "dropped",
                       name.c_str(), speed, max_rate, f);
    const double steer = command.wheels.steer[i];
    const double max_steer = std::min(f * limits.max_steer, kPi);
    const double angle = steer - (steered ? SteerOffset(robot, roles[i]) : 0.0);
    if (!std::isfinite(steer) || (steered && std::abs(angle) > max_steer))
      return Formatted("wheel '%s' steering setpoint %g rad, beyond %g rad (%g x limits.max_steer, at most pi): "
                       "dropped",
                       name.c_str(), steer, max_steer, f);
  }
  return "";
}

agvcal::scan_match_t ToMessage(const SensorMotion& motion) {
  agvcal::scan_match_t msg{};
  msg.utime_start = motion.utime_start;
  msg.utime_end = motion.utime_end;
  msg.x = motion.delta.x;
  msg.y = motion.delta.y;
  msg.theta = motion.delta.theta;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) msg.cov[3 * r + c] = motion.covariance(r, c);
  msg.valid = motion.valid;
  msg.degenerate = motion.degenerate;
  for (int i = 0; i < 3; ++i) msg.weak_direction[i] = motion.weak_direction[i];
  msg.inlier_fraction = motion.inlier_fraction;
  msg.rms = motion.rms;
  return msg;
}

SensorMotion FromMessage(const agvcal::scan_match_t& message, const std::string& origin) {
  const std::string place = "scan_match_t utime_start " + std::to_string(message.utime_start);
  if (message.utime_end <= message.utime_start)
    throw InputError(origin, place,
                     "utime_end " + std::to_string(message.utime_end) + " not after utime_start");
  SensorMotion motion;
  motion.utime_start = message.utime_start;
  motion.utime_end = message.utime_end;
  motion.delta = {message.x, message.y, message.theta};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) motion.covariance(r, c) = message.cov[3 * r + c];
  motion.valid = message.valid;
  motion.degenerate = message.degenerate;
  for (int i = 0; i < 3; ++i) motion.weak_direction[i] = message.weak_direction[i];
  motion.inlier_fraction = message.inlier_fraction;
  motion.rms = message.rms;
  const bool finite = std::isfinite(motion.delta.x) && std::isfinite(motion.delta.y) &&
                      std::isfinite(motion.delta.theta) && motion.covariance.allFinite() &&
                      motion.weak_direction.allFinite() && std::isfinite(motion.inlier_fraction) &&
                      std::isfinite(motion.rms);
  if (!finite) throw InputError(origin, place, "a number is not finite");
  return motion;
}

}  // namespace calib
