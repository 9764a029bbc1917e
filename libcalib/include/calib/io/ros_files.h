#pragma once
// A calibrated sensor mount in the files a ROS integrator puts it in (docs/ros.md): a URDF fixed
// joint, a ROS 2 launch file running tf2_ros' static_transform_publisher, and Autoware's
// sensors_calibration.yaml form. Each names the command and the input (path, SHA-256, date of
// its first message) and gives every calibrated value's sigma in a comment; values are written
// with 9 significant digits. The mounts come from calibrate/ros_results.h (the 2D lidar) and
// ground/ground_ros.h (the 3D lidar).

#include <cstdint>
#include <optional>
#include <string>

#include "calib/core/robot.h"

namespace calib {

// The input a result came from, as the files name it.
struct ResultProvenance {
  std::string command = "agvcal solve";  // the command that wrote the file
  std::string log_path;
  std::string sha256;                   // of the input's bytes, hex
  std::optional<int64_t> start_utime;  // its first message (none for a PCD or KITTI file)
  std::string note;                     // a line more, when not empty
};
// Hashes the input (and, for a recording, reads its first message's time); throws InputError
// when it cannot.
ResultProvenance RecordingProvenance(const std::string& log_path, const std::string& command = "agvcal solve");

// The lines naming the command, the robot and the input, each between `lead` and "\n".
std::string ProvenanceLines(const std::string& lead, const std::string& robot_name, const ResultProvenance& source);
// printf of up to three numbers into a short line.
std::string Formatted(const char* format, double a, double b = 0.0, double c = 0.0);

// The base frame of the ROS files: the robot file's ros.base_frame, base_link without a ros: block.
std::string RosBaseFrame(const RobotDescription& robot);

// One coordinate of a mount: its value, with its sigma when calibrated.
struct RosCoordinate {
  double value = 0.0;
  std::optional<double> sigma;
};
// A sensor's mount in the base frame: translation (m) and roll, pitch, yaw (rad; orientation
// Rz(yaw) Ry(pitch) Rx(roll), URDF's rpy).
struct RosMount {
  std::string robot_name, parent, child;
  RosCoordinate x, y, z, roll, pitch, yaw;
  std::string uncalibrated;  // what the coordinates without a sigma are ("not calibrated (...)")
};

// <robot> with the parent and child links and the fixed joint `<child>_joint` between them.
std::string MountUrdf(const RosMount& mount, const ResultProvenance& source);
// A ROS 2 launch file (XML) running static_transform_publisher with the same transform.
std::string MountStaticTfLaunch(const RosMount& mount, const ResultProvenance& source);
// Autoware's sensors_calibration.yaml form: parent: child: {x, y, z, roll, pitch, yaw}.
std::string MountAutowareYaml(const RosMount& mount, const ResultProvenance& source);

}  // namespace calib
