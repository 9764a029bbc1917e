#pragma once
// `agvcal solve` and `agvcal recal`'s results in the files a ROS integrator puts them in
// (docs/ros.md): the 2D lidar's mount for io/ros_files.h (URDF joint, static transform launch),
// and the ros2_control drive controllers' parameters. Frame names: the robot file's
// ros.base_frame (base_link when there is no ros: block) and `lidar_frame`.

#include <map>
#include <string>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/recalibration.h"
#include "calib/core/robot.h"
#include "calib/core/statistics.h"
#include "calib/io/ros_files.h"

namespace calib {

// The calibrated 2D lidar mount: x, y, yaw with their sigmas; z, roll, pitch 0 (the scan plane
// is level). Throws InputError (command line, `option`) when the result has no 2D lidar mount
// (solved from an external pose or the IMU).
RosMount Lidar2dRosMount(const RobotDescription& robot, const CalibrationResult& result,
                         const std::string& lidar_frame, const std::string& option);
// The same from a recalibration's calibration in use (its values and the covariance's diagonal).
RosMount Lidar2dRosMount(const CalibrationInUse& in_use, const std::string& lidar_frame, const std::string& option);

// ros2_control parameters (YAML): diff_drive_controller (wheel_separation, wheel_radius = the
// mean radius, left/right_wheel_radius_multiplier) for a differential drive; for a tricycle
// tricycle_controller (wheelbase, wheel_radius) and the steering controllers library's
// bicycle_steering_controller (wheelbase and the radii, both the older and the newer parameter
// names), the steering offset as a comment (neither has a parameter for it). `params`: the drive
// parameters with their sigmas (spec/robot.md names). Throws InputError (command line, `option`)
// for a dual steer drive.
std::string DriveControllerYaml(const RobotDescription& robot, DriveType drive,
                                const std::map<std::string, Estimate>& params, const ResultProvenance& source,
                                const std::string& option = "--write-controller");

}  // namespace calib
