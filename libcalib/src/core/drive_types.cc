// Names of drive types, wheel roles and parameters (spec/robot.md).
#include <stdexcept>

#include "calib/core/robot.h"

namespace calib {

const char* DriveTypeName(DriveType type) {
  switch (type) {
    case DriveType::kDifferential: return "differential";
    case DriveType::kTricycle: return "tricycle";
    case DriveType::kDualSteer: return "dual_steer";
  }
  return "unknown";
}

const std::vector<std::string>& WheelRoles(DriveType type) {
  static const std::vector<std::string> kDifferential{"left", "right"};
  static const std::vector<std::string> kTricycle{"drive"};
  static const std::vector<std::string> kDualSteer{"a1", "a2"};
  switch (type) {
    case DriveType::kDifferential: return kDifferential;
    case DriveType::kTricycle: return kTricycle;
    case DriveType::kDualSteer: return kDualSteer;
  }
  throw std::logic_error("unknown drive type");
}

const std::vector<std::string>& ParamNames(DriveType type) {
  static const std::vector<std::string> kDifferential{"left_radius", "right_radius", "track"};
  static const std::vector<std::string> kTricycle{"drive_radius", "wheelbase", "steer_offset"};
  static const std::vector<std::string> kDualSteer{"a1_radius", "a1_steer_offset", "b", "a2_radius",
                                                   "a"};
  switch (type) {
    case DriveType::kDifferential: return kDifferential;
    case DriveType::kTricycle: return kTricycle;
    case DriveType::kDualSteer: return kDualSteer;
  }
  throw std::logic_error("unknown drive type");
}

std::string RadiusParamName(const std::string& role) { return role + "_radius"; }

std::string SteerOffsetParamName(const std::string& role) {
  if (role == "drive") return "steer_offset";
  if (role == "a1") return "a1_steer_offset";
  return "";
}

double RobotDescription::param(const std::string& key) const {
  auto it = params.find(key);
  if (it == params.end()) throw std::out_of_range("robot " + name + " has no parameter " + key);
  return it->second;
}

const std::string& RobotDescription::wheel_name(const std::string& role) const {
  auto it = wheels.find(role);
  if (it == wheels.end()) throw std::out_of_range("robot " + name + " has no wheel role " + role);
  return it->second;
}

}  // namespace calib
