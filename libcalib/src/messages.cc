#include "calib/messages.h"

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

}  // namespace calib
