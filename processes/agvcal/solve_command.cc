#include <cstdio>
#include <iostream>

#include "calib/errors.h"
#include "calib/result_files.h"
#include "calib/solve_log.h"
#include "commands.h"
#include "common/process_util.h"

namespace agvcal_cli {

namespace {
const char* kUsage = R"(usage: agvcal solve ROBOT.yaml LOG [--out RESULT.json] [--write-robot CALIBRATED.yaml]
                    [--source lidar2d|pose] [--time-offset] [--fit-fraction F] [--quiet]

Calibrates the drive parameters of ROBOT.yaml and the mount of its 2D lidar
(scans scan-matched) or of its external pose source (POSE) from a recording
with WHEELS, jointly, by maximum likelihood, with one-sigma uncertainties.
Prints a summary; RESULT.json follows spec/cli.md.
  --out RESULT.json          write the result (atomically)
  --write-robot FILE         write ROBOT.yaml back with the calibrated values, std: and source:
  --source lidar2d|pose      which sensor measures the motion (default: the lidar if scanned)
  --time-offset              also estimate the lidar-to-wheel time offset
  --fit-fraction F           fit on the first fraction F of the recording, and compare the
                             calibrated with the nominal model's odometry on the rest
  --quiet                    no progress on stderr
Exit status: 0 done; 2 unusable input; 3 the recording cannot determine a
parameter (stderr names it and the motion to add); 1 internal error.
)";

void PrintEstimate(const std::string& name, const calib::Estimate& e) {
  std::printf("  %-18s %12.6f  ± %-10.6f (nominal %.6f)\n", name.c_str(), e.value, e.std, e.nominal);
}
}  // namespace

int Solve(int argc, char** argv) {
  const auto args = agvcal_process::ParseArgs(
      argc, argv, 2, {"--out", "--write-robot", "--source", "--fit-fraction"}, {"--time-offset", "--quiet"});
  if (const auto status = agvcal_process::CheckUsage(args, kUsage, 2)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const std::string log_path = args.positional[1];

  calib::SolveLogOptions options;
  options.calibration.estimate_time_offset = args.Has("--time-offset");
  if (args.Has("--fit-fraction")) {
    options.calibration.fit_fraction = args.GetDouble("--fit-fraction", 1.0);
    if (!(options.calibration.fit_fraction > 0.0 && options.calibration.fit_fraction <= 1.0))
      throw calib::InputError("command line", "--fit-fraction", "expected a number in (0, 1]");
  }
  if (args.Has("--source")) {
    const std::string source = args.Get("--source", "");
    if (source == "lidar2d") options.source = calib::MotionSource::kLidar2d;
    else if (source == "pose") options.source = calib::MotionSource::kPose;
    else throw calib::InputError("command line", "--source", "expected lidar2d or pose, got '" + source + "'");
  }
  if (!args.Has("--quiet")) options.progress = [](const std::string& line) { std::cerr << line << "\n"; };

  const calib::CalibrationResult result = calib::SolveLog(robot, log_path, options);

  std::printf("%s drive, %d intervals (%d outliers), residual rms %.2f mm, %.2f mm, %.3f deg\n",
              calib::DriveTypeName(result.drive), result.residual.intervals, result.residual.outliers,
              result.residual.rms_x * 1e3, result.residual.rms_y * 1e3, result.residual.rms_yaw * 180 / M_PI);
  for (const std::string& name : result.param_names) PrintEstimate(name, result.params.at(name));
  const std::string mount = calib::MotionSourceName(result.source);
  PrintEstimate(mount + ".x", result.mount_x);
  PrintEstimate(mount + ".y", result.mount_y);
  PrintEstimate(mount + ".yaw", result.mount_yaw);
  if (result.time_offset) PrintEstimate("time_offset", *result.time_offset);
  if (!result.weak.empty()) {
    std::printf("  weakly determined:");
    for (const std::string& w : result.weak) std::printf(" %s", w.c_str());
    std::printf("\n");
  }
  if (result.heldout) {
    std::printf("held-out odometry error per metre: nominal %.4f, calibrated %.4f (%d windows)\n",
                result.heldout->nominal.error_per_metre, result.heldout->calibrated.error_per_metre,
                result.heldout->calibrated.windows);
  }
  if (args.Has("--out")) calib::WriteFileAtomically(args.Get("--out", ""), calib::CalibrationResultJson(result));
  if (args.Has("--write-robot")) {
    calib::WriteFileAtomically(args.Get("--write-robot", ""),
                               calib::CalibratedRobotYaml(robot, result, log_path));
  }
  return calib::kExitOk;
}

}  // namespace agvcal_cli
