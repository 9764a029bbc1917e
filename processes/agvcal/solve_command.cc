#include <cmath>
#include <cstdio>
#include <iostream>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/calibration_report.h"
#include "calib/calibrate/heldout.h"
#include "calib/calibrate/result_files.h"
#include "calib/calibrate/ros_results.h"
#include "calib/calibrate/recording_input.h"
#include "calib/core/errors.h"
#include "calib/core/statistics.h"
#include "calib/io/atomic_file.h"
#include "calib/io/log_summary.h"
#include "calib/core/units.h"
#include "commands.h"
#include "common/process_util.h"
#include "common/provenance.h"
#include "common/ros_outputs.h"

namespace agvcal_cli {

namespace {
const agvcal_process::RosOutputs kRosOutputs{true, false, "laser"};

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Calibrates the drive parameters of ROBOT.yaml and the mount of its 2D lidar
(scans scan-matched) or of its external pose source (POSE) from a recording
with WHEELS, jointly, by maximum likelihood, with one-sigma uncertainties.
Scans are matched twice: the second time de-skewed with the first fit's values.
A differential drive with an IMU and no lidar (source imu, docs/imu.md) is
calibrated with the gyro as the rotation reference and a measured distance as
the scale, with the gyro's bias, scale (given a measured turn), mount yaw and
time offset. Prints a summary; RESULT.json follows docs/spec/cli.md.)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md)")
      .Positional("LOG", "the recording (lcm-logger)")
      .Option("--out", "RESULT.json", "write the result (atomically)")
      .Option("--write-robot", "FILE", "write ROBOT.yaml back with the calibrated values, std: and source:")
      .Option("--report", "DIR",
              "human report (docs/reports.md): index.html, summary.txt and SVG\n"
              "plots of the residual over time and its histogram with the robot\n"
              "file's values and calibrated, the held-out windows, the route, the\n"
              "parameters with sigmas and units, the observability")
      .Option("--source", "lidar2d|pose|imu",
              "which sensor measures the motion (default: the lidar if scanned,\n"
              "else external poses, else the IMU)")
      .Option("--distance", "METRES", "imu: measured length of the first straight run\n"
              "(default imu.distance)")
      .Option("--distance-std", "METRES", "imu: its one sigma (default 0.001)")
      .Option("--turn-angle", "DEG",
              "imu: measured angle of the first turn in place; calibrates the\n"
              "gyro scale (without it the scale stays at imu.gyro_scale)")
      .Flag("--time-offset",
            "also estimate the lidar-to-wheel time offset (within +-0.5 s,\n"
            "searched again over twice the range, up to +-2 s, when it\n"
            "lies at the bound: a global search, then the joint fit; the\n"
            "same estimate agvcal diagnose starts from); the scans' second\n"
            "matching is then on the wheel clock, at the offset found")
      .Option("--fit-fraction", "F",
              "fit on the first fraction F of the recording, and compare the\n"
              "calibrated with the nominal model's odometry on the rest:\n"
              "windows of equal path, the longest that give N windows\n"
              "(--heldout-windows, default 20), paired by a sign test;\n"
              "also fits the rest alone and says whether the halves agree")
      .Option("--heldout-windows", "N", "the number of held-out windows of --fit-fraction (default 20)");
  agvcal_process::DeclareRosOutputs(args, kRosOutputs);
  args->Flag("--quiet", "no progress on stderr")
      .Footer("Exit status: 0 done; 2 unusable input; 3 the recording cannot determine a\n"
              "parameter (stderr names it and the motion to add); 1 internal error.\n");
}

// --write-urdf, --write-tf, --write-controller (calib/calibrate/ros_results.h).
void WriteRosResults(const agvcal_process::CommandLine& args, const calib::RobotDescription& robot,
                     const calib::CalibrationResult& result, const std::string& log_path,
                     calib::Outputs* outputs) {
  if (!agvcal_process::WantsRosMount(args, kRosOutputs) && !args.Has("--write-controller")) return;
  const calib::ResultProvenance source = calib::RecordingProvenance(log_path);
  if (agvcal_process::WantsRosMount(args, kRosOutputs)) {
    const std::string option = args.Has("--write-urdf") ? "--write-urdf" : "--write-tf";
    const calib::RosMount mount =
        calib::Lidar2dRosMount(robot, result, agvcal_process::LidarFrame(args, kRosOutputs), option);
    agvcal_process::WriteRosMount(args, kRosOutputs, mount, source, outputs);
  }
  if (args.Has("--write-controller"))
    outputs->WriteFile(args.Get("--write-controller", ""),
                       calib::DriveControllerYaml(robot, result.drive, result.params, source));
}
}  // namespace

int Solve(int argc, char** argv) {
  agvcal_process::CommandLine args("agvcal solve");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 2)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const std::string log_path = args.positional[1];
  agvcal_process::RecordProvenance(args, &robot, log_path);

  calib::SolveLogOptions options;
  options.calibration.estimate_time_offset = args.Has("--time-offset");
  if (args.Has("--fit-fraction")) {
    options.calibration.fit_fraction = args.GetDouble("--fit-fraction", 1.0);
    if (!(options.calibration.fit_fraction > 0.0 && options.calibration.fit_fraction <= 1.0))
      throw calib::InputError("command line", "--fit-fraction", "expected a number in (0, 1]");
  }
  if (args.Has("--heldout-windows")) {
    const double n = args.GetDouble("--heldout-windows", 20);
    if (!(n >= 1 && n <= 1000 && n == std::floor(n)))
      throw calib::InputError("command line", "--heldout-windows", "expected a whole number in [1, 1000]");
    options.calibration.heldout_windows = static_cast<int>(n);
  }
  // Without --source: the one the recording calls for (calib::ChooseMotionSource).
  options.source = agvcal_process::MotionSourceOption(
      args, {calib::MotionSource::kLidar2d, calib::MotionSource::kPose, calib::MotionSource::kImu}, std::nullopt);
  auto positive = [&](const char* key) {
    const double v = args.GetDouble(key, 0.0);
    if (!(v > 0.0 && std::isfinite(v))) throw calib::InputError("command line", key, "expected a positive number");
    return v;
  };
  if (args.Has("--distance")) options.imu.distance_m = positive("--distance");
  if (args.Has("--distance-std")) options.imu.distance_std_m = positive("--distance-std");
  if (args.Has("--turn-angle")) options.imu.turn_angle_rad = positive("--turn-angle") * M_PI / 180.0;
  std::vector<calib::OutputTarget> outputs_asked = {{"--out", args.Get("--out", "")},
      {"--write-robot", args.Get("--write-robot", "")}, {"--report", args.Get("--report", ""), true}};
  for (calib::OutputTarget& target : agvcal_process::RosOutputTargets(args, kRosOutputs)) outputs_asked.push_back(target);
  calib::CheckOutputs({args.positional[0], log_path}, outputs_asked);  // before the work: exit 2 at once
  if (!args.Has("--quiet")) options.progress = [](const std::string& line) { std::cerr << line << "\n"; };

  const calib::CalibrationResult result = calib::SolveLog(robot, log_path, options);
  // Said even with --quiet: the result stands on less than the recording holds.
  for (const std::string& note : result.input_notes) std::cerr << "agvcal: left out: " << note << "\n";
  for (const std::string& warning : result.warnings) std::cerr << "agvcal: warning: " << warning << "\n";
  if (result.input_dropped > 0)
    std::cerr << "agvcal: " << result.input_dropped << " message(s) of " << log_path
              << " left out of the fit (RESULT.json input.notes)\n";

  std::printf("%s\n\n", calib::SolveVerdict(result).c_str());
  std::printf("%s", calib::CalibrationConsoleText(result).c_str());
  if (result.heldout) {
    const calib::HeldoutComparison& h = *result.heldout;
    std::printf("held-out odometry error per metre: nominal %.2f mm/m, calibrated %.2f mm/m (%d windows of %.2f m)\n",
                h.nominal.error_per_metre * 1e3, h.calibrated.error_per_metre * 1e3, h.calibrated.windows, h.window_m);
    std::printf("  calibrated better in %d of %d windows (sign test %s); end error %+.4f ± %.4f m\n",
                h.paired.second_better, h.paired.windows - h.paired.ties, calib::PValueText(h.paired.sign_test_p).c_str(),
                h.paired.mean_difference, h.paired.difference_sem);
    const char* range_unit = h.coverage.regressor == "steer" ? " rad" : "";  // turn_share: a fraction
    std::printf("  %s: fit half %.3g..%.3g%s, held-out %.3g..%.3g%s, %.0f %% of held-out intervals outside the fit's range\n",
                h.coverage.regressor.c_str(), h.coverage.fit_low, h.coverage.fit_high, range_unit, h.coverage.heldout_low,
                h.coverage.heldout_high, range_unit, 100 * h.coverage.heldout_outside);
    if (h.paired_within_fit_range.windows < h.paired.windows) {
      std::printf("  windows inside the fit's range: calibrated better in %d of %d (sign test %s)\n",
                  h.paired_within_fit_range.second_better,
                  h.paired_within_fit_range.windows - h.paired_within_fit_range.ties,
                  calib::PValueText(h.paired_within_fit_range.sign_test_p).c_str());
    }
    if (h.halves) {
      const calib::HalvesAgreement& a = *h.halves;
      const calib::Estimate& fit = a.largest_in_fit;
      const calib::Estimate& alone = a.heldout_fit.at(a.largest);
      const std::string unit = calib::ParamUnit(a.largest);
      std::printf("  the held-out half fitted alone: the halves %s (d2 = %.1f, %d dof, %s); most apart:\n"
                  "  %s %s (fit half), %s (held-out half), %.1f sigma\n",
                  a.p < 0.01 ? "disagree" : "agree", a.d2, a.dof, calib::PValueText(a.p).c_str(), a.largest.c_str(),
                  calib::EstimateText(fit.value, fit.std, unit).c_str(),
                  calib::EstimateText(alone.value, alone.std, unit).c_str(), a.largest_sigmas);
      if (a.p < 0.01)
        std::printf("  no fixed calibration fits both halves: the robot's odometry changed during the recording,\n"
                    "  or physics the model leaves out acts differently on the halves' motions (agvcal diagnose)\n");
    } else if (!h.halves_not_compared.empty()) {
      std::printf("  the halves are not compared: fitted alone, the held-out half says %s\n",
                  h.halves_not_compared.c_str());
    }
  }
  calib::Outputs outputs;  // put in place together, only when all were written
  if (args.Has("--out")) outputs.WriteFile(args.Get("--out", ""), calib::CalibrationResultJson(result));
  if (args.Has("--report"))
    calib::WriteSolveReportDir(robot, result, log_path, calib::RecordingStartUtime(calib::SummarizeLog(log_path)),
                               outputs.ReportDir(args.Get("--report", "")));
  if (args.Has("--write-robot")) {
    outputs.WriteFile(args.Get("--write-robot", ""),
                      calib::CalibratedRobotYaml(robot, result, log_path));
  }
  WriteRosResults(args, robot, result, log_path, &outputs);
  outputs.Commit();
  return calib::kExitOk;
}

}  // namespace agvcal_cli
