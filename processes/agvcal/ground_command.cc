#include <iostream>
#include <vector>

#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/ground/ground.h"
#include "calib/ground/ground_ros.h"
#include "calib/ground/ground_session.h"
#include "calib/io/atomic_file.h"
#include "commands.h"
#include "common/process_util.h"
#include "common/provenance.h"
#include "common/ros_outputs.h"

namespace agvcal_cli {

namespace {
const agvcal_process::RosOutputs kRosOutputs{false, true, "lidar"};

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Calibrates the 3D lidar's height, pitch and roll above the floor (robot file
lidar3d) from the CLOUD messages of a recording, or from one PCD file (.pcd) or
KITTI Velodyne frame (.bin). Points inside lidar3d.body are the robot itself;
the floor plane is found by sample consensus and refined by least squares in
every frame, and the frames are combined. The grid search over (z, pitch, roll)
runs as a cross-check; both estimates are printed side by side. A lidar that
turns on its mount (lidar3d.rotation) gets one estimate per sector of its
rotation range. Method and options: docs/ground.md.)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md), with lidar3d")
      .Positional("LOG|CLOUD_FILE", "a recording with CLOUD messages, a PCD file or a KITTI .bin frame")
      .Option("--out", "RESULT.json", "write the result (docs/spec/cli.md, plus grid and sectors), atomically")
      .Option("--write-robot", "FILE",
              "write ROBOT.yaml back with lidar3d z, pitch, roll calibrated\n"
              "(m, rad), its comments and layout kept, each value rounded to its sigma;\n"
              "std: and source: added (docs/spec/robot.md)")
      .Option("--config", "FILE", "options (defaults and every key: config/ground.yaml)")
      .Flag("--no-grid", "skip the grid search")
      .Option("--report", "DIR",
              "human report (docs/reports.md): index.html, summary.txt and SVG plots\n"
              "of the floor points coloured by their height above the calibrated\n"
              "floor, every frame's fit, the mount and per-sector tables")
      .Flag("--quiet", "no table on stdout");
  agvcal_process::DeclareRosOutputs(args, kRosOutputs);
  args->Footer("Exit status: 0 calibrated, 2 unusable input (names file, place, problem), 3 the\n"
              "floor does not determine the answer (too little floor in view, the robot among\n"
              "obstacles, a floor that tilts between frames, a sector without data), 1 internal.\n");
}
}  // namespace

int Ground(int argc, char** argv) {
  agvcal_process::CommandLine args("agvcal ground");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 2)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  agvcal_process::RecordProvenance(args, &robot, args.positional[1]);
  const calib::GroundOptions options =
      args.Has("--config") ? calib::LoadGroundOptions(args.Get("--config", "")) : calib::GroundOptions{};
  std::vector<calib::OutputTarget> outputs_asked = {{"--out", args.Get("--out", "")},
      {"--write-robot", args.Get("--write-robot", "")}, {"--report", args.Get("--report", ""), true}};
  for (calib::OutputTarget& target : agvcal_process::RosOutputTargets(args, kRosOutputs)) outputs_asked.push_back(target);
  calib::CheckOutputs({args.positional[0], args.positional[1], args.Get("--config", "")},  // exit 2 before the work
                      outputs_asked);
  calib::GroundInput input;
  const calib::GroundResult result = calib::CalibrateGroundFile(
      robot, options, args.positional[1], !args.Has("--no-grid"), &input);
  for (const std::string& note : input.drop_notes) std::cerr << "agvcal ground: left out: " << note << "\n";
  if (input.dropped > static_cast<int64_t>(input.drop_notes.size()))
    std::cerr << "agvcal ground: left out: " << input.dropped << " messages in all\n";
  calib::Outputs outputs;  // put in place together, only when all were written
  if (args.Has("--out")) outputs.WriteFile(args.Get("--out", ""), calib::GroundResultJson(result, input));
  if (args.Has("--write-robot"))
    outputs.WriteFile(args.Get("--write-robot", ""),
                      calib::GroundCalibratedRobotYaml(robot, result, args.positional[1]));
  if (agvcal_process::WantsRosMount(args, kRosOutputs))
    agvcal_process::WriteRosMount(args, kRosOutputs,
                                  calib::Lidar3dRosMount(robot, result, agvcal_process::LidarFrame(args, kRosOutputs)),
                                  calib::RecordingProvenance(args.positional[1], "agvcal ground"), &outputs);
  if (args.Has("--report")) calib::WriteGroundReportDir(robot, result, input, outputs.ReportDir(args.Get("--report", "")));
  outputs.Commit();
  if (!args.Has("--quiet")) std::cout << calib::GroundResultText(result, input);
  return calib::kExitOk;
}

}  // namespace agvcal_cli
