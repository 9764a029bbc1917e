#pragma once
// The calibration's input from a recording, for the offline commands (`agvcal
// solve`, diagnose, recal): the same data path as the live processes (the
// messages through a calib/io/message_source.h subscription, scans through a
// ScanMatcher, CalibrationData, Calibrate), fed from a log in its
// order, so a replay through the live group gives the same numbers.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/calibration_data.h"
#include "calib/calibrate/imu_calibration.h"
#include "calib/core/laser_scan.h"
#include "calib/core/robot.h"
#include "calib/core/sensor_data.h"
#include "calib/io/message_source.h"
#include "calib/match/scan_match.h"

namespace calib {

struct SolveLogOptions {
  CalibrationOptions calibration;
  ImuCalibrationOptions imu;  // source kImu
  // Which sensor measures the motion; by default the robot file's 2D lidar when
  // the log has its scans, else the external pose source, else the IMU (with a
  // measured distance: imu_calibration.h).
  std::optional<MotionSource> source;
  std::function<void(const std::string&)> progress;  // occasional one-line updates
};

// The motion source a log and a robot file call for. Throws InputError naming
// the log when a needed channel is missing.
MotionSource ChooseMotionSource(const RobotDescription& robot, const std::string& log_path,
                                std::optional<MotionSource> requested);

// After the last scan of a recording has gone through `matcher` (ScanMatcher::Finish): its counts
// said to `progress` (may be empty), and two clock domains in the recording thrown as the cause
// (InputError naming `log_path`) when no scan could be matched.
void ReportScanMatching(const ScanMatcher& matcher, const std::string& log_path,
                        const std::function<void(const std::string&)>& progress);

// Reads WHEELS and the sensor's channel from the log into CalibrationData, in log order, as the
// live processes receive them: wheel samples through SubscribeWheels, scans (source kLidar2d: the
// robot file's 2D lidar channel) through SubscribeScans into a ScanMatcher, whose matches are
// added as motions; poses or IMU samples for those sources. Throws InputError naming the log and
// the event for a message that does not decode or convert (calib/io/message_source.h).
CalibrationData ReadCalibrationData(const RobotDescription& robot, const std::string& log_path,
                                    MotionSource source,
                                    const std::function<void(const std::string&)>& progress);

// The same, with each scan passed through `adjust_scan` before it is matched
// (the diagnosis re-matches with other beam timing; may be empty), and matched on the wheel
// clock: stamped `deskew_shift_us` earlier, so it is de-skewed with the wheel data of the time
// its beams were taken under a time offset of that size; the motions get the recorded stamps
// back, so the offset stays in the data without the de-skew error it causes. `match_options`
// configure the ScanMatcher (the diagnosis turns its de-skew correction off).
CalibrationData ReadCalibrationData(const RobotDescription& robot, const std::string& log_path,
                                    MotionSource source,
                                    const std::function<void(const std::string&)>& progress,
                                    const std::function<void(LaserScan*)>& adjust_scan,
                                    int64_t deskew_shift_us = 0,
                                    RecordingSource::Mode mode = RecordingSource::Mode::kComplete,
                                    const ScanMatchOptions& match_options = {});

// Whether `solve` runs a second pass (SolveAgainDeskewed) after the first: on scans (their
// de-skewing and the choice of keyframes follow the model the matcher predicts with).
bool SolvesAgainDeskewed(MotionSource source);

// What the second pass read: its wheel data (to compare with what the first pass had) and the
// motions its last pass calibrated on.
struct SecondPassInput {
  std::size_t wheel_states = 0;
  int64_t last_wheel_utime = 0;  // 0 without wheel states
  std::vector<SensorMotion> motions;
};

// The second pass of `solve` (SolveLog), given the first pass's result `first`: the scans of
// `log_path` matched again, de-skewed (and their keyframes chosen) with `first`'s calibrated model,
// on the wheel clock when `first` has a time offset (ReadCalibrationData's deskew_shift_us: the
// offset found), and calibrated again with `options`; `origin` names the input in errors. The first
// pass matched with the robot file's values: a mount or drive model off by a degree or a per cent
// de-skews every scan with an error that turns with the robot, and the mount absorbed it (a bias
// of several sigmas, docs/calibration.md). Without a time offset one pass. With one it is repeated
// from each pass's result until the offset found is the one the scans were matched at (within
// kDeskewedAgreeSigmas of its sigma), at most kMaxDeskewedPasses times: which scans are matched
// (the keyframes) follows the wheel motion predicted between their stamps, so the first pass's
// offset, itself matched on the recorded stamps, chose them, and on slow scan streams that moved
// the answer by up to a sigma with every scan stamp shifted (docs/mismatch.md); the scans matched
// at the offset they give do not depend on the stamps' shift. The live solver runs
// it on the group's recording at its final solve (docs/live.md), so `log_path` may still be being
// written: it is read to its last complete event. `read`, if given, receives what it read.
inline constexpr int kMaxDeskewedPasses = 4;
inline constexpr double kDeskewedAgreeSigmas = 0.25;
CalibrationResult SolveAgainDeskewed(const RobotDescription& robot, const std::string& log_path,
                                     const CalibrationResult& first, const CalibrationOptions& options,
                                     const std::string& origin, SecondPassInput* read = nullptr);

// `agvcal solve`: the motion source (ChooseMotionSource), the data, the calibration. With scans,
// the scans are then matched a second time, de-skewed with the calibrated model (on the wheel
// clock: the offset found, with the time offset), and calibrated again (SolveAgainDeskewed), as
// `agvcal diagnose` does: the robot file's values the first pass de-skewed with leave an error
// that the mount absorbs, and, with the time offset, the matcher places a scan at its mean beam
// time, so the nominal model's error over that lead (its relative turn-rate error times the lead)
// otherwise reads as a small time offset (docs/calibration.md). The live agvcal-solver runs the
// same second pass in its final solve.
CalibrationResult SolveLog(const RobotDescription& robot, const std::string& log_path,
                           const SolveLogOptions& options);

}  // namespace calib
