#pragma once
// 2D scan matching: the motion of the lidar between two scans, the measurement
// the calibration compares with the wheel odometry's prediction.
//
// In: scans (LaserScan), the encoder track, and the robot file's nominal drive
// model and lidar2d mount. Out: SensorMotion, the later scan's sensor pose in
// the earlier scan's sensor frame (x, y in m, theta in rad), its covariance,
// and the least constrained direction, along which a degenerate match (a
// corridor) keeps the odometry's prediction. Steps: de-skew each scan with the
// odometry (DeskewScan), fit a line around each point (PreparedScan), then
// point-to-line ICP one way (MatchPointsToLines) or both ways averaged
// (MatchScans); ScanMatcher runs them on the two streams.
// Method, choices and measured figures: docs/calibration.md, "Scan matching".
//
// All functions are deterministic; no state outside their arguments (ScanMatcher's
// outside the object).

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "calib/core/kinematics.h"
#include "calib/core/robot.h"
#include "calib/core/se2.h"
#include "calib/core/sensor_motion.h"
#include "calib/core/wheel_track.h"
#include "calib/core/laser_scan.h"

namespace calib {

struct DeskewCorrection;  // match/deskew_correction.h

struct ScanMatchOptions {
  // Correspondences.
  double max_correspondence_distance_m = 0.3;  // point to its nearest reference point
  double residual_gate_sigmas = 3.0;  // pairs with |e| beyond this many robust sigmas dropped
  double trim_fraction = 0.05;        // share of pairs with the largest |e| dropped, each iteration
  // Weights: each pair by 1 / (n · beam)², the inverse of its error's variance (a range error
  // moves the point along its beam), (n · beam)² kept at or above this; 1 = unweighted.
  double incidence_weight_floor = 0.1;
  // Reference lines: consecutive beams within the larger of line_fit_radius_m and
  // line_fit_beams beam spacings (at the point's range) fit a point's line.
  double line_fit_radius_m = 0.08;
  double line_fit_beams = 3.0;
  int line_fit_min_points = 3;
  double line_max_flatness = 0.05;  // smallest / largest eigenvalue of the fit's scatter
  // Iterations.
  int max_iterations = 40;
  double convergence_m = 1e-5;    // stop when a step moves less than this...
  double convergence_rad = 1e-6;  // ...and turns less than this
  // Acceptance: fewer kept pairs, or a smaller share of the current scan's points, is a
  // failed match (valid = false).
  int min_correspondences = 40;
  double min_inlier_fraction = 0.2;
  // Degeneracy.
  double degeneracy_ratio = 0.02;   // smallest / largest eigenvalue of the scaled JᵀJ
  double degenerate_sigma_m = 1.0;  // std reported along a weak direction (scaled units)
  // Match both ways and average (see MatchScans).
  bool symmetric = true;
  // Pipeline.
  bool deskew = true;                // false: every beam taken at the scan's utime
  double deskew_smoothing_s = 0.0;   // > 0: readings smoothed over the scan and this margin
                                     // (docs/calibration.md, Scan matching, 1.)
  // Where the match says the sensor moved otherwise than the odometry over a pair by so much that
  // de-skewing with the match's motion moves a point of the scan by more than this (a mount or
  // drive parameter far from nominal, over a turn, at a low scan rate), the scan is de-skewed
  // with the match's motion and matched again, until a pass moves the points by less than a
  // twentieth of it, at most this many passes (ScanMatcher; docs/calibration.md, "Low-rate recordings").
  double deskew_correction_m = 0.02;
  int deskew_correction_passes = 4;
  // An encoder gap within a pair longer than both of these makes the match invalid:
  double max_wheel_gap_s = 0.25;     // s
  double wheel_gap_factor = 2.5;     // times the median of the last 15 encoder intervals
  // A scan is matched to the previous matched scan (keyframe) once the odometry says
  // the sensor moved this far, turned this much, or this much time passed.
  double keyframe_translation_m = 0.2;
  double keyframe_rotation_rad = 0.1;
  double keyframe_max_interval_s = 1.0;
  int max_pending_scans = 200;       // scans waiting for wheel data; beyond, the oldest is dropped
};

// Points of one scan in the sensor frame at the scan's utime (first beam), in
// beam order, only beams with a return.
struct ScanPoints {
  int64_t utime = 0;
  std::vector<Eigen::Vector2d> points;  // m
  double angle_increment = 0.0;         // rad, of the scan (line-fit radius)
  bool full_circle = false;             // the first and last beams are neighbours
};

// Every beam as if taken at scan.utime (no motion correction).
ScanPoints ScanToPoints(const LaserScan& scan);

// Each beam's point carried to the sensor frame at scan.utime with the sensor
// motion the wheel odometry predicts (docs/calibration.md, Scan matching, 1.).
// `mount` is the lidar's pose in the robot frame. smoothing_s > 0: the encoder
// readings are smoothed over the scan and that margin either side (as far as the track
// reaches). Throws std::invalid_argument when the track does not cover the
// scan's beams (scan.utime .. BeamTime(last)).
// `correction`: a constant twist of the sensor (its frame) added to the odometry's motion
// from scan.utime on (ScanMatcher: the match's correction of the odometry over the pair).
ScanPoints DeskewScan(const LaserScan& scan, const WheelTrack& track, const DriveModel& model,
                      const Pose2& mount, double smoothing_s = 0.0, const Twist2& correction = {});

// Motion of the sensor mounted at `mount` over [t0, t1] (us) predicted by the
// odometry: Inverse(mount) ∘ track.Odometry(model, t0, t1) ∘ mount, in the
// sensor frame at t0.
Pose2 PredictSensorMotion(const WheelTrack& track, const DriveModel& model, const Pose2& mount,
                          double t0, double t1);

// A scan prepared for matching: its points, a line fitted around each point
// and an index of those points by polar angle. Built once per scan (each scan
// is the later scan of one pair and the earlier of the next).
class PreparedScan {
 public:
  PreparedScan(ScanPoints points, const ScanMatchOptions& options);

  int64_t utime() const { return points_.utime; }
  const ScanPoints& points() const { return points_; }
  int num_lines() const { return static_cast<int>(lines_.size()); }

  struct Line {
    Eigen::Vector2d point;      // the scan point, m
    Eigen::Vector2d centroid;   // of the fitted neighbourhood, m
    Eigen::Vector2d normal;     // unit normal of the fitted line
    Eigen::Vector2d direction;  // unit vector from the sensor towards `point`
    double angle = 0.0;         // pseudo-angle of `point` (the polar angle's order), [-2, 2)
    int support = 0;            // points in the fit
  };
  const Line& line(int i) const { return lines_[i]; }

  // Index of the line whose point is nearest to p (this scan's frame) and
  // closer than max_distance, or -1. Exact nearest neighbour.
  int Nearest(const Eigen::Vector2d& p, double max_distance) const;

 private:
  ScanPoints points_;
  std::vector<Line> lines_;     // sorted by angle
  std::vector<int> bin_start_;  // first line at or after each angle bin
};

// How a match went, for tests and tuning.
struct ScanMatchReport {
  int iterations = 0;                 // Gauss-Newton iterations (both directions)
  bool converged = false;             // every direction run converged
  int correspondences = 0;            // kept pairs of the last iteration (first direction)
  double eigenvalue_ratio = 0.0;      // smallest / largest of the scaled JᵀJ (first direction)
  double characteristic_range = 0.0;  // L, m
  double sigma = 0.0;                 // estimated range noise along the normals, m
};

// One-way PL-ICP: the points of `current` against the lines of `reference`,
// starting from `prior` (the guess of the current scan's sensor pose in the
// reference scan's sensor frame). Returns the motion from reference.utime()
// to current.utime; valid = false when too few pairs were found, too small a
// share of the points matched, or the iteration did not converge.
SensorMotion MatchPointsToLines(const PreparedScan& reference, const ScanPoints& current,
                                const Pose2& prior, const ScanMatchOptions& options,
                                ScanMatchReport* report = nullptr);

// The match of two prepared scans. With options.symmetric (the default) it
// matches both ways, current's points to reference's lines and reference's
// points to current's lines, and averages the first with the inverse of the
// second (covariance: the mean of the two): a fitted line is not quite the
// surface (at corners, on curved faces), which biases a one-way match by a
// few tenths of the noise; the two ways err in opposite directions. If only
// one way succeeds, its result is returned alone.
SensorMotion MatchScans(const PreparedScan& reference, const PreparedScan& current,
                        const Pose2& prior, const ScanMatchOptions& options,
                        ScanMatchReport* report = nullptr);

// What a ScanMatcher has seen and done.
struct ScanMatchCounts {
  int64_t wheels = 0;          // wheel samples accepted
  int64_t wheels_dropped = 0;  // stamp at or before the previous sample's (out of order, duplicate)
  int64_t scans = 0;           // scans accepted
  int64_t scans_dropped = 0;   // stamp at or before the previous scan's
  int64_t scans_uncovered = 0;  // never covered by wheel data (kNoWheelData)
  int64_t matches = 0;          // scans matched (kMatched)
  int64_t invalid = 0;          // of which valid = false
  int64_t degenerate = 0;       // of which degenerate
  int64_t wheel_gaps = 0;       // of the invalid: an encoder gap too long (max_wheel_gap_s)
  int64_t between_keyframes = 0;  // scans skipped: too little motion since the last keyframe
};

// What became of one scan fed to a ScanMatcher.
enum class ScanMatchStatus {
  kMatched,           // matched with the previous keyframe: `motion` (valid = false: the match failed)
  kFirstKeyframe,     // the first scan the wheel data cover: the reference of the next, no motion yet
  kBetweenKeyframes,  // skipped: too little motion since the last keyframe
  kOutOfOrder,        // skipped: its stamp is at or before the previous scan's
  kNoWheelData,       // skipped: the wheel data never cover it (it begins before the first sample,
                      // ends beyond the last at Finish, or too many scans wait)
};

struct ScanMatchOutcome {
  ScanMatchStatus status = ScanMatchStatus::kMatched;
  int64_t scan_utime = 0;
  SensorMotion motion;  // kMatched only: from the previous keyframe to this scan
  bool matched() const { return status == ScanMatchStatus::kMatched; }
};

// The incremental front end shared by the live process and the offline
// solver: a plain object fed wheel samples and scans in the order they come,
// each call returning the outcomes it completed. Every scan gets one outcome,
// in the order of the scans (an out-of-order scan's at once); a matched scan's
// carries the SensorMotion from the previous keyframe. A scan waits, without
// an outcome, until the wheel data cover it entirely (and the de-skewing's
// smoothing margin after it), so the results depend only on the order of the
// wheel samples among themselves and of the scans among themselves, not on
// how the two streams interleave (provided the wheels lag the scans by fewer
// than max_pending_scans scans). Out-of-order and duplicated stamps are
// dropped and counted. Memory stays bounded: wheel samples older than the
// reference scan (less the smoothing margin) are released.
class ScanMatcher {
 public:
  // Uses the robot file's nominal drive model and lidar2d mount. Throws
  // InputError (the robot file) if it has no lidar2d.
  explicit ScanMatcher(const RobotDescription& robot, ScanMatchOptions options = {});
  ~ScanMatcher();

  // Throws std::invalid_argument for a sample with the wrong number of wheels.
  std::vector<ScanMatchOutcome> AddWheels(const WheelSample& sample);
  std::vector<ScanMatchOutcome> AddScan(const LaserScan& scan);
  // End of data: scans whose beams the wheel data cover are matched (their
  // smoothing margin cut to the data there is), the rest skipped (kNoWheelData).
  std::vector<ScanMatchOutcome> Finish();

  const ScanMatchCounts& counts() const { return counts_; }
  const ScanMatchOptions& options() const { return options_; }
  // Two clocks in one group: when the streams first meet (the first scan after a wheel sample
  // or the reverse), the scan's and the latest wheel sample's stamps are more than
  // kClockDomainGapS apart, e.g. wheels stamped on a recording's clock and scans on the host's.
  // No scan can then be covered by wheel data. One sentence saying so, else "".
  static constexpr double kClockDomainGapS = 10.0;
  const std::string& clock_problem() const { return clock_problem_; }

 private:
  void CheckClocks(int64_t scan_utime, int64_t wheel_utime);
  // Settles the waiting scans the wheel data now cover, in order, into `out`.
  void Process(std::vector<ScanMatchOutcome>* out, bool finishing = false);
  SensorMotion MatchWithReference(const LaserScan& scan, std::optional<PreparedScan>* prepared);
  ScanPoints Deskewed(const LaserScan& scan, const DeskewCorrection& correction) const;
  // Takes the first waiting scan off, with its outcome.
  void SkipFirstWaiting(ScanMatchStatus why, std::vector<ScanMatchOutcome>* out);
  void ReleaseOldWheels();

  ScanMatchOptions options_;
  std::unique_ptr<DriveModel> model_;
  Pose2 mount_;
  std::size_t num_wheels_ = 0;
  WheelTrack track_;
  std::deque<int64_t> recent_intervals_;                       // last encoder intervals, us
  std::deque<std::pair<int64_t, int64_t>> typical_interval_;  // per track sample: utime, median interval
  std::deque<LaserScan> waiting_;                              // for wheel data to cover them
  std::optional<PreparedScan> reference_;
  bool have_scan_ = false;
  int64_t last_scan_utime_ = 0;
  bool clocks_checked_ = false;
  std::string clock_problem_;
  ScanMatchCounts counts_;
};

}  // namespace calib
