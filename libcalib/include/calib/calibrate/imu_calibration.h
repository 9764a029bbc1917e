#pragma once
// Calibration of a differential drive without a lidar: the gyro is the
// rotation reference and a straight distance the user measured is the scale
// (docs/imu.md).
//
// The recording is cut at standstills (no encoder change for
// `standstill_s`) into motions. For every motion k and every standstill j:
//   G_k = s * (r_R Phi_R,k - r_L Phi_L,k) / b + beta * T_k      (rad)
//   G_j = beta * T_j
// with G the integrated gyro z rate over the span (shifted by the time
// offset), Phi the wheels' rotation over it, T its duration, s the gyro scale
// and beta its bias; the heading change of a differential drive is exact
// whatever the path, so each motion is one equation. The first straight
// motion adds (r_L Phi_L + r_R Phi_R)/2 * sinc(dtheta/2) = measured distance
// (the chord of its arc), and, when given, the first turn in place adds
// (r_R Phi_R - r_L Phi_L)/b = measured turn angle. Without a measured angle
// s and b are not separable (only b/s is): s is then held at the robot
// file's value (docs/imu.md). Weighted least squares, variances from the
// gyro noise (measured at standstill) and the encoder quantisation; the
// covariance is scaled by max(1, chi2/dof).
//
// Besides: the IMU's mount yaw from the accelerometer on straight runs
// (sensor acceleration = R(yaw)^T * body acceleration from the wheels), and
// the IMU-to-wheel time offset from the rate during speed changes.

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/calibrate/calibration.h"
#include "calib/core/robot.h"
#include "calib/core/sensor_data.h"
#include "calib/core/wheel_track.h"

namespace calib {

struct ImuCalibrationOptions {
  std::optional<double> distance_m;        // measured length of the first straight motion
  double distance_std_m = 0.001;           // the tape measure's one sigma
  std::optional<double> turn_angle_rad;    // measured angle of the first turn in place
  double turn_angle_std_rad = 0.2 * M_PI / 180;
  double standstill_s = 0.3;               // no encoder change for this long = at rest
  double straight_max_rad = 2.0 * M_PI / 180;  // a "straight" motion turns less than this
  double turn_min_rad = 30.0 * M_PI / 180;     // a motion turning more determines the track
  bool estimate_time_offset = true;
  double max_time_offset_s = 0.1;
};

// A motion or a standstill between standstills, with what the fit saw.
struct ImuSpan {
  int64_t utime_start = 0, utime_end = 0;
  bool moving = false;
  double left_rad = 0.0, right_rad = 0.0;  // wheel rotation
  double gyro_rad = 0.0;                   // integrated raw gyro rate
  double residual_rad = 0.0;               // measured - predicted
  double sigma_rad = 0.0;                  // the equation's one sigma
};

struct ImuCalibrationResult {
  std::map<std::string, Estimate> params;  // left_radius, right_radius, track
  Estimate gyro_bias;    // rad/s
  Estimate gyro_scale;   // std 0 when held (no measured angle)
  bool gyro_scale_estimated = false;
  Estimate yaw;          // IMU mount yaw, rad; std infinite when no acceleration was seen
  Estimate time_offset;  // s
  double gyro_noise = 0.0;   // rad/s/sqrt(Hz), measured at standstill
  double wheel_noise = 0.0;  // rad/sqrt(m), what the gyro noise does not explain of the residuals
  double variance_factor = 1.0;  // chi2 / dof of the fit
  double distance_m = 0.0;       // the measured distance used
  int straight_span = -1, turn_span = -1;  // index in `spans` of the measured straight / turn
  std::vector<ImuSpan> spans;
  std::vector<std::string> estimated_names;  // order of `covariance`
  Eigen::MatrixXd covariance;
  double condition = 0.0;
};

// Calibrates from the encoders and the IMU samples (any order; sorted by
// utime). Nominal values come from `robot` (params and its imu block). Throws
// UnobservableError naming `track` when no motion turns by turn_min_rad, the
// scale (`left_radius/right_radius`) when there is no measured distance or no
// straight motion, and InputError when there is nothing to fit.
ImuCalibrationResult CalibrateWithImu(const RobotDescription& robot, const WheelTrack& wheels,
                                      std::vector<ImuSample> imu,
                                      const ImuCalibrationOptions& options,
                                      const std::string& origin);

// The calibration in the CalibrationResult shape of `agvcal solve` (params,
// observability; no sensor mount), so the result files are shared.
CalibrationResult ToCalibrationResult(const RobotDescription& robot, const ImuCalibrationResult& r);

}  // namespace calib
