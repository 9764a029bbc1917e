#pragma once
// Recalibration during normal operation (the forklift case; docs/recalibration.md).
//
// While the robot does its work (no commander), data are kept only from configured segments
// of its route: from entering a zone (world frame of POSE) to leaving it, or odometry distance
// windows. Once `decision.segments` segments are complete, the calibration is fitted on some
// of them and compared on the others (held out) with the calibration in use:
//   - improvement: per held-out segment k, e_k = odometry error per metre (EvaluateOdometry)
//     of the calibration in use and of the candidate; d_k = e_cur,k - e_cand,k. One-sided
//     paired t-test, H0: mean d <= 0, t = mean(d) / (sd(d) / sqrt(n)), n - 1 dof; significant
//     when p < alpha AND mean(d) / mean(e_cur) >= min_improvement;
//   - consistency: D = candidate - in use (drive parameters and the sensor mount),
//     d2 = D^T (S_cand + S_use)^-1 D, chi-square with as many dof as values; consistent when
//     p = P(chi2 > d2) >= consistency_alpha (the two fits use disjoint data).
// The candidate is accepted only when both hold; otherwise the calibration in use is kept.
// Each decision is one JSON line with its numbers, verdict and reason; the accepted
// calibration is written as a robot file. Both files are written atomically.
//
// Everything here takes plain data; the live process (agvcal-recal) and `agvcal recal` on a
// recording feed the same SegmentRecorder and Decide, so they make the same decisions.
//
// Config file (YAML; unknown keys are errors; zones OR distance_windows):
//   zones:                                       # world frame of POSE (the tracked point), m
//     - {name: rack-ne, polygon: [[1, 0.3], [6, 0.3], [6, 3], [1, 3]]}
//     - {name: dock, circle: {x: 0, y: 0, radius: 1.5}}
//   distance_windows: {start_m: 5, length_m: 10, period_m: 40}   # odometry distance, nominal model
//   segments: {min_duration_s: 2, max_duration_s: 120, min_distance_m: 1, max_pose_gap_s: 1}
//   decision: {segments: 12, holdout_every: 3, window_s: 10, alpha: 0.05, min_improvement: 0.1,
//              consistency_alpha: 0.01}
//   prior_std:                                   # uncertainty of a robot file without std:
//     params: {drive_radius: 0.003, wheelbase: 0.03, steer_offset: 0.03}
//     lidar2d: {x: 0.03, y: 0.03, yaw: 0.03}     # and/or pose: {x:, y:, yaw:}

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/calibration_data.h"
#include "calib/core/kinematics.h"
#include "calib/core/robot.h"
#include "calib/core/sensor_data.h"
#include "calib/core/sensor_motion.h"
#include "calib/core/wheel_track.h"

namespace calib {

// A zone of the route: a polygon (vertices in order, either sense) or a circle, m.
struct Zone {
  std::string name;
  std::vector<Eigen::Vector2d> polygon;  // empty for a circle
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 0.0;
  bool Contains(double x, double y) const;
};

// Windows of the odometry distance travelled since the start (nominal model, m):
// [start_m + k period_m, start_m + k period_m + length_m), k = 0, 1, ... (one window if
// period_m is 0).
struct DistanceWindows {
  double start_m = 0.0, length_m = 0.0, period_m = 0.0;
};

struct RecalConfig {
  std::vector<Zone> zones;
  std::optional<DistanceWindows> windows;
  double min_duration_s = 2.0;    // shorter segments are dropped
  double max_duration_s = 120.0;  // a longer stay is cut into segments of this length
  double min_distance_m = 1.0;    // segments travelling less are dropped
  double max_pose_gap_s = 1.0;    // POSE silent longer: the open segment ends
  int segments_per_decision = 12;
  int holdout_every = 3;          // segments k with k % holdout_every == holdout_every - 1
  double window_s = 10.0;         // odometry windows of the held-out comparison
  double alpha = 0.05;            // level of the paired test
  double min_improvement = 0.1;   // relative improvement required besides significance
  double consistency_alpha = 0.01;
  std::map<std::string, double> prior_std;  // "drive_radius", "lidar2d.x", "pose.yaw", ...
  std::string source_file;
};

// Throws InputError naming the file, line and key for any problem.
RecalConfig LoadRecalConfig(const std::string& path);
RecalConfig ParseRecalConfig(const std::string& yaml_text, const std::string& origin);

struct Segment {
  int index = 0;           // counts complete segments from 0 over the run
  std::string trigger;     // zone name, or "window K"
  int64_t utime_start = 0, utime_end = 0;  // robot clock, us
  double distance_m = 0.0;                 // travelled (POSE path, or odometry for windows)
};

struct SegmentData {
  Segment segment;
  std::vector<WheelSample> wheels;     // spanning the segment
  std::vector<SensorMotion> motions;   // inside it
};

struct SegmentBatch {
  int number = 0;  // 1, 2, ...
  std::vector<SegmentData> segments;
};

// Turns the message streams into segments with their data, in robot time. Decisions depend on
// the messages' contents, not on how the streams interleave (up to `kLookbackS` of skew: a
// segment waits that long, in robot time, for its last scan matches before it is taken
// without them). 30 s: a replay at 10x on a loaded machine once lagged the matcher past 5 s
// (0.5 s of wall time), and the live decision differed from the offline one in the 8th digit.
class SegmentRecorder {
 public:
  static constexpr double kLookbackS = 30.0;

  // `robot`: the description at the start (its nominal model measures distance windows).
  SegmentRecorder(const RecalConfig& config, const RobotDescription& robot, MotionSource source);
  ~SegmentRecorder();

  void AddWheels(const WheelSample& sample);
  void AddMotion(const SensorMotion& motion);  // scan matches (2D lidar source)
  // Zones; with the pose source also the sensor motions.
  void AddPose(const StampedPose& pose);

  // The next `segments_per_decision` complete segments, once there are that many.
  std::optional<SegmentBatch> TakeBatch();

  int segments_complete() const { return next_index_; }
  int segments_dropped() const { return dropped_; }
  int segments_waiting() const { return static_cast<int>(complete_.size()); }

 private:
  void Open(int64_t utime, const std::string& trigger);
  void Close(int64_t utime);
  void Update();
  RecalConfig config_;
  MotionSource source_;
  std::unique_ptr<DriveModel> model_;  // nominal, for distance windows
  std::deque<WheelSample> wheels_;
  std::deque<SensorMotion> motions_;
  std::optional<StampedPose> last_pose_;
  PoseIntervals pose_intervals_;
  std::optional<Segment> open_;
  std::deque<Segment> closed_;  // waiting for their data
  std::deque<SegmentData> complete_;
  double distance_m_ = 0.0;     // odometry distance (windows)
  int next_index_ = 0, dropped_ = 0, batches_ = 0;
};

// The calibration in use: values and their covariance (diagonal: the robot file keeps the
// standard deviations only), in the order of `names`
// (ParamNames(drive), then "<mount>.x", "<mount>.y", "<mount>.yaw", mount = lidar2d or pose).
struct CalibrationInUse {
  RobotDescription robot;
  std::vector<std::string> names;
  Eigen::VectorXd value;
  Eigen::MatrixXd covariance;
  std::string origin;  // where the values and their uncertainty come from
};

// From a robot file: its `std:` section (written by `agvcal solve` or an accepted
// recalibration) or else the config's prior_std. Throws InputError naming the robot file when
// a value has neither, or the robot has no mount for `source`.
CalibrationInUse CalibrationFromRobot(const RobotDescription& robot, MotionSource source,
                                      const RecalConfig& config);

// The calibration in use at the start of a run: `robot_out` when it exists (what an earlier run
// accepted: a restarted process goes on from it), else `robot`.
CalibrationInUse StartingCalibration(const RobotDescription& robot, const std::string& robot_out,
                                     MotionSource source, const RecalConfig& config);

struct ImprovementTest {
  std::vector<double> current, candidate;  // error per metre on each held-out segment
  double mean_current = 0.0, mean_candidate = 0.0;
  double relative = 0.0;   // mean(d) / mean(current)
  double t = 0.0, p = 1.0;
  bool significant = false;
};
ImprovementTest TestImprovement(const std::vector<double>& current,
                                const std::vector<double>& candidate, double alpha,
                                double min_improvement);

struct ConsistencyTest {
  double d2 = 0.0;
  int dof = 0;
  double p = 1.0;
  bool consistent = false;
  std::string largest;         // the value that moved most, in combined sigmas
  double largest_sigmas = 0.0;
};
ConsistencyTest TestConsistency(const CalibrationInUse& in_use, const CalibrationInUse& candidate,
                                double alpha);

enum class Verdict { kAccepted, kRejected, kNoFit };
const char* VerdictName(Verdict verdict);  // "accepted", "rejected", "no_fit"

struct RecalDecision {
  int number = 0;
  int64_t utime = 0;  // end of the batch's last segment
  Verdict verdict = Verdict::kNoFit;
  std::string reason;
  std::vector<Segment> fit, heldout;
  CalibrationInUse in_use;
  std::optional<CalibrationResult> fit_result;
  std::optional<CalibrationInUse> candidate;
  std::optional<ImprovementTest> improvement;
  std::optional<ConsistencyTest> consistency;
  // The calibration in use after the decision: `in_use`, or if accepted the candidate with only
  // its standard deviations (what the robot file written keeps, so that a restarted process
  // goes on exactly as an undisturbed one).
  CalibrationInUse after;
};

RecalDecision Decide(const SegmentBatch& batch, const CalibrationInUse& in_use,
                     MotionSource source, const RecalConfig& config);

// One line of JSON (no newline): decision number, utime, verdict, reason, segments, the tests'
// numbers, the values in use and of the candidate.
std::string DecisionJson(const RecalDecision& decision);

// Writes the outcome: on acceptance the robot file `robot_out` (the in-use robot file with the
// new values, std: and source:), and appends the decision's line to `decisions_path`; both
// written before either is put in place, so a failure (a full disk) changes neither. An empty
// path is skipped.
void RecordDecision(const RecalDecision& decision, const std::string& robot_out,
                    const std::string& decisions_path);

// A recording through the same SegmentRecorder and Decide as agvcal-recal: WHEELS, the scans
// matched as agvcal-scanmatch matches them (with `scan_robot`, the robot file the live scan
// matcher is given; it also measures distance windows) and POSE, in log order. `on_decision`
// gets each decision as it is made (e.g. RecordDecision). A batch still incomplete at the end of
// the log is not decided, as in a live run that stops there.
struct RecalRun {
  std::vector<RecalDecision> decisions;
  CalibrationInUse in_use;  // at the end
  int segments = 0, dropped = 0, waiting = 0;
};
RecalRun RecalibrateLog(const RobotDescription& scan_robot, const CalibrationInUse& start,
                        const std::string& log_path, MotionSource source, const RecalConfig& config,
                        const std::function<void(const RecalDecision&)>& on_decision);

}  // namespace calib
