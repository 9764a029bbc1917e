#include "calib/calibrate/ros_results.h"

#include <cmath>

#include "calib/core/errors.h"

namespace calib {

namespace {

constexpr const char* kLevelScan = "not calibrated (the scan plane is level)";

std::string SteeringOffsetComment(const Estimate& offset, const std::string& controller) {
  return Formatted("# steering offset %.9g rad (sigma %.3g rad): the raw steering reading with the wheel\n",
                   offset.value, offset.std) +
         "# along x; " + controller + " has no parameter for it: subtract it in the steering joint's\n"
         "# hardware interface (or its transmission's offset)\n";
}

std::string DiffDriveYaml(const std::map<std::string, Estimate>& params) {
  const Estimate left = params.at("left_radius"), right = params.at("right_radius"), track = params.at("track");
  const double radius = 0.5 * (left.value + right.value);
  const double radius_std = 0.5 * std::hypot(left.std, right.std);  // the two are fitted apart
  return "diff_drive_controller:\n  ros__parameters:\n" +
         Formatted("    wheel_separation: %.9g  # sigma %.3g m\n", track.value, track.std) +
         Formatted("    wheel_radius: %.9g  # mean of left %.9g and right %.9g m;", radius, left.value, right.value) +
         Formatted(" sigma %.3g m\n", radius_std) +
         "    wheel_separation_multiplier: 1.0\n" +
         Formatted("    left_wheel_radius_multiplier: %.9g  # left_radius sigma %.3g m\n", left.value / radius,
                   left.std) +
         Formatted("    right_wheel_radius_multiplier: %.9g  # right_radius sigma %.3g m\n", right.value / radius,
                   right.std);
}

std::string TricycleYaml(const std::map<std::string, Estimate>& params) {
  const Estimate radius = params.at("drive_radius"), wheelbase = params.at("wheelbase");
  const Estimate offset = params.at("steer_offset");
  const std::string wheelbase_line = Formatted("    wheelbase: %.9g  # sigma %.3g m\n", wheelbase.value, wheelbase.std);
  auto radius_line = [&](const std::string& name) {
    return "    " + name + Formatted(": %.9g  # the steered drive wheel's; sigma %.3g m\n", radius.value, radius.std);
  };
  return "tricycle_controller:\n  ros__parameters:\n" + wheelbase_line +
         Formatted("    wheel_radius: %.9g  # sigma %.3g m\n", radius.value, radius.std) +
         SteeringOffsetComment(offset, "tricycle_controller") +
         "# The steering controllers library (ros2_control) takes its traction wheel on the fixed\n"
         "# axle: for a steered drive wheel its odometry is off by cos(steer) in turns, tricycle_controller\n"
         "# models this drive exactly. traction_wheel_radius from Kilted on, front/rear_wheel_radius before.\n"
         "bicycle_steering_controller:\n  ros__parameters:\n    front_steering: true\n" + wheelbase_line +
         radius_line("traction_wheel_radius") + radius_line("front_wheel_radius") +
         radius_line("rear_wheel_radius") + SteeringOffsetComment(offset, "bicycle_steering_controller");
}

RosMount LevelLidar(const std::string& robot_name, const std::string& parent, const std::string& lidar) {
  RosMount mount;
  mount.robot_name = robot_name;
  mount.parent = parent;
  mount.child = lidar;
  mount.uncalibrated = kLevelScan;
  return mount;
}

}  // namespace

RosMount Lidar2dRosMount(const RobotDescription& robot, const CalibrationResult& result, const std::string& lidar,
                         const std::string& option) {
  if (result.source != MotionSource::kLidar2d)
    throw InputError("command line", option, "needs the 2D lidar's mount: solve from the scans (--source lidar2d)");
  RosMount mount = LevelLidar(robot.name, RosBaseFrame(robot), lidar);
  mount.x = {result.mount_x.value, result.mount_x.std};
  mount.y = {result.mount_y.value, result.mount_y.std};
  mount.yaw = {result.mount_yaw.value, result.mount_yaw.std};
  return mount;
}

RosMount Lidar2dRosMount(const CalibrationInUse& in_use, const std::string& lidar, const std::string& option) {
  RosMount mount = LevelLidar(in_use.robot.name, RosBaseFrame(in_use.robot), lidar);
  int found = 0;
  for (size_t i = 0; i < in_use.names.size(); ++i) {
    const std::string& name = in_use.names[i];
    RosCoordinate* c = name == "lidar2d.x" ? &mount.x : name == "lidar2d.y" ? &mount.y
                     : name == "lidar2d.yaw" ? &mount.yaw : nullptr;
    if (!c) continue;
    *c = {in_use.value[static_cast<int>(i)], std::sqrt(in_use.covariance(static_cast<int>(i), static_cast<int>(i)))};
    ++found;
  }
  if (found != 3)
    throw InputError("command line", option, "needs the 2D lidar's mount: recalibrate from the scans (--source lidar2d)");
  return mount;
}

std::string DriveControllerYaml(const RobotDescription& robot, DriveType drive,
                                const std::map<std::string, Estimate>& params, const ResultProvenance& source,
                                const std::string& option) {
  const std::string provenance = ProvenanceLines("# ", robot.name, source);
  if (drive == DriveType::kDifferential) return provenance + DiffDriveYaml(params);
  if (drive == DriveType::kTricycle) return provenance + TricycleYaml(params);
  throw InputError("command line", option,
                   "no ros2_control controller takes a dual steer drive's parameters (docs/ros.md)");
}

}  // namespace calib
