#include <cstdio>
#include <iostream>

#include "calib/calibrate/calibration_report.h"
#include "calib/calibrate/recalibration.h"
#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"
#include "calib/io/log_summary.h"
#include "commands.h"
#include "common/process_util.h"
#include "common/provenance.h"

namespace agvcal_cli {

namespace {
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
              "and the residual, route and parameter plots of the last fit")
      .Footer("Prints one line per decision.\n"
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
  const std::string robot_out = args.Get("--out-robot", ""), decisions = args.Get("--decisions", "");
  const calib::CalibrationInUse start = calib::StartingCalibration(robot, robot_out, source, config);
  calib::CheckOutputs({args.positional[0], args.positional[1], args.Get("--config", "")}, {{"--out-robot", robot_out},
      {"--decisions", decisions}, {"--report", args.Get("--report", ""), true}});  // exit 2 before the work
  std::printf("calibration in use: %s\n", start.origin.c_str());
  const calib::RecalRun run = calib::RecalibrateLog(
      robot, start, args.positional[1], source, config, [&](const calib::RecalDecision& d) {
        calib::RecordDecision(d, robot_out, decisions);
        std::printf("decision %d: %s: %s\n", d.number, calib::VerdictName(d.verdict), d.reason.c_str());
        std::fflush(stdout);
      });
  std::printf("%d segments (%d dropped as too short, %d waiting for a decision), %zu decisions\n",
              run.segments, run.dropped, run.waiting, run.decisions.size());
  if (args.Has("--report")) {
    calib::Outputs outputs;
    calib::WriteRecalReportDir(start, run, args.positional[1],
                               calib::RecordingStartUtime(calib::SummarizeLog(args.positional[1])),
                               outputs.ReportDir(args.Get("--report", "")));
    outputs.Commit();
  }
  return calib::kExitOk;
}

}  // namespace agvcal_cli
