// Reading and validating robot files (spec/robot.md). Every key must be known
// and used exactly once, so a typo never passes silently; every error names the
// file, the 1-based line and the key path.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/core/units.h"
#include "core/robot_ros.h"
#include "core/yaml_checked.h"

namespace calib {
namespace {

constexpr double kHalfPi = 1.57079632679489661923;
constexpr double kPi = 3.14159265358979323846;

using yaml::CheckedMap;
using yaml::Describe;
using yaml::Field;
using yaml::Join;
using yaml::LineOf;
using yaml::NumberOr;
using yaml::ReadBounded;
using yaml::ReadNumber;
using yaml::ReadPositive;
using yaml::ReadString;
using yaml::Reporter;
using yaml::Suggest;

std::string ChannelOr(const Reporter& reporter, const CheckedMap& map, const std::string& fallback) {
  const auto field = map.Find("channel");
  return field ? ReadString(reporter, *field) : fallback;
}

DriveType ReadDrive(const Reporter& reporter, const Field& field) {
  static const std::vector<std::string> kNames{"differential", "tricycle", "dual_steer"};
  static const std::vector<DriveType> kTypes{DriveType::kDifferential, DriveType::kTricycle,
                                             DriveType::kDualSteer};
  const YAML::Node& v = field.value;
  if (!v.IsScalar()) reporter.Fail(field, "expected " + Join(kNames, " or ") + ", got " + Describe(v));
  for (size_t i = 0; i < kNames.size(); ++i) {
    if (v.Scalar() == kNames[i]) return kTypes[i];
  }
  const std::string suggestion = Suggest(v.Scalar(), kNames);
  reporter.Fail(field, "unknown drive type " + Describe(v) +
                           (suggestion.empty() ? "" : " (did you mean " + suggestion + "?)") +
                           "; expected " + Join(kNames, " or "));
}

std::map<std::string, std::string> ReadWheels(const Reporter& reporter, const Field& field,
                                              DriveType drive) {
  const std::vector<std::string>& roles = WheelRoles(drive);
  const std::string roles_text =
      std::string("wheel roles of a ") + DriveTypeName(drive) + " drive are " + Join(roles);
  const CheckedMap map(reporter, field, roles, roles_text);
  std::map<std::string, std::string> wheels;
  std::map<std::string, std::string> role_of_name;
  for (const auto& role : roles) {
    const Field wheel = map.Get(role, roles_text);
    const std::string name = ReadString(reporter, wheel);
    const auto clash = role_of_name.find(name);
    if (clash != role_of_name.end()) {
      reporter.Fail(wheel, "wheel name '" + name + "' is also used by wheels." + clash->second);
    }
    role_of_name[name] = role;
    wheels[role] = name;
  }
  return wheels;
}

// No wheel, track or wheel position of a vehicle is this large: a value beyond it is a typo or
// a unit slip, which would otherwise surface as an unusable log ("only 4 usable intervals").
constexpr double kMaxLengthM = 100.0;
// Nor one smaller than a millimetre (a radius of 1e-300 would make every wheel turn "impossible").
constexpr double kMinLengthM = 0.001;
// No robot is slower than this or faster than that (m/s, rad/s, m/s^2): a limit outside is a
// typo or a unit slip, which the wheel gate would otherwise turn into dropped data.
constexpr double kMinLimit = 0.001;
constexpr double kMaxLimit = 100.0;

double ReadBetween(const Reporter& reporter, const Field& field, double low, double high, const std::string& unit) {
  const double value = ReadNumber(reporter, field);
  if (!(value >= low && value <= high))
    reporter.Fail(field, Formatted("must be from %g to %g %s, got ", low, high, unit.c_str()) + Describe(field.value));
  return value;
}

// A position in the robot frame (m), and a positive length (a radius, a height).
double ReadCoordinate(const Reporter& reporter, const Field& field) {
  return ReadBetween(reporter, field, -kMaxLengthM, kMaxLengthM, "m");
}
double ReadLength(const Reporter& reporter, const Field& field) {
  return ReadBetween(reporter, field, kMinLengthM, kMaxLengthM, "m");
}
double CoordinateOr(const Reporter& reporter, const CheckedMap& map, const std::string& key) {
  const auto field = map.Find(key);
  return field ? ReadCoordinate(reporter, *field) : 0.0;
}
double YawOr(const Reporter& reporter, const CheckedMap& map, const std::string& key) {
  const auto field = map.Find(key);
  return field ? ReadBounded(reporter, *field, 2 * kPi, "2 pi") : 0.0;
}

std::map<std::string, double> ReadParams(const Reporter& reporter, const Field& field,
                                         DriveType drive) {
  const std::vector<std::string>& names = ParamNames(drive);
  const std::string names_text =
      std::string("parameters of a ") + DriveTypeName(drive) + " drive are " + Join(names);
  const CheckedMap map(reporter, field, names, names_text);
  std::map<std::string, double> params;
  for (const auto& name : names) {
    const Field param = map.Get(name, names_text);
    const bool is_length = name == "track" || name == "wheelbase" ||
                           (name.size() >= 7 && name.compare(name.size() - 7, 7, "_radius") == 0);
    const bool is_offset = name.size() >= 12 &&
                           name.compare(name.size() - 12, 12, "steer_offset") == 0;
    if (is_offset) {
      params[name] = ReadBounded(reporter, param, kHalfPi, "pi/2");
      continue;
    }
    params[name] = is_length ? ReadLength(reporter, param) : ReadCoordinate(reporter, param);
  }
  if (drive == DriveType::kDualSteer && params["a"] == 0.0 && params["b"] == 0.0) {
    reporter.Fail(map.Get("a").line, map.path() + ".a",
                  "a and b are both 0, which puts both wheels at the same point");
  }
  return params;
}

Mount2d ReadMount2d(const Reporter& reporter, const Field& field, const std::string& channel) {
  const CheckedMap map(reporter, field, {"channel", "x", "y", "yaw"});
  Mount2d mount;
  mount.channel = ChannelOr(reporter, map, channel);
  mount.x = CoordinateOr(reporter, map, "x");
  mount.y = CoordinateOr(reporter, map, "y");
  mount.yaw = YawOr(reporter, map, "yaw");
  return mount;
}

std::array<double, 3> ReadPoint3(const Reporter& reporter, const Field& field) {
  if (!field.value.IsSequence() || field.value.size() != 3)
    reporter.Fail(field, "expected [x, y, z], got " + Describe(field.value));
  std::array<double, 3> v{};
  for (size_t i = 0; i < 3; ++i) v[i] = ReadCoordinate(reporter, Field{field.path, field.line, field.value[i]});
  return v;
}

BodyBox ReadBody(const Reporter& reporter, const Field& field) {
  const CheckedMap map(reporter, field, {"min", "max"});
  BodyBox box;
  box.min = ReadPoint3(reporter, map.Get("min", "lower corner [x, y, z] of the body box, m"));
  const Field max_field = map.Get("max", "upper corner [x, y, z] of the body box, m");
  box.max = ReadPoint3(reporter, max_field);
  for (int i = 0; i < 3; ++i) {
    if (!(box.max[i] > box.min[i]))
      reporter.Fail(max_field, "max must exceed min on every axis (axis " + std::string(1, "xyz"[i]) + ")");
  }
  return box;
}

MountRotation ReadRotation(const Reporter& reporter, const Field& field) {
  const CheckedMap map(reporter, field, {"channel", "min", "max", "sector_width", "max_age"});
  MountRotation rotation;
  rotation.channel = ChannelOr(reporter, map, rotation.channel);
  if (const auto f = map.Find("min")) rotation.min = ReadBounded(reporter, *f, 2 * kPi, "2 pi");
  if (const auto f = map.Find("max")) rotation.max = ReadBounded(reporter, *f, 2 * kPi, "2 pi");
  if (!(rotation.max > rotation.min) || rotation.max - rotation.min > 2 * kPi + 1e-9) {
    const Field f = map.Find("max") ? *map.Find("max") : field;
    reporter.Fail(f, "the rotation range must satisfy min < max <= min + 2 pi");
  }
  if (const auto f = map.Find("sector_width")) {
    rotation.sector_width = ReadPositive(reporter, *f);
    if (rotation.sector_width > rotation.max - rotation.min + 1e-9)
      reporter.Fail(*f, "wider than the rotation range");
  }
  if (const auto f = map.Find("max_age")) rotation.max_age_s = ReadPositive(reporter, *f);
  return rotation;
}

Mount3d ReadMount3d(const Reporter& reporter, const Field& field) {
  const CheckedMap map(reporter, field,
                       {"channel", "z", "pitch", "roll", "x", "y", "yaw", "body", "rotation"});
  Mount3d mount;
  mount.channel = ChannelOr(reporter, map, "CLOUD");
  // The height is what the floor observes; a nominal value is needed to start from.
  mount.z = ReadLength(reporter, map.Get("z", "height of the 3D lidar above the floor, m"));
  if (const auto f = map.Find("pitch")) mount.pitch = ReadBounded(reporter, *f, kHalfPi, "pi/2");
  if (const auto f = map.Find("roll")) mount.roll = ReadBounded(reporter, *f, kHalfPi, "pi/2");
  mount.x = CoordinateOr(reporter, map, "x");
  mount.y = CoordinateOr(reporter, map, "y");
  mount.yaw = YawOr(reporter, map, "yaw");
  if (const auto f = map.Find("body")) mount.body = ReadBody(reporter, *f);
  if (const auto f = map.Find("rotation")) mount.rotation = ReadRotation(reporter, *f);
  return mount;
}

ImuMount ReadImu(const Reporter& reporter, const Field& field) {
  const CheckedMap map(reporter, field, {"channel", "yaw", "gyro_bias", "gyro_scale", "time_offset",
                                        "gyro_noise", "wheel_noise", "distance"});
  ImuMount mount;
  mount.channel = ChannelOr(reporter, map, "IMU");
  mount.yaw = YawOr(reporter, map, "yaw");
  mount.gyro_bias = NumberOr(reporter, map, "gyro_bias", mount.gyro_bias);
  if (const auto f = map.Find("gyro_scale")) mount.gyro_scale = ReadPositive(reporter, *f);
  mount.time_offset = NumberOr(reporter, map, "time_offset", mount.time_offset);
  if (const auto f = map.Find("gyro_noise")) mount.gyro_noise = ReadPositive(reporter, *f);
  if (const auto f = map.Find("wheel_noise")) mount.wheel_noise = ReadPositive(reporter, *f);
  if (const auto f = map.Find("distance")) mount.distance = ReadLength(reporter, *f);
  return mount;
}

Limits ReadLimits(const Reporter& reporter, const Field& field) {
  const CheckedMap map(reporter, field,
                       {"max_speed", "max_omega", "max_accel", "max_steer", "max_steer_rate"});
  Limits limits;
  auto read = [&](const char* key, double* value, double high, const char* unit) {
    if (const auto f = map.Find(key)) *value = ReadBetween(reporter, *f, kMinLimit, high, unit);
  };
  read("max_speed", &limits.max_speed, kMaxLimit, "m/s");
  read("max_omega", &limits.max_omega, kMaxLimit, "rad/s");
  read("max_accel", &limits.max_accel, kMaxLimit, "m/s^2");
  read("max_steer", &limits.max_steer, kPi, "rad (pi)");
  read("max_steer_rate", &limits.max_steer_rate, kMaxLimit, "rad/s");
  return limits;
}

RobotDescription ParseDocument(const Reporter& reporter, const YAML::Node& root,
                               const std::string& origin) {
  static const std::vector<std::string> kTopKeys{"name",  "drive", "wheels", "params",
                                                 "lidar2d", "lidar3d", "imu", "pose",
                                                 "limits", "commands", "std", "source", "ros"};
  const int root_line = std::max(1, LineOf(root.Mark()));
  if (!root.IsMap()) {
    reporter.Fail(root_line, "",
                  "the top level must be a map with keys name, drive, wheels, params, ..., got " +
                      Describe(root));
  }
  // A drive parameter at the top level would otherwise get a misleading suggestion.
  for (const auto& entry : root) {
    if (!entry.first.IsScalar()) continue;
    const std::string& key = entry.first.Scalar();
    for (DriveType type : {DriveType::kDifferential, DriveType::kTricycle, DriveType::kDualSteer}) {
      const std::vector<std::string>& names = ParamNames(type);
      if (std::find(names.begin(), names.end(), key) != names.end()) {
        reporter.Fail(LineOf(entry.first.Mark()), key,
                      "unknown key (drive parameters go under params:)");
      }
    }
  }
  const CheckedMap top(reporter, Field{"", root_line, root}, kTopKeys,
                       "expected " + Join(kTopKeys) + "; drive parameters go under params");

  RobotDescription robot;
  robot.source_file = origin;
  robot.name = ReadString(reporter, top.Get("name"));
  robot.drive = ReadDrive(reporter, top.Get("drive", "differential, tricycle or dual_steer"));
  robot.wheels = ReadWheels(reporter, top.Get("wheels", "map of wheel role to wheel name"),
                            robot.drive);
  robot.params = ReadParams(reporter, top.Get("params", "nominal drive parameters"), robot.drive);
  if (const auto f = top.Find("lidar2d")) robot.lidar2d = ReadMount2d(reporter, *f, "SCAN");
  if (const auto f = top.Find("lidar3d")) robot.lidar3d = ReadMount3d(reporter, *f);
  if (const auto f = top.Find("imu")) robot.imu = ReadImu(reporter, *f);
  if (const auto f = top.Find("pose")) robot.pose = ReadMount2d(reporter, *f, "POSE");
  if (const auto f = top.Find("limits")) robot.limits = ReadLimits(reporter, *f);
  if (const auto f = top.Find("commands")) {
    const CheckedMap map(reporter, *f, {"between"});
    if (const auto v = map.Find("between")) {
      const std::string word = ReadString(reporter, *v);
      robot.commands_between = CommandsBetweenNamed(word);
      if (!robot.commands_between) reporter.Fail(*v, "expected hold, ramp or continuous, got '" + word + "'");
    }
  }
  if (const auto f = top.Find("ros")) robot.ros = yaml::ReadRosTopics(reporter, *f, robot.drive);
  // Written by `agvcal solve`; carried for the user, not read back.
  if (const auto f = top.Find("std")) {
    if (!f->value.IsMap()) reporter.Fail(*f, "expected a map of standard deviations, got " +
                                                 Describe(f->value));
  }
  if (const auto f = top.Find("source")) {
    if (!f->value.IsScalar()) reporter.Fail(*f, "expected a log name, got " + Describe(f->value));
  }
  return robot;
}

}  // namespace

const char* CommandsBetweenName(CommandsBetween between) {
  switch (between) {
    case CommandsBetween::kRamp: return "ramp";
    case CommandsBetween::kContinuous: return "continuous";
    case CommandsBetween::kHold: break;
  }
  return "hold";
}

std::optional<CommandsBetween> CommandsBetweenNamed(const std::string& word) {
  for (CommandsBetween b : {CommandsBetween::kHold, CommandsBetween::kRamp, CommandsBetween::kContinuous})
    if (word == CommandsBetweenName(b)) return b;
  return std::nullopt;
}

RobotDescription ParseRobot(const std::string& yaml_text, const std::string& origin) {
  const Reporter reporter(origin);
  const Field root = yaml::ParseSingleDocument(reporter, yaml_text, "robot file");
  try {
    return ParseDocument(reporter, root.value, origin);
  } catch (const YAML::Exception& e) {  // Not expected: every access is checked first.
    reporter.Fail(LineOf(e.mark), "", std::string("YAML error: ") + e.what());
  }
}

RobotDescription LoadRobotFile(const std::string& path) {
  return ParseRobot(yaml::ReadTextFile(path, "robot file"), path);
}

}  // namespace calib
