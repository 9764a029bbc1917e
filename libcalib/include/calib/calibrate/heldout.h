#pragma once
// The held-out evaluation of a calibration: the model's odometry chained over windows of
// held-out motions against the measured motion (OdometryError), two models compared window by
// window (nominal against calibrated), where the held-out half drove motions the fit half did
// not (MotionCoverage), and the agreement of the calibrations fitted on either half.

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "calib/core/robot.h"
#include "calib/core/se2.h"
#include "calib/core/sensor_motion.h"
#include "calib/core/statistics.h"
#include "calib/core/wheel_track.h"

namespace calib {

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
// `min_windows` windows of `steps` (OdometryErrorOverPath's rule). When none does, the longest
// with the most windows among the lengths no shorter than the longest step (and that step's length). It depends on the measured motions and their gaps only, not on a model.
double PathWindowLength(const std::vector<OdometryStep>& steps, int min_windows);

// The two models' end translation errors window by window (ComparePaired of statistics.h).
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

// MotionCoverage of `motions` (in stamp order), the first `num_fit` the fit half and the
// others held out.
MotionCoverage CompareMotion(DriveType drive, const WheelTrack& wheels,
                             const std::vector<const SensorMotion*>& motions, std::size_t num_fit);

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

// The nominal and the calibrated model compared on the held-out half.
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
  // Absent when the held-out half alone cannot determine every value (or has too few intervals).
  std::optional<HalvesAgreement> halves;
  // Why the halves were not compared when the held-out half cannot determine a value:
  // "the recording cannot determine track" (empty otherwise).
  std::string halves_not_compared;
};

// The comparison of the nominal and the calibrated model's `nominal` and `calibrated` steps
// over the same held-out motions, `coverage` theirs: over path windows of PathWindowLength
// (at least `min_windows` of the nominal steps), all of them and those where the calibration
// did not extrapolate. The number of intervals and the halves' agreement are the caller's.
HeldoutComparison CompareHeldout(const std::vector<OdometryStep>& nominal,
                                 const std::vector<OdometryStep>& calibrated,
                                 const MotionCoverage& coverage, int min_windows);

}  // namespace calib
