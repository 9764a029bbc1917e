#pragma once
// The human reports of `agvcal solve --report DIR` and `agvcal recal --report DIR`, made like the
// diagnosis's (diagnose.h, WriteDiagnoseReportDir): index.html, summary.txt and SVG plots of the
// residual over time and its histogram with the robot file's values and with the calibration,
// the held-out windows of both, the route, the parameters with sigmas and units and the
// observability (condition number, weak parameters). Times are seconds since the recording's
// first message (`origin_utime`, calib::RecordingStartUtime). docs/reports.md shows them.

#include <cstdint>
#include <string>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/recalibration.h"
#include "calib/core/robot.h"

namespace calib {

// One sentence a person acts on: whether to write the calibration, what to record when the data
// fall short, or to diagnose when the recording's parts disagree; first on the console, the
// page and summary.txt.
std::string SolveVerdict(const CalibrationResult& result);

// A residual's angle or a heading error in milliradians with degrees beside, as a residual's
// length is in mm (docs/units.md): "0.0705 mrad (0.00404 deg)", `significant` digits each.
std::string MilliradiansText(double radians, int significant = 3);

// The calibration as the console shows it (`agvcal solve`, and agvcal-solver at its end): the
// residual RMS, then one row per value with its sigma, unit and nominal value, the weak ones.
std::string CalibrationConsoleText(const CalibrationResult& result);

// The text of summary.txt (also the top of index.html): the verdict, then the figures.
std::string SolveReportSummary(const CalibrationResult& result, const std::string& log_path);

void WriteSolveReportDir(const RobotDescription& robot, const CalibrationResult& result,
                         const std::string& log_path, int64_t origin_utime, const std::string& dir);

// One line per decision and the calibration in use at the end; the plots of the last
// decision that fitted a candidate.
void WriteRecalReportDir(const CalibrationInUse& start, const RecalRun& run, const std::string& log_path,
                         int64_t origin_utime, const std::string& dir);

}  // namespace calib
