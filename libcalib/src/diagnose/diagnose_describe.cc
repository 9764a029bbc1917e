// What the diagnosis's report says of the model (diagnose_describe.h).

#include "diagnose/diagnose_describe.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

#include "calib/core/kinematics_generic.h"
#include "calib/calibrate/recalibration.h"
#include "calib/core/statistics.h"
#include "diagnose/diagnose_heldout.h"
#include "diagnose/diagnose_internal.h"

namespace calib::diag {

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

namespace {

// Motion conditions per interval from the encoders and the baseline model.
void Conditions(const Recording& recording, const Model& baseline, DiagnoseReport* report) {
  const Track& tr = recording.track;
  const std::size_t n = tr.size();
  std::vector<double> vx(n), om(n), xs(n), ys(n), route(n);
  double x = 0, y = 0, th = 0, dist = 0;
  for (std::size_t i = 0; i < n; ++i) {
    double rates[2] = {tr.speed[i][0], tr.speed[i][1]}, steer[2] = {tr.steer(i, 0), tr.steer(i, 1)};
    double vy = 0;
    generic::BodyDisplacement(tr.drive, baseline.params, rates, steer, &vx[i], &vy, &om[i]);
    if (i > 0) {
      const double dt = (tr.utime(i) - tr.utime(i - 1)) * 1e-6;
      x += std::cos(th) * vx[i - 1] * dt;
      y += std::sin(th) * vx[i - 1] * dt;
      th += om[i - 1] * dt;
      dist += std::abs(vx[i - 1]) * dt;
    }
    xs[i] = x, ys[i] = y, route[i] = dist;
  }
  const int steer_param = tr.drive == DriveType::kTricycle ? 2 : tr.drive == DriveType::kDualSteer ? 1 : -1;
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
      c.steer = 0.5 * (tr.steer(a, 0) + tr.steer(b, 0)) - baseline.params[steer_param];
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
double Regressor(const Recording& recording, const std::string& name, const DiagnosedInterval& d, const Interval& it) {
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
    const std::size_t mid = (it.cost->first() + it.cost->last()) / 2;
    return std::fmod(std::fmod(recording.track.pos(mid, w), 2 * M_PI) + 2 * M_PI, 2 * M_PI);
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

FoundEffect Describe(const Recording& recording, const Candidate& c, const Fit& final_fit, const Fit& without,
                     const DiagnoseReport& report) {
  const std::vector<Interval>& intervals = recording.intervals;
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
  const Localized loc = Localize(recording, c, final_fit.m, without.m);
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
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    const Interval& it = intervals[k];
    if (it.outlier) continue;
    if (loc.flagged[k]) flagged_spans.push_back({it.motion->utime_start, it.motion->utime_end});
    x.push_back(Regressor(recording, reg, report.intervals[k], it));
    sb.push_back(ErrorOf(it, without.m)[sig]);
    sa.push_back(ErrorOf(it, final_fit.m)[sig]);
  }
  fe.where = MergeSpans(flagged_spans, 2000000);
  fe.heldout_rms_before = loc.rms_before;
  fe.heldout_rms_after = loc.rms_after;
  fe.heldout_rms_all_before = loc.rms_all_before;
  fe.heldout_rms_all_after = loc.rms_all_after;
  const OdometryError drift_before = HeldoutDrift(recording, without.m), drift_after = HeldoutDrift(recording, final_fit.m);
  const bool heading = comp == 2;
  fe.drift_component = heading ? "heading" : "translation";
  fe.drift_window_s = recording.drift_window_s;
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
  fe.stretches = HeldoutStretches(recording, c, final_fit.m, without.m, comp);
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
    fe.heldout_confirmed_by = ScoreConfirmed(recording, without, final_fit)                  ? "score"
                              : DriftConfirmed(recording, without, final_fit, heading) ? "drift"
                                                                                : "";
  }
  fe.signature = Signature(x, sb, sa);
  std::vector<DiagnosedInterval> kept;
  std::vector<bool> kept_flag;
  for (std::size_t k = 0; k < intervals.size(); ++k)
    if (!intervals[k].outlier) kept.push_back(report.intervals[k]), kept_flag.push_back(loc.flagged[k]);
  fe.regime = Regime(kept, kept_flag);
  return fe;
}

}  // namespace

// Residual structure left after the final model that catalogued effects do not
// explain: a held-out residual component trending with where or how the robot drove.
void FindUnexplained(const Recording& recording, double alpha, DiagnoseReport* report) {
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
  const double s = std::sqrt(recording.noise_scale2);
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
        for (int l = 1; l <= recording.hac_lags && l <= int(k); ++l)
          v += 2.0 * (1.0 - double(l) / (recording.hac_lags + 1)) * u[k] * u[k - l];
      }
      if (v <= 0) continue;
      const double t = sze / std::sqrt(v);
      const double p = std::erfc(std::abs(t) / std::sqrt(2.0));
      if (p * m >= alpha) continue;
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

void DescribeOutliers(DiagnoseReport* report) {
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

void DescribeModel(const Recording& recording, const Fit& f0, const Fit& current, DiagnoseReport* report) {
  const std::vector<Interval>& intervals = recording.intervals;
  report->intervals.resize(intervals.size());
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    const Interval& it = intervals[k];
    DiagnosedInterval& d = report->intervals[k];
    d.utime_start = it.motion->utime_start;
    d.utime_end = it.motion->utime_end;
    d.heldout = it.heldout;
    d.outlier = it.outlier;
    d.before = ErrorOf(it, f0.m);
    d.after = ErrorOf(it, current.m);
    d.sigma = it.sigma * std::sqrt(recording.noise_scale2);
  }
  Conditions(recording, f0.m, report);
  std::vector<double> hb[3], ha[3];
  for (const DiagnosedInterval& d : report->intervals) {
    if (!d.heldout || d.outlier) continue;
    for (int c = 0; c < 3; ++c) hb[c].push_back(d.before[c]), ha[c].push_back(d.after[c]);
  }
  for (int c = 0; c < 3; ++c) report->heldout_rms_before[c] = Rms(hb[c]), report->heldout_rms_after[c] = Rms(ha[c]);
  report->heldout_chi2_before = f0.chi2_heldout / std::max(1, f0.n_heldout);
  report->heldout_chi2_after = current.chi2_heldout / std::max(1, current.n_heldout);
  report->heldout_drift_before = HeldoutDrift(recording, f0.m);
  report->heldout_drift_after = HeldoutDrift(recording, current.m);
}

void ReportFound(const Recording& recording, const std::vector<Candidate>& cands, const Selection& selection,
                 const SelectionLevels& levels, const Fit& f0, const Fit& current, double log_n,
                 DiagnoseReport* report) {
  const int m_odo = levels.candidates, m_act = levels.actuation_candidates;
  for (std::size_t n = 0; n < selection.chosen.size(); ++n) {
    const Candidate& c = cands[selection.chosen[n]];
    std::vector<int> free;
    const Fit without = FitWithout(recording, current, c.beta, &free);
    FoundEffect fe = Describe(recording, c, current, without, *report);
    fe.wald = selection.wald[n];
    fe.p_value = selection.p[n];
    fe.p_adjusted = std::min(1.0, selection.p[n] * double(m_odo - n) * double(m_odo + m_act) / m_odo);
    fe.delta_bic = DeltaBicAt(without, f0, current.chi2_fit, without.chi2_fit, c.beta.size(), log_n);
    if (c.beta[0] == kTimeOffset && std::abs(current.m.beta[kTimeOffset]) > 0.95 * recording.max_offset_s)
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

void ReportCalibration(const Recording& recording, MotionSource source, const Fit& f0, const Fit& current,
                       const CalibrationResult& cal, DiagnoseReport* report) {
  for (int i = 0; i < recording.num_params; ++i) {
    report->calibration[report->param_names[i]] = {f0.m.params[i], cal.params.at(report->param_names[i]).std};
    report->refitted[report->param_names[i]] = {current.m.params[i], cal.params.at(report->param_names[i]).std};
  }
  const std::string mount = MotionSourceName(source);
  const char* axes[3] = {".x", ".y", ".yaw"};
  const Estimate* mstd[3] = {&cal.mount_x, &cal.mount_y, &cal.mount_yaw};
  for (int i = 0; i < 3; ++i) {
    report->calibration[mount + axes[i]] = {f0.m.mount[i], mstd[i]->std};
    report->refitted[mount + axes[i]] = {current.m.mount[i], mstd[i]->std};
  }
}

}  // namespace calib::diag
