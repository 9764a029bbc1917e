#pragma once
// Joint calibration of a drive's kinematic parameters and a planar sensor's
// mount (2D lidar or the tracked point of an external pose source), optionally
// with the sensor-to-wheel time offset.
//
// The data: the wheel encoders (WheelTrack) and the sensor's own motion between
// consecutive observations (SensorMotion: scan matching or external poses).
// For every interval [t0, t1] the drive model integrates the encoders into the
// robot's motion q; the mount l carries it into the sensor's motion
// l^-1 ∘ q ∘ l, which is compared with the measured one. Calibration:
//   1. a closed-form first estimate (closed_form.h);
//   2. maximum likelihood with Ceres over all parameters, robust loss first,
//      then outlier rejection (chi-square, 3 dof, p = 0.001) and a plain
//      least-squares refit on the inliers;
//   3. the covariance from the Fisher information, scaled by the residuals'
//      variance factor (the matcher's covariances set the shape, the data the
//      scale), and an observability check that names what the recording
//      cannot determine (UnobservableError, exit status 3).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "calib/core/robot.h"
#include "calib/core/sensor_motion.h"
#include "calib/core/wheel_track.h"

namespace calib {

// Where the motion reference comes from; names the mount in results ("lidar2d",
// "pose", "imu"). kImu: the gyro and a measured distance (imu_calibration.h).
enum class MotionSource { kLidar2d, kPose, kImu };
const char* MotionSourceName(MotionSource source);

// Search bound of a sensor-to-wheel time offset: real recordings show 0.02-0.4 s (the
// Lego robot's 4 Hz streams 0.4 s, docs/mismatch.md).
inline constexpr double kMaxTimeOffsetS = 0.5;

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
};

struct Estimate {
  double value = 0.0;
  double std = 0.0;
  double nominal = 0.0;
};

struct IntervalResidual {
  int64_t utime_start = 0, utime_end = 0;
  Eigen::Vector3d error = Eigen::Vector3d::Zero();  // measured - predicted sensor motion (m, m, rad)
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

// One window of chained odometry: its span, the distance travelled and the end-pose error.
struct WindowError {
  int64_t utime_start = 0, utime_end = 0;
  double distance_m = 0.0;
  double translation_m = 0.0;  // |position error| at the window's end
  double heading_rad = 0.0;    // heading error at the window's end
};

// Odometry over held-out windows: the model's prediction chained over a window
// against the sensor's measured motion over the same span.
struct OdometryError {
  int windows = 0;
  std::vector<WindowError> per_window;  // in time order
  double distance_m = 0.0;           // travelled in those windows
  double rms_translation_m = 0.0;    // per window
  double rms_heading_rad = 0.0;      // per window
  double error_per_metre = 0.0;      // sum of translation errors / distance
};

// One step of a stretch of consecutive sensor motions: the measured motion and the
// model's error on it (measured minus predicted: x, y, theta).
struct OdometryStep {
  int64_t utime_start = 0, utime_end = 0;
  Pose2 measured;
  double error[3] = {0, 0, 0};
};

// The model's motion chained over windows of `window_s` of consecutive steps (a gap
// between steps starts a new window) against the measured motion chained over the
// same span. `keep_partial`: a window cut short by a gap or the end counts too.
// Chaining lets systematic errors add up while a scan's registration error, shared
// by the two motions either side of it, cancels.
OdometryError OdometryErrorOverWindows(const std::vector<OdometryStep>& steps, double window_s,
                                       bool keep_partial);

// The same as OdometryErrorOverWindows with windows of `window_m` of measured path instead of
// time. A window cut short by a gap or the end counts when it holds at least half that path.
// Path windows compare like with like across robots and speeds (a robot standing still adds
// no window) and make the count of windows a matter of the data's coverage alone.
OdometryError OdometryErrorOverPath(const std::vector<OdometryStep>& steps, double window_m);

// The longest path window (among the path's length times 0.95^k) that gives at least
// `min_windows` windows of `steps` (OdometryErrorOverPath's rule); the one with the most windows
// when none does. It depends on the measured motions and their gaps only, not on a model.
double PathWindowLength(const std::vector<OdometryStep>& steps, int min_windows);

// Two models' errors over the same windows, window by window: the paired comparison that
// says whether one is better beyond chance.
struct PairedComparison {
  int windows = 0;
  int second_better = 0;           // windows where the second model's end error is smaller
  int ties = 0;                    // equal within 1e-9 m (left out of the sign test)
  double sign_test_p = 1.0;        // two-sided exact binomial test of "either is as likely better"
  double mean_difference_m = 0.0;  // mean of (second - first) end translation error
  double difference_sem_m = 0.0;   // its standard error
};
PairedComparison ComparePaired(const OdometryError& first, const OdometryError& second);

// Where the held-out half drove motions the fit half did not: the share of held-out intervals
// whose regressor (differential: the share of turning in the wheel rotations, -1..1; steered
// drives: the raw steering angle of the first steered wheel) lies outside the
// range of the fit half's central 98 % (widened by 2 % of its width).
struct MotionCoverage {
  std::string regressor;          // "turn_share" (differential) or "steer" (rad)
  double fit_low = 0.0, fit_high = 0.0;          // 1st and 99th percentile over the fit half
  double heldout_low = 0.0, heldout_high = 0.0;  // the same over the held-out half
  double heldout_outside = 0.0;   // share of held-out intervals outside [fit_low, fit_high] (+ margin)
  std::vector<std::pair<int64_t, int64_t>> outside_spans;  // those intervals (utime start, end)
};

// The calibration fitted on the held-out half alone against the fit half's: the squared
// Mahalanobis distance of their difference under the sum of their covariances, a chi-square
// with one degree per value. When they differ beyond their uncertainties, no fixed calibration
// fits both halves: the robot's odometry changed during the recording (wear, load, the floor),
// or physics the model leaves out acts differently on the halves' different motions.
struct HalvesAgreement {
  double d2 = 0.0;
  int dof = 0;
  double p = 1.0;
  std::string largest;          // the value that differs most, in combined sigmas
  double largest_sigmas = 0.0;
  Estimate largest_in_fit;      // its estimate from the fit half
  std::map<std::string, Estimate> heldout_fit;  // the held-out half's own fit (drive and mount)
};

// P(chi2 > x) with `dof` degrees of freedom.
double ChiSquareUpperTail(double x, int dof);

// Two estimates of the same values compared: `delta` their difference (angles wrapped),
// `sum` the sum of their covariances, `names` the values' names. d2 is the squared
// Mahalanobis distance, a chi-square with one degree per value (infinite when `sum` cannot
// weigh the difference); `largest` the value that differs most, in combined sigmas.
struct EstimateDifference {
  double d2 = 0.0;
  int dof = 0;
  double p = 1.0;
  std::string largest;
  double largest_sigmas = 0.0;
};
EstimateDifference CompareEstimates(const Eigen::VectorXd& delta, const Eigen::MatrixXd& sum,
                                    const std::vector<std::string>& names);

struct HeldoutComparison {
  int intervals = 0;
  double window_m = 0.0;     // path length of a window
  OdometryError nominal;     // robot file's nominal parameters and mount
  OdometryError calibrated;  // the calibration's
  PairedComparison paired;   // first nominal, second calibrated
  MotionCoverage coverage;
  // The same over the windows without an interval outside the fit half's range: how the
  // models compare where the calibration did not extrapolate.
  PairedComparison paired_within_fit_range;
  // Absent when the held-out half alone cannot determine every value.
  std::optional<HalvesAgreement> halves;
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

// The robot description with the calibrated values in place of the nominal ones.
RobotDescription Calibrated(const RobotDescription& robot, const CalibrationResult& result);

}  // namespace calib
