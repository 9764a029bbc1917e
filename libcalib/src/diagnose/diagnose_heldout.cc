// The held-out proofs of the diagnosis (diagnose_heldout.h).

#include "diagnose/diagnose_heldout.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "calib/calibrate/recalibration.h"
#include "calib/core/statistics.h"
#include "diagnose/diagnose_internal.h"

namespace calib::diag {
namespace {

constexpr double kHeldoutZ = 1.645;  // one-sided 5 % on the held-out blocks
constexpr double kDriftP = 0.01;     // one-sided level of the held-out drift confirmation

}  // namespace

// Where the effect's contribution stands out (exceeds the noise; at least 10 held-out
// intervals), in the component it shows most, and the held-out residual there without
// and with it.
Localized Localize(const Recording& recording, const Candidate& c, const Model& with, const Model& without) {
  const std::vector<Interval>& intervals = recording.intervals;
  Localized out;
  Model zeroed = with;
  for (int b : c.beta) zeroed.beta[b] = 0.0;
  const double s = std::sqrt(recording.noise_scale2);
  std::vector<Eigen::Vector3d> contribution(intervals.size(), Eigen::Vector3d::Zero());
  Eigen::Vector3d weight = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    if (intervals[k].outlier) continue;
    contribution[k] = ErrorOf(intervals[k], zeroed) - ErrorOf(intervals[k], with);
    weight += contribution[k].cwiseQuotient(intervals[k].sigma * s).cwiseAbs2();
  }
  weight.maxCoeff(&out.comp);
  std::vector<double> ratio(intervals.size(), 0.0);
  for (std::size_t k = 0; k < intervals.size(); ++k)
    if (!intervals[k].outlier) ratio[k] = std::abs(contribution[k][out.comp]) / (intervals[k].sigma[out.comp] * s);
  // Intervals by the size of the effect's contribution: all where it exceeds the noise,
  // then more until they hold enough held-out intervals to judge the fit there.
  constexpr int kMinHeldout = 10;
  std::vector<std::size_t> order(intervals.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return ratio[x] > ratio[y]; });
  double threshold = 0;
  int heldout = 0;
  for (std::size_t k : order) {
    if (ratio[k] <= 0 || (ratio[k] < 1.0 && heldout >= kMinHeldout)) break;
    threshold = ratio[k];
    heldout += intervals[k].heldout;
  }
  out.flagged.assign(intervals.size(), false);
  std::vector<double> in_before, in_after, all_before, all_after;
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    const Interval& it = intervals[k];
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
OdometryError HeldoutDrift(const Recording& recording, const Model& m) {
  const std::vector<Interval>& intervals = recording.intervals;
  std::vector<OdometryStep> steps;
  for (const Interval& it : intervals) {
    if (!it.heldout || it.outlier) continue;
    const Eigen::Vector3d e = ErrorOf(it, m);
    steps.push_back({it.motion->utime_start, it.motion->utime_end, it.motion->delta, {e[0], e[1], e[2]}});
  }
  return OdometryErrorOverWindows(steps, recording.drift_window_s, false);
}

// The effect over stretches of held-out motion: in each run of consecutive held-out intervals
// (a held-out block, cut where an outlier breaks the chain) the stretch over which the effect
// changes the chained motion most in `comp`, chosen from the two models' predictions alone,
// never from the measurement. An effect whose error telescopes along a chain (a time offset:
// offset x the change of speed or turn rate; a longitudinal slip: k (v1^2 - v0^2) / 2) is
// small per interval against the scan matcher's noise; from its low to its high point it is as
// large as the block allows, while the registration error stays that of the stretch's two end
// scans. A wrong effect fares worse here, not better: the stretch is where it predicts most.
std::vector<HeldoutStretch> HeldoutStretches(const Recording& recording, const Candidate& c, const Model& with,
                                             const Model& without, int comp) {
  const std::vector<Interval>& intervals = recording.intervals;
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
  for (const Interval& it : intervals) {
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

// Held-out confirmation: does the effect's predicted contribution (its Jacobian times the
// fitted change) explain the held-out residual left without it? A score test on data the
// fit never saw, one-sided at 5 %, with an autocorrelation-robust variance. The Jacobian
// is the model's (for the time offset: from the smoothed speeds), so encoder noise in
// the residual cannot correlate with it.
bool ScoreConfirmed(const Recording& recording, const Fit& before, const Fit& after) {
  const std::vector<Interval>& intervals = recording.intervals;
  std::vector<int> added;  // the effect terms free after, not before
  for (int b : after.free)
    if (std::find(before.free.begin(), before.free.end(), b) == before.free.end()) added.push_back(b);
  std::vector<double> terms, noise;
  for (const Interval& it : intervals) {
    if (!it.heldout || it.outlier) continue;
    double r[3], ra[3];
    Residual(it, before.m, r);
    Jacobians jac;
    Residual(it, after.m, ra, &jac, added);
    Eigen::Vector3d contribution = Eigen::Vector3d::Zero();  // change of the residual the effect makes
    for (int b : added) contribution -= jac.beta.col(b) * after.m.beta[b];
    terms.push_back(contribution.dot(Eigen::Vector3d(r[0], r[1], r[2])) / recording.noise_scale2);
    noise.push_back(contribution.dot(Eigen::Vector3d(ra[0], ra[1], ra[2])) / recording.noise_scale2);
  }
  const std::size_t n = terms.size();
  if (n < 10) return false;
  // Variance of the score from what is left with the effect (the noise), not from the
  // effect itself: under no effect the two agree.
  double sum = 0, v = 0;
  for (std::size_t k = 0; k < n; ++k) {
    sum += terms[k];
    v += noise[k] * noise[k];
    for (int l = 1; l <= recording.hac_lags && l <= int(k); ++l)
      v += 2.0 * (1.0 - double(l) / (recording.hac_lags + 1)) * noise[k] * noise[k - l];
  }
  return v > 0 && sum / std::sqrt(v) > kHeldoutZ;
}

// Or as dead reckoning: with the effect, the held-out drift is lower window by window (paired
// one-sided t-test, level kDriftP, stricter than the score test's since either confirms). A
// small effect that biases every interval the same way hides in each interval's noise but
// adds up over a window (docs/mismatch.md).
bool DriftConfirmed(const Recording& recording, const Fit& before, const Fit& after, bool heading) {
  const OdometryError b = HeldoutDrift(recording, before.m), a = HeldoutDrift(recording, after.m);
  if (b.windows < 5) return false;
  auto errors = [heading](const OdometryError& e) {
    std::vector<double> out;
    for (const WindowError& w : e.per_window) out.push_back(heading ? std::abs(w.heading_rad) : w.translation_m);
    return out;
  };
  return TestImprovement(errors(b), errors(a), kDriftP, 0.0).significant;
}

bool HeldoutConfirms(const Recording& recording, const Candidate& c, const Fit& before, const Fit& after) {
  return ScoreConfirmed(recording, before, after) || DriftConfirmed(recording, before, after, Localize(recording, c, after.m, before.m).comp == 2);
}

}  // namespace calib::diag
