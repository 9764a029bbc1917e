#pragma once
// `agvcal solve`'s results in the files a ROS integrator puts them in (docs/ros.md): the 2D
// lidar's joint for a URDF, a static transform launch file, and the ros2_control drive
// controller's parameters. Each names the recording (path, SHA-256, start date) and gives every
// value's sigma in a comment; values are written with 9 significant digits. Frame names: the
// robot file's ros.base_frame (base_link when there is no ros: block) and `lidar_frame`.

#include <cstdint>
#include <string>

#include "calib/calibrate/calibration.h"
#include "calib/core/robot.h"

namespace calib {

// The recording a result came from, as the files name it.
struct ResultProvenance {
  std::string log_path;
  std::string sha256;      // of the recording's bytes, hex
  int64_t start_utime = 0; // its first message
};
// Reads the recording; throws InputError when it cannot.
ResultProvenance RecordingProvenance(const std::string& log_path);

// <robot> with base and lidar links and the fixed joint between them: origin xyz = (x, y, 0),
// rpy = (0, 0, yaw) of the calibrated lidar2d mount. Throws InputError (command line, `option`)
// when the result has no 2D lidar mount (solved from an external pose or the IMU).
std::string LidarUrdf(const RobotDescription& robot, const CalibrationResult& result,
                      const ResultProvenance& source, const std::string& lidar_frame,
                      const std::string& option = "--write-urdf");

// A ROS 2 launch file (XML) running tf2_ros' static_transform_publisher with the same transform.
std::string LidarStaticTfLaunch(const RobotDescription& robot, const CalibrationResult& result,
                                const ResultProvenance& source, const std::string& lidar_frame,
                                const std::string& option = "--write-tf");

// ros2_control parameters (YAML): diff_drive_controller (wheel_separation, wheel_radius = the
// mean radius, left/right_wheel_radius_multiplier) for a differential drive, tricycle_controller
// (wheelbase, wheel_radius; the steering offset as a comment, the controller has no parameter
// for it) for a tricycle. Throws InputError (command line, `option`) for a dual steer drive.
std::string DriveControllerYaml(const RobotDescription& robot, const CalibrationResult& result,
                                const ResultProvenance& source,
                                const std::string& option = "--write-controller");

}  // namespace calib
