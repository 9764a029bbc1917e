#pragma once
// The sensor's motion within a scan for the de-skewing, corrected by the scan match over the pair
// (ScanMatcher, docs/calibration.md "Low-rate recordings"). The odometry with the robot file's
// model and mount predicts the motion; with a mount or drive parameter far from the robot file's,
// its error over a turn grows with the time a scan takes, and at a low scan rate it bends the
// de-skewed scan by more than the range noise (a lidar ahead of the axle sweeps sideways on a
// turn in place, which a mount at the axle does not predict). The match of the pair says where
// the sensor went: the mount that carries the odometry's robot motion onto it, and what remains
// as a constant sensor twist, give the motion within the scan to de-skew it with again.

#include "calib/core/se2.h"

namespace calib {

struct DeskewCorrection {
  Pose2 mount;   // the robot file's mount with its position corrected by the match
  Twist2 twist;  // the rest of the match's difference, spread evenly over the pair (sensor frame)
};

// From the odometry's robot motion over the pair (`robot_motion`, over `duration_s` > 0), the
// robot file's `mount` and the matched sensor motion. The mount's position moves only as far as
// the pair's turn determines it (damped below a few degrees: a straight pair leaves it).
DeskewCorrection CorrectionFromMatch(const Pose2& robot_motion, const Pose2& mount, const Pose2& matched,
                                     double duration_s);

// The sensor's motion under `correction` while the robot moves by `robot_motion` in `duration_s`.
Pose2 CorrectedSensorMotion(const DeskewCorrection& correction, const Pose2& robot_motion, double duration_s);

}  // namespace calib
