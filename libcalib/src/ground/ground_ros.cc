#include "calib/ground/ground_ros.h"

namespace calib {

RosMount Lidar3dRosMount(const RobotDescription& robot, const GroundResult& result, const std::string& lidar) {
  const Mount3d& nominal = *robot.lidar3d;  // ground refuses a robot file without lidar3d before
  const MountEstimate& e = result.lidar3d;
  RosMount mount;
  mount.robot_name = robot.name;
  mount.parent = RosBaseFrame(robot);
  mount.child = lidar;
  mount.x.value = nominal.x;
  mount.y.value = nominal.y;
  mount.yaw.value = nominal.yaw;
  mount.z = {e.value.z, e.std.z};
  mount.pitch = {e.value.pitch, e.std.pitch};
  mount.roll = {e.value.roll, e.std.roll};
  mount.uncalibrated = "the robot file's lidar3d (the floor does not determine them)";
  return mount;
}

}  // namespace calib
