#include "calib/diagnose/diagnose.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <memory>
#include <numeric>
#include <sstream>
#include <utility>

#include <Eigen/Dense>
#include <ceres/ceres.h>

#include "calib/calibrate/heldout.h"
#include "calib/calibrate/interval_model.h"
#include "calib/calibrate/recalibration.h"
#include "calib/calibrate/recording_input.h"
#include "calib/core/errors.h"
#include "calib/core/laser_scan.h"
#include "calib/core/progress.h"
#include "calib/io/log_summary.h"
#include "calib/core/statistics.h"
#include "calib/core/units.h"
#include "calib/diagnose/selection.h"
#include "calib/io/message_source.h"
#include "diagnose/diagnose_internal.h"
#include "diagnose/diagnose_model.h"

namespace calib {
namespace diag {

Track MakeTrack(const RobotDescription& robot, const WheelTrack& wheels) {
  Track tr(EncoderTrack(robot.drive, wheels));
  const auto& roles = WheelRoles(robot.drive);
  const auto& names = ParamNames(robot.drive);
  for (int w = 0; w < tr.wheels; ++w) {
    tr.steered[w] = robot.drive != DriveType::kDifferential;
    tr.radius_index[w] = static_cast<int>(
        std::find(names.begin(), names.end(), RadiusParamName(roles[w])) - names.begin());
  }
  const std::size_t n = tr.size();
  tr.speed.assign(n, {0, 0});
  tr.steer_sign.assign(n, {0, 0});
  tr.travel_sign.assign(n, 1.0);
  if (n < 3) return tr;
  // Speeds by central differences over about +-50 ms: below that, tick quantisation dominates.
  const double dt = (tr.utimes().back() - tr.utimes().front()) * 1e-6 / double(n - 1);
  const int k = std::max(1, int(std::lround(0.05 / std::max(dt, 1e-4))));
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t lo = i >= std::size_t(k) ? i - k : 0, hi = std::min(n - 1, i + k);
    const double span = (tr.utime(hi) - tr.utime(lo)) * 1e-6;
    for (int w = 0; w < tr.wheels; ++w) tr.speed[i][w] = (tr.pos(hi, w) - tr.pos(lo, w)) / span;
  }
  tr.smooth_k = k;
  // Direction of the last steering motion, with hysteresis above the reading's noise.
  constexpr double kSteerHysteresis = 0.002;  // rad
  for (int w = 0; w < tr.wheels; ++w) {
    if (!tr.steered[w]) continue;
    double sign = 0, extreme = tr.steer(0, w);
    for (std::size_t i = 0; i < n; ++i) {
      const double s = tr.steer(i, w);
      if (sign >= 0 && s < extreme - kSteerHysteresis) sign = -1, extreme = s;
      else if (sign <= 0 && s > extreme + kSteerHysteresis) sign = 1, extreme = s;
      else if ((sign > 0 && s > extreme) || (sign < 0 && s < extreme)) extreme = s;
      tr.steer_sign[i][w] = sign;
    }
  }
  // Direction of travel (the first wheel's; the mean of both for a differential drive).
  double travel = 1;
  for (std::size_t i = 0; i < n; ++i) {
    double s = tr.speed[i][0];
    if (robot.drive == DriveType::kDifferential) s = 0.5 * (s + tr.speed[i][1]);
    if (std::abs(s) > 0.05) travel = s > 0 ? 1 : -1;
    tr.travel_sign[i] = travel;
  }
  return tr;
}

std::vector<double> HolmAdjust(const std::vector<double>& p) {
  const std::size_t m = p.size();
  std::vector<std::size_t> order(m);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p[a] < p[b]; });
  std::vector<double> out(m);
  double running = 0;
  for (std::size_t r = 0; r < m; ++r) {
    running = std::max(running, std::min(1.0, (m - r) * p[order[r]]));
    out[order[r]] = running;
  }
  return out;
}

double Rms(const std::vector<double>& v) {
  if (v.empty()) return 0.0;
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / v.size());
}

std::vector<TimeSpan> MergeSpans(std::vector<TimeSpan> flagged, int64_t gap_us) {
  std::sort(flagged.begin(), flagged.end(),
            [](const TimeSpan& a, const TimeSpan& b) { return a.utime_start < b.utime_start; });
  std::vector<TimeSpan> out;
  for (const TimeSpan& s : flagged) {
    if (!out.empty() && s.utime_start - out.back().utime_end <= gap_us)
      out.back().utime_end = std::max(out.back().utime_end, s.utime_end);
    else
      out.push_back(s);
  }
  return out;
}

}  // namespace diag

namespace {
using namespace diag;

constexpr double kOutlierChi2 = 50.0;  // 3 dof, p ~ 1e-10 at the robust scale: failed matches only
constexpr double kHeldoutZ = 1.645;  // one-sided 5 % on the held-out blocks
constexpr double kDriftP = 0.01;     // one-sided level of the held-out drift confirmation
constexpr double kHeldoutP = 0.05;   // one-sided level of a region effect's held-out improvement
constexpr double kMinRegionGain = 0.05;  // and its practical floor (as the actuation layer's kMinGain)

struct Model {
  double params[5] = {0, 0, 0, 0, 0};
  double mount[3] = {0, 0, 0};
  double beta[kNumBeta] = {};
};

struct Interval {
  const SensorMotion* motion = nullptr;
  std::unique_ptr<IntervalModel> model;
  int block = 0;  // index of its fit (even) or held-out (odd) block
  bool heldout = false, outlier = false;
  Eigen::Vector3d sigma = Eigen::Vector3d::Ones();  // unscaled measurement std per component
};

struct Candidate {
  std::string name, layer, wheel;
  std::vector<int> beta;
  std::vector<std::string> keys;  // effects.md parameter keys
  double plausible = 0;           // largest size a real robot plausibly shows
  std::string excitation;         // motion that excites it
  std::string regressor;          // what its signature is binned by
  bool catalogued = true;
};

// A fitted model with its statistics.
struct Fit {
  Model m;
  std::vector<int> free;
  double chi2_fit = 0, chi2_heldout = 0;  // whitened, divided by the variance factor
  std::vector<double> heldout_terms;      // chi2 of each held-out interval, in order
  int n_fit = 0, n_heldout = 0;
  int dof = 1;                 // 3 n_fit less the parameters fitted
  Eigen::MatrixXd cov;         // robust covariance of the free effect parameters
  Eigen::MatrixXd info_cov;    // the same from the information alone (H^-1: independent residuals)
  double wald = 0, p = 1;      // of the free effect parameters named in `tested`
  std::vector<int> tested;
};

// The variance factor of `model` in units of `baseline`'s (the noise scale s2 every chi-square
// is divided by): the noise scale of a test against `model` instead of the baseline.
double RelativeScale(const Fit& model, const Fit& baseline) {
  return (model.chi2_fit / model.dof) / (baseline.chi2_fit / baseline.dof);
}

// DeltaBic (selection.h) with the chi-squares in the noise scale of `reference`, the model the
// parameters are added to: the baseline has no effect, and a large one (a time offset of 50 ms
// on the forklift: variance factor 707 against 1.3 once it is modelled) would otherwise keep
// every second effect from paying for its parameter.
double DeltaBicAt(const Fit& reference, const Fit& f0, double chi2_with, double chi2_without, std::size_t params,
                  double log_n) {
  const double scale = RelativeScale(reference, f0);
  return DeltaBic(chi2_with / scale, chi2_without / scale, params, log_n);
}

// How much lower, as a fraction, the held-out chi-square is after than before.
double HeldoutGain(const Fit& before, const Fit& after) {
  return before.chi2_heldout > 0 ? (before.chi2_heldout - after.chi2_heldout) / before.chi2_heldout : 0.0;
}

// Correlation of the estimates `a` and `b` of a covariance.
double Correlation(const Eigen::MatrixXd& cov, int a, int b) {
  return cov(a, b) / std::sqrt(std::max(cov(a, a) * cov(b, b), 1e-300));
}

Eigen::Vector3d ErrorOf(const Interval& it, const Model& m) {
  double e[3];
  it.model->Error(m.params, m.mount, m.beta, e);
  return {e[0], e[1], e[2]};
}

// An interval's Jacobians by parameter block.
struct Jacobians {
  Eigen::Matrix<double, 3, 5, Eigen::RowMajor> params;
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> mount;
  Eigen::Matrix<double, 3, kNumBeta, Eigen::RowMajor> beta;
};

// An interval's whitened residual `r` under `m`, and its Jacobians when `jac` is given: over
// the drive parameters, the mount and the effect terms `betas` (the other columns zero).
void Residual(const Interval& it, const Model& m, double r[3], Jacobians* jac = nullptr,
              const std::vector<int>& betas = {}) {
  const IntervalFunction function(it.model.get(), &betas);
  const double* blocks[3] = {m.params, m.mount, m.beta};
  if (jac == nullptr) {
    function.Evaluate(blocks, r, nullptr);
    return;
  }
  double* jacobians[3] = {jac->params.data(), jac->mount.data(), jac->beta.data()};
  function.Evaluate(blocks, r, jacobians);
}

double Chi2Of(const Interval& it, const Model& m) {
  double r[3];
  Residual(it, m, r);
  return r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
}

class Diagnoser {
 public:
  Diagnoser(const RobotDescription& robot, const DiagnoseData& data, const DiagnoseOptions& options,
            const std::string& origin)
      : robot_(robot), data_(data), options_(options), origin_(origin) {}

  DiagnoseReport Run();

 private:
  void Progress(const std::string& line) const {
    if (options_.progress) options_.progress(line);
  }
  void BuildIntervals();
  Eigen::Vector3d SpreadDerivative(const SensorMotion* m,
                                   const std::map<std::pair<int64_t, int64_t>, const SensorMotion*>& spread) const;
  // Sets aside the intervals that are outliers under every model of `models` (each at its own
  // robust scale, at most the chosen model's, the last of `models`): a large residual that some
  // candidate explains is evidence, not noise.
  void Gate(const std::vector<Model>& models);
  // The share of intervals set aside and its correlation with each motion regressor.
  void DescribeOutliers(DiagnoseReport* report) const;
  // The baseline fitted, every candidate tested and the effects selected (selection.h).
  DiagnoseReport Select(const Model& start, const CalibrationResult& cal);
  // Select's steps.
  Fit FitBaseline(const Model& start, DiagnoseReport* report);  // sets the variance factor
  std::vector<Fit> FitSingles(const std::vector<Candidate>& cands, const Fit& f0) const;
  // The value of effect parameter `beta` on `grid` with the lowest chi-square on the fit blocks.
  double BestOnGrid(const Model& m, int beta, const std::vector<double>& grid) const;
  std::vector<SingleFit> SingleFigures(const std::vector<Candidate>& cands, const std::vector<Fit>& single,
                                       const Fit& f0, double log_n) const;
  bool ScoreConfirmed(const Fit& before, const Fit& after) const;
  bool DriftConfirmed(const Fit& before, const Fit& after, bool heading) const;
  // Either confirms `after`'s effects against `before` on the held-out blocks.
  bool HeldoutConfirms(const Candidate& c, const Fit& before, const Fit& after) const;
  // `with` refitted without `c`; `others` receives the effect parameters left free.
  Fit FitWithout(const Fit& with, const Candidate& c, std::vector<int>* others) const;
  // The intervals before and after, and the held-out figures of the whole model.
  void DescribeModel(const Fit& f0, const Fit& current, DiagnoseReport* report) const;
  void ReportFound(const std::vector<Candidate>& cands, const Selection& selection, const SelectionLevels& levels,
                   const Fit& f0, const Fit& current, double log_n, DiagnoseReport* report) const;
  void ReportCalibration(const Fit& f0, const Fit& current, const CalibrationResult& cal,
                         DiagnoseReport* report) const;
  class RecordingFits;
  Fit FitModel(const Model& start, const std::vector<int>& free, const std::vector<int>& tested) const;
  std::vector<Candidate> Candidates() const;
  void Conditions(DiagnoseReport* report) const;
  FoundEffect Describe(const Candidate& c, const Fit& final_fit, const Fit& without,
                       const DiagnoseReport& report) const;
  double Regressor(const std::string& name, const DiagnosedInterval& d, const Interval& it) const;
  struct Localized {
    int comp = 0;
    std::vector<bool> flagged;  // per interval: the effect's contribution stands out
    double rms_before = 0, rms_after = 0, rms_all_before = 0, rms_all_after = 0;  // held-out
    double span_gain() const { return rms_before > 0 ? 1.0 - rms_after / rms_before : 0.0; }
  };
  OdometryError HeldoutDrift(const Model& m) const;
  std::vector<HeldoutStretch> HeldoutStretches(const Candidate& c, const Model& with, const Model& without, int comp) const;
  Localized Localize(const Candidate& c, const Model& with, const Model& without) const;
  void FindUnexplained(DiagnoseReport* report) const;
  // Floor effects not found over the whole recording, tested over regions of the route.
  void TestRegions(const std::vector<Candidate>& cands, const Fit& current, const SelectionLevels& levels,
                   DiagnoseReport* report) const;

  const RobotDescription& robot_;
  const DiagnoseData& data_;
  const DiagnoseOptions& options_;
  std::string origin_;
  Track track_;
  std::vector<Interval> intervals_;
  std::vector<int> constant_params_;
  int num_params_ = 0;
  double s2_ = 1.0;  // variance factor of the baseline fit
  Model baseline_, final_;
  std::vector<Model> alternatives_;  // the candidates' single fits of the last selection
  double offset_start_ = 0.0;
  // The bound of the time offset: kMaxOffsetS, or the calibration's wider one when its search
  // found the offset at that bound (calibration.h kWidestTimeOffsetS).
  double max_offset_s_ = kMaxOffsetS;
  std::vector<std::string> notes_;
  int m_odo_ = 0, m_act_ = 0;
};

class Diagnoser::RecordingFits : public SelectionFits {
 public:
  RecordingFits(const Diagnoser& d, const std::vector<Candidate>& cands, const std::vector<Fit>& single,
                const Fit& f0, double log_n);
  // The catalogue's pairs both of whose members are candidates, fitted together from the baseline.
  std::vector<PairFit> FitPairs(const std::vector<ConfusablePair>& catalogue);
  const Fit& current() const { return current_; }

  bool PairConfirmed(int k) override;
  void StartFromPair(int k) override;
  StepTest TryAdd(int j) override;
  bool AddConfirmed(int j) override;
  void Add(int j) override;
  StepTest TryKeep(int j) override;
  bool KeepConfirmed(int j) override;
  void Drop(int j) override;
  LookAlikeFit FitLookAlike(int x, int y) override;

 private:
  const Diagnoser& d_;
  const std::vector<Candidate>& cands_;
  const std::vector<Fit>& single_;
  const Fit& f0_;
  const double log_n_;
  Fit current_;
  std::vector<PairFit> pairs_;
  std::vector<Fit> joints_;  // per pair
  std::vector<Fit> trials_;  // per candidate: its last TryAdd
  Fit with_, without_;       // the last TryKeep
  std::vector<int> others_;  // free in `without_`
};

// d(measured motion)/d(scan period): the same interval matched with beams spread over
// the scan period, minus the plain match, per second of period (zero when unmatched).
Eigen::Vector3d Diagnoser::SpreadDerivative(
    const SensorMotion* m, const std::map<std::pair<int64_t, int64_t>, const SensorMotion*>& spread) const {
  const auto it = spread.find({m->utime_start, m->utime_end});
  if (it == spread.end() || !(data_.scan_period_s > 0)) return Eigen::Vector3d::Zero();
  const Pose2& a = m->delta;
  const Pose2& b = it->second->delta;
  return Eigen::Vector3d(b.x - a.x, b.y - a.y, WrapAngle(b.theta - a.theta)) / data_.scan_period_s;
}

void Diagnoser::BuildIntervals() {
  track_ = MakeTrack(robot_, data_.wheels);
  const double margin = (kHistoryS + max_offset_s_) * 1e6;
  std::vector<const SensorMotion*> usable;
  for (const SensorMotion& m : data_.motions) {
    if (m.valid && !m.degenerate && m.utime_end > m.utime_start &&
        data_.wheels.Covers(m.utime_start - margin, m.utime_end + max_offset_s_ * 1e6))
      usable.push_back(&m);
  }
  std::stable_sort(usable.begin(), usable.end(),
                   [](const SensorMotion* a, const SensorMotion* b) { return a->utime_start < b->utime_start; });
  // Too little data is exit 3 (spec/cli.md), as for the calibration: the recording is
  // fine, it is only too short to tell an effect from noise.
  if (usable.size() < 40)
    throw UnobservableError(origin_ + ": only " + std::to_string(usable.size()) +
                                " usable intervals with encoder data; the diagnosis needs at least 40",
                            "record a longer run (more scan-matched motion)");
  std::map<std::pair<int64_t, int64_t>, const SensorMotion*> spread;
  for (const SensorMotion& m : data_.motions_spread)
    if (m.valid) spread[{m.utime_start, m.utime_end}] = &m;
  const int64_t t_first = usable.front()->utime_start;
  const auto& ut = track_.utimes();
  const double lead_s = data_.deskew_robot ? data_.deskew_lead_s : 0.0;
  const std::unique_ptr<DriveModel> deskew_model = lead_s > 0 ? MakeDriveModel(*data_.deskew_robot) : nullptr;
  // The de-skew odometry over the lead after a stamp, on the wheel clock the matcher used.
  auto deskew_over_lead = [&](int64_t stamp) {
    if (!deskew_model) return Pose2{};
    const double t = stamp - data_.deskew_offset_s * 1e6;
    return data_.wheels.Odometry(*deskew_model, t, t + lead_s * 1e6);
  };
  for (const SensorMotion* m : usable) {
    Interval it;
    it.motion = m;
    const int64_t mid = (m->utime_start + m->utime_end) / 2;
    it.block = static_cast<int>((mid - t_first) * 1e-6 / options_.block_s);
    it.heldout = it.block % 2 == 1;
    std::size_t first = std::upper_bound(ut.begin(), ut.end(), int64_t(m->utime_start - margin)) - ut.begin();
    first = first > 0 ? first - 1 : 0;
    std::size_t last = std::lower_bound(ut.begin(), ut.end(), int64_t(m->utime_end + max_offset_s_ * 1e6)) - ut.begin();
    last = std::min(last, ut.size() - 1);
    for (int k = 0; k < 3; ++k) it.sigma[k] = std::sqrt(std::max(m->covariance(k, k), 1e-18));
    it.model = std::make_unique<IntervalModel>(
        &track_, first, last, m->utime_start, (m->utime_end - m->utime_start) * 1e-6,
        Eigen::Vector3d(m->delta.x, m->delta.y, m->delta.theta), SqrtInformation(m->covariance),
        SpreadDerivative(m, spread), lead_s, deskew_over_lead(m->utime_start), deskew_over_lead(m->utime_end));
    intervals_.push_back(std::move(it));
  }
}

Fit Diagnoser::FitModel(const Model& start, const std::vector<int>& free,
                        const std::vector<int>& tested) const {
  Fit fit;
  fit.m = start;
  fit.free = free;
  fit.tested = tested;
  for (int j = 0; j < kNumBeta; ++j)
    if (std::find(free.begin(), free.end(), j) == free.end()) fit.m.beta[j] = 0.0;
  {
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    std::deque<IntervalFunction> functions;  // derivatives over the free effect terms only
    for (const Interval& it : intervals_) {
      if (it.heldout || it.outlier) continue;
      functions.emplace_back(it.model.get(), &fit.free);
      problem.AddResidualBlock(&functions.back(), nullptr, fit.m.params, fit.m.mount, fit.m.beta);
    }
    if (!constant_params_.empty()) problem.SetManifold(fit.m.params, new ceres::SubsetManifold(5, constant_params_));
    std::vector<int> fixed;
    for (int j = 0; j < kNumBeta; ++j)
      if (std::find(free.begin(), free.end(), j) == free.end()) fixed.push_back(j);
    if (fixed.size() == kNumBeta) {
      problem.SetParameterBlockConstant(fit.m.beta);
    } else {
      problem.SetManifold(fit.m.beta, new ceres::SubsetManifold(kNumBeta, fixed));
      problem.SetParameterLowerBound(fit.m.beta, kLag, 0.0);
      problem.SetParameterUpperBound(fit.m.beta, kLag, 0.5);
      problem.SetParameterLowerBound(fit.m.beta, kTimeOffset, -max_offset_s_);
      problem.SetParameterUpperBound(fit.m.beta, kTimeOffset, max_offset_s_);
      // A scan period is not negative: unbounded, MIT CSAIL's single fit went to -0.19 s and the
      // joint fit traded the period against the time offset (241 ms with 0.17 s, 147 ms alone).
      problem.SetParameterLowerBound(fit.m.beta, kDistortion, 0.0);
      // Nor is a play's width: a negative "backlash" (the wheel ahead of its encoder in the
      // direction it last moved) is no play but the interval's steering read at its ends while
      // it turns slowly, as under a steering rate limit; on three dual-steer recordings with a
      // rate limit and no backlash it came out -0.4 to -0.75 mrad at p < 1e-7 and was named.
      problem.SetParameterLowerBound(fit.m.beta, kBacklash, 0.0);
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.max_num_iterations = 50;
    so.function_tolerance = 1e-10;
    so.parameter_tolerance = 1e-10;
    so.num_threads = 1;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
  }
  // Statistics: information H and Newey-West spread M of the scores; cov = H^-1 M H^-1.
  std::vector<int> active;  // columns: free params, mount, free betas
  for (int i = 0; i < 5; ++i)
    if (i < num_params_ && std::find(constant_params_.begin(), constant_params_.end(), i) == constant_params_.end())
      active.push_back(i);
  const int np = static_cast<int>(active.size());
  const int dim = np + 3 + static_cast<int>(free.size());
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(dim, dim);
  std::vector<Eigen::VectorXd> scores;
  const double s = std::sqrt(s2_);
  for (const Interval& it : intervals_) {
    if (it.outlier) continue;
    double r[3];
    if (it.heldout) {
      Residual(it, fit.m, r);
      fit.chi2_heldout += (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / s2_;
      fit.heldout_terms.push_back((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / s2_);
      ++fit.n_heldout;
      continue;
    }
    Jacobians jac;
    Residual(it, fit.m, r, &jac, free);
    Eigen::MatrixXd J(3, dim);
    for (int c = 0; c < np; ++c) J.col(c) = jac.params.col(active[c]);
    J.block(0, np, 3, 3) = jac.mount;
    for (std::size_t c = 0; c < free.size(); ++c) J.col(np + 3 + c) = jac.beta.col(free[c]);
    J /= s;
    const Eigen::Vector3d rv = Eigen::Vector3d(r[0], r[1], r[2]) / s;
    fit.chi2_fit += rv.squaredNorm();
    ++fit.n_fit;
    H += J.transpose() * J;
    scores.push_back(J.transpose() * rv);
  }
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(dim, dim);
  const int L = options_.hac_lags;
  for (std::size_t k = 0; k < scores.size(); ++k) {
    M += scores[k] * scores[k].transpose();
    for (int l = 1; l <= L && l <= int(k); ++l) {
      const double w = 1.0 - double(l) / (L + 1);
      M += w * (scores[k] * scores[k - l].transpose() + scores[k - l] * scores[k].transpose());
    }
  }
  fit.dof = std::max(1, 3 * fit.n_fit - dim);
  M *= double(3 * fit.n_fit) / fit.dof;
  const Eigen::VectorXd d = H.diagonal().cwiseMax(1e-300).cwiseSqrt();
  const Eigen::MatrixXd C = d.asDiagonal().inverse() * H * d.asDiagonal().inverse();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(C);
  const double lmax = eig.eigenvalues().maxCoeff();
  Eigen::VectorXd inv(dim);
  for (int i = 0; i < dim; ++i) inv[i] = eig.eigenvalues()[i] > 1e-12 * lmax ? 1.0 / eig.eigenvalues()[i] : 0.0;
  const Eigen::MatrixXd Hinv = d.asDiagonal().inverse() * eig.eigenvectors() * inv.asDiagonal() *
                               eig.eigenvectors().transpose() * d.asDiagonal().inverse();
  const Eigen::MatrixXd full = Hinv * M * Hinv;
  const int nb = static_cast<int>(free.size());
  fit.cov = full.block(np + 3, np + 3, nb, nb);
  fit.info_cov = Hinv.block(np + 3, np + 3, nb, nb);
  if (!tested.empty()) {
    std::vector<int> idx;
    for (int t : tested) idx.push_back(int(std::find(free.begin(), free.end(), t) - free.begin()));
    Eigen::MatrixXd V(idx.size(), idx.size());
    Eigen::VectorXd b(idx.size());
    for (std::size_t i = 0; i < idx.size(); ++i) {
      b[i] = fit.m.beta[tested[i]];
      for (std::size_t j = 0; j < idx.size(); ++j) V(i, j) = fit.cov(idx[i], idx[j]);
    }
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(V);
    fit.wald = (ldlt.info() == Eigen::Success && V.diagonal().minCoeff() > 0) ? b.dot(ldlt.solve(b)) : 0.0;
    fit.p = ChiSquareUpperTail(fit.wald, static_cast<int>(tested.size()));
  }
  return fit;
}

std::vector<Candidate> Diagnoser::Candidates() const {
  std::vector<Candidate> out;
  const bool steered = robot_.drive != DriveType::kDifferential;
  out.push_back({"time_offset", "sensing", "", {kTimeOffset}, {"offset_s"}, 0.05,
                 "starts, stops and changes of turn rate", "accel", true});
  out.push_back({"longitudinal_slip", "odometry", "", {kSlip}, {"slip_per_accel"}, 0.1,
                 "hard accelerations and braking at speed", "speed_x_accel", true});
  out.push_back({"lateral_slip", "odometry", "", {kLateral}, {"gain"}, 0.1,
                 "fast turns: the same curvature at several speeds, both ways", "centripetal", true});
  if (steered) {
    out.push_back({"steering_lag", "odometry", "", {kLag}, {"tau_s"}, 0.3,
                   "steering changes while driving (slalom, steering steps)", "speed_x_steer_rate", true});
    out.push_back({"steering_backlash", "odometry", "", {kBacklash}, {"width_rad"}, 0.05,
                   "straights entered after a left and after a right steering correction",
                   "steer_direction", true});
    out.push_back({"travel_direction_offset", "odometry", "", {kTravelOffset}, {"offset_rad"}, 0.05,
                   "the same path forward and in reverse", "travel_direction", false});
  }
  if (data_.scan_period_s > 0) {
    out.push_back({"scan_distortion", "sensing", "", {kDistortion}, {"scan_period_s"}, 0.2,
                   "fast turns in place and fast straights", "turn_rate", true});
  }
  const auto& roles = WheelRoles(robot_.drive);
  for (std::size_t w = 0; w < roles.size(); ++w) {
    out.push_back({"wheel_eccentricity", "odometry", roles[w],
                   {int(kEcc0C + 2 * w), int(kEcc0S + 2 * w)}, {"amplitude", "phase"}, 0.02,
                   "long straight runs (many wheel turns)", "wheel_angle_" + std::to_string(w), true});
  }
  return out;
}

// Motion conditions per interval from the encoders and the baseline model.
void Diagnoser::Conditions(DiagnoseReport* report) const {
  const Track& tr = track_;
  const std::size_t n = tr.size();
  std::vector<double> vx(n), om(n), xs(n), ys(n), route(n);
  double x = 0, y = 0, th = 0, dist = 0;
  for (std::size_t i = 0; i < n; ++i) {
    double rates[2] = {tr.speed[i][0], tr.speed[i][1]}, steer[2] = {tr.steer(i, 0), tr.steer(i, 1)};
    double vy = 0;
    generic::BodyDisplacement(tr.drive, baseline_.params, rates, steer, &vx[i], &vy, &om[i]);
    if (i > 0) {
      const double dt = (tr.utime(i) - tr.utime(i - 1)) * 1e-6;
      x += std::cos(th) * vx[i - 1] * dt;
      y += std::sin(th) * vx[i - 1] * dt;
      th += om[i - 1] * dt;
      dist += std::abs(vx[i - 1]) * dt;
    }
    xs[i] = x, ys[i] = y, route[i] = dist;
  }
  const int steer_param = robot_.drive == DriveType::kTricycle ? 2 : robot_.drive == DriveType::kDualSteer ? 1 : -1;
  for (DiagnosedInterval& d : report->intervals) {
    const auto i0 = std::size_t(std::lower_bound(tr.utimes().begin(), tr.utimes().end(), d.utime_start) - tr.utimes().begin());
    auto i1 = std::size_t(std::upper_bound(tr.utimes().begin(), tr.utimes().end(), d.utime_end) - tr.utimes().begin());
    i1 = i1 > 0 ? i1 - 1 : 0;
    const std::size_t a = std::min(i0, n - 1), b = std::max(std::min(i1, n - 1), a);
    MotionConditions& c = d.motion;
    double sv = 0, so = 0;
    for (std::size_t i = a; i <= b; ++i) sv += vx[i], so += om[i];
    c.speed = sv / double(b - a + 1);
    c.turn_rate = so / double(b - a + 1);
    const double span = std::max((tr.utime(b) - tr.utime(a)) * 1e-6, 1e-3);
    c.accel = b > a ? (vx[b] - vx[a]) / span : 0.0;
    c.turn_accel = b > a ? (om[b] - om[a]) / span : 0.0;
    c.centripetal = c.speed * c.turn_rate;
    if (steer_param >= 0) {
      c.steer = 0.5 * (tr.steer(a, 0) + tr.steer(b, 0)) - baseline_.params[steer_param];
      c.steer_rate = b > a ? (tr.steer(b, 0) - tr.steer(a, 0)) / span : 0.0;
      c.steer_direction = int(tr.steer_sign[a][0]);
    }
    c.route_m = route[a];
    c.x = xs[a];
    c.y = ys[a];
  }
}

// The regressor of an effect's signature, scaled by the interval's duration where the
// effect accumulates over it (what the residual of one interval is proportional to).
double Diagnoser::Regressor(const std::string& name, const DiagnosedInterval& d, const Interval& it) const {
  const MotionConditions& c = d.motion;
  const double dur = (d.utime_end - d.utime_start) * 1e-6;
  if (name == "accel") return c.accel * dur;
  if (name == "turn_accel") return c.turn_accel * dur;
  if (name == "speed_x_accel") return c.speed * c.accel * dur;
  if (name == "centripetal") return c.centripetal * dur;
  if (name == "speed_x_steer_rate") return c.speed * c.steer_rate * dur;
  if (name == "steer_direction") return c.steer_direction * c.speed * dur;
  if (name == "travel_direction") return c.speed * dur;
  if (name.rfind("wheel_angle_", 0) == 0) {
    const int w = std::stoi(name.substr(12));
    const std::size_t mid = (it.model->first() + it.model->last()) / 2;
    return std::fmod(std::fmod(track_.pos(mid, w), 2 * M_PI) + 2 * M_PI, 2 * M_PI);
  }
  if (name == "speed") return c.speed;
  if (name == "turn_rate") return c.turn_rate;
  return 0.0;
}

std::string RegressorLabel(const std::string& name) {
  if (name == "accel") return "speed change over the interval (m/s)";
  if (name == "turn_accel") return "turn-rate change over the interval (rad/s)";
  if (name == "speed_x_accel") return "speed x speed change (m^2/s^2)";
  if (name == "centripetal") return "speed x turn rate x duration (m rad/s)";
  if (name == "speed_x_steer_rate") return "speed x steering change (m rad/s)";
  if (name == "steer_direction") return "distance signed by the last steering direction (m)";
  if (name == "travel_direction") return "signed distance (m)";
  if (name.rfind("wheel_angle_", 0) == 0) return "wheel angle at mid-interval (rad)";
  if (name == "turn_rate") return "turn rate (rad/s)";
  return name;
}

// Mean residual per bin of a regressor: quantile bins, or one bin per value of a sign.
std::vector<SignatureBin> Signature(const std::vector<double>& x, const std::vector<double>& before,
                                    const std::vector<double>& after) {
  std::vector<SignatureBin> bins;
  if (x.empty()) return bins;
  std::vector<double> sorted = x;
  std::sort(sorted.begin(), sorted.end());
  std::vector<double> edges;
  const bool discrete = std::all_of(x.begin(), x.end(), [](double v) { return v == -1 || v == 0 || v == 1; });
  if (discrete) {
    edges = {-1.5, -0.5, 0.5, 1.5};
  } else {  // equal widths over the central 96 %, so a trend reads as a line
    const int nb = 9;
    const double lo = sorted[sorted.size() * 2 / 100], hi = sorted[sorted.size() * 98 / 100];
    for (int b = 0; b <= nb; ++b) edges.push_back(lo + (hi - lo) * b / nb);
    edges.back() += 1e-12 * std::max(1.0, std::abs(hi));
  }
  for (std::size_t b = 0; b + 1 < edges.size(); ++b) {
    SignatureBin bin;
    double sx = 0, sb = 0, sa = 0, sa2 = 0;
    for (std::size_t k = 0; k < x.size(); ++k) {
      if (x[k] < edges[b] || x[k] >= edges[b + 1]) continue;
      ++bin.count;
      sx += x[k], sb += before[k], sa += after[k], sa2 += after[k] * after[k];
    }
    if (bin.count < 3) continue;
    bin.x = sx / bin.count;
    bin.before = sb / bin.count;
    bin.after = sa / bin.count;
    bin.std_error = std::sqrt(std::max(sa2 / bin.count - bin.after * bin.after, 0.0) / bin.count);
    bins.push_back(bin);
  }
  return bins;
}

const char* kComponents[3] = {"x", "y", "yaw"};

// The motion under which flagged intervals differ most from the rest, in words.
std::string Regime(const std::vector<DiagnosedInterval>& all, const std::vector<bool>& flagged) {
  struct Q {
    const char* words;
    const char* unit;
    double (*get)(const MotionConditions&);
  };
  const Q qs[] = {
      {"speed", "m/s", [](const MotionConditions& c) { return std::abs(c.speed); }},
      {"acceleration", "m/s^2", [](const MotionConditions& c) { return std::abs(c.accel); }},
      {"turn rate", "rad/s", [](const MotionConditions& c) { return std::abs(c.turn_rate); }},
      {"centripetal acceleration", "m/s^2", [](const MotionConditions& c) { return std::abs(c.centripetal); }},
      {"steering rate", "rad/s", [](const MotionConditions& c) { return std::abs(c.steer_rate); }},
      {"steering angle", "rad", [](const MotionConditions& c) { return std::abs(c.steer); }},
  };
  std::vector<std::pair<double, std::string>> ranked;
  for (const Q& q : qs) {
    double in = 0, out = 0;
    int n_in = 0, n_out = 0;
    for (std::size_t k = 0; k < all.size(); ++k) (flagged[k] ? (in += q.get(all[k].motion), ++n_in) : (out += q.get(all[k].motion), ++n_out));
    if (n_in == 0 || n_out == 0) continue;
    in /= n_in, out /= n_out;
    if (in > 1.3 * out && in > 1e-6) {
      std::ostringstream s;
      s.precision(2);
      s << "high " << q.words << " (" << in << " " << q.unit << " there, " << out << " elsewhere)";
      ranked.push_back({in / std::max(out, 1e-9), s.str()});
    }
  }
  std::sort(ranked.rbegin(), ranked.rend());
  if (ranked.empty()) return "no particular motion: spread over the recording";
  std::string out = "while " + ranked[0].second;
  if (ranked.size() > 1) out += " and " + ranked[1].second;
  return out;
}

// Where the effect's contribution stands out (exceeds the noise; at least 10 held-out
// intervals), in the component it shows most, and the held-out residual there without
// and with it.
Diagnoser::Localized Diagnoser::Localize(const Candidate& c, const Model& with, const Model& without) const {
  Localized out;
  Model zeroed = with;
  for (int b : c.beta) zeroed.beta[b] = 0.0;
  const double s = std::sqrt(s2_);
  std::vector<Eigen::Vector3d> contribution(intervals_.size(), Eigen::Vector3d::Zero());
  Eigen::Vector3d weight = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < intervals_.size(); ++k) {
    if (intervals_[k].outlier) continue;
    contribution[k] = ErrorOf(intervals_[k], zeroed) - ErrorOf(intervals_[k], with);
    weight += contribution[k].cwiseQuotient(intervals_[k].sigma * s).cwiseAbs2();
  }
  weight.maxCoeff(&out.comp);
  std::vector<double> ratio(intervals_.size(), 0.0);
  for (std::size_t k = 0; k < intervals_.size(); ++k)
    if (!intervals_[k].outlier) ratio[k] = std::abs(contribution[k][out.comp]) / (intervals_[k].sigma[out.comp] * s);
  // Intervals by the size of the effect's contribution: all where it exceeds the noise,
  // then more until they hold enough held-out intervals to judge the fit there.
  constexpr int kMinHeldout = 10;
  std::vector<std::size_t> order(intervals_.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return ratio[x] > ratio[y]; });
  double threshold = 0;
  int heldout = 0;
  for (std::size_t k : order) {
    if (ratio[k] <= 0 || (ratio[k] < 1.0 && heldout >= kMinHeldout)) break;
    threshold = ratio[k];
    heldout += intervals_[k].heldout;
  }
  out.flagged.assign(intervals_.size(), false);
  std::vector<double> in_before, in_after, all_before, all_after;
  for (std::size_t k = 0; k < intervals_.size(); ++k) {
    const Interval& it = intervals_[k];
    if (it.outlier) continue;
    out.flagged[k] = ratio[k] >= threshold && ratio[k] > 0;
    if (!it.heldout) continue;
    const double eb = ErrorOf(it, without)[out.comp], ea = ErrorOf(it, with)[out.comp];
    all_before.push_back(eb), all_after.push_back(ea);
    if (out.flagged[k]) in_before.push_back(eb), in_after.push_back(ea);
  }
  out.rms_before = Rms(in_before), out.rms_after = Rms(in_after);
  out.rms_all_before = Rms(all_before), out.rms_all_after = Rms(all_after);
  return out;
}

// The model's dead reckoning over held-out windows (outliers break the chain).
OdometryError Diagnoser::HeldoutDrift(const Model& m) const {
  std::vector<OdometryStep> steps;
  for (const Interval& it : intervals_) {
    if (!it.heldout || it.outlier) continue;
    const Eigen::Vector3d e = ErrorOf(it, m);
    steps.push_back({it.motion->utime_start, it.motion->utime_end, it.motion->delta, {e[0], e[1], e[2]}});
  }
  return OdometryErrorOverWindows(steps, options_.drift_window_s, false);
}

// The effect over stretches of held-out motion: in each run of consecutive held-out intervals
// (a held-out block, cut where an outlier breaks the chain) the stretch over which the effect
// changes the chained motion most in `comp`, chosen from the two models' predictions alone,
// never from the measurement. An effect whose error telescopes along a chain (a time offset:
// offset x the change of speed or turn rate; a longitudinal slip: k (v1^2 - v0^2) / 2) is
// small per interval against the scan matcher's noise; from its low to its high point it is as
// large as the block allows, while the registration error stays that of the stretch's two end
// scans. A wrong effect fares worse here, not better: the stretch is where it predicts most.
std::vector<HeldoutStretch> Diagnoser::HeldoutStretches(const Candidate& c, const Model& with,
                                                        const Model& without, int comp) const {
  Model zeroed = with;
  for (int b : c.beta) zeroed.beta[b] = 0.0;
  std::vector<HeldoutStretch> out;
  auto add_run = [&](const std::vector<const Interval*>& run) {
    // Prefix chains of the measured motion and of each model's prediction (measured - error).
    const std::size_t n = run.size();
    std::vector<Pose2> measured(n + 1), before(n + 1), after(n + 1), without_effect(n + 1);
    for (std::size_t k = 0; k < n; ++k) {
      const Pose2& z = run[k]->motion->delta;
      auto predicted = [&](const Model& m) {
        const Eigen::Vector3d e = ErrorOf(*run[k], m);
        return Pose2{z.x - e[0], z.y - e[1], z.theta - e[2]};
      };
      measured[k + 1] = Compose(measured[k], z);
      before[k + 1] = Compose(before[k], predicted(without));
      after[k + 1] = Compose(after[k], predicted(with));
      without_effect[k + 1] = Compose(without_effect[k], predicted(zeroed));
    }
    auto error = [&](const std::vector<Pose2>& chain, std::size_t i, std::size_t j) {
      const Pose2 d = Between(Between(chain[i], chain[j]), Between(measured[i], measured[j]));
      return Eigen::Vector3d(d.x, d.y, WrapAngle(d.theta))[comp];
    };
    double largest = -1;
    std::size_t from = 0, to = 0;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = i + 1; j <= n; ++j) {
        const double contribution = std::abs(error(without_effect, i, j) - error(after, i, j));
        if (contribution > largest) largest = contribution, from = i, to = j;
      }
    if (to == 0) return;
    out.push_back({run[from]->motion->utime_start, run[to - 1]->motion->utime_end, error(before, from, to),
                   error(after, from, to)});
  };
  std::vector<const Interval*> run;
  for (const Interval& it : intervals_) {
    const bool continues = !run.empty() && run.back()->block == it.block &&
                           run.back()->motion->utime_end == it.motion->utime_start;
    if (!continues || !it.heldout || it.outlier) {
      if (!run.empty()) add_run(run);
      run.clear();
    }
    if (it.heldout && !it.outlier) run.push_back(&it);
  }
  if (!run.empty()) add_run(run);
  return out;
}

FoundEffect Diagnoser::Describe(const Candidate& c, const Fit& final_fit, const Fit& without,
                                const DiagnoseReport& report) const {
  FoundEffect fe;
  fe.name = c.name;
  fe.layer = c.layer;
  fe.wheel = c.wheel;
  auto index_of = [&](int beta) {
    return int(std::find(final_fit.free.begin(), final_fit.free.end(), beta) - final_fit.free.begin());
  };
  if (c.name == "wheel_eccentricity") {
    const int ic = index_of(c.beta[0]), is = index_of(c.beta[1]);
    const double cc = final_fit.m.beta[c.beta[0]], ss = final_fit.m.beta[c.beta[1]];
    const double amp = std::hypot(cc, ss);
    Eigen::Vector2d ga(cc / std::max(amp, 1e-12), ss / std::max(amp, 1e-12));
    Eigen::Vector2d gp(-ss / std::max(amp * amp, 1e-24), cc / std::max(amp * amp, 1e-24));
    Eigen::Matrix2d V;
    V << final_fit.cov(ic, ic), final_fit.cov(ic, is), final_fit.cov(is, ic), final_fit.cov(is, is);
    fe.params["amplitude"] = {amp, std::sqrt(std::max(ga.dot(V * ga), 0.0))};
    fe.params["phase"] = {std::atan2(ss, cc), std::sqrt(std::max(gp.dot(V * gp), 0.0))};
  } else {
    const int i = index_of(c.beta[0]);
    fe.params[c.keys[0]] = {final_fit.m.beta[c.beta[0]], std::sqrt(std::max(final_fit.cov(i, i), 0.0))};
  }
  const Localized loc = Localize(c, final_fit.m, without.m);
  const int comp = loc.comp;
  fe.component = kComponents[comp];
  std::vector<TimeSpan> flagged_spans;
  std::vector<double> x, sb, sa;
  std::string reg = c.regressor;
  if (c.name == "time_offset" && comp == 2) reg = "turn_accel";
  fe.regressor = RegressorLabel(reg);
  // The signature in the component the effect's formula names (slip: along, skid: across).
  const int sig = c.name == "longitudinal_slip" ? 0 : c.name == "lateral_slip" ? 1 : comp;
  fe.signature_component = kComponents[sig];
  for (std::size_t k = 0; k < intervals_.size(); ++k) {
    const Interval& it = intervals_[k];
    if (it.outlier) continue;
    if (loc.flagged[k]) flagged_spans.push_back({it.motion->utime_start, it.motion->utime_end});
    x.push_back(Regressor(reg, report.intervals[k], it));
    sb.push_back(ErrorOf(it, without.m)[sig]);
    sa.push_back(ErrorOf(it, final_fit.m)[sig]);
  }
  fe.where = MergeSpans(flagged_spans, 2000000);
  fe.heldout_rms_before = loc.rms_before;
  fe.heldout_rms_after = loc.rms_after;
  fe.heldout_rms_all_before = loc.rms_all_before;
  fe.heldout_rms_all_after = loc.rms_all_after;
  const OdometryError drift_before = HeldoutDrift(without.m), drift_after = HeldoutDrift(final_fit.m);
  const bool heading = comp == 2;
  fe.drift_component = heading ? "heading" : "translation";
  fe.drift_window_s = options_.drift_window_s;
  fe.drift_windows = drift_after.windows;
  fe.heldout_drift_before = heading ? drift_before.rms_heading_rad : drift_before.rms_translation_m;
  fe.heldout_drift_after = heading ? drift_after.rms_heading_rad : drift_after.rms_translation_m;
  // Chained over a window, only errors that keep their sign add up: a lateral skid in a turn,
  // a steering angle off by the play or the lag, a scan smeared by the speed; those are judged
  // by the drift. A time offset's or a longitudinal slip's telescopes to the window's ends (the
  // shifted windows, the slip k (v1^2 - v0^2) / 2): judged over the stretch from its low to its
  // high point. An eccentric wheel's cancels over each revolution, and one interval already
  // spans a third of one: judged per interval where it acts.
  const bool adds_up = c.name == "lateral_slip" || c.name == "steering_backlash" || c.name == "steering_lag" ||
                       c.name == "scan_distortion" || c.name == "travel_direction_offset";
  const bool telescopes = c.name == "time_offset" || c.name == "longitudinal_slip";
  fe.stretches = HeldoutStretches(c, final_fit.m, without.m, comp);
  std::vector<double> stretch_before, stretch_after;
  for (const HeldoutStretch& h : fe.stretches) stretch_before.push_back(h.before), stretch_after.push_back(h.after);
  fe.heldout_stretch_before = Rms(stretch_before);
  fe.heldout_stretch_after = Rms(stretch_after);
  constexpr std::size_t kMinStretches = 5;
  if (adds_up && drift_after.windows > 0)
    fe.heldout_measure = "drift";
  else if (telescopes && fe.stretches.size() >= kMinStretches)
    fe.heldout_measure = "stretch";
  const bool by_drift = fe.heldout_measure == "drift", by_stretch = fe.heldout_measure == "stretch";
  const double judged_before = by_drift ? fe.heldout_drift_before : by_stretch ? fe.heldout_stretch_before : fe.heldout_rms_before;
  const double judged_after = by_drift ? fe.heldout_drift_after : by_stretch ? fe.heldout_stretch_after : fe.heldout_rms_after;
  if (!(judged_after < judged_before)) {
    fe.heldout_disagrees = true;
    fe.heldout_confirmed_by = ScoreConfirmed(without, final_fit)                  ? "score"
                              : DriftConfirmed(without, final_fit, heading) ? "drift"
                                                                                : "";
  }
  fe.signature = Signature(x, sb, sa);
  std::vector<DiagnosedInterval> kept;
  std::vector<bool> kept_flag;
  for (std::size_t k = 0; k < intervals_.size(); ++k)
    if (!intervals_[k].outlier) kept.push_back(report.intervals[k]), kept_flag.push_back(loc.flagged[k]);
  fe.regime = Regime(kept, kept_flag);
  return fe;
}

// Residual structure left after the final model that catalogued effects do not
// explain: a held-out residual component trending with where or how the robot drove.
void Diagnoser::FindUnexplained(DiagnoseReport* report) const {
  struct R {
    const char* name;
    double (*get)(const DiagnosedInterval&);
  };
  const R regs[] = {
      {"speed", [](const DiagnosedInterval& d) { return d.motion.speed; }},
      {"turn rate magnitude", [](const DiagnosedInterval& d) { return std::abs(d.motion.turn_rate); }},
      {"steering angle", [](const DiagnosedInterval& d) { return d.motion.steer; }},
      {"position x along the route", [](const DiagnosedInterval& d) { return d.motion.x; }},
      {"position y along the route", [](const DiagnosedInterval& d) { return d.motion.y; }},
      {"time", [](const DiagnosedInterval& d) { return d.utime_start * 1e-6; }},
  };
  const int m = 3 * int(sizeof(regs) / sizeof(regs[0]));
  const double s = std::sqrt(s2_);
  for (int comp = 0; comp < 3; ++comp) {
    for (const R& r : regs) {
      std::vector<double> z, e;
      std::vector<const DiagnosedInterval*> used;
      for (const DiagnosedInterval& d : report->intervals) {
        if (!d.heldout || d.outlier) continue;
        z.push_back(r.get(d));
        e.push_back(d.after[comp] / (d.sigma[comp] * s));
        used.push_back(&d);
      }
      const std::size_t n = z.size();
      if (n < 30) continue;
      const double mz = std::accumulate(z.begin(), z.end(), 0.0) / n, me = std::accumulate(e.begin(), e.end(), 0.0) / n;
      double szz = 0, sze = 0;
      for (std::size_t k = 0; k < n; ++k) szz += (z[k] - mz) * (z[k] - mz), sze += (z[k] - mz) * (e[k] - me);
      if (szz <= 1e-12) continue;
      const double slope = sze / szz;
      std::vector<double> u(n);
      for (std::size_t k = 0; k < n; ++k) u[k] = (z[k] - mz) * (e[k] - me - slope * (z[k] - mz));
      double v = 0;
      for (std::size_t k = 0; k < n; ++k) {
        v += u[k] * u[k];
        for (int l = 1; l <= options_.hac_lags && l <= int(k); ++l)
          v += 2.0 * (1.0 - double(l) / (options_.hac_lags + 1)) * u[k] * u[k - l];
      }
      if (v <= 0) continue;
      const double t = sze / std::sqrt(v);
      const double p = std::erfc(std::abs(t) / std::sqrt(2.0));
      if (p * m >= options_.alpha) continue;
      Unexplained un;
      un.p_value = std::min(1.0, p * m);
      un.component = kComponents[comp];
      std::ostringstream what;
      what.precision(3);
      what << r.name << " (" << kComponents[comp] << " residual, slope " << slope
           << " sigma per unit, t = " << t << ")";
      un.correlates_with = what.str();
      // Where: the tenth of the held-out intervals with the regressor furthest along the
      // trend (largest for a rising residual, smallest for a falling one).
      std::vector<double> sorted = z;
      std::sort(sorted.begin(), sorted.end());
      const double cut = slope > 0 ? sorted[n * 9 / 10] : sorted[n / 10];
      std::vector<TimeSpan> spans;
      for (std::size_t k = 0; k < n; ++k)
        if (slope > 0 ? z[k] >= cut : z[k] <= cut) spans.push_back({used[k]->utime_start, used[k]->utime_end});
      un.where = MergeSpans(spans, 2000000);
      report->unexplained.push_back(un);
    }
  }
}

// Effects of the floor (longitudinal and lateral slip) that the whole recording did not show,
// tested over boxes of the route in the odometry frame (diagnose_region.cc): the box most
// significant on the fit blocks, Bonferroni over the boxes and the catalogue's share, confirmed
// on the held-out intervals inside it. Linearised at the current model; reported with its box.
void Diagnoser::TestRegions(const std::vector<Candidate>& cands, const Fit& current, const SelectionLevels& levels,
                            DiagnoseReport* report) const {
  std::vector<int> active;  // the calibration's free parameters
  for (int i = 0; i < num_params_; ++i)
    if (std::find(constant_params_.begin(), constant_params_.end(), i) == constant_params_.end()) active.push_back(i);
  const double s = std::sqrt(s2_);
  for (CandidateOutcome& o : report->candidates) {
    if (o.status == CandidateStatus::kFound || (o.name != "longitudinal_slip" && o.name != "lateral_slip")) continue;
    const auto c = std::find_if(cands.begin(), cands.end(), [&](const Candidate& k) { return k.name == o.name; });
    if (c == cands.end()) continue;
    const int b = c->beta[0];
    std::vector<RegionInterval> in;
    std::vector<std::size_t> index;  // into intervals_ and report->intervals
    // Outliers too: a patch's slip is many sigma per interval, and the gate at the whole
    // recording's scale sets exactly those intervals aside; a failed match stays harmless
    // (alone in a box its own scatter is its variance, so its Wald statistic stays near 1).
    for (std::size_t k = 0; k < intervals_.size(); ++k) {
      const Interval& it = intervals_[k];
      double r[3];
      Jacobians jac;
      Residual(it, current.m, r, &jac, {b});
      RegionInterval ri;
      ri.x = report->intervals[k].motion.x, ri.y = report->intervals[k].motion.y, ri.heldout = it.heldout;
      ri.r = Eigen::Vector3d(r[0], r[1], r[2]) / s;
      ri.g = jac.beta.col(b) / s;
      ri.A.resize(3, int(active.size()) + 3);
      for (std::size_t a = 0; a < active.size(); ++a) ri.A.col(a) = jac.params.col(active[a]) / s;
      ri.A.rightCols(3) = jac.mount / s;
      in.push_back(ri), index.push_back(k);
    }
    // Physical sign: a floor that slips loses ground while accelerating (slip_per_accel > 0)
    // and lets the robot skid outwards in a turn (gain > 0).
    const RegionTest t = BestRegion(in, options_.hac_lags, 1.0, +1);
    const double share = levels.alpha / std::max(1, levels.candidates);
    // The held-out residual inside the region, in the effect's component, without and with it.
    const int comp = o.name == "lateral_slip" ? 1 : 0;
    std::vector<TimeSpan> spans;
    std::vector<double> rb, ra, abs_b, abs_a;
    Model with = current.m;
    with.beta[b] += t.beta;
    for (std::size_t j = 0; j < t.inside.size(); ++j) {
      if (!t.inside[j] || in[j].g.squaredNorm() == 0) continue;
      const Interval& it = intervals_[index[j]];
      spans.push_back({it.motion->utime_start, it.motion->utime_end});
      if (!it.heldout) continue;
      rb.push_back(ErrorOf(it, current.m)[comp]);
      ra.push_back(ErrorOf(it, with)[comp]);
      abs_b.push_back(std::abs(rb.back())), abs_a.push_back(std::abs(ra.back()));
    }
    // The region's effect at the size the fit blocks give must make the held-out intervals
    // inside it fit better: their errors lower (paired one-sided test, 5 %) and by at least the
    // practical floor of a held-out gain (kMinRegionGain), as a wet patch does (76 % on the
    // suite's). Its held-out estimate can be significant without that: the route crosses the
    // same places in the fit and the held-out blocks, and what the model of a large effect found
    // elsewhere leaves there (a backlash's, a time offset's) repeats in both; all 9 regions named
    // in the randomized suite were of that kind (no floor effect there was confined to a
    // region), and none lowered the held-out residual inside its box by more than 7 %; one by
    // 0.5 % passed the test alone (many intervals, each a little lower).
    const bool lowers = TestImprovement(abs_b, abs_a, kHeldoutP, kMinRegionGain).significant;
    if (!(t.p_adjusted < share) || !t.heldout_confirmed || !lowers) {
      std::ostringstream note;
      note.precision(3);
      note << "not confined to a region either: the best of " << t.boxes << " boxes of the route (x " << t.box[0]
           << " .. " << t.box[2] << ", y " << t.box[1] << " .. " << t.box[3] << " m) gives "
           << EstimateText(t.beta, t.std, ParamUnit(c->keys[0])) << ", " << PValueText(t.p_adjusted)
           << " over the boxes, held-out z = " << t.heldout_z << ", held-out RMS there " << Rms(rb) << " without, "
           << Rms(ra) << " with it";
      o.note += (o.note.empty() ? "" : "; ") + note.str();
      continue;
    }
    // Found: its size, where it acts and the held-out residual inside the box without and with it.
    FoundEffect fe;
    fe.name = o.name, fe.layer = o.layer;
    fe.params[c->keys[0]] = {t.beta, t.std};
    fe.wald = t.wald, fe.p_value = t.p, fe.p_adjusted = std::min(1.0, t.p_adjusted / share * levels.alpha);
    fe.region = t.box;
    fe.component = comp == 1 ? "y" : "x";
    fe.where = MergeSpans(spans, 1000000);
    fe.heldout_rms_before = fe.heldout_rms_all_before = Rms(rb);
    fe.heldout_rms_after = fe.heldout_rms_all_after = Rms(ra);
    std::ostringstream regime;
    regime.precision(3);
    regime << "only inside the region x " << t.box[0] << " .. " << t.box[2] << " m, y " << t.box[1] << " .. "
           << t.box[3] << " m of the odometry frame (best of " << t.boxes << " boxes; held-out estimate there "
           << t.heldout_beta << ", z = " << t.heldout_z << ")";
    fe.regime = regime.str();
    fe.regressor = c->regressor;
    report->effects.push_back(fe);
    o.status = CandidateStatus::kFound;
    o.estimate = {t.beta, t.std};
    o.p_value = t.p, o.p_adjusted = fe.p_adjusted;
    o.note = "confined to a region of the floor: " + fe.regime;
  }
}

// The catalogue's confusable pairs, with the motion that separates each.
const std::vector<ConfusablePair>& Confusable() {
  static const auto* const kConfusable = new std::vector<ConfusablePair>{
      {"time_offset", "steering_lag",
       "speed changes while driving straight (a time offset shows there, steering lag does not), and steering "
       "changes at constant speed"},
      {"time_offset", "longitudinal_slip",
       "the same accelerations at two different speeds (slip grows with speed, a time offset does not), and "
       "changes of turn rate"},
      {"steering_backlash", "travel_direction_offset",
       "straights entered after a left and after a right steering correction, in both travel directions"},
  };
  return *kConfusable;
}

DiagnoseReport Diagnoser::Run() {
  const std::vector<std::string>& names = ParamNames(robot_.drive);
  num_params_ = static_cast<int>(names.size());
  BuildIntervals();

  // Starting values: the calibration of calibration.h on everything (it is only a start).
  // Where `agvcal solve` refuses (a straight-only recording), so does the diagnosis: a model
  // with parameters held at their nominal values would blame their error on missing physics,
  // or call the recording explained (spec/cli.md: exit 3, naming what and the motion to add).
  // The plain calibration and the one with the time offset are independent: side by side.
  CalibrationOptions co;
  CalibrationOptions co_offset = co;
  co_offset.check_observability = false;
  co_offset.estimate_time_offset = true;
  co_offset.max_time_offset_s = kMaxOffsetS;
  std::optional<CalibrationResult> cal_plain, cal_offset;
  std::optional<UnobservableError> refused;
  ParallelFor(2, WorkerThreads(options_.jobs), [&](std::size_t k) {
    if (k == 1) {
      cal_offset = Calibrate(robot_, data_.wheels, data_.motions, data_.source, co_offset, origin_);
      return;
    }
    try {
      cal_plain = Calibrate(robot_, data_.wheels, data_.motions, data_.source, co, origin_);
    } catch (const UnobservableError& e) {
      refused = e;
    }
  });
  if (refused) {
    // A large time offset the plain calibration ignores can make it refuse a mount parameter
    // the recording determines once the offset is modelled (issue 16: Mines exp1 with every
    // scan stamp +120 ms refused lidar2d.y): then the calibration with the offset, which must
    // determine everything, is the start.
    CalibrationOptions checked = co_offset;
    checked.check_observability = true;
    try {
      cal_plain = Calibrate(robot_, data_.wheels, data_.motions, data_.source, checked, origin_);
      notes_.push_back("the calibration without a time offset refuses (" + std::string(refused->what()) +
                       "); the one with the offset is the start");
    } catch (const UnobservableError&) {
      const std::string what = refused->what();
      throw UnobservableError(what.substr(0, what.size() - std::min(what.size(), refused->remedy().size() + 2)) +
                                  ", so the calibration the diagnosis compares with cannot be made",
                              refused->remedy());
    }
  }
  const CalibrationResult& cal = *cal_plain;
  offset_start_ = cal_offset->time_offset->value;
  if (cal_offset->time_offset_bound_s > max_offset_s_) {
    // The intervals again, with room for the wider offset on the wheel data.
    max_offset_s_ = cal_offset->time_offset_bound_s;
    intervals_.clear();
    BuildIntervals();
  }
  Model start;
  for (int i = 0; i < num_params_; ++i) {
    start.params[i] = cal.params.at(names[i]).value;
    if (!std::isfinite(cal.params.at(names[i]).std)) {
      constant_params_.push_back(i);
      start.params[i] = robot_.params.at(names[i]);
      notes_.push_back(names[i] + " is not determined by this recording: held at nominal");
    }
  }
  for (int i = num_params_; i < 5; ++i) constant_params_.push_back(i);
  start.mount[0] = cal.mount_x.value;
  start.mount[1] = cal.mount_y.value;
  start.mount[2] = cal.mount_yaw.value;

  // Outliers are gated at the robust scale of the baseline; once the effects are known,
  // again with them (a strong effect must not hide its own evidence), and the selection rerun.
  Progress("baseline calibration on " + std::to_string(intervals_.size()) + " intervals");
  s2_ = 1.0;
  Gate({FitModel(start, {}, {}).m});
  DiagnoseReport report = Select(start, cal);
  for (int pass = 1; pass < 4; ++pass) {  // until the outliers no longer change
    std::vector<bool> before_gate;
    for (const Interval& it : intervals_) before_gate.push_back(it.outlier);
    s2_ = 1.0;
    // Set aside only what neither the model chosen nor any candidate's own fit explains: under
    // the baseline alone, the turn starts and stops a 5 ms offset disturbs were set aside (39
    // intervals) and what was left carried no offset (issue 16).
    std::vector<Model> models = alternatives_;
    models.push_back(final_);
    Gate(models);
    bool changed = false;
    for (std::size_t k = 0; k < intervals_.size(); ++k) changed = changed || before_gate[k] != intervals_[k].outlier;
    if (!changed) break;
    Progress("outliers re-gated with the effects found; selecting again");
    report = Select(start, cal);
  }
  DescribeOutliers(&report);
  DiagnoseActuation(robot_, data_, options_, options_.alpha * m_act_ / double(m_odo_ + m_act_), &report);
  FindUnexplained(&report);
  std::stable_sort(report.unexplained.begin(), report.unexplained.end(),
                   [](const Unexplained& a, const Unexplained& b) { return a.p_value < b.p_value; });
  if (report.unexplained.size() > 3) report.unexplained.resize(3);  // the strongest; the rest add little
  report.verdict = report.effects.empty() ? "no_significant_effect" : "effects_found";
  return report;
}

void Diagnoser::Gate(const std::vector<Model>& models) {
  for (Interval& it : intervals_) it.outlier = true;
  auto robust_scale2 = [&](const Model& m) {
    std::vector<double> chi2;
    for (const Interval& it : intervals_)
      if (!it.heldout) chi2.push_back(Chi2Of(it, m));
    return RobustScale2(std::move(chi2));
  };
  const double chosen2 = robust_scale2(models.back());
  for (const Model& m : models) {
    // A model that leaves out what the chosen one explains has residuals, and so a robust
    // scale, inflated by it: at its own scale it excused failed matches the chosen model puts
    // at hundreds of times the noise, the more the larger the effect left out (issue 16: Mines
    // exp2 with every scan +120 ms kept one at 556 times the offset model's scale, which
    // pulled the offset 26 ms and its sigma from 4 to 25 ms). No model's scale exceeds the chosen one's.
    const double scale2 = std::min(robust_scale2(m), chosen2);
    for (Interval& it : intervals_) it.outlier = it.outlier && IsOutlier(Chi2Of(it, m), scale2, kOutlierChi2);
  }
}

void Diagnoser::DescribeOutliers(DiagnoseReport* report) const {
  struct R {
    const char* name;
    double (*get)(const MotionConditions&);
  };
  const R regs[] = {
      {"speed", [](const MotionConditions& c) { return std::abs(c.speed); }},
      {"acceleration", [](const MotionConditions& c) { return std::abs(c.accel); }},
      {"turn_rate", [](const MotionConditions& c) { return std::abs(c.turn_rate); }},
      {"turn_rate_change", [](const MotionConditions& c) { return std::abs(c.turn_accel); }},
      {"centripetal", [](const MotionConditions& c) { return std::abs(c.centripetal); }},
      {"steering_rate", [](const MotionConditions& c) { return std::abs(c.steer_rate); }},
  };
  const std::vector<DiagnosedInterval>& all = report->intervals;
  const double n = double(all.size());
  if (all.empty()) return;
  double share = 0;
  for (const DiagnosedInterval& d : all) share += d.outlier;
  report->outlier_share = share / n;
  for (const R& r : regs) {  // the point-biserial correlation of "set aside" with the regressor
    double mx = 0, mo = report->outlier_share, sxx = 0, sxo = 0, soo = 0;
    for (const DiagnosedInterval& d : all) mx += r.get(d.motion) / n;
    for (const DiagnosedInterval& d : all) {
      const double x = r.get(d.motion) - mx, o = (d.outlier ? 1.0 : 0.0) - mo;
      sxx += x * x, sxo += x * o, soo += o * o;
    }
    if (sxx > 0 && soo > 0) report->outlier_correlation[r.name] = sxo / std::sqrt(sxx * soo);
  }
}

DiagnoseReport Diagnoser::Select(const Model& start, const CalibrationResult& cal) {
  DiagnoseReport report;
  report.drive = robot_.drive;
  report.source = data_.source;
  report.param_names = ParamNames(robot_.drive);
  report.notes = notes_;
  const Fit f0 = FitBaseline(start, &report);

  // Every candidate against the baseline.
  const std::vector<Candidate> cands = Candidates();
  const int m_odo = m_odo_ = static_cast<int>(cands.size());
  const int m_act = m_act_ = ActuationCandidates(robot_, data_);
  SelectionLevels levels;
  levels.candidates = m_odo;
  levels.actuation_candidates = m_act;
  levels.alpha = options_.alpha * m_odo / double(m_odo + m_act);
  const double log_n = std::log(3.0 * f0.n_fit);
  const std::vector<Fit> single = FitSingles(cands, f0);
  SingleVerdicts verdicts = JudgeSingles(SingleFigures(cands, single, f0, log_n), levels);

  // Every confusable pair fitted together from the baseline: the detectable sizes when the
  // look-alike is present too, and the pair's joint test in the selection.
  RecordingFits fits(*this, cands, single, f0, log_n);
  const std::vector<PairFit> pairs = fits.FitPairs(Confusable());
  NoteDetectableWith(pairs, levels, &verdicts.outcomes);
  const Selection selection = SelectEffects(Confusable(), pairs, verdicts.eligible, levels, &fits,
                                            &verdicts.outcomes, &report.indistinguishable);

  // The final model and what each chosen effect contributes.
  const Fit& current = fits.current();
  DescribeModel(f0, current, &report);
  ReportFound(cands, selection, levels, f0, current, log_n, &report);
  ReportCalibration(f0, current, cal, &report);
  report.candidates = verdicts.outcomes;
  TestRegions(cands, current, levels, &report);
  final_ = current.m;
  alternatives_.clear();
  for (const Fit& f : single) alternatives_.push_back(f.m);
  return report;
}

Fit Diagnoser::FitBaseline(const Model& start, DiagnoseReport* report) {
  s2_ = 1.0;
  Fit f0 = FitModel(start, {}, {});
  f0 = FitModel(f0.m, {}, {});
  const int dof_base = 3 * f0.n_fit - (5 - int(constant_params_.size())) - 3;
  s2_ = f0.chi2_fit / std::max(1, dof_base);
  f0 = FitModel(f0.m, {}, {});
  baseline_ = f0.m;
  report->variance_factor = s2_;
  for (const Interval& it : intervals_) {
    report->fit_intervals += (!it.heldout && !it.outlier);
    report->heldout_intervals += (it.heldout && !it.outlier);
    report->outliers += it.outlier;
  }
  return f0;
}

double Diagnoser::BestOnGrid(const Model& m, int beta, const std::vector<double>& grid) const {
  double best = grid.front(), best_chi2 = 1e300;
  for (double v : grid) {
    Model trial = m;
    trial.beta[beta] = v;
    double chi2 = 0;
    for (const Interval& it : intervals_)
      if (!it.heldout && !it.outlier) chi2 += Chi2Of(it, trial);
    if (chi2 < best_chi2) best_chi2 = chi2, best = v;
  }
  return best;
}

std::vector<Fit> Diagnoser::FitSingles(const std::vector<Candidate>& cands, const Fit& f0) const {
  // Independent fits on the worker threads, each into its own slot; the progress lines come
  // from this thread in the catalogue's order, each before its candidate's result is awaited.
  std::vector<Fit> single(cands.size());
  const ProgressEstimate estimate(static_cast<int>(cands.size()));
  auto fit = [&](std::size_t j) {
    const Candidate& c = cands[j];
    Model from = f0.m;
    // The time offset's cost has local minima a sample period apart (encoder ticks): start
    // it where the calibration's own joint estimate put it.
    if (c.beta[0] == kTimeOffset) from.beta[kTimeOffset] = offset_start_;
    // A lag's cost is far from quadratic in tau (a 90 ms steering lag fitted from zero stopped
    // at 48 ms, issue 16): global before local, the best of a grid over its range.
    if (c.beta[0] == kLag) from.beta[kLag] = BestOnGrid(from, kLag, {0.0, 0.01, 0.02, 0.04, 0.07, 0.1, 0.15, 0.2, 0.3, 0.4});
    single[j] = FitModel(from, c.beta, c.beta);
  };
  auto report = [&](std::size_t j) {
    const Candidate& c = cands[j];
    Progress("testing " + c.name + (c.wheel.empty() ? "" : " (" + c.wheel + ")") + " (" +
             estimate.Label(static_cast<int>(j)) + ")");
  };
  ParallelFor(cands.size(), WorkerThreads(options_.jobs), fit, report);
  return single;
}

std::vector<SingleFit> Diagnoser::SingleFigures(const std::vector<Candidate>& cands, const std::vector<Fit>& single,
                                                const Fit& f0, double log_n) const {
  std::vector<SingleFit> out(cands.size());
  ParallelFor(cands.size(), WorkerThreads(options_.jobs), [&](std::size_t j) {  // each into its own slot
    const Candidate& c = cands[j];
    const Fit& f = single[j];
    SingleFit& s = out[j];
    s.name = c.name, s.layer = c.layer, s.wheel = c.wheel;
    s.p = f.p;
    s.delta_bic = DeltaBic(f.chi2_fit, f0.chi2_fit, c.beta.size(), log_n);
    double var = 0, info_var = 0;
    for (std::size_t i = 0; i < c.beta.size(); ++i) {
      var += f.cov(i, i) / c.beta.size();
      info_var += f.info_cov(i, i) / c.beta.size();
    }
    const double sigma = std::sqrt(std::max(var, 0.0));
    s.params = static_cast<int>(c.beta.size());
    s.bic_drop = c.beta.size() * log_n;
    s.information_std = std::sqrt(std::max(info_var, 0.0));
    s.estimate = {c.beta.size() == 2 ? std::hypot(f.m.beta[c.beta[0]], f.m.beta[c.beta[1]]) : f.m.beta[c.beta[0]], sigma};
    s.plausible = c.plausible;
    s.excitation = c.excitation;
    const Localized where = Localize(c, f.m, f0.m);
    s.heldout_gain = HeldoutGain(f0, f), s.span_gain = where.span_gain();
    s.heldout_confirmed = ScoreConfirmed(f0, f) || DriftConfirmed(f0, f, where.comp == 2);
  });
  return out;
}

// Held-out confirmation: does the effect's predicted contribution (its Jacobian times the
// fitted change) explain the held-out residual left without it? A score test on data the
// fit never saw, one-sided at 5 %, with an autocorrelation-robust variance. The Jacobian
// is the model's (for the time offset: from the smoothed speeds), so encoder noise in
// the residual cannot correlate with it.
bool Diagnoser::ScoreConfirmed(const Fit& before, const Fit& after) const {
  std::vector<int> added;  // the effect terms free after, not before
  for (int b : after.free)
    if (std::find(before.free.begin(), before.free.end(), b) == before.free.end()) added.push_back(b);
  std::vector<double> terms, noise;
  for (const Interval& it : intervals_) {
    if (!it.heldout || it.outlier) continue;
    double r[3], ra[3];
    Residual(it, before.m, r);
    Jacobians jac;
    Residual(it, after.m, ra, &jac, added);
    Eigen::Vector3d contribution = Eigen::Vector3d::Zero();  // change of the residual the effect makes
    for (int b : added) contribution -= jac.beta.col(b) * after.m.beta[b];
    terms.push_back(contribution.dot(Eigen::Vector3d(r[0], r[1], r[2])) / s2_);
    noise.push_back(contribution.dot(Eigen::Vector3d(ra[0], ra[1], ra[2])) / s2_);
  }
  const std::size_t n = terms.size();
  if (n < 10) return false;
  // Variance of the score from what is left with the effect (the noise), not from the
  // effect itself: under no effect the two agree.
  double sum = 0, v = 0;
  for (std::size_t k = 0; k < n; ++k) {
    sum += terms[k];
    v += noise[k] * noise[k];
    for (int l = 1; l <= options_.hac_lags && l <= int(k); ++l)
      v += 2.0 * (1.0 - double(l) / (options_.hac_lags + 1)) * noise[k] * noise[k - l];
  }
  return v > 0 && sum / std::sqrt(v) > kHeldoutZ;
}

// Or as dead reckoning: with the effect, the held-out drift is lower window by window (paired
// one-sided t-test, level kDriftP, stricter than the score test's since either confirms). A
// small effect that biases every interval the same way hides in each interval's noise but
// adds up over a window (docs/mismatch.md).
bool Diagnoser::DriftConfirmed(const Fit& before, const Fit& after, bool heading) const {
  const OdometryError b = HeldoutDrift(before.m), a = HeldoutDrift(after.m);
  if (b.windows < 5) return false;
  auto errors = [heading](const OdometryError& e) {
    std::vector<double> out;
    for (const WindowError& w : e.per_window) out.push_back(heading ? std::abs(w.heading_rad) : w.translation_m);
    return out;
  };
  return TestImprovement(errors(b), errors(a), kDriftP, 0.0).significant;
}

bool Diagnoser::HeldoutConfirms(const Candidate& c, const Fit& before, const Fit& after) const {
  return ScoreConfirmed(before, after) || DriftConfirmed(before, after, Localize(c, after.m, before.m).comp == 2);
}

Fit Diagnoser::FitWithout(const Fit& with, const Candidate& c, std::vector<int>* others) const {
  others->clear();
  for (int b : with.free)
    if (std::find(c.beta.begin(), c.beta.end(), b) == c.beta.end()) others->push_back(b);
  Model startm = with.m;
  for (int b : c.beta) startm.beta[b] = 0.0;
  return FitModel(startm, *others, {});
}

void Diagnoser::DescribeModel(const Fit& f0, const Fit& current, DiagnoseReport* report) const {
  report->intervals.resize(intervals_.size());
  for (std::size_t k = 0; k < intervals_.size(); ++k) {
    const Interval& it = intervals_[k];
    DiagnosedInterval& d = report->intervals[k];
    d.utime_start = it.motion->utime_start;
    d.utime_end = it.motion->utime_end;
    d.heldout = it.heldout;
    d.outlier = it.outlier;
    d.before = ErrorOf(it, f0.m);
    d.after = ErrorOf(it, current.m);
    d.sigma = it.sigma * std::sqrt(s2_);
  }
  Conditions(report);
  std::vector<double> hb[3], ha[3];
  for (const DiagnosedInterval& d : report->intervals) {
    if (!d.heldout || d.outlier) continue;
    for (int c = 0; c < 3; ++c) hb[c].push_back(d.before[c]), ha[c].push_back(d.after[c]);
  }
  for (int c = 0; c < 3; ++c) report->heldout_rms_before[c] = Rms(hb[c]), report->heldout_rms_after[c] = Rms(ha[c]);
  report->heldout_chi2_before = f0.chi2_heldout / std::max(1, f0.n_heldout);
  report->heldout_chi2_after = current.chi2_heldout / std::max(1, current.n_heldout);
  report->heldout_drift_before = HeldoutDrift(f0.m);
  report->heldout_drift_after = HeldoutDrift(current.m);
}

void Diagnoser::ReportFound(const std::vector<Candidate>& cands, const Selection& selection,
                            const SelectionLevels& levels, const Fit& f0, const Fit& current, double log_n,
                            DiagnoseReport* report) const {
  const int m_odo = levels.candidates, m_act = levels.actuation_candidates;
  for (std::size_t n = 0; n < selection.chosen.size(); ++n) {
    const Candidate& c = cands[selection.chosen[n]];
    std::vector<int> free;
    const Fit without = FitWithout(current, c, &free);
    FoundEffect fe = Describe(c, current, without, *report);
    fe.wald = selection.wald[n];
    fe.p_value = selection.p[n];
    fe.p_adjusted = std::min(1.0, selection.p[n] * double(m_odo - n) * double(m_odo + m_act) / m_odo);
    fe.delta_bic = DeltaBicAt(without, f0, current.chi2_fit, without.chi2_fit, c.beta.size(), log_n);
    if (c.beta[0] == kTimeOffset && std::abs(current.m.beta[kTimeOffset]) > 0.95 * max_offset_s_)
      report->notes.push_back("the time offset is at its search bound: treat it as larger than shown");
    if (!c.catalogued) {
      Unexplained un;
      un.where = fe.where;
      un.p_value = fe.p_adjusted;
      un.component = fe.component;
      std::ostringstream s;
      s.precision(3);
      s << "the direction of travel: the steering offset differs forward and in reverse by "
        << fe.params.begin()->second.value << " rad (not in effects.md; " << fe.regime << ")";
      un.correlates_with = s.str();
      report->unexplained.push_back(un);
    } else {
      report->effects.push_back(fe);
    }
  }
}

void Diagnoser::ReportCalibration(const Fit& f0, const Fit& current, const CalibrationResult& cal,
                                  DiagnoseReport* report) const {
  for (int i = 0; i < num_params_; ++i) {
    report->calibration[report->param_names[i]] = {f0.m.params[i], cal.params.at(report->param_names[i]).std};
    report->refitted[report->param_names[i]] = {current.m.params[i], cal.params.at(report->param_names[i]).std};
  }
  const std::string mount = MotionSourceName(data_.source);
  const char* axes[3] = {".x", ".y", ".yaw"};
  const Estimate* mstd[3] = {&cal.mount_x, &cal.mount_y, &cal.mount_yaw};
  for (int i = 0; i < 3; ++i) {
    report->calibration[mount + axes[i]] = {f0.m.mount[i], mstd[i]->std};
    report->refitted[mount + axes[i]] = {current.m.mount[i], mstd[i]->std};
  }
}

// The selection's fits of the recording (selection.h SelectionFits); an added candidate starts
// from its single fit.
Diagnoser::RecordingFits::RecordingFits(const Diagnoser& d, const std::vector<Candidate>& cands,
                                        const std::vector<Fit>& single, const Fit& f0, double log_n)
    : d_(d), cands_(cands), single_(single), f0_(f0), log_n_(log_n), current_(f0), trials_(cands.size()) {}

std::vector<PairFit> Diagnoser::RecordingFits::FitPairs(const std::vector<ConfusablePair>& catalogue) {
  for (const ConfusablePair& pair : catalogue) {
    int ia = -1, ib = -1;
    for (std::size_t j = 0; j < cands_.size(); ++j) {
      if (cands_[j].name == pair.a) ia = int(j);
      if (cands_[j].name == pair.b) ib = int(j);
    }
    if (ia < 0 || ib < 0) continue;
    PairFit pf;
    pf.pair = &pair, pf.a = ia, pf.b = ib;
    pairs_.push_back(pf);
  }
  // The joint fits are independent: on the worker threads, each into its own slot.
  joints_.assign(pairs_.size(), Fit());
  ParallelFor(pairs_.size(), WorkerThreads(d_.options_.jobs), [&](std::size_t k) {
    const int ba = cands_[pairs_[k].a].beta[0], bb = cands_[pairs_[k].b].beta[0];
    Model startm = f0_.m;
    startm.beta[ba] = single_[pairs_[k].a].m.beta[ba];
    startm.beta[bb] = single_[pairs_[k].b].m.beta[bb];
    joints_[k] = d_.FitModel(startm, {ba, bb}, {ba, bb});
  });
  for (std::size_t k = 0; k < pairs_.size(); ++k) {
    const Fit& joint = joints_[k];
    PairFit& pf = pairs_[k];
    pf.p = joint.p, pf.wald = joint.wald;
    pf.delta_bic = DeltaBic(joint.chi2_fit, f0_.chi2_fit, 2, log_n_);
    pf.var_a = joint.cov(0, 0), pf.var_b = joint.cov(1, 1);
    pf.correlation = Correlation(joint.cov, 0, 1);
  }
  return pairs_;
}

bool Diagnoser::RecordingFits::PairConfirmed(int k) {
  return d_.HeldoutConfirms(cands_[pairs_[k].a], f0_, joints_[k]);
}

void Diagnoser::RecordingFits::StartFromPair(int k) { current_ = joints_[k]; }

StepTest Diagnoser::RecordingFits::TryAdd(int j) {
  const Candidate& c = cands_[j];
  std::vector<int> free = current_.free;
  free.insert(free.end(), c.beta.begin(), c.beta.end());
  Model startm = current_.m;
  for (int b : c.beta) startm.beta[b] = single_[j].m.beta[b];
  trials_[j] = d_.FitModel(startm, free, c.beta);
  const Fit& f = trials_[j];
  return {f.p, f.wald, DeltaBicAt(current_, f0_, f.chi2_fit, current_.chi2_fit, c.beta.size(), log_n_)};
}

bool Diagnoser::RecordingFits::AddConfirmed(int j) { return d_.HeldoutConfirms(cands_[j], current_, trials_[j]); }

void Diagnoser::RecordingFits::Add(int j) { current_ = trials_[j]; }

StepTest Diagnoser::RecordingFits::TryKeep(int j) {
  without_ = d_.FitWithout(current_, cands_[j], &others_);
  with_ = d_.FitModel(current_.m, current_.free, cands_[j].beta);
  return {with_.p, with_.wald, 0.0};
}

bool Diagnoser::RecordingFits::KeepConfirmed(int j) { return d_.HeldoutConfirms(cands_[j], without_, with_); }

void Diagnoser::RecordingFits::Drop(int j) { current_ = d_.FitModel(without_.m, others_, {}); }

LookAlikeFit Diagnoser::RecordingFits::FitLookAlike(int x, int y) {
  const int bx = cands_[x].beta[0], by = cands_[y].beta[0];
  std::vector<int> free = current_.free;
  free.push_back(by);
  Model startm = current_.m;
  startm.beta[by] = single_[y].m.beta[by];
  const Fit joint = d_.FitModel(startm, free, {by});
  const int a = int(std::find(free.begin(), free.end(), bx) - free.begin());
  const int b = int(free.size()) - 1;
  LookAlikeFit out;
  out.correlation = Correlation(joint.cov, a, b);
  out.p_x = joint.cov(a, a) > 0 ? ChiSquareUpperTail(std::pow(joint.m.beta[bx], 2) / joint.cov(a, a), 1) : 1.0;
  out.p_y = joint.p;
  return out;
}

}  // namespace

DiagnoseReport Diagnose(const RobotDescription& robot, const DiagnoseData& data,
                        const DiagnoseOptions& options, const std::string& origin) {
  Diagnoser d(robot, data, options, origin);
  return d.Run();
}

namespace {

// WHEELS and the sensor motions, the scans de-skewed with `robot`'s drive model.
// `shift_us` moves the scans' stamps onto the wheel clock for de-skewing and matching;
// the motions get their recorded stamps back, so a time offset stays in the data.
void ReadMotions(const RobotDescription& robot, const std::string& log_path,
                 const std::function<void(const std::string&)>& progress, int64_t shift_us,
                 DiagnoseData* data) {
  DiagnoseData& out = *data;
  // Beam timing the scans declare: all zero makes scan_distortion testable.
  int64_t zero_timing = 0, scans = 0;
  std::vector<int64_t> stamps;
  std::vector<double> leads;  // per scan: mean time of the beams with a return after the stamp, s
  double scan_time = 0;
  auto check_scan = [&](LaserScan* scan) {
    ++scans;
    zero_timing += scan->time_increment == 0.0;
    if (scan->scan_time > 0) scan_time = scan->scan_time;
    stamps.push_back(scan->utime);
    double sum = 0;
    int returns = 0;
    for (int i = 0; i < scan->size(); ++i)
      if (scan->HasReturn(i)) sum += i * scan->time_increment, ++returns;
    leads.push_back(returns > 0 ? sum / returns : 0.0);
  };
  const CalibrationData cal = ReadCalibrationData(robot, log_path, out.source, progress,
                                                  std::function<void(LaserScan*)>(check_scan), shift_us);
  out.wheels = cal.wheels();
  out.motions = cal.motions();
  out.deskew_robot = robot;
  out.deskew_offset_s = shift_us * 1e-6;
  out.deskew_lead_s = 0.0;
  if (!leads.empty() && out.source == MotionSource::kLidar2d) {
    std::nth_element(leads.begin(), leads.begin() + leads.size() / 2, leads.end());
    out.deskew_lead_s = leads[leads.size() / 2];
  }
  if (scans > 10 && zero_timing == scans) {
    if (!(scan_time > 0)) {
      std::vector<int64_t> gaps;
      for (std::size_t i = 1; i < stamps.size(); ++i) gaps.push_back(stamps[i] - stamps[i - 1]);
      std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
      scan_time = gaps[gaps.size() / 2] * 1e-6;
    }
    out.scan_period_s = scan_time;
    if (progress) progress("scans declare no beam timing: matching again with beams spread over the scan");
    const CalibrationData spread = ReadCalibrationData(
        robot, log_path, out.source, nullptr,
        [&](LaserScan* scan) {
          if (scan->size() > 1) scan->time_increment = scan_time / scan->size();
        },
        shift_us);
    out.motions_spread = spread.motions();
  }
}

}  // namespace

DiagnoseData ReadDiagnoseData(const RobotDescription& robot, const std::string& log_path,
                              const std::function<void(const std::string&)>& progress,
                              double deskew_offset_s) {
  DiagnoseData out;
  out.source = ChooseMotionSource(robot, log_path, std::nullopt);
  const int64_t shift_us = std::llround(deskew_offset_s * 1e6);
  ReadMotions(robot, log_path, progress, shift_us, &out);
  if (out.source == MotionSource::kLidar2d) {
    // The matcher de-skews scans with the robot file's nominal odometry; the nominal
    // model's error then leaves a residual that looks like a time offset where the
    // robot turns fast. Match again with the calibrated model, as the calibration does
    // for its final answer.
    try {
      CalibrationOptions co;
      co.check_observability = false;
      const CalibrationResult cal = Calibrate(robot, out.wheels, out.motions, out.source, co, log_path);
      if (progress) progress("matching the scans again, de-skewed with the calibrated model");
      out.motions_spread.clear();
      ReadMotions(Calibrated(robot, cal), log_path, progress, shift_us, &out);
    } catch (const InputError&) {
      // Too little to calibrate: keep the nominal de-skew; Diagnose reports the problem.
    }
  }
  RecordingSource commands(log_path);
  if (progress) commands.set_on_drop([&](const std::string& note) { progress("left out: " + note); });
  SubscribeDriveCommands(&commands, robot, [&](const DriveCommand& c) { out.commands.push_back(c); });
  commands.HandleAll();
  std::stable_sort(out.commands.begin(), out.commands.end(),
                   [](const DriveCommand& a, const DriveCommand& b) { return a.utime < b.utime; });
  return out;
}

}  // namespace calib

namespace calib {

DiagnoseReport DiagnoseLog(const RobotDescription& robot, const std::string& log_path,
                           const DiagnoseOptions& options) {
  DiagnoseData data = ReadDiagnoseData(robot, log_path, options.progress);
  DiagnoseReport report = Diagnose(robot, data, options, log_path);
  const int64_t origin = RecordingStartUtime(SummarizeLog(log_path));
  report.recording_start_utime = origin;
  if (data.source != MotionSource::kLidar2d) return report;
  for (const FoundEffect& e : report.effects) {
    if (e.name != "time_offset") continue;
    // Scans were de-skewed with wheel data from the wrong time: match them again on the
    // wheel clock (stamps kept) and diagnose once more.
    const double offset = e.params.at("offset_s").value;
    if (std::abs(offset) < 0.001) break;
    if (options.progress) options.progress("time offset found: matching again with the scans de-skewed on the wheel clock");
    data = ReadDiagnoseData(robot, log_path, options.progress, offset);
    report = Diagnose(robot, data, options, log_path);
    report.notes.push_back("scans de-skewed with the wheel data " + std::to_string(offset) +
                           " s earlier than their stamps (the time offset found in a first pass)");
    break;
  }
  report.recording_start_utime = origin;
  return report;
}

}  // namespace calib
