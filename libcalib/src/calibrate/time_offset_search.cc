#include "calib/calibrate/time_offset_search.h"

#include <algorithm>
#include <cmath>

#include "calib/calibrate/interval_model.h"
#include "calib/core/kinematics_generic.h"

namespace calib {
namespace {

// Cumulative heading and path length of the wheel odometry at each encoder sample.
struct Cumulative {
  std::vector<double> t, heading, path;  // s from the first sample, rad, m

  // Linear interpolation of `v` at time t (clamped).
  double At(const std::vector<double>& v, double time) const {
    if (time <= t.front()) return v.front();
    if (time >= t.back()) return v.back();
    const std::size_t i = std::upper_bound(t.begin(), t.end(), time) - t.begin() - 1;
    const double f = (time - t[i]) / std::max(t[i + 1] - t[i], 1e-12);
    return v[i] + f * (v[i + 1] - v[i]);
  }
};

Cumulative Integrate(const EncoderTrack& track, const double* params) {
  Cumulative c;
  const std::size_t n = track.size();
  c.t.resize(n), c.heading.assign(n, 0.0), c.path.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    c.t[i] = (track.utime(i) - track.utime(0)) * 1e-6;
    if (i == 0) continue;
    double rotation[2], steer[2];
    for (int w = 0; w < 2; ++w) {
      rotation[w] = track.pos(i, w) - track.pos(i - 1, w);  // 0 for a wheel the drive lacks
      steer[w] = 0.5 * (track.steer(i, w) + track.steer(i - 1, w));
    }
    double dx = 0, dy = 0, dtheta = 0;
    generic::BodyDisplacement(track.drive, params, rotation, steer, &dx, &dy, &dtheta);
    c.heading[i] = c.heading[i - 1] + dtheta;
    c.path[i] = c.path[i - 1] + std::hypot(dx, dy);
  }
  return c;
}

struct Observed {
  double t0, t1;          // s from the first encoder sample
  double turn, distance;  // measured
  double sigma_turn, sigma_distance;
};

// The residuals of the turn and of the distance at offset d, in units of the matches' sigmas.
void Residuals(const Cumulative& c, const std::vector<Observed>& obs, double d, std::vector<double>* turn,
               std::vector<double>* dist) {
  turn->clear(), dist->clear();
  for (const Observed& o : obs) {
    turn->push_back((o.turn - (c.At(c.heading, o.t1 - d) - c.At(c.heading, o.t0 - d))) / o.sigma_turn);
    dist->push_back((o.distance - (c.At(c.path, o.t1 - d) - c.At(c.path, o.t0 - d))) / o.sigma_distance);
  }
}

// Squared robust scale of residuals: their median square over 0.455 (the median of a chi-square
// with one degree of freedom), at least 1e-12.
double Scale2(std::vector<double> r) {
  for (double& x : r) x *= x;
  std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
  return std::max(r[r.size() / 2] / 0.455, 1e-12);
}

// The Cauchy cost sum log(1 + r^2 / (2 s)^2) of both components at offset d, each at its own
// fixed scale s: every interval counts (a residual many sigma large still raises the cost, with
// bounded influence), so the turn starts and stops that carry the offset are never trimmed away
// as outliers, and neither component's weight rests on the matcher's covariances.
double Cost(const Cumulative& c, const std::vector<Observed>& obs, double d, const double scale2[2],
            std::vector<double>* turn, std::vector<double>* dist) {
  Residuals(c, obs, d, turn, dist);
  double sum = 0;
  for (std::size_t k = 0; k < turn->size(); ++k)
    sum += std::log1p((*turn)[k] * (*turn)[k] / (4 * scale2[0])) + std::log1p((*dist)[k] * (*dist)[k] / (4 * scale2[1]));
  return sum / double(turn->size());
}

}  // namespace

TimeOffsetSearch SearchTimeOffset(DriveType drive, const double* params, const WheelTrack& wheels,
                                  const std::vector<SensorMotion>& motions, double max_offset_s) {
  TimeOffsetSearch out;
  if (wheels.size() < 2) return out;
  const EncoderTrack track(drive, wheels);
  const Cumulative c = Integrate(track, params);
  std::vector<Observed> obs;
  for (const SensorMotion& m : motions) {
    if (!m.valid || m.degenerate || m.utime_end <= m.utime_start) continue;
    Observed o;
    // Every match counts, also where the wheel data end before the offset's reach (Cumulative::At
    // holds their ends there): a set that depended on the range searched would not move with the
    // offset, and the minimum would depend on where the offset lies in the range.
    o.t0 = (m.utime_start - track.utime(0)) * 1e-6;
    o.t1 = (m.utime_end - track.utime(0)) * 1e-6;
    o.turn = m.delta.theta;
    o.distance = std::hypot(m.delta.x, m.delta.y);
    // The match's sigmas, with floors so one overconfident match cannot dominate.
    o.sigma_turn = std::max(std::sqrt(std::max(m.covariance(2, 2), 0.0)), 1e-4);
    o.sigma_distance = std::max(std::sqrt(std::max(0.5 * (m.covariance(0, 0) + m.covariance(1, 1)), 0.0)), 1e-4);
    obs.push_back(o);
  }
  out.intervals = static_cast<int>(obs.size());
  if (obs.size() < 10) return out;
  std::vector<double> turn, dist;
  double scale2[2];
  auto rescale = [&](double d) {
    Residuals(c, obs, d, &turn, &dist);
    scale2[0] = Scale2(turn), scale2[1] = Scale2(dist);
  };
  auto best_on_grid = [&](double from, double to, double step) {
    double best = from, best_cost = Cost(c, obs, from, scale2, &turn, &dist);
    for (double d = from + step; d <= to + 1e-12; d += step) {
      const double cost = Cost(c, obs, d, scale2, &turn, &dist);
      if (cost < best_cost) best_cost = cost, best = d;
    }
    return std::make_pair(best, best_cost);
  };
  // The scales first from the offset on the grid where they are smallest (the least median of
  // squares: a large offset inflates them at 0), then again from the first pass's best offset.
  double least = 0.0, least_product = INFINITY;
  for (double d = -max_offset_s; d <= max_offset_s + 1e-12; d += 1e-3) {
    Residuals(c, obs, d, &turn, &dist);
    const double product = Scale2(turn) * Scale2(dist);
    if (product < least_product) least_product = product, least = d;
  }
  rescale(least);
  double best = best_on_grid(-max_offset_s, max_offset_s, 1e-3).first;
  rescale(best);
  best = best_on_grid(-max_offset_s, max_offset_s, 1e-3).first;
  const auto fine = best_on_grid(std::max(-max_offset_s, best - 2e-3), std::min(max_offset_s, best + 2e-3), 5e-5);
  out.offset_s = fine.first;
  out.cost = fine.second;
  out.cost_at_zero = Cost(c, obs, 0.0, scale2, &turn, &dist);
  return out;
}

}  // namespace calib
