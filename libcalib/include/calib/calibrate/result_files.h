#pragma once
// The result files of spec/cli.md: RESULT.json of `solve`, and the robot file
// written back with calibrated values (spec/robot.md: `std:` and `source:`).
// Files are written atomically: a reader sees the old file or the new one.

#include <string>

#include "calib/calibrate/calibration.h"
#include "calib/core/robot.h"
#include "calib/io/atomic_file.h"  // results are written with WriteFileAtomically

namespace calib {

// RESULT.json text (spec/cli.md), with the closed-form estimate and the held-out
// comparison as extra keys.
std::string CalibrationResultJson(const CalibrationResult& result);

// The robot file `robot.source_file` with the calibrated values in place (its comments and
// layout kept, each value rounded to its sigma: core/robot_file_edit.h), their standard
// deviations under `std:` and the log under `source:`. `command` names the writer in the
// first comment line.
std::string CalibratedRobotYaml(const RobotDescription& robot, const CalibrationResult& result,
                                const std::string& log_path, const std::string& command = "solve");

}  // namespace calib
