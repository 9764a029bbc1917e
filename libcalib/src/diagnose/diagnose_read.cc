// Reading a recording for the diagnosis, and the diagnosis of a recording file (diagnose.h).

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/recording_input.h"
#include "calib/core/errors.h"
#include "calib/core/laser_scan.h"
#include "calib/diagnose/diagnose.h"
#include "calib/io/log_summary.h"
#include "calib/io/message_source.h"

namespace calib {
namespace {

// The matcher the diagnosis reads with: its interval model (DiagnoseData::deskew_robot) closes
// each match with the de-skew odometry, so every scan must be de-skewed with the odometry alone.
// The matcher's correction by the match would de-skew the pairs where the match and the
// odometry disagree (under a time offset: every change of speed or turn rate) with the match's
// motion instead, which the model does not describe; the diagnosis corrects the de-skewing its
// own way (matched again with the calibrated model, then on the wheel clock of the offset found).
ScanMatchOptions DiagnosisMatching() {
  ScanMatchOptions options;
  options.deskew_correction_passes = 0;
  return options;
}

// WHEELS and the sensor motions, the scans de-skewed with `robot`'s drive model.
// `shift_us` moves the scans' stamps onto the wheel clock for de-skewing and matching;
// the motions get their recorded stamps back, so a time offset stays in the data.
void ReadMotions(const RobotDescription& robot, const std::string& log_path,
                 const std::function<void(const std::string&)>& progress, int64_t shift_us,
                 DiagnoseData* data) {
  DiagnoseData& out = *data;
  // Beam timing the scans declare: all zero makes scan_distortion testable.
  int64_t zero_timing = 0, scans = 0;
  std::vector<int64_t> stamps;
  std::vector<double> leads;  // per scan: mean time of the beams with a return after the stamp, s
  double scan_time = 0;
  auto check_scan = [&](LaserScan* scan) {
    ++scans;
    zero_timing += scan->time_increment == 0.0;
    if (scan->scan_time > 0) scan_time = scan->scan_time;
    stamps.push_back(scan->utime);
    double sum = 0;
    int returns = 0;
    for (int i = 0; i < scan->size(); ++i)
      if (scan->HasReturn(i)) sum += i * scan->time_increment, ++returns;
    leads.push_back(returns > 0 ? sum / returns : 0.0);
  };
  const CalibrationData cal =
      ReadCalibrationData(robot, log_path, out.source, progress, std::function<void(LaserScan*)>(check_scan),
                          shift_us, RecordingSource::Mode::kComplete, DiagnosisMatching());
  out.wheels = cal.wheels();
  out.motions = cal.motions();
  out.input_dropped = cal.dropped_input();
  out.input_notes = cal.drop_notes();
  out.deskew_robot = robot;
  out.deskew_offset_s = shift_us * 1e-6;
  out.deskew_lead_s = 0.0;
  if (!leads.empty() && out.source == MotionSource::kLidar2d) {
    std::nth_element(leads.begin(), leads.begin() + leads.size() / 2, leads.end());
    out.deskew_lead_s = leads[leads.size() / 2];
  }
  if (scans > 10 && zero_timing == scans) {
    if (!(scan_time > 0)) {
      std::vector<int64_t> gaps;
      for (std::size_t i = 1; i < stamps.size(); ++i) gaps.push_back(stamps[i] - stamps[i - 1]);
      std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
      scan_time = gaps[gaps.size() / 2] * 1e-6;
    }
    out.scan_period_s = scan_time;
    if (progress) progress("scans declare no beam timing: matching again with beams spread over the scan");
    const CalibrationData spread = ReadCalibrationData(
        robot, log_path, out.source, nullptr,
        [&](LaserScan* scan) {
          if (scan->size() > 1) scan->time_increment = scan_time / scan->size();
        },
        shift_us, RecordingSource::Mode::kComplete, DiagnosisMatching());
    out.motions_spread = spread.motions();
  }
}

}  // namespace

DiagnoseData ReadDiagnoseData(const RobotDescription& robot, const std::string& log_path,
                              const std::function<void(const std::string&)>& progress,
                              double deskew_offset_s) {
  DiagnoseData out;
  out.source = ChooseMotionSource(robot, log_path, std::nullopt);
  const int64_t shift_us = std::llround(deskew_offset_s * 1e6);
  ReadMotions(robot, log_path, progress, shift_us, &out);
  if (out.source == MotionSource::kLidar2d) {
    // The matcher de-skews scans with the robot file's nominal odometry; the nominal
    // model's error then leaves a residual that looks like a time offset where the
    // robot turns fast. Match again with the calibrated model, as the calibration does
    // for its final answer.
    try {
      CalibrationOptions co;
      co.check_observability = false;
      const CalibrationResult cal = Calibrate(robot, out.wheels, out.motions, out.source, co, log_path);
      if (progress) progress("matching the scans again, de-skewed with the calibrated model");
      out.motions_spread.clear();
      ReadMotions(Calibrated(robot, cal), log_path, progress, shift_us, &out);
    } catch (const InputError& e) {
      // A fault of the robot file (its wheels do not fit the recording's readings) is the cause
      // to name: the nominal de-skew it spoils would leave only "too few intervals".
      if (!robot.source_file.empty() && e.file() == robot.source_file) throw;
      // Too little to calibrate: keep the nominal de-skew; Diagnose reports the problem.
    }
  }
  RecordingSource commands(log_path);
  SubscribeDriveCommands(&commands, robot, [&](const DriveCommand& c) { out.commands.push_back(c); });
  commands.HandleAll();
  // The reader's skips were noted by the motions' read already: only DRIVE_CMD's own drops add.
  int64_t repeated = 0;
  for (const std::string& note : commands.drop_notes()) {
    if (std::find(out.input_notes.begin(), out.input_notes.end(), note) != out.input_notes.end()) ++repeated;
    else out.input_notes.push_back(note);
  }
  out.input_dropped += commands.dropped() - repeated;
  std::stable_sort(out.commands.begin(), out.commands.end(),
                   [](const DriveCommand& a, const DriveCommand& b) { return a.utime < b.utime; });
  return out;
}

DiagnoseReport DiagnoseLog(const RobotDescription& robot, const std::string& log_path,
                           const DiagnoseOptions& options) {
  DiagnoseData data = ReadDiagnoseData(robot, log_path, options.progress);
  DiagnoseReport report = Diagnose(robot, data, options, log_path);
  const int64_t origin = RecordingStartUtime(SummarizeLog(log_path));
  report.recording_start_utime = origin;
  report.input_dropped = data.input_dropped;
  report.input_notes = data.input_notes;
  if (data.source != MotionSource::kLidar2d) return report;
  for (const FoundEffect& e : report.effects) {
    if (e.name != "time_offset") continue;
    // Scans were de-skewed with wheel data from the wrong time: match them again on the
    // wheel clock (stamps kept) and diagnose once more.
    const double offset = e.params.at("offset_s").value;
    if (std::abs(offset) < 0.001) break;
    if (options.progress) options.progress("time offset found: matching again with the scans de-skewed on the wheel clock");
    data = ReadDiagnoseData(robot, log_path, options.progress, offset);
    report = Diagnose(robot, data, options, log_path);
    report.notes.push_back("scans de-skewed with the wheel data " + std::to_string(offset) +
                           " s earlier than their stamps (the time offset found in a first pass)");
    break;
  }
  report.recording_start_utime = origin;
  report.input_dropped = data.input_dropped;
  report.input_notes = data.input_notes;
  return report;
}

}  // namespace calib
