#pragma once
// Sim-to-real mismatch (`agvcal diagnose`): where the calibrated model and a
// recording disagree, which physics of spec/effects.md the model left out,
// how large it is, and how much better the model fits once it is modelled, on
// data the fit did not see.
//
// Three layers, each a comparison of two things the recording holds:
//   odometry + sensing: encoders (through the drive model, the mount and the
//     effect terms) against the sensor's measured motion per interval;
//   actuation: DRIVE_CMD setpoints against the encoders' speeds and angles.
// The recording is cut into alternating blocks of `block_s`: even blocks fit,
// odd blocks are held out. Every candidate effect is fitted jointly with the
// calibration on the fit blocks and tested with a Wald statistic whose
// covariance is autocorrelation-robust (Newey-West over neighbouring
// intervals); Holm's correction over the whole catalogue keeps the chance of
// any false alarm below `alpha`. Effects that pass must also explain the
// held-out residual (a score test on the held-out blocks) and are added
// greedily, each tested given those already chosen. Confusable pairs are fitted together: separated when the data
// tell them apart, reported as indistinguishable (with the motion that would
// separate them) when not. A candidate whose minimum detectable size exceeds
// any plausible size is reported as not identifiable, never as something else.
// An effect must also lower BIC on the fit blocks: a Wald statistic can overstate
// the evidence where the model is far from linear or the regressor sparse.

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/heldout.h"
#include "calib/core/drive_command.h"
#include "calib/core/robot.h"
#include "calib/core/sensor_motion.h"
#include "calib/core/wheel_track.h"

namespace calib {

struct DiagnoseOptions {
  double alpha = 0.01;       // family-wise false-alarm rate over all candidates
  double block_s = 10.0;     // length of the alternating fit / held-out blocks
  double drift_window_s = 2.0;  // held-out drift windows (FoundEffect::heldout_drift_*)
  int hac_lags = 4;          // Newey-West lags (neighbouring intervals share a scan)
  // Threads for the independent fits (each candidate's, each look-alike pair's); 0: the
  // hardware's, at most 2 (core/progress.h WorkerThreads). The report is the same for any number.
  int jobs = 0;
  // Iterations of each fit's solve; a fit that stops at this limit is named in the notes.
  int max_iterations = 50;
  std::function<void(const std::string&)> progress;
};

// What a recording holds for the diagnosis.
struct DiagnoseData {
  WheelTrack wheels;
  std::vector<SensorMotion> motions;
  MotionSource source = MotionSource::kLidar2d;
  std::vector<DriveCommand> commands;  // DRIVE_CMD, in time order (may be empty)
  // Scans that declare no beam timing (time_increment 0) are matched a second time as if
  // their beams spread over `scan_period_s`: the first-order effect of scan_distortion.
  double scan_period_s = 0.0;  // 0: the scans declare their timing (scan_distortion not testable)
  std::vector<SensorMotion> motions_spread;
  // The matcher de-skews each scan with `deskew_robot`'s odometry (no effects), on the wheel
  // clock `deskew_offset_s` before the stamps. The registration then places the scan where its
  // beams sit on average, `deskew_lead_s` (the mean beam time) after its stamp, less the
  // de-skew odometry over that lead: a match carries the truth over the interval shifted by the
  // lead, so what the de-skew model leaves out (an eccentric wheel's phase) shows shifted by it.
  // 0: the scans were not de-skewed.
  double deskew_lead_s = 0.0;
  double deskew_offset_s = 0.0;
  std::optional<RobotDescription> deskew_robot;
  // What the reader left out (bad or out-of-order messages, torn events), for REPORT.json
  // `input`, as RESULT.json carries it.
  int64_t input_dropped = 0;
  std::vector<std::string> input_notes;
};

// Reads WHEELS, the motion sensor (scan-matched SCAN or POSE) and DRIVE_CMD. The scans
// are de-skewed with the calibrated model, using the wheel data `deskew_offset_s` before
// their stamps (the motions keep the recorded stamps).
DiagnoseData ReadDiagnoseData(const RobotDescription& robot, const std::string& log_path,
                              const std::function<void(const std::string&)>& progress,
                              double deskew_offset_s = 0.0);

// The motion under which an interval was driven (calibrated model, encoders).
struct MotionConditions {
  double speed = 0, accel = 0, turn_rate = 0, centripetal = 0;  // m/s, m/s^2, rad/s, m/s^2
  double turn_accel = 0;             // rad/s^2
  double steer = 0, steer_rate = 0;  // rad, rad/s (first steered wheel; 0 without steering)
  int steer_direction = 0;           // sign of the last steering motion (+1 left, -1 right, 0 none)
  double route_m = 0;                // distance along the route since the start
  double x = 0, y = 0;               // odometry position of the reference point, m
};

struct DiagnosedInterval {
  int64_t utime_start = 0, utime_end = 0;
  bool heldout = false, outlier = false;
  Eigen::Vector3d before = Eigen::Vector3d::Zero();  // residual of the calibrated model (x, y, yaw)
  Eigen::Vector3d after = Eigen::Vector3d::Zero();   // with the effects found
  Eigen::Vector3d sigma = Eigen::Vector3d::Ones();   // measurement std per component (scaled)
  MotionConditions motion;
};

struct TimeSpan {
  int64_t utime_start = 0, utime_end = 0;
};

struct ParamEstimate {
  double value = 0, std = 0;
};

// Binned mean residual against the effect's regressor, before and after.
struct SignatureBin {
  double x = 0;  // bin centre of the regressor
  double before = 0, after = 0, std_error = 0;
  int count = 0;
};

// The chained error over one held-out stretch, without and with the effect.
struct HeldoutStretch {
  int64_t utime_start = 0, utime_end = 0;
  double before = 0, after = 0;
};

struct FoundEffect {
  std::string name, layer, wheel;  // effects.md name; wheel role when it applies to one wheel
  std::map<std::string, ParamEstimate> params;
  double wald = 0, p_value = 1, p_adjusted = 1, delta_bic = 0;
  std::string component;  // residual the effect shows in: x, y, yaw (odometry) or speed, steer
  // Held-out RMS of `component` where the effect stands out (`where`), and over all held-out data.
  double heldout_rms_before = 0, heldout_rms_after = 0;
  double heldout_rms_all_before = 0, heldout_rms_all_after = 0;
  // Dead-reckoning drift over `drift_window_s` of consecutive held-out motion (the model
  // chained against the measured motion chained, heldout.h OdometryErrorOverWindows),
  // RMS of the translation or heading error per window. Per interval the noise is large
  // against a small effect; chained, the effect adds up and a scan's registration error
  // cancels. Actuation effects (compared with the encoders, not chained) leave it empty.
  std::string drift_component;  // translation, heading or "" (not measured)
  double drift_window_s = 0, heldout_drift_before = 0, heldout_drift_after = 0;
  int drift_windows = 0;
  // In `component`, over one stretch of consecutive held-out intervals per held-out block:
  // the stretch over which the effect changes the chained motion most (chosen from the
  // models' predictions, not the measurement), RMS over the stretches of the chained error.
  std::vector<HeldoutStretch> stretches;
  double heldout_stretch_before = 0, heldout_stretch_after = 0;  // RMS over the stretches
  // The held-out measure that judges the effect: "drift" for effects whose error keeps its
  // sign and adds up along the way (lateral slip, backlash, steering lag, scan distortion);
  // "stretch" for those whose chained error telescopes to the window's ends (time offset,
  // longitudinal slip): from its low to its high point the effect is as large as a block
  // allows; "per_interval" (the `heldout_rms_*`) for eccentricity (it cancels over a wheel
  // revolution, a third of which one interval spans), effects not chained (actuation), and
  // too few held-out stretches.
  std::string heldout_measure = "per_interval";
  // The held-out proofs disagree: the measure that judges it is not lower with the effect,
  // although a held-out test declared it; `heldout_confirmed_by` names the test that confirms it
  // against the final model without it: "score", "drift", or "" (neither). The score test sees
  // each interval, the drift the chained motion: an effect can lower one and raise the other.
  bool heldout_disagrees = false;
  std::string heldout_confirmed_by;
  std::vector<TimeSpan> where;
  // An effect confined to a region of the floor: its bounding box in the odometry frame
  // (x0, y0, x1, y1, m; REPORT.json `region` beside `where`). Absent: it acts everywhere.
  std::optional<std::array<double, 4>> region;
  std::string regime;     // the motion under which it shows, in words
  std::string regressor;  // what the signature is binned by
  std::string signature_component;  // the residual component binned
  std::vector<SignatureBin> signature;
};

// What became of a candidate. Written out (REPORT.json, summary) by CandidateStatusName.
enum class CandidateStatus {
  kFound,              // "found"
  kNotSignificant,     // "not_significant"
  kNotIdentifiable,    // "not_identifiable": its minimum detectable size exceeds any plausible size
  kIndistinguishable,  // "indistinguishable": from its confusable look-alike
  kRejected,           // "rejected": significant alone, explained by the effects found
};
const char* CandidateStatusName(CandidateStatus status);

// The parameter key (spec/effects.md) an effect's size is given in: "offset_s" for
// time_offset, "slip_per_accel" for longitudinal_slip, ...; its unit: core/units.h ParamUnit.
std::string EffectSizeKey(const std::string& effect_name);

// The SI unit of a residual component or actuation trace by its first word: "m" (x, y,
// translation), "rad" (yaw, heading, steer ...), "rad/s" (speed ...).
std::string ComponentUnit(const std::string& component);

// Every candidate tested, with its outcome.
struct CandidateOutcome {
  std::string name, layer, wheel;
  CandidateStatus status = CandidateStatus::kNotSignificant;
  ParamEstimate estimate;
  double p_value = 1, p_adjusted = 1, delta_bic = 0;
  double detectable = 0;  // minimum detectable size (alpha, power 0.8) with this recording
  // The same when its confusable look-alike is fitted too (both present): by look-alike.
  std::map<std::string, double> detectable_with;
  std::string note;       // e.g. the motion that would excite it
  // Fitted alone: how much lower, as a fraction, the held-out chi-square is with it, and
  // whether a held-out test confirms it.
  double heldout_change = 0;
  bool heldout_confirmed = false;
};

// A decision near its gate, which an unrelated change to the recording (another effect, a
// few intervals more or less) can flip: an effect found, or significant alone but not found,
// whose catalogue-wide p lies within a factor kBorderlineFactor of the level.
inline constexpr double kBorderlineFactor = 10.0;
struct Borderline {
  std::string name, wheel;
  CandidateStatus status = CandidateStatus::kNotSignificant;
  double p_value = 1;  // catalogue-wide: a found effect's given the others found, else alone
  double alpha = 0;    // the family-wise level it is judged at
  double heldout_change = 0;  // CandidateOutcome::heldout_change
  bool heldout_confirmed = false;
};

// An effect found whose size with the other effects found differs by more than two sigma from
// its size alone: it depends on them (and moves when they do).
struct MovedEffect {
  std::string name, wheel;
  ParamEstimate alone, with_others;
  std::vector<std::string> others;  // the other effects found
};

struct Indistinguishable {
  std::string first, second;
  double correlation = 0;
  std::string motion;  // what would separate them
};

struct Unexplained {
  std::vector<TimeSpan> where;
  std::string correlates_with;
  double p_value = 1;
  std::string component;
};

// Physics outside effects.md the diagnosis modelled from the library of core/physics_terms.h
// (REPORT.json `discovered`, spec/cli.md; diagnose/discover.h says how).
struct DiscoveredTerm {
  std::string regressor;    // e.g. "turn_rate*|turn_rate|"
  ParamEstimate coefficient;
  std::string unit;         // of the coefficient
};

struct Discovered {
  std::string channel;      // yaw_rate, radius, steer, timing (physics_terms.h)
  std::vector<DiscoveredTerm> terms;
  std::string equation, interpretation;
  std::string component;    // the residual component it shows most in (x, y, yaw)
  double wald = 0, p_value = 1, p_adjusted = 1, delta_bic = 0;
  // Held-out, with the other terms and the calibration refitted without and with it: the RMS of
  // `component` where it stands out and the heading error chained over drift_window_s windows.
  double heldout_rms_before = 0, heldout_rms_after = 0;
  double heldout_drift_before = 0, heldout_drift_after = 0;
  int drift_windows = 0;
  double drift_window_s = 0;
  std::vector<TimeSpan> where;
};

// How far the final model's residuals are beyond a well-fitting recording's.
struct Misfit {
  // The final model's chi-square per degree of freedom on the fit blocks in the matcher's own
  // covariance (a well-fitting recording's is near 1).
  double variance_factor = 1;
  // The held-out heading error chained over drift windows against what independent noise of the
  // final model's own per-interval size would chain to (near 1 without structure in time).
  double heading_drift_ratio = 1;
  bool beyond = false;  // far beyond a well-fitting recording's
};

struct DiagnoseReport {
  DriveType drive = DriveType::kDifferential;
  MotionSource source = MotionSource::kLidar2d;
  std::string verdict;  // effects_found | no_significant_effect | unmodelled_structure
  std::vector<std::string> param_names;
  std::map<std::string, ParamEstimate> calibration;  // baseline (fit blocks), params + mount.*
  std::map<std::string, ParamEstimate> refitted;     // jointly with the effects found
  std::vector<FoundEffect> effects;
  std::vector<CandidateOutcome> candidates;
  std::vector<Indistinguishable> indistinguishable;
  std::vector<Borderline> borderline;
  std::vector<MovedEffect> moved;
  std::vector<Unexplained> unexplained;
  std::vector<Discovered> discovered;
  Misfit misfit;
  std::vector<DiagnosedInterval> intervals;
  double heldout_rms_before[3] = {0, 0, 0}, heldout_rms_after[3] = {0, 0, 0};
  double heldout_chi2_before = 0, heldout_chi2_after = 0;  // per held-out interval
  OdometryError heldout_drift_before, heldout_drift_after;  // over drift_window_s windows
  int fit_intervals = 0, heldout_intervals = 0, outliers = 0;
  // Share of all intervals set aside (outliers under the final model and under every
  // candidate's own fit) and its correlation with each motion regressor (|speed|,
  // |acceleration|, |turn rate|, |turn-rate change|, |centripetal|, |steering rate|): outliers
  // that cluster where the turn rate changes are a time offset left unmodelled.
  double outlier_share = 0;
  std::map<std::string, double> outlier_correlation;
  double variance_factor = 1;
  // Actuation layer time series (for plots): utime, measured, predicted before/after.
  struct Trace {
    std::string name;  // "speed <role>" or "steer <role>"
    std::vector<int64_t> utime;
    std::vector<double> measured, before, after;
  };
  std::vector<Trace> actuation;
  std::vector<std::string> notes;
  // What the reader left out of the recording (DiagnoseData's); REPORT.json `input` (absent
  // when nothing was).
  int64_t input_dropped = 0;
  std::vector<std::string> input_notes;
  // A fit that stopped short of convergence (the starting calibrations, the baseline, a candidate
  // alone, a confusable pair, the final model): its test or its values are uncertain. REPORT.json
  // `warnings` (absent when empty).
  std::vector<std::string> warnings;
  // The robot-clock utime of the recording's first message: t = 0 of the report's times
  // (DiagnoseLog sets it; 0: the first interval's start).
  int64_t recording_start_utime = 0;
};

// Diagnoses a recording against `robot` (its nominal values are only the
// starting point: the calibration is refitted). Throws InputError when there
// is too little to work with.
DiagnoseReport Diagnose(const RobotDescription& robot, const DiagnoseData& data,
                        const DiagnoseOptions& options, const std::string& origin);

// ReadDiagnoseData + Diagnose; when a time offset is found, the scans are matched again
// de-skewed on the wheel clock and the recording diagnosed once more (what `agvcal
// diagnose` runs).
DiagnoseReport DiagnoseLog(const RobotDescription& robot, const std::string& log_path,
                           const DiagnoseOptions& options);

// REPORT.json (spec/cli.md) with the extra keys of DiagnoseReport.
// t = 0 of the report's times: recording_start_utime, or the first interval's start.
int64_t ReportTimeOrigin(const DiagnoseReport& report);
// "12.3–15.0 s, 40.1–44.0 s, … (9 spans)": the first `shown` spans in seconds since `origin`
// (summary.txt and the report page alike).
// A candidate's note without the figures of the test over boxes of the route that did not name it
// (REPORT.json keeps them): what the summary and the page say of it.
std::string CandidateNoteInWords(const std::string& note);

std::string SpanTimes(const std::vector<TimeSpan>& spans, int64_t origin, std::size_t shown = 6);

std::string DiagnoseReportJson(const DiagnoseReport& report);

// One sentence a person acts on: what is missing from the model, how sure, what to do about it
// (the first line of the summary, the top of the page).
std::string DiagnoseVerdict(const DiagnoseReport& report);

// Plain-words summary: the verdict, then what physics was missing, how large, how much better. `verbose` adds the
// diagnosis's own bookkeeping (REPORT.json `notes`, the status and statistics of the candidates
// tested and not named, the region test's figures); the console shows it with --verbose only.
std::string DiagnoseSummaryText(const DiagnoseReport& report, bool verbose = false);

// The human report: summary.txt and SVG plots in `dir` (created if needed).
void WriteDiagnoseReportDir(const DiagnoseReport& report, const std::string& dir);

// `real` compared with a simulator's recording of the same commands (`sim`):
// the effects and parameters on which they differ, in JSON.
std::string CompareWithSimJson(const DiagnoseReport& real, const DiagnoseReport& sim);

// A simulation config that reproduces the real robot: the refitted calibration
// as truth and the effects found, for `robot_path` (written as given).
std::string SimConfigYaml(const DiagnoseReport& report, const std::string& robot_path);

}  // namespace calib
