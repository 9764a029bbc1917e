#include <cmath>
#include <iostream>
#include <optional>

#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"
#include "calib/core/robot_file_edit.h"
#include "calib/core/robot.h"
#include "calib/import/importers.h"
#include "commands.h"
#include "common/command_line.h"

namespace agvcal_cli {

namespace {
// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Turns a dataset recorded elsewhere into an lcm-logger recording of the messages
of docs/spec/messages.md (WHEELS, SCAN, POSE), so that it can be calibrated like a
live recording. INPUT may be gzip-compressed. OUT.log is written atomically.)")
      .Positional("FORMAT", "carmen, mines, lego, optiodom, pose-csv, rosbag2 or rosbag\n(below)")
      .Positional("INPUT", "the dataset's file (rosbag2: or the bag's directory)")
      .Positional("OUT.log", "the recording to write")
      .Option("--robot", "ROBOT.yaml",
              "robot file (docs/spec/robot.md): wheel names, nominal values,\n"
              "channels; required except for pose-csv. Bundled:\n"
              "config/robots/datasets/*.yaml (docs/datasets.md)")
      .Option("--write-robot", "FILE",
              "rosbag2, rosbag: ROBOT.yaml with lidar2d x, y, yaw set from the bag's\n"
              "tf_static (ros.base_frame -> the scan's frame): the nominal mount\n"
              "calibration starts from (docs/ros.md)")
      .Flag("--quiet", "no summary on stderr")
      .Footer("FORMAT:\n"
              "  carmen    CARMEN log: FLASER/RAWLASER1 -> SCAN; ODOM (or the odometry in the\n"
              "            FLASER lines) -> WHEELS of a differential drive, inverted with the\n"
              "            robot file's nominal radii and track\n"
              "  mines     Mines rover log (CoreSLAM exp*.dat): ticks -> WHEELS, URG -> SCAN\n"
              "  lego      Brenner's Lego robot: INPUT = the motor file; the scan file beside\n"
              "            it (motors -> scan in the name) -> SCAN\n"
              "  optiodom  OptiOdom run <id>_run-NN.csv (metadata file beside it): ticks and\n"
              "            steering -> WHEELS, OptiTrack ground truth -> POSE\n"
              "  pose-csv  external poses: time,x,y,theta[,3 variances | 9 covariances];\n"
              "            integer time = us, decimal = s; '#' comments, optional header\n"
              "  rosbag2   ROS 2 bag: its directory, an .mcap or a .db3 file; rosbag: a ROS 1\n"
              "            .bag. The robot file's ros: block names the topics: joint_states ->\n"
              "            WHEELS, scan -> SCAN, imu -> IMU, odom -> POSE (or, as: wheels, a\n"
              "            differential drive's WHEELS), cmd_vel -> DRIVE_CMD, tf_static noted;\n"
              "            header stamps unless ros.stamps: record (docs/ros.md)\n"
              "Records repeating their predecessor's stamp are dropped and counted; a stamp\n"
              "going backwards, a malformed line or a truncated file is an error naming the\n"
              "file and line (exit 2).\n"
              "Exit status: 0 written; 2 unusable input (one line naming the file, the place and\n"
              "the problem); 1 internal error.\n");
}
}  // namespace

int Import(int argc, char** argv) {
  agvcal_process::CommandLine args("agvcal import");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 2)) return *status;
  const std::string& format = args.positional[0];
  std::optional<calib::RobotDescription> robot;
  if (args.Has("--robot")) robot = calib::LoadRobotFile(args.Get("--robot", ""));
  // On any error the writer's destructor removes the partial output.
  const std::string robot_out = args.Get("--write-robot", "");
  if (!robot_out.empty() && (!robot || (format != "rosbag2" && format != "rosbag")))
    throw calib::InputError("command line", "--write-robot", "only for rosbag2 and rosbag, with --robot");
  calib::CheckOutputs({args.positional[1], args.Get("--robot", "")},
                      {{"OUT.log", args.positional[2]}, {"--write-robot", robot_out}});
  calib::LogWriter writer(args.positional[2]);
  const calib::ImportSummary summary =
      calib::Import(format, args.positional[1], robot ? &*robot : nullptr, &writer);
  if (!robot_out.empty()) {
    if (!summary.scan_mount_tf)
      throw calib::InputError(args.positional[1], "tf_static",
                              "no transform from the base frame to the scan's frame for --write-robot");
    const auto& [x, y, yaw] = *summary.scan_mount_tf;
    calib::Outputs outputs;
    outputs.WriteFile(robot_out, calib::WriteCalibratedRobotFile(
                                     robot->source_file,
                                     {{"lidar2d.x", x, NAN, 9}, {"lidar2d.y", y, NAN, 9}, {"lidar2d.yaw", yaw, NAN, 9}},
                                     "import", args.positional[1], "lidar2d x, y, yaw: the bag's tf_static"));
    writer.Close();
    outputs.Commit();
  } else {
    writer.Close();
  }
  if (!args.Has("--quiet")) {
    std::cerr << "imported " << summary.lines << " lines of " << args.positional[1] << " -> "
              << args.positional[2] << " (" << (summary.last_utime - summary.first_utime) * 1e-6
              << " s)\n";
    for (const auto& [channel, count] : summary.messages)
      std::cerr << "  " << channel << ": " << count << " messages\n";
    if (summary.duplicates_dropped)
      std::cerr << "  warning: dropped " << summary.duplicates_dropped
                << " records repeating their predecessor's stamp\n";
    for (const auto& note : summary.notes) std::cerr << "  note: " << note << "\n";
  }
  return calib::kExitOk;
}

}  // namespace agvcal_cli
