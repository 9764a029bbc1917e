#pragma once
// Where Calibrate (calibration.h) refuses an estimate: for the diagnosis, which tries its
// candidate effects inside the baseline before it refuses a recording.

#include <string>

#include "calib/core/robot.h"

namespace calib {

// The one sigma above which a recording does not determine estimate `name` (as in
// CalibrationResult::estimated_names) of nominal value `nominal`: Calibrate refuses it there.
double UndeterminedAbove(DriveType drive, const std::string& name, double nominal);

}  // namespace calib
