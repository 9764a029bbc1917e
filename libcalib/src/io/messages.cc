#include "calib/io/messages.h"

#include <cmath>

#include "calib/core/errors.h"

namespace calib {

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
