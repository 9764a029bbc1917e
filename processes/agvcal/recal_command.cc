#include <cstdio>
#include <iostream>
#include <vector>

#include "calib/calibrate/calibration_report.h"
#include "calib/calibrate/ros_results.h"
#include "calib/calibrate/recalibration.h"
#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"
#include "calib/io/log_summary.h"
#include "commands.h"
#include "common/process_util.h"
#include "common/provenance.h"
#include "common/ros_outputs.h"

namespace agvcal_cli {

namespace {
const agvcal_process::RosOutputs kRosOutputs{false, false, "laser"};

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Recalibration during normal operation, on a recording: what agvcal-recal does
live, with the same decisions. Segments of the route (zones of the config in the
POSE frame, or odometry distance windows) are collected; every `decision.segments`
of them the robot is calibrated on some and the result compared with the
calibration in use on the others; it is accepted only when significantly better
there and consistent with the calibration in use (docs/recalibration.md).)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md)")
      .Positional("LOG", "the recording (lcm-logger)")
      .Option("--config", "RECAL.yaml", "zones or distance windows, decision levels, prior\n"
              "uncertainties (required)")
      .Option("--out-robot", "CAL.yaml",
              "the accepted calibration, as a robot file (written atomically);\n"
              "when it exists, the calibration in use starts from it")
      .Option("--decisions", "FILE", "every decision appended as a JSON line (atomically)")
      .Option("--source", "lidar2d|pose",
              "the sensor whose motion calibrates (default lidar2d if the robot\n"
              "file has one, else pose)")
      .Option("--report", "DIR",
              "human report (docs/reports.md): the decisions, the calibration in\n"
              "use at the start and the end, every decision's held-out segments,\n"
              "and the residual, route and parameter plots of the last fit");
  agvcal_process::DeclareRosOutputs(args, kRosOutputs);
  args->Footer("Prints one line per decision.\n"
               "Exit status: 0 done (whatever was decided); 2 unusable input (robot file, config,\n"
               "log); 1 internal error.\n");
}
}  // namespace

int Recal(int argc, char** argv) {
  agvcal_process::CommandLine args("agvcal recal");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 2)) return *status;
  if (!args.Has("--config")) throw calib::InputError("command line", "--config", "missing (the recalibration config)");
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  agvcal_process::RecordProvenance(args, &robot, args.positional[1]);
  const calib::RecalConfig config = calib::LoadRecalConfig(args.Get("--config", ""));
  const calib::MotionSource source =
      agvcal_process::MotionSourceOption(args, {calib::MotionSource::kLidar2d, calib::MotionSource::kPose},
                                         agvcal_process::LiveMotionSource(robot))
          .value();
  if (agvcal_process::WantsRosMount(args, kRosOutputs) && source != calib::MotionSource::kLidar2d)
    throw calib::InputError("command line", args.Has("--write-urdf") ? "--write-urdf" : "--write-tf",
                            "needs the 2D lidar's mount: recalibrate from the scans (--source lidar2d)");
  const std::string robot_out = args.Get("--out-robot", ""), decisions = args.Get("--decisions", "");
  const calib::CalibrationInUse start = calib::StartingCalibration(robot, robot_out, source, config);
  std::vector<calib::OutputTarget> outputs_asked = {
      {"--out-robot", robot_out}, {"--decisions", decisions}, {"--report", args.Get("--report", ""), true}};
  for (calib::OutputTarget& target : agvcal_process::RosOutputTargets(args, kRosOutputs)) outputs_asked.push_back(target);
  calib::CheckOutputs({args.positional[0], args.positional[1], args.Get("--config", "")},  // exit 2 before the work
                      outputs_asked);
  std::printf("calibration in use: %s\n", start.origin.c_str());
  const calib::RecalRun run = calib::RecalibrateLog(
      robot, start, args.positional[1], source, config, [&](const calib::RecalDecision& d) {
        calib::RecordDecision(d, robot_out, decisions);
        std::printf("decision %d: %s: %s\n", d.number, calib::VerdictName(d.verdict), d.reason.c_str());
        std::fflush(stdout);
      });
  std::printf("%d segments (%d dropped as too short, %d waiting for a decision), %zu decisions\n",
              run.segments, run.dropped, run.waiting, run.decisions.size());
  calib::Outputs outputs;  // put in place together, only when all were written
  if (args.Has("--report"))
    calib::WriteRecalReportDir(start, run, args.positional[1],
                               calib::RecordingStartUtime(calib::SummarizeLog(args.positional[1])),
                               outputs.ReportDir(args.Get("--report", "")));
  // The calibration in use at the end: the last one accepted, or the one the run started from.
  if (agvcal_process::WantsRosMount(args, kRosOutputs)) {
    const std::string option = args.Has("--write-urdf") ? "--write-urdf" : "--write-tf";
    calib::ResultProvenance provenance = calib::RecordingProvenance(args.positional[1], "agvcal recal");
    provenance.note = "the calibration in use at the end of the recording: " + run.in_use.origin;
    const calib::RosMount mount =
        calib::Lidar2dRosMount(run.in_use, agvcal_process::LidarFrame(args, kRosOutputs), option);
    agvcal_process::WriteRosMount(args, kRosOutputs, mount, provenance, &outputs);
  }
  outputs.Commit();
  return calib::kExitOk;
}

}  // namespace agvcal_cli
