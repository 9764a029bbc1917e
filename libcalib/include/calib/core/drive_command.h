#pragma once
// A drive command as plain data: what the commander decides and what the
// simulator (or a robot) executes. Converted to and from drive_command_t by
// calib/io/messages.h.

#include <cstdint>

#include "calib/core/kinematics.h"
#include "calib/core/se2.h"

namespace calib {

enum class DriveMode : int8_t { kTwist = 0, kWheels = 1, kStop = 2 };

struct DriveCommand {
  int64_t utime = 0;              // robot-clock time of issue, us
  DriveMode mode = DriveMode::kStop;
  Twist2 twist;                   // mode kTwist: setpoint at the reference point
  WheelSetpoint wheels;           // mode kWheels: per role, in WheelRoles() order
  double timeout_s = 0.5;         // the robot stops if no newer command arrives within it
};

}  // namespace calib
