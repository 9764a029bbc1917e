// The fits of the diagnosis (diagnose_fit.h).

#include "diagnose/diagnose_fit.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <utility>

#include <Eigen/Dense>

#include "calib/core/errors.h"
#include "calib/core/statistics.h"
#include "calib/diagnose/selection.h"

namespace calib::diag {

namespace {

// How far wheel w's readings stray from any smooth motion, as a share of a typical step between
// samples. Each reading is compared with the cubic through the two samples either side; a reading
// displaced from the smooth path (a tick counted one sample late, uneven read-out) leaves
// residuals of opposite sign at consecutive samples, real acceleration leaves residuals of the
// same sign, so the negative part of their lag-one covariance is the irregularity alone.
double StepIrregularity(const EncoderTrack& tr, int w) {
  const std::size_t n = tr.size();
  if (n < 8) return 0.0;
  std::vector<double> residual;
  for (std::size_t i = 2; i + 2 < n; ++i) {
    const std::size_t at[4] = {i - 2, i - 1, i + 1, i + 2};
    double smooth = 0;
    for (int j = 0; j < 4; ++j) {
      double weight = 1;  // Lagrange weight of sample at[j] at the time of sample i
      for (int m = 0; m < 4; ++m)
        if (m != j) weight *= double(tr.utime(i) - tr.utime(at[m])) / double(tr.utime(at[j]) - tr.utime(at[m]));
      smooth += weight * tr.pos(at[j], w);
    }
    residual.push_back(tr.pos(i, w) - smooth);
  }
  double covariance = 0;
  for (std::size_t i = 0; i + 1 < residual.size(); ++i) covariance += residual[i] * residual[i + 1];
  covariance /= double(residual.size() - 1);
  // Independent displacements of variance s2 give a lag-one covariance of -(56/36) s2 (equal spacing).
  const double displacement = std::sqrt(std::max(0.0, -covariance) * 36.0 / 56.0);
  double step2 = 0;
  int moving = 0;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double step = tr.pos(i + 1, w) - tr.pos(i, w);
    if (step != 0) step2 += step * step, ++moving;
  }
  return moving > 0 ? displacement / std::sqrt(step2 / moving) : 0.0;
}

// Half-width, in samples, of the central differences that give the wheel speeds: about +-50 ms
// (below that, tick quantisation dominates), wider where the readings stray from a smooth motion
// by a large share of a step, until the speed error that leaves is at most kSpeedError of the
// speed: over +-k samples, irregularity x step x sqrt(2) / (2 k steps).
int SpeedHalfWidth(const EncoderTrack& tr) {
  constexpr double kSpeedError = 0.1;
  const std::size_t n = tr.size();
  const double dt = (tr.utime(n - 1) - tr.utime(0)) * 1e-6 / double(n - 1);
  int k = std::max(1, int(std::lround(0.05 / std::max(dt, 1e-4))));
  double irregularity = 0;
  for (int w = 0; w < tr.wheels; ++w) irregularity = std::max(irregularity, StepIrregularity(tr, w));
  const int needed = int(std::ceil(irregularity * std::sqrt(0.5) / kSpeedError));
  return std::min(std::max(k, needed), std::max(1, int(n / 8)));
}

}  // namespace

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
  const int k = SpeedHalfWidth(tr);
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

namespace {

// d(measured motion)/d(scan period): the same interval matched with beams spread over
// the scan period, minus the plain match, per second of period (zero when unmatched).
Eigen::Vector3d SpreadDerivative(const DiagnoseData& data, const SensorMotion* m,
                                 const std::map<std::pair<int64_t, int64_t>, const SensorMotion*>& spread) {
  const auto it = spread.find({m->utime_start, m->utime_end});
  if (it == spread.end() || !(data.scan_period_s > 0)) return Eigen::Vector3d::Zero();
  const Pose2& a = m->delta;
  const Pose2& b = it->second->delta;
  return Eigen::Vector3d(b.x - a.x, b.y - a.y, WrapAngle(b.theta - a.theta)) / data.scan_period_s;
}

}  // namespace

void BuildIntervals(const RobotDescription& robot, const DiagnoseData& data, double block_s,
                    const std::string& origin, Recording* recording) {
  recording->intervals.clear();
  recording->track = MakeTrack(robot, data.wheels);
  const Track& track = recording->track;
  const double max_offset_s = recording->max_offset_s;
  const double margin = (kHistoryS + max_offset_s) * 1e6;
  std::vector<const SensorMotion*> usable;
  for (const SensorMotion& m : data.motions) {
    if (m.valid && !m.degenerate && m.utime_end > m.utime_start &&
        data.wheels.Covers(m.utime_start - margin, m.utime_end + max_offset_s * 1e6))
      usable.push_back(&m);
  }
  std::stable_sort(usable.begin(), usable.end(),
                   [](const SensorMotion* a, const SensorMotion* b) { return a->utime_start < b->utime_start; });
  // Too little data is exit 3 (spec/cli.md), as for the calibration: the recording is
  // fine, it is only too short to tell an effect from noise.
  if (usable.size() < 40)
    throw UnobservableError(origin + ": only " + std::to_string(usable.size()) +
                                " usable intervals with encoder data; the diagnosis needs at least 40",
                            "record a longer run (more scan-matched motion)");
  std::map<std::pair<int64_t, int64_t>, const SensorMotion*> spread;
  for (const SensorMotion& m : data.motions_spread)
    if (m.valid) spread[{m.utime_start, m.utime_end}] = &m;
  const int64_t t_first = usable.front()->utime_start;
  const auto& ut = track.utimes();
  const double lead_s = data.deskew_robot ? data.deskew_lead_s : 0.0;
  const std::unique_ptr<DriveModel> deskew_model = lead_s > 0 ? MakeDriveModel(*data.deskew_robot) : nullptr;
  // The de-skew odometry over the lead after a stamp, on the wheel clock the matcher used.
  auto deskew_over_lead = [&](int64_t stamp) {
    if (!deskew_model) return Pose2{};
    const double t = stamp - data.deskew_offset_s * 1e6;
    return data.wheels.Odometry(*deskew_model, t, t + lead_s * 1e6);
  };
  for (const SensorMotion* m : usable) {
    Interval it;
    it.motion = m;
    const int64_t mid = (m->utime_start + m->utime_end) / 2;
    it.block = static_cast<int>((mid - t_first) * 1e-6 / block_s);
    it.heldout = it.block % 2 == 1;
    std::size_t first = std::upper_bound(ut.begin(), ut.end(), int64_t(m->utime_start - margin)) - ut.begin();
    first = first > 0 ? first - 1 : 0;
    std::size_t last = std::lower_bound(ut.begin(), ut.end(), int64_t(m->utime_end + max_offset_s * 1e6)) - ut.begin();
    last = std::min(last, ut.size() - 1);
    for (int k = 0; k < 3; ++k) it.sigma[k] = std::sqrt(std::max(m->covariance(k, k), 1e-18));
    it.cost = std::make_unique<IntervalModel>(
        &track, first, last, m->utime_start, (m->utime_end - m->utime_start) * 1e-6,
        Eigen::Vector3d(m->delta.x, m->delta.y, m->delta.theta), SqrtInformation(m->covariance),
        SpreadDerivative(data, m, spread), lead_s, deskew_over_lead(m->utime_start), deskew_over_lead(m->utime_end));
    recording->intervals.push_back(std::move(it));
  }
}

namespace {

// The fit's solve: the calibration with the effect terms `fit->free` on the fit blocks, from and
// into `fit->m`.
void SolveFit(const Recording& recording, Fit* fit) {
  Model& m = fit->m;
  std::vector<int> held_beta;
  for (int j = 0; j < kNumBeta; ++j) {
    if (std::find(fit->free.begin(), fit->free.end(), j) != fit->free.end()) continue;
    m.beta[j] = 0.0;
    held_beta.push_back(j);
  }
  IntervalProblem problem(m.params, 5, m.mount, m.beta, kNumBeta);
  std::deque<IntervalFunction> functions;  // derivatives over the free effect terms only
  for (const Interval& it : recording.intervals) {
    if (!it.fitted()) continue;
    functions.emplace_back(it.cost.get(), &fit->free);
    problem.AddInterval(&functions.back());
  }
  problem.HoldParams(recording.held_params);
  problem.HoldExtra(held_beta);
  if (held_beta.size() < kNumBeta) {
    problem.BoundExtra(kLag, 0.0, 0.5);
    problem.BoundExtra(kTimeOffset, -recording.max_offset_s, recording.max_offset_s);
    // Neither a scan period nor a play's width is negative. Unbounded, a negative period traded
    // against the time offset, and a negative "backlash" (the wheel ahead of its encoder in the
    // direction it last moved) fitted what is no play: the steering read at the interval's ends
    // while it turns slowly, as under a steering rate limit.
    problem.BoundExtraBelow(kDistortion, 0.0);
    problem.BoundExtraBelow(kBacklash, 0.0);
  }
  IntervalSolveSettings settings;
  settings.max_iterations = recording.max_iterations;
  settings.tolerance = 1e-10;
  fit->not_converged = NotConverged(problem.Solve(settings));
}

// The robust covariance of a fit's effect terms, and the Wald test of its tested ones: the
// information H and the Newey-West spread M of the per-interval scores (neighbouring intervals
// share a scan), cov = H^-1 M H^-1; also the held-out chi-squares.
void FitStatistics(const Recording& recording, Fit* fit) {
  const std::vector<int>& free = fit->free;
  std::vector<int> active;  // columns: free params, mount, free betas
  for (int i = 0; i < 5; ++i)
    if (i < recording.num_params &&
        std::find(recording.held_params.begin(), recording.held_params.end(), i) == recording.held_params.end())
      active.push_back(i);
  const int np = static_cast<int>(active.size());
  const int dim = np + 3 + static_cast<int>(free.size());
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(dim, dim);
  std::vector<Eigen::VectorXd> scores;
  const double s2 = recording.noise_scale2;
  const double s = std::sqrt(s2);
  for (const Interval& it : recording.intervals) {
    if (it.outlier) continue;
    double r[3];
    if (it.heldout) {
      Residual(it, fit->m, r);
      fit->chi2_heldout += (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / s2;
      fit->heldout_terms.push_back((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / s2);
      ++fit->n_heldout;
      continue;
    }
    Jacobians jac;
    Residual(it, fit->m, r, &jac, free);
    Eigen::MatrixXd J(3, dim);
    for (int c = 0; c < np; ++c) J.col(c) = jac.params.col(active[c]);
    J.block(0, np, 3, 3) = jac.mount;
    for (std::size_t c = 0; c < free.size(); ++c) J.col(np + 3 + c) = jac.beta.col(free[c]);
    J /= s;
    const Eigen::Vector3d rv = Eigen::Vector3d(r[0], r[1], r[2]) / s;
    fit->chi2_fit += rv.squaredNorm();
    ++fit->n_fit;
    H += J.transpose() * J;
    scores.push_back(J.transpose() * rv);
  }
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(dim, dim);
  const int L = recording.hac_lags;
  for (std::size_t k = 0; k < scores.size(); ++k) {
    M += scores[k] * scores[k].transpose();
    for (int l = 1; l <= L && l <= int(k); ++l) {
      const double w = 1.0 - double(l) / (L + 1);
      M += w * (scores[k] * scores[k - l].transpose() + scores[k - l] * scores[k].transpose());
    }
  }
  fit->dof = std::max(1, 3 * fit->n_fit - dim);
  M *= double(3 * fit->n_fit) / fit->dof;
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
  fit->cov = full.block(np + 3, np + 3, nb, nb);
  fit->calibration_std.assign(8, std::nan(""));
  for (int c = 0; c < np; ++c) fit->calibration_std[active[c]] = std::sqrt(std::max(full(c, c), 0.0));
  for (int c = 0; c < 3; ++c) fit->calibration_std[5 + c] = std::sqrt(std::max(full(np + c, np + c), 0.0));
  fit->info_cov = Hinv.block(np + 3, np + 3, nb, nb);
  const std::vector<int>& tested = fit->tested;
  if (!tested.empty()) {
    std::vector<int> idx;
    for (int t : tested) idx.push_back(int(std::find(free.begin(), free.end(), t) - free.begin()));
    Eigen::MatrixXd V(idx.size(), idx.size());
    Eigen::VectorXd b(idx.size());
    for (std::size_t i = 0; i < idx.size(); ++i) {
      b[i] = fit->m.beta[tested[i]];
      for (std::size_t j = 0; j < idx.size(); ++j) V(i, j) = fit->cov(idx[i], idx[j]);
    }
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(V);
    fit->wald = (ldlt.info() == Eigen::Success && V.diagonal().minCoeff() > 0) ? b.dot(ldlt.solve(b)) : 0.0;
    fit->p = ChiSquareUpperTail(fit->wald, static_cast<int>(tested.size()));
  }
}

}  // namespace

Fit FitModel(const Recording& recording, const Model& start, const std::vector<int>& free,
             const std::vector<int>& tested) {
  Fit fit;
  fit.m = start;
  fit.free = free;
  fit.tested = tested;
  SolveFit(recording, &fit);
  FitStatistics(recording, &fit);
  return fit;
}

Fit FitWithout(const Recording& recording, const Fit& with, const std::vector<int>& effect,
               std::vector<int>* others) {
  others->clear();
  for (int b : with.free)
    if (std::find(effect.begin(), effect.end(), b) == effect.end()) others->push_back(b);
  Model start = with.m;
  for (int b : effect) start.beta[b] = 0.0;
  return FitModel(recording, start, *others, {});
}

Fit FitAcrossOffsetMinima(const Recording& recording, const Model& start, const std::vector<int>& free,
                          const std::vector<int>& tested) {
  Fit best = FitModel(recording, start, free, tested);
  if (std::find(free.begin(), free.end(), int(kTimeOffset)) == free.end()) return best;
  const Track& tr = recording.track;
  if (tr.size() < 2) return best;
  const double period = (tr.utimes().back() - tr.utimes().front()) * 1e-6 / double(tr.size() - 1);
  // Global before local: the offset on a grid of quarter periods over the range searched, the
  // other terms at their start, and the neighbouring minima either side of the start.
  std::vector<double> grid;
  const double step = std::max(period / 4, 1e-3);
  for (double t = -recording.max_offset_s; t <= recording.max_offset_s; t += step) grid.push_back(t);
  std::vector<double> starts = {BestOnGrid(recording, start, kTimeOffset, grid)};
  for (int shift : {-1, 1}) starts.push_back(start.beta[kTimeOffset] + shift * period);
  for (double offset : starts) {
    if (!(std::abs(offset) <= recording.max_offset_s) || std::abs(offset - start.beta[kTimeOffset]) < step / 2)
      continue;
    Model from = start;
    from.beta[kTimeOffset] = offset;
    Fit f = FitModel(recording, from, free, tested);
    // Another basin only when it fits better by more than the solve's own convergence: the same
    // minimum reached from elsewhere must not change the digits.
    constexpr double kBetterBasin = 0.01;  // chi-square, in the baseline's noise scale
    if (f.chi2_fit < best.chi2_fit - kBetterBasin) best = std::move(f);
  }
  return best;
}

double BestOnGrid(const Recording& recording, const Model& m, int beta, const std::vector<double>& grid) {
  double best = grid.front(), best_chi2 = 1e300;
  for (double v : grid) {
    Model trial = m;
    trial.beta[beta] = v;
    double chi2 = 0;
    for (const Interval& it : recording.intervals)
      if (it.fitted()) chi2 += Chi2Of(it, trial);
    if (chi2 < best_chi2) best_chi2 = chi2, best = v;
  }
  return best;
}

void Gate(const std::vector<Model>& models, Recording* recording) {
  std::vector<Interval>& intervals = recording->intervals;
  for (Interval& it : intervals) it.outlier = true;
  auto robust_scale2 = [&](const Model& m) {
    std::vector<double> chi2;
    for (const Interval& it : intervals)
      if (!it.heldout) chi2.push_back(Chi2Of(it, m));
    return RobustScale2(std::move(chi2));
  };
  const double chosen2 = robust_scale2(models.back());
  for (const Model& m : models) {
    // A model that leaves out what the chosen one explains has residuals, and so a robust scale,
    // inflated by it: at its own scale it would excuse failed matches the chosen model puts at
    // hundreds of times the noise, and those would pull the chosen model's estimates. No model's
    // scale exceeds the chosen one's.
    const double scale2 = std::min(robust_scale2(m), chosen2);
    for (Interval& it : intervals) it.outlier = it.outlier && IsOutlier(Chi2Of(it, m), scale2, kOutlierChi2);
  }
}

double RelativeScale(const Fit& model, const Fit& baseline) {
  return (model.chi2_fit / model.dof) / (baseline.chi2_fit / baseline.dof);
}

double DeltaBicAt(const Fit& reference, const Fit& f0, double chi2_with, double chi2_without, std::size_t params,
                  double log_n) {
  const double scale = RelativeScale(reference, f0);
  return DeltaBic(chi2_with / scale, chi2_without / scale, params, log_n);
}

double HeldoutGain(const Fit& before, const Fit& after) {
  return before.chi2_heldout > 0 ? (before.chi2_heldout - after.chi2_heldout) / before.chi2_heldout : 0.0;
}

double Correlation(const Eigen::MatrixXd& cov, int a, int b) {
  return cov(a, b) / std::sqrt(std::max(cov(a, a) * cov(b, b), 1e-300));
}

Eigen::Vector3d ErrorOf(const Interval& it, const Model& m) { return it.cost->ErrorAt(m.params, m.mount, m.beta); }

void Residual(const Interval& it, const Model& m, double r[3], Jacobians* jac, const std::vector<int>& betas) {
  const IntervalFunction function(it.cost.get(), &betas);
  const double* blocks[3] = {m.params, m.mount, m.beta};
  if (jac == nullptr) {
    function.Evaluate(blocks, r, nullptr);
    return;
  }
  double* jacobians[3] = {jac->params.data(), jac->mount.data(), jac->beta.data()};
  function.Evaluate(blocks, r, jacobians);
}

double Chi2Of(const Interval& it, const Model& m) {
  const std::vector<int> none;
  const IntervalFunction function(it.cost.get(), &none);
  const double* blocks[3] = {m.params, m.mount, m.beta};
  return Chi2At(function, blocks);
}

}  // namespace calib::diag
