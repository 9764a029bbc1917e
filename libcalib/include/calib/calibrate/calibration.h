#pragma once
// Joint calibration of a drive's kinematic parameters and a planar sensor's
// mount (2D lidar or the tracked point of an external pose source), optionally
// with the sensor-to-wheel time offset.
//
// The data: the wheel encoders (WheelTrack) and the sensor's own motion between
// consecutive observations (SensorMotion: scan matching or external poses).
// For every interval [t0, t1] the drive model integrates the encoders into the
// robot's motion q; the mount l carries it into the sensor's motion
// l^-1 ∘ q ∘ l, which is compared with the measured one (interval_model.h).
// Calibration:
//   1. a closed-form first estimate (closed_form.h);
//   2. maximum likelihood with Ceres over all parameters, robust loss first,
//      then outlier rejection (chi-square, 3 dof, p = 0.001) and a plain
//      least-squares refit on the inliers;
//   3. the covariance from the Fisher information, scaled by the residuals'
//      variance factor (the matcher's covariances set the shape, the data the
//      scale), and an observability check that names what the recording
//      cannot determine (UnobservableError, exit status 3);
//   4. with a held-out part of the recording, the calibrated model against the
//      nominal one on it (heldout.h).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/calibrate/heldout.h"
#include "calib/core/robot.h"
#include "calib/core/sensor_motion.h"
#include "calib/core/statistics.h"
#include "calib/core/wheel_track.h"

namespace calib {

// Where the motion reference comes from; names the mount in results ("lidar2d",
// "pose", "imu"). kImu: the gyro and a measured distance (imu_calibration.h).
enum class MotionSource { kLidar2d, kPose, kImu };
const char* MotionSourceName(MotionSource source);

// Search bound of a sensor-to-wheel time offset: above those real recordings show (slow
// streams reach close to it, docs/mismatch.md).
inline constexpr double kMaxTimeOffsetS = 0.5;
// When the search's best lies at its bound, the offset may lie beyond it: the search is repeated
// over twice the range, up to this bound.
inline constexpr double kWidestTimeOffsetS = 2.0;

struct CalibrationOptions {
  bool estimate_time_offset = false;
  double max_time_offset_s = kMaxTimeOffsetS;
  double outlier_chi2 = 16.27;      // chi-square (3 dof) beyond which an interval is an outlier
  // Fit on the first `fit_fraction` of the recording's intervals; the rest is
  // held out to compare the calibrated model with the nominal one.
  double fit_fraction = 1.0;
  // Held-out windows: the longest equal lengths of path that give at least this many windows
  // (PathWindowLength), so the paired comparison can show a difference beyond chance.
  int heldout_windows = 20;
  bool check_observability = true;  // throw UnobservableError when a parameter is undetermined
  // Iterations of the solver; a fit that stops at this limit is reported (CalibrationResult::warnings).
  int max_iterations = 100;
};

struct IntervalResidual {
  int64_t utime_start = 0, utime_end = 0;
  Eigen::Vector3d error = Eigen::Vector3d::Zero();  // measured - predicted sensor motion (m, m, rad)
  Eigen::Vector3d nominal_error = Eigen::Vector3d::Zero();  // the same with the robot file's values
  Eigen::Vector3d measured = Eigen::Vector3d::Zero();       // the measured sensor motion (m, m, rad)
  double chi2 = 0.0;                                // standardized, 3 dof
  bool outlier = false;
  bool heldout = false;
};

struct ResidualSummary {
  int intervals = 0;  // used in the fit (inliers + outliers)
  int outliers = 0;
  int degenerate = 0;  // matches flagged degenerate, left out
  int invalid = 0;     // failed matches or intervals without encoder data, left out
  double rms_x = 0.0, rms_y = 0.0, rms_yaw = 0.0;  // of the inliers, m, m, rad
  double variance_factor = 1.0;  // chi2 / dof: how far the matcher's covariances were off
};

// What the IMU-referenced calibration adds (imu_calibration.h): the gyro's
// model and mount, and the noise the fused odometry takes from it.
struct ImuEstimates {
  Estimate gyro_bias, gyro_scale, yaw, time_offset;  // rad/s, 1, rad, s
  bool gyro_scale_estimated = false;  // false: held at the robot file's value (std 0)
  double gyro_noise = 0.0;            // rad/s/sqrt(Hz)
  double wheel_noise = 0.0;           // rad/sqrt(m)
  double distance_m = 0.0;            // the measured distance used as the scale
};

struct CalibrationResult {
  DriveType drive = DriveType::kDifferential;
  MotionSource source = MotionSource::kLidar2d;
  std::vector<std::string> param_names;  // ParamNames(drive)
  std::map<std::string, Estimate> params;
  Estimate mount_x, mount_y, mount_yaw;
  std::optional<Estimate> time_offset;  // when estimated
  double time_offset_bound_s = 0.0;     // when estimated: the bound (+-) it was searched and fitted within
  std::optional<ImuEstimates> imu;      // source kImu (no mount_x/y/yaw then)
  std::map<std::string, double> closed_form;  // first estimate: params and mount_x/y/yaw
  std::string closed_form_note;               // why the closed form was not used, if so
  ResidualSummary residual;
  double condition = 0.0;         // of the correlation-normalised Fisher information
  std::vector<std::string> weak;  // parameters the data determine poorly
  std::vector<std::string> estimated_names;  // order of `covariance`
  Eigen::MatrixXd covariance;
  std::vector<IntervalResidual> intervals;
  std::optional<HeldoutComparison> heldout;
  // What the numbers above cannot show, in words: a fit that stopped short of convergence, a time
  // offset at its search bound that could not be searched beyond (RESULT.json `warnings`).
  std::vector<std::string> warnings;
  // Input left out before the fit (calib/io/message_source.h, Drop): how many messages and
  // the first notes naming them. Not set by Calibrate, which sees only what was kept.
  int64_t input_dropped = 0;
  std::vector<std::string> input_notes;
};

// Calibrates from the encoders and the sensor motions. The nominal values come
// from `robot` (params and the mount of `source`; a missing mount starts at 0).
// Throws UnobservableError when the data cannot determine a parameter (naming
// it and the motion to add), InputError when there is nothing to fit.
CalibrationResult Calibrate(const RobotDescription& robot, const WheelTrack& wheels,
                            const std::vector<SensorMotion>& motions, MotionSource source,
                            const CalibrationOptions& options, const std::string& origin);

// The odometry error of the robot description's model (its drive parameters and the mount of
// `source`) against the measured sensor motions, chained over windows of `window_s` as in the
// held-out comparison, except that a window cut short by a gap or the end counts too. Motions
// that are invalid, degenerate or not covered by `wheels` are left out.
OdometryError EvaluateOdometry(const RobotDescription& robot, MotionSource source,
                               const WheelTrack& wheels, const std::vector<SensorMotion>& motions,
                               double window_s);

// The motion a recording needs for the data to determine `name` (a drive parameter, a mount
// value, "time_offset"): what to record when it is weak or undetermined.
std::string MotionThatDetermines(DriveType drive, const std::string& name);

// The robot description with the calibrated values in place of the nominal ones.
RobotDescription Calibrated(const RobotDescription& robot, const CalibrationResult& result);

}  // namespace calib
