// Where on the floor (docs/mismatch.md, "Effects confined to a region"): an effect that acts only
// in one area of the floor (a wet patch, a ramp, a floor joint) can be too weak over the whole
// recording to pass its test. It is tested again over boxes of the route in the odometry frame:
// linearised at the current model, its term restricted to the intervals that start inside the
// box, the calibration's parameters projected out, an autocorrelation-robust Wald statistic on
// the fit blocks. The box with the largest statistic is chosen; its p-value is multiplied by the
// number of boxes tried (Bonferroni), and the effect must then show with the same sign on the
// held-out intervals inside the box (one-sided score test at 5 %). TestRegions also requires the
// effect at its fitted size to lower the held-out errors inside the region.

#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Cholesky>

#include "calib/calibrate/recalibration.h"
#include "calib/core/statistics.h"
#include "calib/core/units.h"
#include "diagnose/diagnose_internal.h"
#include "diagnose/diagnose_region.h"

namespace calib::diag {
namespace {

constexpr int kMinInside = 10;      // fit intervals inside a box that carry the effect's term
constexpr int kMinHeldout = 5;      // held-out intervals inside the chosen box that carry it
constexpr double kHeldoutZ = 1.645;  // one-sided 5 %

// Newey-West variance of a series of scores (Bartlett weights over `lags` neighbours).
double NeweyWest(const std::vector<double>& e, int lags) {
  double v = 0;
  for (std::size_t k = 0; k < e.size(); ++k) {
    v += e[k] * e[k];
    for (int l = 1; l <= lags && l <= int(k); ++l) v += 2.0 * (1.0 - double(l) / (lags + 1)) * e[k] * e[k - l];
  }
  return v;
}

// The intervals' per-interval sums, on a grid of cells over their positions.
struct Grid {
  double x0 = 0, y0 = 0, cell = 1;
  int nx = 1, ny = 1;
  std::vector<int> cx, cy;       // per interval
  std::vector<double> c, q;      // g'r, g'g per interval (whitened)
  double q_floor = 0;            // below: the interval does not carry the effect's term
  bool Within(const std::array<int, 4>& b, std::size_t k) const {
    return cx[k] >= b[0] && cx[k] <= b[1] && cy[k] >= b[2] && cy[k] <= b[3];
  }
  std::array<double, 4> Box(const std::array<int, 4>& b) const {
    return {x0 + b[0] * cell, y0 + b[2] * cell, x0 + (b[1] + 1) * cell, y0 + (b[3] + 1) * cell};
  }
};

// Cells a side at most: every box of whole cells is tried, their number grows with the fourth
// power of the side, each over all intervals (a 10-minute differential recording's route of
// tens of metres in 1 m cells took minutes), so a long route gets coarser cells.
constexpr double kMaxCellsPerSide = 16;

Grid MakeGrid(const std::vector<RegionInterval>& intervals, double cell_m) {
  Grid g;
  double x1 = -INFINITY, y1 = -INFINITY;
  g.x0 = g.y0 = INFINITY;
  for (const RegionInterval& it : intervals)
    g.x0 = std::min(g.x0, it.x), g.y0 = std::min(g.y0, it.y), x1 = std::max(x1, it.x), y1 = std::max(y1, it.y);
  cell_m = std::max(cell_m, std::max(x1 - g.x0, y1 - g.y0) / kMaxCellsPerSide);
  g.cell = cell_m;
  g.nx = std::max(1, int(std::ceil((x1 - g.x0) / cell_m + 1e-9)));
  g.ny = std::max(1, int(std::ceil((y1 - g.y0) / cell_m + 1e-9)));
  double q_max = 0;
  for (const RegionInterval& it : intervals) {
    g.cx.push_back(std::clamp(int((it.x - g.x0) / cell_m), 0, g.nx - 1));
    g.cy.push_back(std::clamp(int((it.y - g.y0) / cell_m), 0, g.ny - 1));
    g.c.push_back(it.g.dot(it.r)), g.q.push_back(it.g.squaredNorm());
    q_max = std::max(q_max, g.q.back());
  }
  g.q_floor = 1e-12 * (q_max + 1e-300);
  return g;
}

struct Tried {
  std::array<int, 4> cells;  // i0, i1, j0, j1
  double beta = 0, std = 0, wald = 0;
};

// Every box of whole cells, tested on the fit blocks: the effect's term inside it, the
// calibration projected out, scores at the fitted effect (the residual left after it, so that
// its own signal does not count as scatter) for the Newey-West variance.
std::vector<Tried> ScanBoxes(const std::vector<RegionInterval>& intervals, const Grid& grid, int hac_lags) {
  std::vector<std::size_t> fit;
  for (std::size_t k = 0; k < intervals.size(); ++k)
    if (!intervals[k].heldout) fit.push_back(k);
  std::vector<Tried> tried;
  if (fit.empty()) return tried;
  const int p = int(intervals[fit[0]].A.cols());
  Eigen::MatrixXd AtA = Eigen::MatrixXd::Zero(p, p);
  std::vector<Eigen::VectorXd> u, v;
  std::vector<Eigen::MatrixXd> P;
  Eigen::VectorXd v_sum = Eigen::VectorXd::Zero(p);  // ~0: the model was fitted on these intervals
  for (std::size_t k : fit) {
    const RegionInterval& it = intervals[k];
    P.push_back(it.A.transpose() * it.A), u.push_back(it.A.transpose() * it.g), v.push_back(it.A.transpose() * it.r);
    AtA += P.back(), v_sum += v.back();
  }
  const Eigen::MatrixXd AtA_inv = AtA.ldlt().solve(Eigen::MatrixXd::Identity(p, p));
  std::vector<double> e(fit.size());
  for (int i0 = 0; i0 < grid.nx; ++i0)
    for (int i1 = i0; i1 < grid.nx; ++i1)
      for (int j0 = 0; j0 < grid.ny; ++j0)
        for (int j1 = j0; j1 < grid.ny; ++j1) {
          const std::array<int, 4> b{i0, i1, j0, j1};
          Tried t{b};
          double S = 0, zz = 0;
          int inside = 0;
          Eigen::VectorXd Az = Eigen::VectorXd::Zero(p);
          for (std::size_t j = 0; j < fit.size(); ++j) {
            if (!grid.Within(b, fit[j])) continue;
            S += grid.c[fit[j]], zz += grid.q[fit[j]], Az += u[j];
            inside += grid.q[fit[j]] > grid.q_floor;
          }
          const Eigen::VectorXd w = AtA_inv * Az;
          const double info = zz - Az.dot(w);
          if (inside >= kMinInside && info > 0) {
            t.beta = -(S - w.dot(v_sum)) / info;
            for (std::size_t j = 0; j < fit.size(); ++j) {
              const bool in = grid.Within(b, fit[j]);
              e[j] = (in ? grid.c[fit[j]] : 0.0) - w.dot(v[j]) +
                     t.beta * ((in ? grid.q[fit[j]] - 2.0 * w.dot(u[j]) : 0.0) + w.dot(P[j] * w));
            }
            const double var = NeweyWest(e, hac_lags) / (info * info);
            t.std = std::sqrt(var), t.wald = var > 0 ? t.beta * t.beta / var : 0.0;
          }
          tried.push_back(t);
        }
  return tried;
}

// The effect's own estimate over the intervals `in` selects (time order kept; the calibration
// fixed), and its Newey-West variance at that estimate; false when nothing carries its term.
bool Estimate(const Grid& grid, const std::function<bool(std::size_t)>& in, int hac_lags, double* beta, double* var,
              double* information) {
  double S = 0, I = 0;
  int carrying = 0;
  for (std::size_t k = 0; k < grid.c.size(); ++k)
    if (in(k)) S += grid.c[k], I += grid.q[k], carrying += grid.q[k] > grid.q_floor;
  if (carrying == 0 || !(I > 0)) return false;
  *beta = -S / I, *information = I;
  std::vector<double> e;
  for (std::size_t k = 0; k < grid.c.size(); ++k)
    if (in(k)) e.push_back(grid.c[k] + *beta * grid.q[k]);
  *var = NeweyWest(e, hac_lags) / (I * I);
  return carrying >= kMinHeldout;
}

// The largest box around `best` whose other intervals (fit and held-out) agree with it: their
// own estimate within 2 sigma of the box's, or nothing to estimate from. Cells the route crosses
// without exciting the effect neither support nor contradict it, so the region extends over
// them up to where the data contradict it (and no further than the route).
std::array<int, 4> Grow(const Grid& grid, const std::vector<Tried>& tried, const Tried& best, int hac_lags) {
  std::array<int, 4> chosen = best.cells;
  int area = -1;
  const std::array<int, 4>& a = best.cells;
  for (const Tried& t : tried) {
    const std::array<int, 4>& b = t.cells;
    if (b[0] > a[0] || b[1] < a[1] || b[2] > a[2] || b[3] < a[3]) continue;
    const int box_area = (b[1] - b[0] + 1) * (b[3] - b[2] + 1);
    if (box_area <= area) continue;
    double beta = 0, var = 0, info = 0;
    const bool estimated = Estimate(
        grid, [&](std::size_t k) { return grid.Within(b, k) && !grid.Within(a, k); }, hac_lags, &beta, &var, &info);
    if (!estimated || std::abs(beta - best.beta) <= 2.0 * std::sqrt(var + best.std * best.std))
      area = box_area, chosen = b;
  }
  return chosen;
}

}  // namespace

RegionTest BestRegion(const std::vector<RegionInterval>& intervals, int hac_lags, double cell_m, int sign) {
  RegionTest out;
  if (intervals.empty()) return out;
  const Grid grid = MakeGrid(intervals, cell_m);
  const std::vector<Tried> tried = ScanBoxes(intervals, grid, hac_lags);
  out.boxes = int(tried.size());
  const Tried* best = nullptr;
  for (const Tried& t : tried)
    if (t.beta * sign >= 0 && (!best || t.wald > best->wald)) best = &t;
  if (!best || !(best->wald > 0)) return out;
  out.beta = best->beta, out.std = best->std, out.wald = best->wald;
  out.p = ChiSquareUpperTail(out.wald, 1);
  out.p_adjusted = std::min(1.0, out.p * out.boxes);
  // Held-out intervals inside the most significant box: the effect's own estimate there, one
  // sided in the fitted direction.
  double beta = 0, var = 0, info = 0;
  if (Estimate(grid, [&](std::size_t k) { return intervals[k].heldout && grid.Within(best->cells, k); }, hac_lags,
               &beta, &var, &info) &&
      var > 0) {
    out.heldout_beta = beta;
    out.heldout_z = (out.beta > 0 ? beta : -beta) / std::sqrt(var);
    // A real effect has one size: the held-out estimate must also agree with the fit blocks'
    // (a place where the scan matcher errs shows as different "slips" in the two halves).
    const bool agrees = std::abs(beta - out.beta) <= 2.0 * std::sqrt(var + out.std * out.std);
    out.heldout_confirmed = out.heldout_z > kHeldoutZ && agrees;
  }
  const std::array<int, 4> region = Grow(grid, tried, *best, hac_lags);
  out.box = grid.Box(region);
  for (std::size_t k = 0; k < intervals.size(); ++k) out.inside.push_back(grid.Within(region, k));
  return out;
}

namespace {

constexpr double kHeldoutP = 0.05;       // one-sided level of a region effect's held-out improvement
constexpr double kMinRegionGain = 0.05;  // and its practical floor (as the actuation layer's kMinGain)

}  // namespace

// Effects of the floor (longitudinal and lateral slip) that the whole recording did not show,
// tested over boxes of the route in the odometry frame (diagnose_region.cc): the box most
// significant on the fit blocks, Bonferroni over the boxes and the catalogue's share, confirmed
// on the held-out intervals inside it. Linearised at the current model; reported with its box.
void TestRegions(const Recording& recording, const std::vector<Candidate>& cands, const Fit& current,
                 const SelectionLevels& levels, DiagnoseReport* report) {
  const std::vector<Interval>& intervals = recording.intervals;
  std::vector<int> active;  // the calibration's free parameters
  for (int i = 0; i < recording.num_params; ++i)
    if (std::find(recording.held_params.begin(), recording.held_params.end(), i) == recording.held_params.end()) active.push_back(i);
  const double s = std::sqrt(recording.noise_scale2);
  for (CandidateOutcome& o : report->candidates) {
    if (o.status == CandidateStatus::kFound || (o.name != "longitudinal_slip" && o.name != "lateral_slip")) continue;
    const auto c = std::find_if(cands.begin(), cands.end(), [&](const Candidate& k) { return k.name == o.name; });
    if (c == cands.end()) continue;
    const int b = c->beta[0];
    std::vector<RegionInterval> in;
    std::vector<std::size_t> index;  // into intervals and report->intervals
    // Outliers too: a patch's slip is many sigma per interval, and the gate at the whole
    // recording's scale sets exactly those intervals aside; a failed match stays harmless
    // (alone in a box its own scatter is its variance, so its Wald statistic stays near 1).
    for (std::size_t k = 0; k < intervals.size(); ++k) {
      const Interval& it = intervals[k];
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
    const RegionTest t = BestRegion(in, recording.hac_lags, 1.0, +1);
    const double share = levels.alpha / std::max(1, levels.candidates);
    // The held-out residual inside the region, in the effect's component, without and with it.
    const int comp = o.name == "lateral_slip" ? 1 : 0;
    std::vector<TimeSpan> spans;
    std::vector<double> rb, ra, abs_b, abs_a;
    Model with = current.m;
    with.beta[b] += t.beta;
    for (std::size_t j = 0; j < t.inside.size(); ++j) {
      if (!t.inside[j] || in[j].g.squaredNorm() == 0) continue;
      const Interval& it = intervals[index[j]];
      spans.push_back({it.motion->utime_start, it.motion->utime_end});
      if (!it.heldout) continue;
      rb.push_back(ErrorOf(it, current.m)[comp]);
      ra.push_back(ErrorOf(it, with)[comp]);
      abs_b.push_back(std::abs(rb.back())), abs_a.push_back(std::abs(ra.back()));
    }
    // The region's effect at the size the fit blocks give must make the held-out intervals
    // inside it fit better: their errors lower (paired one-sided test, 5 %) and by at least the
    // practical floor of a held-out gain (kMinRegionGain). Its held-out estimate can be
    // significant without that: the route crosses the same places in the fit and the held-out
    // blocks, so what the model of a large effect found elsewhere leaves there (a backlash's, a
    // time offset's) repeats in both; and over many intervals, each a little lower, a tiny gain
    // passes the paired test alone (docs/mismatch.md, "Effects confined to a region").
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

}  // namespace calib::diag
