#pragma once
// `agvcal ground`'s result as a ROS mount (io/ros_files.h: URDF joint, static transform launch,
// Autoware's sensors_calibration.yaml).

#include <string>

#include "calib/core/robot.h"
#include "calib/ground/ground.h"
#include "calib/io/ros_files.h"

namespace calib {

// The 3D lidar's mount in the base frame: z, pitch, roll calibrated from the floor (with their
// sigmas; a turning lidar: the estimate of the sector holding angle 0), x, y, yaw the robot
// file's lidar3d. z is the height above the floor, so the base frame is taken to lie on the
// floor (REP-120's base_footprint).
RosMount Lidar3dRosMount(const RobotDescription& robot, const GroundResult& result, const std::string& lidar_frame);

}  // namespace calib
