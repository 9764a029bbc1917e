#pragma once
// The motion of an exteroceptive sensor (2D lidar, tracked point of an external
// pose source) between two of its observations: the measurement the
// calibration compares with the wheel odometry's prediction of the same motion.

#include <cstdint>

#include <Eigen/Core>

#include "calib/core/se2.h"

namespace calib {

struct SensorMotion {
  int64_t utime_start = 0;  // stamp of the first observation (robot clock, us)
  int64_t utime_end = 0;    // stamp of the second observation
  Pose2 delta;              // sensor pose at utime_end in the sensor frame at utime_start
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  // of (x, y, theta), m^2 / rad^2
  bool valid = true;         // false: no usable motion (matching failed); kept so gaps are visible
  bool degenerate = false;   // the geometry leaves a direction unconstrained (e.g. a corridor)
  Eigen::Vector3d weak_direction = Eigen::Vector3d::Zero();  // unit (x, y, theta) least constrained
  double inlier_fraction = 0.0;  // share of points that found a correspondence (1 for poses)
  double rms = 0.0;              // point-to-line residual RMS of the match, m (0 for poses)
};

}  // namespace calib
