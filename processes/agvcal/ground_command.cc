#include <iostream>

#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/ground/ground.h"
#include "calib/ground/ground_session.h"
#include "calib/io/atomic_file.h"
#include "commands.h"
#include "common/process_util.h"

namespace agvcal_cli {

namespace {
const char* kUsage =
    R"(usage: agvcal ground ROBOT.yaml LOG|CLOUD_FILE [--out RESULT.json] [--write-robot CALIBRATED.yaml]
                     [--config GROUND.yaml] [--no-grid] [--report DIR] [--quiet]

Calibrates the 3D lidar's height, pitch and roll above the floor (robot file
lidar3d) from the CLOUD messages of a recording, or from one PCD file (.pcd) or
KITTI Velodyne frame (.bin). Points inside lidar3d.body are the robot itself;
the floor plane is found by sample consensus and refined by least squares in
every frame, and the frames are combined. The grid search over (z, pitch, roll)
runs as a cross-check; both estimates are printed side by side. A lidar that
turns on its mount (lidar3d.rotation) gets one estimate per sector of its
rotation range. Method and options: docs/ground.md.
  --out RESULT.json    write the result (spec/cli.md, plus grid and sectors), atomically
  --write-robot FILE   write ROBOT.yaml back with lidar3d z, pitch, roll calibrated (m, rad),
                       its comments and layout kept, each value rounded to its sigma;
                       std: and source: added (spec/robot.md)
  --config FILE        options (defaults and every key: config/ground.yaml)
  --no-grid            skip the grid search
  --report DIR         human report (docs/reports.md): index.html, summary.txt and SVG plots
                       of the floor points coloured by their height above the calibrated
                       floor, every frame's fit, the mount and per-sector tables
  --quiet              no table on stdout
Exit status: 0 calibrated, 2 unusable input (names file, place, problem), 3 the
floor does not determine the answer (too little floor in view, the robot among
obstacles, a floor that tilts between frames, a sector without data), 1 internal.
)";
}  // namespace

int Ground(int argc, char** argv) {
  const auto args = agvcal_process::ParseArgs(argc, argv, 2, {"--out", "--write-robot", "--config", "--report"},
                                              {"--no-grid", "--quiet"});
  if (const auto status = agvcal_process::CheckUsage(args, kUsage, 2)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const calib::GroundOptions options =
      args.Has("--config") ? calib::LoadGroundOptions(args.Get("--config", "")) : calib::GroundOptions{};
  calib::CheckOutputs({args.positional[0], args.positional[1], args.Get("--config", "")},  // exit 2 before the work
      {{"--out", args.Get("--out", "")}, {"--write-robot", args.Get("--write-robot", "")}, {"--report", args.Get("--report", ""), true}});
  calib::GroundInput input;
  const calib::GroundResult result = calib::CalibrateGroundFile(
      robot, options, args.positional[1], !args.Has("--no-grid"), &input);
  calib::Outputs outputs;  // put in place together, only when all were written
  if (args.Has("--out")) outputs.WriteFile(args.Get("--out", ""), calib::GroundResultJson(result, input));
  if (args.Has("--write-robot"))
    outputs.WriteFile(args.Get("--write-robot", ""),
                      calib::GroundCalibratedRobotYaml(robot, result, args.positional[1]));
  if (args.Has("--report")) calib::WriteGroundReportDir(robot, result, input, outputs.ReportDir(args.Get("--report", "")));
  outputs.Commit();
  if (!args.Has("--quiet")) std::cout << calib::GroundResultText(result, input);
  return calib::kExitOk;
}

}  // namespace agvcal_cli
