#include "calib/calibrate/calibration.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <ceres/ceres.h>

#include "calib/calibrate/closed_form.h"
#include "calib/calibrate/heldout.h"
#include "calib/calibrate/interval_model.h"
#include "calib/calibrate/interval_problem.h"
#include "calib/calibrate/time_offset_search.h"
#include "calib/calibrate/undetermined.h"
#include "calib/core/errors.h"
#include "calib/core/statistics.h"
#include "calib/core/units.h"

namespace calib {
namespace {

constexpr int kMaxParams = 5;

// The parameter vector: drive parameters, mount, time offset.
struct State {
  double params[kMaxParams] = {0, 0, 0, 0, 0};
  double mount[3] = {0, 0, 0};
  double offset[1] = {0};
};

// An interval with the Ceres cost of its model, sized to the drive's parameters.
struct Interval : FittedInterval<DriveIntervalCost> {
  std::unique_ptr<ceres::CostFunction> function;
};

template <int N>
ceres::CostFunction* MakeFunction(DriveIntervalCost* cost) {
  return new ceres::AutoDiffCostFunction<DriveIntervalCost, 3, N, 3, 1>(cost, ceres::DO_NOT_TAKE_OWNERSHIP);
}

// Whitened residual chi-square of an interval at `state`.
double Chi2(const Interval& interval, const State& state) {
  const double* blocks[3] = {state.params, state.mount, state.offset};
  return Chi2At(*interval.function, blocks);
}

Eigen::Vector3d Error(const Interval& interval, const State& state) {
  return interval.cost->ErrorAt(state.params, state.mount, state.offset);
}

// Least squares over the fitted intervals, with the residuals divided by `scale` (robust: with
// a Cauchy loss at 3 `scale`), from and into `state`. Returns why it did not converge ("" when it did).
std::string Solve(const std::vector<Interval>& intervals, State* state, int num_params, double scale, bool robust,
                  const CalibrationOptions& options) {
  IntervalProblem problem(state->params, num_params, state->mount, state->offset, 1);
  for (const Interval& it : intervals) {
    if (!it.fitted()) continue;
    // The residual divided by `scale` is a chi-square cost scaled by 1/scale^2.
    problem.AddInterval(it.function.get(),
                        new ceres::ScaledLoss(robust ? new ceres::CauchyLoss(3.0 * scale) : nullptr,
                                              1.0 / (scale * scale), ceres::TAKE_OWNERSHIP));
  }
  if (options.estimate_time_offset)
    problem.BoundExtra(0, -options.max_time_offset_s, options.max_time_offset_s);
  else
    problem.HoldExtra({0});
  IntervalSolveSettings settings;
  settings.max_iterations = options.max_iterations;
  settings.tolerance = 1e-12;
  return NotConverged(problem.Solve(settings));
}

// Thresholds on one sigma beyond which the recording cannot determine a parameter, and the
// motion that would.
struct Requirement {
  double refuse;  // one sigma above this: not determined
  std::string remedy;
};

Requirement RequirementFor(DriveType type, const std::string& name, double nominal) {
  const double length = std::max(std::abs(nominal), 0.1);
  if (name.find("radius") != std::string::npos)
    return {0.05 * std::abs(nominal), "drive straight over a few metres, forward and back"};
  if (name == "track")
    return {0.1 * length, "turn: arcs of different curvature or turns in place, both ways"};
  if (name == "wheelbase" || name == "steer_offset")
    return {name == "wheelbase" ? 0.1 * length : 0.087,
            "drive arcs at two or more distinct steering angles, to both sides"};
  if (name == "b" || name == "a1_steer_offset")
    return {name == "b" ? 0.1 * length : 0.087,
            "drive arcs with a1 steered to both sides while a2 stays at zero"};
  if (name == "a")
    return {0.1 * length, "turn while a2 is driven: arcs with a1 steered and a2 at zero"};
  if (name == "time_offset")
    return {0.05, "change speed and turn rate often: starts, stops and changing arcs"};
  if (name.size() > 4 && name.compare(name.size() - 4, 4, ".yaw") == 0)
    return {0.087, "drive straight as well as turning"};
  return {0.05, "turn while driving: the sensor's position shows only when the robot rotates"};
}

}  // namespace

std::string MotionThatDetermines(DriveType drive, const std::string& name) {
  return RequirementFor(drive, name, 1.0).remedy;
}

namespace {

// The model's error at `state` on each held-out interval, as steps to chain (heldout.h).
std::vector<OdometryStep> HeldoutSteps(const std::vector<Interval>& intervals, const State& state) {
  std::vector<OdometryStep> steps;
  for (const Interval& it : intervals) {
    if (!it.heldout) continue;
    const Eigen::Vector3d e = Error(it, state);
    steps.push_back({it.motion->utime_start, it.motion->utime_end, it.motion->delta, {e[0], e[1], e[2]}});
  }
  return steps;
}

OdometryError HeldoutOdometry(const std::vector<Interval>& intervals, const State& state,
                              double window_s, bool keep_partial = false) {
  return OdometryErrorOverWindows(HeldoutSteps(intervals, state), window_s, keep_partial);
}

// The motions the encoders cover at the time offset `center_us` (a stamp t read at wheel time
// t - center) with `margin_us` either side, in stamp order; the others are counted in `summary`.
std::vector<const SensorMotion*> UsableMotions(const WheelTrack& wheels,
                                               const std::vector<SensorMotion>& motions, double center_us,
                                               double margin_us, ResidualSummary* summary) {
  std::vector<const SensorMotion*> usable;
  for (const SensorMotion& m : motions) {
    if (!m.valid || m.utime_end <= m.utime_start) {
      ++summary->invalid;
    } else if (m.degenerate) {
      ++summary->degenerate;
    } else if (!wheels.Covers(m.utime_start - center_us - margin_us, m.utime_end - center_us + margin_us)) {
      ++summary->invalid;
    } else {
      usable.push_back(&m);
    }
  }
  std::stable_sort(usable.begin(), usable.end(), [](const SensorMotion* a, const SensorMotion* b) {
    return a->utime_start < b->utime_start;
  });
  return usable;
}

// The cost of an interval: the encoder samples spanning it (with `margin_us` either side).
Interval MakeInterval(const EncoderTrack& track, int num_params, const SensorMotion& m,
                      double margin_us, bool heldout) {
  const std::vector<int64_t>& utime = track.utimes();
  const double t0 = m.utime_start - margin_us, t1 = m.utime_end + margin_us;
  auto first = std::upper_bound(utime.begin(), utime.end(), t0, [](double t, int64_t u) { return t < u; });
  if (first != utime.begin()) --first;
  auto last = std::lower_bound(utime.begin(), utime.end(), t1, [](int64_t u, double t) { return u < t; });
  if (last == utime.end()) --last;
  Interval it;
  it.motion = &m;
  it.heldout = heldout;
  it.cost = std::make_unique<DriveIntervalCost>(
      &track, first - utime.begin(), last - utime.begin(), m.utime_start, (m.utime_end - m.utime_start) * 1e-6,
      Eigen::Vector3d(m.delta.x, m.delta.y, m.delta.theta), SqrtInformation(m.covariance));
  it.function.reset(num_params == 3 ? MakeFunction<3>(it.cost.get()) : MakeFunction<5>(it.cost.get()));
  return it;
}

// The robot file's values: drive parameters and the mount of `source` (0 when it has none).
State StateOf(const RobotDescription& robot, MotionSource source) {
  State state;
  const std::vector<std::string>& names = ParamNames(robot.drive);
  for (std::size_t i = 0; i < names.size(); ++i) state.params[i] = robot.params.at(names[i]);
  const std::optional<Mount2d>& mount = source == MotionSource::kPose ? robot.pose : robot.lidar2d;
  if (mount) {
    state.mount[0] = mount->x;
    state.mount[1] = mount->y;
    state.mount[2] = mount->yaw;
  }
  return state;
}

// The spread M of the per-interval scores J_k' r_k for the sandwich covariance (J_k, r_k the
// whitened Jacobian and residual of interval k). Neighbouring intervals share an observation (a
// scan, a pose), so their errors are anti-correlated and M is a small difference of large
// terms. Summed over the sample's own products (sum s_k s_k' + s_k s_k-1' + s_k-1 s_k') it
// comes out near zero or negative in some directions by chance, which would claim a parameter
// known exactly, and make its errors many sigma. So the residuals' covariance is modelled instead: one
// 3x3 covariance C0 and one neighbour covariance C1, pooled over the recording after dividing
// each residual by its local size w_k (the rms over kLocalScaleHalfWidth intervals either side,
// since the noise grows with the motion), giving
//   M = sum w_k^2 J_k' C0 J_k + w_k w_k-1 (J_k' C1 J_k-1 + J_k-1' C1' J_k).
// C1 is shrunk until the block-Toeplitz covariance of the residuals is positive semi-definite,
// so M is too.
Eigen::MatrixXd ScoreSpread(const std::vector<Eigen::MatrixXd>& jacobians, const std::vector<Eigen::Vector3d>& residuals,
                            const std::vector<bool>& follows_previous) {
  constexpr int kLocalScaleHalfWidth = 5;
  const int n = static_cast<int>(residuals.size());
  const int dim = n > 0 ? static_cast<int>(jacobians[0].cols()) : 0;
  std::vector<double> scale(n);
  for (int k = 0; k < n; ++k) {
    double sum = 0.0;
    int count = 0;
    for (int j = std::max(0, k - kLocalScaleHalfWidth); j <= std::min(n - 1, k + kLocalScaleHalfWidth); ++j) {
      sum += residuals[j].squaredNorm() / 3.0;
      ++count;
    }
    scale[k] = std::sqrt(std::max(sum / count, 1e-300));
  }
  Eigen::Matrix3d c0 = Eigen::Matrix3d::Zero(), c1 = Eigen::Matrix3d::Zero();
  int pairs = 0;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d u = residuals[k] / scale[k];
    c0 += u * u.transpose();
    if (follows_previous[k]) {
      c1 += u * (residuals[k - 1] / scale[k - 1]).transpose();
      ++pairs;
    }
  }
  c0 /= std::max(1, n);
  c1 /= std::max(1, pairs);
  // The residuals' covariance is positive semi-definite when c0 + c1 e^iw + c1' e^-iw is for
  // every frequency w (as a Hermitian 3x3, written as a real 6x6).
  const auto positive = [&](const Eigen::Matrix3d& cross) {
    for (int step = 0; step <= 64; ++step) {
      const double w = M_PI * step / 64;
      const Eigen::Matrix3d re = c0 + std::cos(w) * (cross + cross.transpose());
      const Eigen::Matrix3d im = std::sin(w) * (cross - cross.transpose());
      Eigen::Matrix<double, 6, 6> h;
      h << re, -im, im, re;
      if (Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(h).eigenvalues()[0] < 0.0) return false;
    }
    return true;
  };
  double shrink = 1.0;
  while (shrink > 0.0 && !positive(shrink * c1)) shrink -= 0.02;
  c1 *= std::max(shrink, 0.0);
  Eigen::MatrixXd spread = Eigen::MatrixXd::Zero(dim, dim);
  for (int k = 0; k < n; ++k) {
    spread += scale[k] * scale[k] * jacobians[k].transpose() * c0 * jacobians[k];
    if (follows_previous[k]) {
      const Eigen::MatrixXd cross = scale[k] * scale[k - 1] * jacobians[k].transpose() * c1 * jacobians[k - 1];
      spread += cross + cross.transpose();
    }
  }
  return spread;
}

}  // namespace

const char* MotionSourceName(MotionSource source) {
  switch (source) {
    case MotionSource::kPose: return "pose";
    case MotionSource::kImu: return "imu";
    case MotionSource::kLidar2d: break;
  }
  return "lidar2d";
}

namespace {

// A result's estimates in the order of its `estimated_names` (and `covariance`).
std::vector<Estimate> EstimatesInOrder(const CalibrationResult& r) {
  std::vector<Estimate> out;
  for (const std::string& name : r.param_names) out.push_back(r.params.at(name));
  for (const Estimate& e : {r.mount_x, r.mount_y, r.mount_yaw}) out.push_back(e);
  if (r.time_offset) out.push_back(*r.time_offset);
  return out;
}

// The held-out half's own fit against the fit half's `fit` (HalvesAgreement). Without it when
// the held-out half cannot determine a value (`why_not` says which): a value a half cannot
// determine would differ between the halves by chance alone.
std::optional<HalvesAgreement> CompareHalves(const RobotDescription& robot, const WheelTrack& wheels,
                                             const std::vector<SensorMotion>& heldout_motions,
                                             MotionSource source, const CalibrationOptions& options,
                                             const std::string& origin, const CalibrationResult& fit,
                                             std::string* why_not) {
  CalibrationOptions alone = options;
  alone.fit_fraction = 1.0;
  alone.check_observability = true;
  CalibrationResult other;
  const std::string half = origin + " (held-out half)";
  try {
    other = Calibrate(robot, wheels, heldout_motions, source, alone, half);
  } catch (const InputError&) {
    return std::nullopt;  // too few intervals
  } catch (const UnobservableError& e) {
    // "<origin>: the recording cannot determine X, Y; <remedy>": the values, without the remedy.
    std::string what = e.what();
    if (what.rfind(half + ": ", 0) == 0) what = what.substr(half.size() + 2);
    *why_not = what.substr(0, what.find("; "));
    return std::nullopt;
  }
  if (other.estimated_names != fit.estimated_names) return std::nullopt;
  const std::vector<Estimate> mine = EstimatesInOrder(fit), theirs = EstimatesInOrder(other);
  const int dim = static_cast<int>(mine.size());
  HalvesAgreement a;
  Eigen::VectorXd delta(dim);
  const Eigen::MatrixXd sum = fit.covariance + other.covariance;
  for (int i = 0; i < dim; ++i) {
    if (!std::isfinite(mine[i].std) || !std::isfinite(theirs[i].std) || !(sum(i, i) > 0.0))
      return std::nullopt;  // a value one half cannot determine
    delta[i] = WrapAngle(theirs[i].value - mine[i].value);  // a no-op on all but the angles
    a.heldout_fit[fit.estimated_names[i]] = theirs[i];
  }
  const EstimateDifference d = CompareEstimates(delta, sum, fit.estimated_names);
  if (std::isinf(d.d2)) return std::nullopt;
  a.d2 = d.d2, a.dof = d.dof, a.p = d.p, a.largest = d.largest, a.largest_sigmas = d.largest_sigmas;
  const auto largest = std::find(fit.estimated_names.begin(), fit.estimated_names.end(), d.largest);
  a.largest_in_fit = mine[largest - fit.estimated_names.begin()];
  return a;
}

// 1. The closed-form first estimate (kept in `result`): the refinement's start, or the nominal
// values where it is not available or implausible.
State FirstEstimate(const RobotDescription& robot, const State& nominal,
                    const std::vector<MotionInterval>& input, CalibrationResult* result) {
  const std::vector<std::string>& names = result->param_names;
  const int num_params = static_cast<int>(names.size());
  State state = nominal;
  const ClosedFormEstimate cf = ClosedFormCalibration(robot.drive, robot.params, input);
  if (!cf.ok) {
    result->closed_form_note = "closed form not available: " + cf.problem;
    return state;
  }
  for (int i = 0; i < num_params; ++i) result->closed_form[names[i]] = cf.params.at(names[i]);
  result->closed_form["mount_x"] = cf.mount.x;
  result->closed_form["mount_y"] = cf.mount.y;
  result->closed_form["mount_yaw"] = cf.mount.theta;
  // Plausible: every length within a factor of two of nominal, same sign.
  bool plausible = true;
  for (int i = 0; i < num_params; ++i) {
    const double v = cf.params.at(names[i]), n = nominal.params[i];
    if (names[i].find("offset") == std::string::npos && std::abs(n) > 1e-6)
      plausible = plausible && v / n > 0.5 && v / n < 2.0;
  }
  if (!plausible) {
    result->closed_form_note = "closed form far from nominal; refinement started from nominal";
    return state;
  }
  for (int i = 0; i < num_params; ++i) state.params[i] = cf.params.at(names[i]);
  state.mount[0] = cf.mount.x;
  state.mount[1] = cf.mount.y;
  state.mount[2] = cf.mount.theta;
  return state;
}

// 2. Robust fit with a scale from the residuals at the start, then outliers, then the plain
// maximum-likelihood refit on the inliers. Returns the residuals' robust scale; `not_converged`
// gets why the last refit, the one reported, stopped short of convergence ("" when it converged).
double RobustFit(std::vector<Interval>& intervals, int num_params, const CalibrationOptions& options,
                 State* state, std::string* not_converged) {
  auto robust_scale = [&]() {
    std::vector<double> chi2;
    for (const Interval& it : intervals)
      if (!it.heldout && !it.outlier) chi2.push_back(Chi2(it, *state));
    return std::sqrt(RobustScale2(std::move(chi2)));
  };
  Solve(intervals, state, num_params, robust_scale(), true, options);
  double scale = 1.0;
  for (int round = 0; round < 2; ++round) {
    scale = robust_scale();
    for (Interval& it : intervals) {
      if (!it.heldout) it.outlier = IsOutlier(Chi2(it, *state), scale * scale, options.outlier_chi2);
    }
    *not_converged = Solve(intervals, state, num_params, scale, false, options);
  }
  return scale;
}

// Every interval's residual at `state` and at `nominal` (result->intervals) and their summary over the inliers
// (result->residual), chi-squares in the robust `scale`; `dim` values were fitted.
void SummarizeResiduals(const std::vector<Interval>& intervals, const State& state, const State& nominal,
                        double scale, std::size_t num_fit, int dim, CalibrationResult* result) {
  double chi2_sum = 0.0;
  int inliers = 0;
  Eigen::Vector3d sum_e2 = Eigen::Vector3d::Zero();
  for (const Interval& it : intervals) {
    IntervalResidual r;
    r.utime_start = it.motion->utime_start;
    r.utime_end = it.motion->utime_end;
    r.error = Error(it, state);
    r.nominal_error = Error(it, nominal);
    r.measured = Eigen::Vector3d(it.motion->delta.x, it.motion->delta.y, it.motion->delta.theta);
    r.chi2 = Chi2(it, state) / (scale * scale);
    r.outlier = it.outlier;
    r.heldout = it.heldout;
    result->intervals.push_back(r);
    if (it.heldout || it.outlier) continue;
    chi2_sum += r.chi2;
    sum_e2 += r.error.cwiseAbs2();
    ++inliers;
  }
  result->residual.intervals = static_cast<int>(num_fit);
  for (const Interval& it : intervals) result->residual.outliers += (!it.heldout && it.outlier) ? 1 : 0;
  result->residual.rms_x = std::sqrt(sum_e2[0] / inliers);
  result->residual.rms_y = std::sqrt(sum_e2[1] / inliers);
  result->residual.rms_yaw = std::sqrt(sum_e2[2] / inliers);
  const double variance_factor = chi2_sum / std::max(1, 3 * inliers - dim);
  result->residual.variance_factor = variance_factor * scale * scale;
}

// The inliers' whitened Jacobians J_k (columns: drive parameters, mount, the time offset when
// estimated) and residuals r_k at `state`, both divided by the robust `scale`.
struct Scores {
  Eigen::MatrixXd information;  // H = sum J_k' J_k
  std::vector<Eigen::MatrixXd> jacobians;
  std::vector<Eigen::Vector3d> residuals;
  std::vector<bool> follows_previous;  // the interval starts where the previous one ended
};

Scores InlierScores(const std::vector<Interval>& intervals, const State& state, int num_params,
                    bool with_offset, double scale) {
  const int dim = num_params + 3 + (with_offset ? 1 : 0);
  Scores s;
  s.information = Eigen::MatrixXd::Zero(dim, dim);
  int64_t previous_end = -1;
  for (const Interval& it : intervals) {
    if (it.heldout || it.outlier) continue;
    double residual[3];
    std::vector<double> jp_compact(3 * num_params);  // row-major 3 x num_params
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> jm;
    Eigen::Matrix<double, 3, 1> jo;
    double* jacobians[3] = {jp_compact.data(), jm.data(), jo.data()};
    const double* values[3] = {state.params, state.mount, state.offset};
    it.function->Evaluate(values, residual, jacobians);
    Eigen::MatrixXd J(3, dim);
    for (int row = 0; row < 3; ++row) {
      for (int c = 0; c < num_params; ++c) J(row, c) = jp_compact[row * num_params + c];
      for (int c = 0; c < 3; ++c) J(row, num_params + c) = jm(row, c);
      if (with_offset) J(row, num_params + 3) = jo(row);
    }
    J /= scale;
    s.information += J.transpose() * J;
    s.follows_previous.push_back(!s.residuals.empty() && previous_end == it.motion->utime_start);
    s.jacobians.push_back(J);
    s.residuals.push_back(Eigen::Vector3d(residual[0], residual[1], residual[2]) / scale);
    previous_end = it.motion->utime_end;
  }
  return s;
}

// 3. Covariance: the sandwich H^-1 M H^-1 with H the information of the whitened Jacobians and
// M the spread of the per-interval scores g_k = J_k^T r_k, including the covariance of
// neighbouring intervals (ScoreSpread). Neighbours share an observation (a scan, a pose), so
// their errors are correlated: a shared pose's noise cancels in the sum of two motions, and
// treating them as independent would make every sigma wrong. Sets result->covariance and
// result->condition; returns the sigmas, infinite for what the data do not determine.
std::vector<double> Covariance(const Scores& scores, CalibrationResult* result) {
  const Eigen::MatrixXd& information = scores.information;
  const int dim = static_cast<int>(information.rows());
  const int inliers = static_cast<int>(scores.residuals.size());
  // The sample spread is a little small by the parameters fitted; the usual dof correction.
  const Eigen::MatrixXd spread = ScoreSpread(scores.jacobians, scores.residuals, scores.follows_previous) *
                                 (double(3 * inliers) / std::max(1, 3 * inliers - dim));
  // Observability: eigen-analysis of the correlation-normalised information.
  const Eigen::VectorXd d = information.diagonal().cwiseMax(1e-300).cwiseSqrt();
  const Eigen::MatrixXd correlation = d.asDiagonal().inverse() * information * d.asDiagonal().inverse();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(correlation);
  const double lmin = std::max(eig.eigenvalues()[0], 0.0), lmax = eig.eigenvalues()[dim - 1];
  result->condition = lmin > 0 ? lmax / lmin : INFINITY;
  // Pseudo-inverse restricted to the determined directions, so a singular direction shows as
  // an unbounded sigma rather than a crash.
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(dim);
  for (int i = 0; i < dim; ++i)
    inv[i] = eig.eigenvalues()[i] > 1e-12 * lmax ? 1.0 / eig.eigenvalues()[i] : 0.0;
  const Eigen::MatrixXd correlation_inverse =
      eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
  const Eigen::MatrixXd information_inverse =
      d.asDiagonal().inverse() * correlation_inverse * d.asDiagonal().inverse();
  result->covariance = information_inverse * spread * information_inverse;
  std::vector<double> sigma(dim);
  for (int i = 0; i < dim; ++i) {
    sigma[i] = std::sqrt(std::max(result->covariance(i, i), 0.0));
    for (int e = 0; e < dim; ++e) {  // a parameter in a singular direction is not determined
      if (inv[e] == 0.0 && std::abs(eig.eigenvectors()(i, e)) > 0.3) sigma[i] = INFINITY;
    }
    if (d[i] <= 1e-150) sigma[i] = INFINITY;
  }
  return sigma;
}

// The estimates of `state` with their `sigma` and the `nominal` values, named in the order of
// the covariance (result->estimated_names; the mount after the sensor `source`).
void SetEstimates(const State& state, const State& nominal, const std::vector<double>& sigma,
                  MotionSource source, bool with_offset, CalibrationResult* result) {
  const int num_params = static_cast<int>(result->param_names.size());
  for (int i = 0; i < num_params; ++i) result->estimated_names.push_back(result->param_names[i]);
  for (const char* axis : {".x", ".y", ".yaw"})
    result->estimated_names.push_back(std::string(MotionSourceName(source)) + axis);
  if (with_offset) result->estimated_names.push_back("time_offset");
  auto estimate = [&](int i, double value, double nominal_value) {
    return Estimate{value, sigma[i], nominal_value};
  };
  for (int i = 0; i < num_params; ++i)
    result->params[result->param_names[i]] = estimate(i, state.params[i], nominal.params[i]);
  result->mount_x = estimate(num_params, state.mount[0], nominal.mount[0]);
  result->mount_y = estimate(num_params + 1, state.mount[1], nominal.mount[1]);
  result->mount_yaw = estimate(num_params + 2, WrapAngle(state.mount[2]), nominal.mount[2]);
  if (with_offset) result->time_offset = estimate(num_params + 3, state.offset[0], 0.0);
}

// Refuses what the data cannot determine (UnobservableError naming it and the motion to add,
// when `check`); lists what they determine poorly in result->weak, the refused ones last.
void RefuseUndetermined(DriveType drive, const State& nominal, const std::vector<double>& sigma,
                        bool check, const std::string& origin, CalibrationResult* result) {
  const int num_params = static_cast<int>(result->param_names.size());
  std::vector<std::string> refused, remedies, figures;
  const double nominal_values[] = {nominal.params[0], nominal.params[1], nominal.params[2],
                                   nominal.params[3], nominal.params[4]};
  // The estimates in covariance order (SetEstimates), so a refusal shows what it refused.
  std::vector<double> values;
  for (int i = 0; i < num_params; ++i) values.push_back(result->params[result->param_names[i]].value);
  for (const Estimate& e : {result->mount_x, result->mount_y, result->mount_yaw}) values.push_back(e.value);
  if (result->time_offset) values.push_back(result->time_offset->value);
  for (std::size_t i = 0; i < sigma.size(); ++i) {
    const std::string& name = result->estimated_names[i];
    const Requirement req = RequirementFor(drive, name, int(i) < num_params ? nominal_values[i] : 0.0);
    if (!(sigma[i] <= req.refuse)) {
      refused.push_back(name);
      const std::string unit = ParamUnit(name);
      figures.push_back(name + " " + EstimateText(i < values.size() ? values[i] : NAN, sigma[i], unit) +
                        ", determined only below " + QuantityText(req.refuse, unit, 2));
      if (std::find(remedies.begin(), remedies.end(), req.remedy) == remedies.end())
        remedies.push_back(req.remedy);
    } else if (sigma[i] > 0.1 * req.refuse) {
      result->weak.push_back(name);
    }
  }
  if (check && !refused.empty()) {
    std::ostringstream what, remedy;
    what << origin << ": the recording cannot determine ";
    for (std::size_t i = 0; i < refused.size(); ++i) what << (i ? ", " : "") << refused[i];
    what << " (";
    for (std::size_t i = 0; i < figures.size(); ++i) what << (i ? "; " : "") << figures[i];
    what << ")";
    for (std::size_t i = 0; i < remedies.size(); ++i) remedy << (i ? "; " : "") << remedies[i];
    throw UnobservableError(what.str(), remedy.str());
  }
  result->weak.insert(result->weak.end(), refused.begin(), refused.end());
}

// Room the joint fit has around the searched offset: each interval's encoder data reach this
// far beyond its ends at that offset.
constexpr double kOffsetRoomS = 0.25;

// The global search's offset (time_offset_search.h) on the first `fit_fraction` of the valid
// motions, with the robot file's drive parameters: nothing in it depends on where the offset lies
// in the range searched (intervals or scales chosen by the range, or drive parameters from the
// closed form at offset 0, would), so shifting every sensor stamp moves it by the shift. It is
// searched once: searched again with the closed form's parameters at the offset found, it ended
// further from the truth on simulated recordings.
double SearchedOffset(const RobotDescription& robot, const State& nominal, const WheelTrack& wheels,
                      const std::vector<SensorMotion>& motions, const CalibrationOptions& options) {
  std::vector<SensorMotion> fit;
  for (const SensorMotion& m : motions)
    if (m.valid && !m.degenerate && m.utime_end > m.utime_start) fit.push_back(m);
  std::stable_sort(fit.begin(), fit.end(),
                   [](const SensorMotion& a, const SensorMotion& b) { return a.utime_start < b.utime_start; });
  fit.resize(static_cast<std::size_t>(std::floor(fit.size() * std::clamp(options.fit_fraction, 0.0, 1.0))));
  return SearchTimeOffset(robot.drive, nominal.params, wheels, fit, options.max_time_offset_s).offset_s;
}

// The time offset (search or fit) within this of its bound lies at the bound: within the reach of
// the search's fine grid.
constexpr double kAtBoundS = 0.002;

// Steps 1 and 2 at the time-offset bound of `options`, kept for the steps after them.
struct BoundedFit {
  CalibrationOptions options;  // with the bound it was fitted within
  CalibrationResult result;    // the closed form and the motions left out, so far
  std::vector<const SensorMotion*> usable;  // in stamp order; the first num_fit are fitted
  std::size_t num_fit = 0;
  std::vector<Interval> intervals;
  State nominal, state;
  double scale = 1.0;               // the residuals' robust scale
  bool offset_at_bound = false;     // the search's or the fit's offset at the bound
  std::string not_converged;        // why the fit stopped short of convergence ("" when it converged)
};

// With the offset: the global search first, then the intervals the encoders cover with room for
// the joint fit around its offset (stamp order), their closed form at that offset and the joint
// fit from there (global before local: the offset's cost has minima an encoder or scan period
// apart and a basin as wide as the motion's bandwidth, time_offset_search.h). InputError when too
// few intervals are left.
BoundedFit FitWithin(const RobotDescription& robot, const EncoderTrack& track, const WheelTrack& wheels,
                     const std::vector<SensorMotion>& motions, MotionSource source, const CalibrationOptions& options,
                     const std::string& origin) {
  BoundedFit fit;
  fit.options = options;
  CalibrationResult& result = fit.result;
  result.drive = robot.drive;
  result.source = source;
  result.param_names = ParamNames(robot.drive);
  const int num_params = static_cast<int>(result.param_names.size());
  const bool with_offset = options.estimate_time_offset;
  fit.nominal = StateOf(robot, source);
  const double center_s = with_offset ? SearchedOffset(robot, fit.nominal, wheels, motions, options) : 0.0;
  const double center_us = std::round(center_s * 1e6);
  if (with_offset) result.time_offset_bound_s = options.max_time_offset_s;
  fit.usable = UsableMotions(wheels, motions, center_us, with_offset ? kOffsetRoomS * 1e6 : 0.0, &result.residual);
  fit.num_fit = static_cast<std::size_t>(std::floor(fit.usable.size() * std::clamp(options.fit_fraction, 0.0, 1.0)));
  if (fit.num_fit < 20) {
    throw InputError(origin, "sensor motions",
                     "only " + std::to_string(fit.num_fit) + " usable intervals with encoder data (" +
                         std::to_string(motions.size()) + " motions, " +
                         std::to_string(result.residual.degenerate) + " degenerate, " +
                         std::to_string(result.residual.invalid) +
                         " failed or outside the encoder data); at least 20 are needed");
  }
  // Each interval's encoder samples reach over every offset the fit may take.
  const double margin_us = with_offset ? (options.max_time_offset_s + kOffsetRoomS) * 1e6 : 0.0;
  std::vector<MotionInterval> closed_form_input;
  for (std::size_t k = 0; k < fit.usable.size(); ++k) {
    const SensorMotion& m = *fit.usable[k];
    fit.intervals.push_back(MakeInterval(track, num_params, m, margin_us, k >= fit.num_fit));
    if (k < fit.num_fit) {
      closed_form_input.push_back({&wheels, m.utime_start - int64_t(center_us), m.utime_end - int64_t(center_us),
                                   m.delta});
    }
  }
  fit.state = FirstEstimate(robot, fit.nominal, closed_form_input, &result);
  fit.state.offset[0] = center_s;
  fit.scale = RobustFit(fit.intervals, num_params, options, &fit.state, &fit.not_converged);
  fit.offset_at_bound = with_offset && std::max(std::abs(center_s), std::abs(fit.state.offset[0])) >=
                                           options.max_time_offset_s - kAtBoundS;
  return fit;
}

// Steps 3 and 4 on the fit: the residuals, the covariance, what the data cannot determine, and
// the held-out comparison.
CalibrationResult Conclude(const RobotDescription& robot, const WheelTrack& wheels, MotionSource source,
                           const std::string& origin, BoundedFit fit) {
  CalibrationResult& result = fit.result;
  const CalibrationOptions& options = fit.options;
  const int num_params = static_cast<int>(result.param_names.size());
  const bool with_offset = options.estimate_time_offset;
  if (!fit.not_converged.empty())
    result.warnings.push_back("the fit " + fit.not_converged + ": the values are its last");
  const int dim = num_params + 3 + (with_offset ? 1 : 0);
  SummarizeResiduals(fit.intervals, fit.state, fit.nominal, fit.scale, fit.num_fit, dim, &result);
  const std::vector<double> sigma =
      Covariance(InlierScores(fit.intervals, fit.state, num_params, with_offset, fit.scale), &result);
  SetEstimates(fit.state, fit.nominal, sigma, source, with_offset, &result);
  // A wheel radius fitted at or below zero is no robot's: the readings belong to other roles
  // than the robot file gives them (the cause, not "cannot determine"; no model is made of it).
  for (const std::string& role : WheelRoles(robot.drive)) {
    const std::string name = RadiusParamName(role);
    const auto it = result.params.find(name);
    if (it != result.params.end() && !(it->second.value > 0.0)) {
      throw InputError(robot.source_file, "wheels",
                       Formatted("the recording's wheel readings do not fit this drive: the fit gives %s = %g m "
                                 "(wheels: names given to the wrong roles, e.g. two swapped, or the wrong drive type?)",
                                 name.c_str(), it->second.value));
    }
  }
  RefuseUndetermined(robot.drive, fit.nominal, sigma, options.check_observability, origin, &result);

  // 4. Held-out comparison of the nominal and the calibrated model.
  if (fit.num_fit < fit.intervals.size()) {
    HeldoutComparison h = CompareHeldout(HeldoutSteps(fit.intervals, fit.nominal), HeldoutSteps(fit.intervals, fit.state),
                                         CompareMotion(robot.drive, wheels, fit.usable, fit.num_fit),
                                         options.heldout_windows);
    h.intervals = static_cast<int>(fit.intervals.size() - fit.num_fit);
    std::vector<SensorMotion> heldout_motions;
    for (std::size_t k = fit.num_fit; k < fit.usable.size(); ++k) heldout_motions.push_back(*fit.usable[k]);
    h.halves = CompareHalves(robot, wheels, heldout_motions, source, options, origin, result, &h.halves_not_compared);
    result.heldout = h;
  }
  return std::move(result);
}

}  // namespace

double UndeterminedAbove(DriveType drive, const std::string& name, double nominal) {
  return RequirementFor(drive, name, nominal).refuse;
}

CalibrationResult Calibrate(const RobotDescription& robot, const WheelTrack& wheels,
                            const std::vector<SensorMotion>& motions, MotionSource source,
                            const CalibrationOptions& options, const std::string& origin) {
  const EncoderTrack track(robot.drive, wheels);
  BoundedFit fit = FitWithin(robot, track, wheels, motions, source, options, origin);
  // An offset at its bound may lie beyond it: searched and fitted again over twice the range, up
  // to kWidestTimeOffsetS. A recording too short for the wider margin keeps the bound it has, and
  // the result says why.
  while (fit.offset_at_bound && fit.options.max_time_offset_s < kWidestTimeOffsetS) {
    CalibrationOptions wider = fit.options;
    wider.max_time_offset_s = std::min(2.0 * wider.max_time_offset_s, kWidestTimeOffsetS);
    try {
      fit = FitWithin(robot, track, wheels, motions, source, wider, origin);
    } catch (const InputError& e) {
      std::ostringstream warning;
      warning << "the time offset lies at its bound (+-" << fit.options.max_time_offset_s
              << " s) and could not be searched beyond it: " << e.what();
      fit.result.warnings.push_back(warning.str());
      break;
    }
  }
  return Conclude(robot, wheels, source, origin, std::move(fit));
}

OdometryError EvaluateOdometry(const RobotDescription& robot, MotionSource source,
                               const WheelTrack& wheels, const std::vector<SensorMotion>& motions,
                               double window_s) {
  ResidualSummary ignored;
  const int num_params = static_cast<int>(ParamNames(robot.drive).size());
  const EncoderTrack track(robot.drive, wheels);
  std::vector<Interval> intervals;
  for (const SensorMotion* m : UsableMotions(wheels, motions, 0.0, 0.0, &ignored))
    intervals.push_back(MakeInterval(track, num_params, *m, 0.0, true /* heldout */));
  return HeldoutOdometry(intervals, StateOf(robot, source), window_s, true /* keep_partial */);
}

RobotDescription Calibrated(const RobotDescription& robot, const CalibrationResult& result) {
  RobotDescription out = robot;
  for (const auto& [name, e] : result.params) out.params[name] = e.value;
  if (result.imu) {
    if (!out.imu) out.imu = ImuMount{};
    out.imu->gyro_bias = result.imu->gyro_bias.value;
    out.imu->gyro_scale = result.imu->gyro_scale.value;
    if (std::isfinite(result.imu->yaw.std)) out.imu->yaw = result.imu->yaw.value;
    out.imu->time_offset = result.imu->time_offset.value;
    out.imu->gyro_noise = result.imu->gyro_noise;
    out.imu->wheel_noise = result.imu->wheel_noise;
    return out;
  }
  std::optional<Mount2d>& mount = result.source == MotionSource::kPose ? out.pose : out.lidar2d;
  if (!mount) mount = Mount2d{result.source == MotionSource::kPose ? "POSE" : "SCAN", 0, 0, 0};
  mount->x = result.mount_x.value;
  mount->y = result.mount_y.value;
  mount->yaw = result.mount_yaw.value;
  return out;
}

}  // namespace calib
