#pragma once
// `agvcal solve` on a recording: the same data path as the live processes
// (scan matcher pipeline, CalibrationData, Calibrate), fed from a log in its
// order, so a replay through the live group gives the same numbers.

#include <functional>
#include <optional>
#include <string>

#include "calib/calibration.h"
#include "calib/calibration_data.h"
#include "calib/robot.h"

namespace calib {

struct SolveLogOptions {
  CalibrationOptions calibration;
  // Which sensor measures the motion; by default the robot file's 2D lidar when
  // the log has its scans, else the external pose source.
  std::optional<MotionSource> source;
  std::function<void(const std::string&)> progress;  // occasional one-line updates
};

// The motion source a log and a robot file call for. Throws InputError naming
// the log when a needed channel is missing.
MotionSource ChooseMotionSource(const RobotDescription& robot, const std::string& log_path,
                                std::optional<MotionSource> requested);

// Reads WHEELS and the sensor's channel from the log; scans are scan-matched.
CalibrationData ReadCalibrationData(const RobotDescription& robot, const std::string& log_path,
                                    MotionSource source,
                                    const std::function<void(const std::string&)>& progress);

// The same, with each scan passed through `adjust_scan` before it is matched
// (the diagnosis re-matches with other beam timing; may be empty).
struct LaserScan;
CalibrationData ReadCalibrationData(const RobotDescription& robot, const std::string& log_path,
                                    MotionSource source,
                                    const std::function<void(const std::string&)>& progress,
                                    const std::function<void(LaserScan*)>& adjust_scan);

CalibrationResult SolveLog(const RobotDescription& robot, const std::string& log_path,
                           const SolveLogOptions& options);

}  // namespace calib
