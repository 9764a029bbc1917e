#include "common/ros_outputs.h"

namespace agvcal_process {

void DeclareRosOutputs(CommandLine* args, const RosOutputs& which) {
  args->Option("--write-urdf", "FILE", "ROS: the lidar's fixed joint (URDF), sigma and recording in\n"
               "comments (docs/ros.md)")
      .Option("--write-tf", "FILE", "ROS 2: a launch file publishing the lidar's static transform");
  if (which.autoware)
    args->Option("--write-autoware", "FILE", "Autoware: the lidar's mount in sensors_calibration.yaml form");
  if (which.controller)
    args->Option("--write-controller", "FILE",
                 "ROS 2: ros2_control diff_drive_controller / tricycle_controller and\n"
                 "bicycle_steering_controller parameters");
  args->Option("--lidar-frame", "NAME", "the lidar's frame in those files (default " + which.lidar_default +
               "; the base:\nthe robot file's ros.base_frame, default base_link)");
}

std::vector<calib::OutputTarget> RosOutputTargets(const CommandLine& args, const RosOutputs& which) {
  std::vector<calib::OutputTarget> targets = {{"--write-urdf", args.Get("--write-urdf", "")},
                                              {"--write-tf", args.Get("--write-tf", "")}};
  if (which.autoware) targets.push_back({"--write-autoware", args.Get("--write-autoware", "")});
  if (which.controller) targets.push_back({"--write-controller", args.Get("--write-controller", "")});
  return targets;
}

bool WantsRosMount(const CommandLine& args, const RosOutputs& which) {
  return args.Has("--write-urdf") || args.Has("--write-tf") || (which.autoware && args.Has("--write-autoware"));
}

std::string LidarFrame(const CommandLine& args, const RosOutputs& which) {
  return args.Get("--lidar-frame", which.lidar_default);
}

void WriteRosMount(const CommandLine& args, const RosOutputs& which, const calib::RosMount& mount, const calib::ResultProvenance& source,
                   calib::Outputs* outputs) {
  if (args.Has("--write-urdf")) outputs->WriteFile(args.Get("--write-urdf", ""), calib::MountUrdf(mount, source));
  if (args.Has("--write-tf"))
    outputs->WriteFile(args.Get("--write-tf", ""), calib::MountStaticTfLaunch(mount, source));
  if (which.autoware && args.Has("--write-autoware"))
    outputs->WriteFile(args.Get("--write-autoware", ""), calib::MountAutowareYaml(mount, source));
}

}  // namespace agvcal_process
