#pragma once
// The ROS result files' options (docs/ros.md), declared and written the same way by `agvcal
// solve`, `ground` and `recal`: --write-urdf and --write-tf for every one of them, the
// controller parameters where drive parameters are calibrated, Autoware's form for the 3D lidar.

#include <string>
#include <vector>

#include "calib/io/atomic_file.h"
#include "calib/io/ros_files.h"
#include "common/command_line.h"

namespace agvcal_process {

struct RosOutputs {
  bool controller = false;  // --write-controller
  bool autoware = false;    // --write-autoware
  std::string lidar_default = "laser";  // --lidar-frame's default
};

void DeclareRosOutputs(CommandLine* args, const RosOutputs& which);
// Those given, for calib::CheckOutputs.
std::vector<calib::OutputTarget> RosOutputTargets(const CommandLine& args, const RosOutputs& which);
// Whether any of the mount's files (URDF, tf, Autoware) was asked for.
bool WantsRosMount(const CommandLine& args, const RosOutputs& which);
// --lidar-frame or the default of `which`.
std::string LidarFrame(const CommandLine& args, const RosOutputs& which);
// Writes the mount's files that were asked for into `outputs`.
void WriteRosMount(const CommandLine& args, const RosOutputs& which, const calib::RosMount& mount, const calib::ResultProvenance& source,
                   calib::Outputs* outputs);

}  // namespace agvcal_process
