#include "calib/messages.h"

#include <cmath>

#include "calib/errors.h"

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

agvcal::calib_estimate_t ToMessage(const CalibrationResult& result, int64_t utime,
                                   const std::string& status) {
  agvcal::calib_estimate_t m{};
  m.utime = utime;
  m.drive = DriveTypeName(result.drive);
  m.status = status;
  auto add = [&](const std::string& name, const Estimate& e) {
    m.names.push_back(name);
    m.values.push_back(e.value);
    m.stds.push_back(std::isfinite(e.std) ? e.std : -1.0);
    m.nominal.push_back(e.nominal);
  };
  for (const std::string& name : result.param_names) add(name, result.params.at(name));
  const std::string mount = MotionSourceName(result.source);
  add(mount + ".x", result.mount_x);
  add(mount + ".y", result.mount_y);
  add(mount + ".yaw", result.mount_yaw);
  if (result.time_offset) add("time_offset", *result.time_offset);
  m.num_values = static_cast<int32_t>(m.names.size());
  m.intervals = result.residual.intervals;
  m.outliers = result.residual.outliers;
  m.condition = std::isfinite(result.condition) ? result.condition : -1.0;
  m.weak = result.weak;
  m.num_weak = static_cast<int32_t>(m.weak.size());
  return m;
}

agvcal::calib_residual_t ToMessage(const IntervalResidual& r) {
  agvcal::calib_residual_t m{};
  m.utime_start = r.utime_start;
  m.utime_end = r.utime_end;
  for (int i = 0; i < 3; ++i) m.error[i] = r.error[i];
  m.chi2 = r.chi2;
  m.outlier = r.outlier;
  return m;
}

}  // namespace calib
