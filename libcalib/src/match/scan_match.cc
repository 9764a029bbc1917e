#include "calib/match/scan_match.h"

#include "match/deskew_correction.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <utility>

#include <Eigen/Eigenvalues>

#include "calib/core/errors.h"
#include "calib/core/units.h"

namespace calib {

namespace {

constexpr int kAngleBins = 1024;

// A pseudo-angle of (x, y): increases with the polar angle over [-pi, pi), in [-2, 2), without
// atan2 (the index by angle needs the order only; a tenth of atan2's time).
double PseudoAngle(double x, double y) {
  const double sum = std::abs(x) + std::abs(y);
  if (!(sum > 0.0)) return 0.0;
  const double p = y / sum;  // -1 .. 1
  if (x >= 0.0) return p;    // polar angle -pi/2 .. pi/2
  const double a = y >= 0.0 ? 2.0 - p : -2.0 - p;
  return a >= 2.0 ? a - 4.0 : a;
}

// A scan covers a full turn when its beams span 2 pi (within one beam).
bool FullCircle(const LaserScan& scan) {
  return scan.size() > 1 && std::abs(scan.angle_increment) * scan.size() >=
                                2.0 * M_PI - 1.5 * std::abs(scan.angle_increment);
}

ScanPoints EmptyPoints(const LaserScan& scan) {
  ScanPoints out;
  out.utime = scan.utime;
  out.angle_increment = scan.angle_increment;
  out.full_circle = FullCircle(scan);
  out.points.reserve(scan.ranges.size());
  return out;
}

Eigen::Vector2d Apply(const Pose2& pose, const Eigen::Vector2d& p) {
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  return {pose.x + c * p.x() - s * p.y(), pose.y + s * p.x() + c * p.y()};
}

// Variance of a standard normal kept within |e| <= z: what the mean square of
// the kept errors underestimates sigma^2 by.
double TruncatedVarianceFactor(double z) {
  if (!std::isfinite(z)) return 1.0;
  const double inside = std::erf(z / std::sqrt(2.0));
  if (inside <= 1e-6) return 1.0;
  const double pdf = std::exp(-0.5 * z * z) / std::sqrt(2.0 * M_PI);
  return std::max(1.0 - 2.0 * z * pdf / inside, 1e-3);
}

// A current point paired with a reference line (MatchPointsToLines).
struct Pair {
  int index;      // current point
  int line;       // reference line
  double error;   // n · (T q − c)
  double weight;  // 1 / the error's variance in units of the range noise (IncidenceWeight)
};

// A range error moves a point along its beam, so it moves the point-to-line error by its
// projection on the line's normal: the error's variance is sigma² (n · beam)², the reference
// line's share included (its points look along nearly the same beams). The weight is the inverse,
// with (n · beam)² kept at or above `floor` (grazing beams: the line fit and the beam's footprint
// err too).
double IncidenceWeight(const Eigen::Vector2d& normal, const Eigen::Vector2d& moved_q, double range, double floor) {
  if (floor >= 1.0) return 1.0;
  const double cosine = normal.dot(moved_q) / range;
  return 1.0 / std::max(cosine * cosine, floor);
}

// Pairs each current point, moved by x = (x, y, theta) (c, s: cos and sin theta), with the
// nearest reference line within `max_distance`; abs_errors gets each pair's |error|.
void PairPointsWithLines(const PreparedScan& reference, const ScanPoints& current,
                         const Eigen::Vector3d& x, double c, double s, double max_distance,
                         double incidence_floor, std::vector<Pair>* pairs, std::vector<double>* abs_errors) {
  pairs->clear();
  abs_errors->clear();
  const int n = static_cast<int>(current.points.size());
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d& q = current.points[i];
    const Eigen::Vector2d rotated(c * q.x() - s * q.y(), s * q.x() + c * q.y());
    const Eigen::Vector2d p(x[0] + rotated.x(), x[1] + rotated.y());
    const int j = reference.Nearest(p, max_distance);
    if (j < 0) continue;
    const PreparedScan::Line& line = reference.line(j);
    const double e = line.normal.dot(p - line.centroid);
    const double w = IncidenceWeight(line.normal, rotated, q.norm(), incidence_floor);
    pairs->push_back({i, j, e, w});
    abs_errors->push_back(std::abs(e) * std::sqrt(w));
  }
}

// Robust scale of the errors (MAD), then keep the pairs with |e| within
// residual_gate_sigmas of it and up to the (1 - trim) quantile: the threshold on |e|,
// with *keep the most pairs kept and *truncation what the kept errors' mean square
// underestimates the variance by. Reorders abs_errors.
double GateThreshold(std::vector<double>* abs_errors, const ScanMatchOptions& options, int* keep,
                     double* truncation) {
  std::vector<double>& errors = *abs_errors;
  const std::size_t mid = errors.size() / 2;
  std::nth_element(errors.begin(), errors.begin() + mid, errors.end());
  const double robust_sigma = std::max(1.4826 * errors[mid], 1e-9);
  double threshold = options.residual_gate_sigmas > 0
                         ? options.residual_gate_sigmas * robust_sigma
                         : std::numeric_limits<double>::infinity();
  *keep = static_cast<int>(std::ceil((1.0 - options.trim_fraction) * errors.size()));
  if (*keep < static_cast<int>(errors.size()) && *keep > 0) {
    std::nth_element(errors.begin(), errors.begin() + (*keep - 1), errors.end());
    threshold = std::min(threshold, errors[*keep - 1]);
  }
  *truncation = TruncatedVarianceFactor(threshold / robust_sigma);
  return threshold;
}

// Gauss-Newton sums over the kept pairs (the first `keep` with |error| <= threshold).
struct PairSums {
  Eigen::Matrix3d hessian = Eigen::Matrix3d::Zero();
  Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
  double sum_e2 = 0.0;        // weighted squared errors
  double sum_raw_e2 = 0.0;    // squared errors
  double sum_r2 = 0.0;        // squared ranges of the current points
  double sum_support = 0.0;   // points behind the lines
  int kept = 0;
};

// The sums at the pose whose rotation has cosine c and sine s.
PairSums SumPairs(const PreparedScan& reference, const ScanPoints& current,
                  const std::vector<Pair>& pairs, double threshold, int keep, double c, double s) {
  PairSums sums;
  for (const Pair& pair : pairs) {
    if (std::abs(pair.error) * std::sqrt(pair.weight) > threshold || sums.kept >= keep) continue;
    const PreparedScan::Line& line = reference.line(pair.line);
    const Eigen::Vector2d& q = current.points[pair.index];
    // d(T q)/d theta = R(theta + pi/2) q.
    const Eigen::Vector2d dp(-s * q.x() - c * q.y(), c * q.x() - s * q.y());
    const Eigen::Vector3d jacobian(line.normal.x(), line.normal.y(), line.normal.dot(dp));
    sums.hessian.noalias() += pair.weight * jacobian * jacobian.transpose();
    sums.gradient += pair.weight * pair.error * jacobian;
    sums.sum_e2 += pair.weight * pair.error * pair.error;
    sums.sum_raw_e2 += pair.error * pair.error;
    sums.sum_r2 += q.squaredNorm();
    sums.sum_support += line.support;
    ++sums.kept;
  }
  return sums;
}

// The match's covariance from the scaled normal equations' eigen-decomposition (the
// `weak` smallest directions uninformative) and its weakest direction, unscaled.
void SetUncertainty(const Eigen::Vector3d& eigenvalues, const Eigen::Matrix3d& eigenvectors, int weak,
                    double sigma2, double scale, const ScanMatchOptions& options, SensorMotion* result) {
  // Covariance in scaled coordinates, the weak directions uninformative.
  Eigen::Matrix3d scaled_cov = Eigen::Matrix3d::Zero();
  for (int k = 0; k < 3; ++k) {
    const double variance = k < weak ? options.degenerate_sigma_m * options.degenerate_sigma_m
                                     : 2.0 * sigma2 / eigenvalues[k];
    scaled_cov += variance * eigenvectors.col(k) * eigenvectors.col(k).transpose();
  }
  const Eigen::Vector3d unscale(1.0, 1.0, 1.0 / scale);
  result->covariance = unscale.asDiagonal() * scaled_cov * unscale.asDiagonal();
  Eigen::Vector3d direction = unscale.asDiagonal() * eigenvectors.col(0);
  direction.normalize();
  Eigen::Index largest = 0;
  direction.cwiseAbs().maxCoeff(&largest);
  if (direction[largest] < 0) direction = -direction;
  result->weak_direction = direction;
}

}  // namespace

ScanPoints ScanToPoints(const LaserScan& scan) {
  ScanPoints out = EmptyPoints(scan);
  for (int i = 0; i < scan.size(); ++i) {
    if (!scan.HasReturn(i)) continue;
    const double a = scan.BeamAngle(i), r = scan.ranges[i];
    out.points.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return out;
}

Pose2 PredictSensorMotion(const WheelTrack& track, const DriveModel& model, const Pose2& mount,
                          double t0, double t1) {
  return Between(mount, Compose(track.Odometry(model, t0, t1), mount));
}

namespace {

// Encoder readings at the knots, each drive and steering reading smoothed by a
// least-squares quadratic in time over the samples within `smoothing_s` of
// the knots' span (raw, interpolated readings when there are too few).
std::vector<WheelSample> ReadingsAt(const WheelTrack& track, const std::vector<double>& knots,
                                    double smoothing_s) {
  std::vector<WheelSample> out;
  const double margin = smoothing_s * 1e6;
  const double lo = std::max(knots.front() - margin, double(track.first_utime()));
  const double hi = std::min(knots.back() + margin, double(track.last_utime()));
  const std::vector<int64_t>& utime = track.utimes();
  const std::size_t first = std::lower_bound(utime.begin(), utime.end(), lo,
                                             [](int64_t u, double t) { return double(u) < t; }) - utime.begin();
  const std::size_t last = std::upper_bound(utime.begin(), utime.end(), hi,
                                            [](double t, int64_t u) { return t < double(u); }) - utime.begin();
  if (smoothing_s <= 0.0 || last < first + 5) {
    for (double t : knots) out.push_back(track.At(t));
    return out;
  }
  const double centre = 0.5 * (knots.front() + knots.back());
  const std::size_t roles = track.roles();
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(3, 2 * roles);
  for (std::size_t i = first; i != last; ++i) {
    const double tau = (double(utime[i]) - centre) * 1e-6;
    const Eigen::Vector3d basis(1.0, tau, tau * tau);
    normal += basis * basis.transpose();
    for (std::size_t r = 0; r < roles; ++r) {
      // Relative to the first sample: positions are unbounded, keep precision.
      rhs.col(r) += basis * (track.position(i, r) - track.position(first, r));
      rhs.col(roles + r) += basis * track.steer(i, r);
    }
  }
  const Eigen::MatrixXd coefficients = normal.ldlt().solve(rhs);
  for (double t : knots) {
    const double tau = (t - centre) * 1e-6;
    const Eigen::Vector3d basis(1.0, tau, tau * tau);
    WheelSample sample;
    sample.utime = static_cast<int64_t>(std::llround(t));
    for (std::size_t r = 0; r < roles; ++r) {
      sample.position.push_back(track.position(first, r) + basis.dot(coefficients.col(r)));
      sample.steer.push_back(basis.dot(coefficients.col(roles + r)));
    }
    out.push_back(sample);
  }
  return out;
}

}  // namespace

ScanPoints DeskewScan(const LaserScan& scan, const WheelTrack& track, const DriveModel& model,
                      const Pose2& mount, double smoothing_s, const Twist2& correction) {
  if (scan.time_increment <= 0.0 || scan.size() < 2) return ScanToPoints(scan);
  const double t0 = double(scan.utime), t1 = scan.BeamTime(scan.size() - 1);
  if (!track.Covers(t0, t1))
    throw std::invalid_argument("DeskewScan: wheel data do not cover the scan at utime " +
                                std::to_string(scan.utime));
  // Knots: the scan's ends and the encoder samples between them. The sensor
  // moves with a constant twist between knots.
  std::vector<double> knots{t0};
  const std::vector<int64_t>& utime = track.utimes();
  auto it = std::upper_bound(utime.begin(), utime.end(), t0, [](double t, int64_t u) { return t < double(u); });
  for (; it != utime.end() && double(*it) < t1; ++it) knots.push_back(double(*it));
  knots.push_back(t1);
  const std::vector<WheelSample> readings = ReadingsAt(track, knots, smoothing_s);

  std::vector<Pose2> sensor(knots.size());  // sensor pose at each knot, frame of the sensor at t0
  std::vector<Twist2> twist(knots.size() - 1);
  Pose2 robot;  // robot pose relative to the robot at t0
  WheelIncrement increment;
  for (std::size_t k = 0; k + 1 < knots.size(); ++k) {
    const WheelSample& a = readings[k];
    const WheelSample& b = readings[k + 1];
    increment.rotation.resize(a.position.size());
    for (std::size_t r = 0; r < a.position.size(); ++r)
      increment.rotation[r] = b.position[r] - a.position[r];
    increment.steer_start = a.steer;
    increment.steer_end = b.steer;
    robot = Compose(robot, model.Integrate(increment));
    sensor[k + 1] = Between(mount, Compose(robot, mount));
    twist[k] = LogTwist(Between(sensor[k], sensor[k + 1]), (knots[k + 1] - knots[k]) * 1e-6);
  }

  ScanPoints out = EmptyPoints(scan);
  std::size_t k = 0;
  for (int i = 0; i < scan.size(); ++i) {
    if (!scan.HasReturn(i)) continue;
    const double t = scan.BeamTime(i);
    while (k + 2 < knots.size() && t > knots[k + 1]) ++k;
    const Pose2 pose = Compose(Compose(sensor[k], ExpTwist(twist[k], (t - knots[k]) * 1e-6)),
                               ExpTwist(correction, (t - t0) * 1e-6));
    const double a = scan.BeamAngle(i), r = scan.ranges[i];
    out.points.push_back(Apply(pose, {r * std::cos(a), r * std::sin(a)}));
  }
  return out;
}

PreparedScan::PreparedScan(ScanPoints points, const ScanMatchOptions& options)
    : points_(std::move(points)) {
  const std::vector<Eigen::Vector2d>& pts = points_.points;
  const int n = static_cast<int>(pts.size());
  constexpr int kMaxSide = 25;  // neighbours each side at most
  lines_.reserve(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector2d& q = pts[i];
    const double range = q.norm();
    if (!(range > 0.0)) continue;
    const double radius =
        std::max(options.line_fit_radius_m,
                 options.line_fit_beams * range * std::abs(points_.angle_increment));
    // The neighbourhood: consecutive points within the radius, both sides;
    // sums relative to q for precision.
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    double sxx = 0.0, sxy = 0.0, syy = 0.0;
    int count = 1;
    for (int side = -1; side <= 1; side += 2) {
      for (int k = 1; k <= kMaxSide && k < n; ++k) {
        int j = i + side * k;
        if (j < 0 || j >= n) {
          if (!points_.full_circle) break;
          j = (j + n) % n;
        }
        const Eigen::Vector2d d = pts[j] - q;
        if (d.squaredNorm() > radius * radius) break;
        sum += d;
        sxx += d.x() * d.x();
        sxy += d.x() * d.y();
        syy += d.y() * d.y();
        ++count;
      }
    }
    if (count < options.line_fit_min_points) continue;
    const Eigen::Vector2d mean = sum / count;
    const double a = sxx / count - mean.x() * mean.x();
    const double b = sxy / count - mean.x() * mean.y();
    const double c = syy / count - mean.y() * mean.y();
    const double half_trace = 0.5 * (a + c);
    const double root = std::sqrt(0.25 * (a - c) * (a - c) + b * b);
    const double lambda_max = half_trace + root, lambda_min = half_trace - root;
    if (!(lambda_max > 0.0) || lambda_min > options.line_max_flatness * lambda_max) continue;
    // The normal: the scatter's eigenvector of the smallest eigenvalue, from the row of
    // (scatter - lambda_min) with the larger entries (the better conditioned).
    Eigen::Vector2d normal = a - lambda_min >= c - lambda_min ? Eigen::Vector2d(-b, a - lambda_min)
                                                              : Eigen::Vector2d(c - lambda_min, -b);
    const double norm = normal.norm();
    normal = norm > 0.0 ? Eigen::Vector2d(normal / norm) : Eigen::Vector2d(1.0, 0.0);
    Line line;
    line.point = q;
    line.centroid = q + mean;
    line.normal = normal;
    line.direction = q / range;
    line.angle = PseudoAngle(q.x(), q.y());
    line.support = count;
    lines_.push_back(line);
  }
  // Beams come in angle order: sorting is needed only where de-skewing or a full turn's seam
  // reorders them.
  const auto by_angle = [](const Line& x, const Line& y) { return x.angle < y.angle; };
  if (!std::is_sorted(lines_.begin(), lines_.end(), by_angle))
    std::stable_sort(lines_.begin(), lines_.end(), by_angle);
  bin_start_.resize(kAngleBins + 1);
  std::size_t j = 0;
  for (int b = 0; b <= kAngleBins; ++b) {
    const double lower = -2.0 + b * (4.0 / kAngleBins);
    while (j < lines_.size() && lines_[j].angle < lower) ++j;
    bin_start_[b] = static_cast<int>(j);
  }
}

int PreparedScan::Nearest(const Eigen::Vector2d& p, double max_distance) const {
  const int n = static_cast<int>(lines_.size());
  if (n == 0) return -1;
  const double range = p.norm();
  const double alpha = PseudoAngle(p.x(), p.y());
  int bin = static_cast<int>((alpha + 2.0) * (kAngleBins / 4.0));
  bin = std::clamp(bin, 0, kAngleBins - 1);
  int start = bin_start_[bin];
  while (start < n && lines_[start].angle < alpha) ++start;
  if (start == n) start = 0;

  double best = max_distance * max_distance;
  int best_index = -1;
  // Walk outwards in angle both ways. The distance to any point at angular
  // offset d from p is at least range * sin(d) (range beyond a quarter turn),
  // and d only grows along the walk, so a walk stops once that bound exceeds
  // the best distance so far.
  auto visit = [&](int j) {
    const Line& line = lines_[j];
    const double along = p.dot(line.direction);
    const double across = p.x() * line.direction.y() - p.y() * line.direction.x();
    const double bound = along > 0.0 ? across * across : range * range;
    if (bound >= best) return false;
    const double d2 = (p - line.point).squaredNorm();
    if (d2 < best) {
      best = d2;
      best_index = j;
    }
    return true;
  };
  for (int k = 0; k < n; ++k)
    if (!visit((start + k) % n)) break;
  for (int k = 1; k < n; ++k)
    if (!visit((start - k + n) % n)) break;
  return best_index;
}

SensorMotion MatchPointsToLines(const PreparedScan& reference, const ScanPoints& current,
                                const Pose2& prior, const ScanMatchOptions& options,
                                ScanMatchReport* report) {
  SensorMotion result;
  result.utime_start = reference.utime();
  result.utime_end = current.utime;
  result.delta = prior;
  result.valid = false;
  ScanMatchReport local;
  ScanMatchReport& rep = report ? *report : local;
  rep = ScanMatchReport{};

  const int n = static_cast<int>(current.points.size());
  if (n == 0 || reference.num_lines() == 0) return result;

  std::vector<Pair> pairs;
  pairs.reserve(n);
  std::vector<double> abs_errors;
  abs_errors.reserve(n);

  Eigen::Vector3d x(prior.x, prior.y, prior.theta);
  Eigen::Matrix3d eigenvectors = Eigen::Matrix3d::Identity();
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero();
  double sum_e2 = 0.0, sum_raw_e2 = 0.0, mean_support = 0.0, scale = 1.0, truncation = 1.0;
  int kept = 0;
  int weak = 0;  // eigen-directions (smallest first) too weak to be measured
  constexpr int kCycleMemory = 4;
  Eigen::Vector3d history[kCycleMemory];  // latest iterates, newest first
  for (auto& h : history) h.setConstant(std::numeric_limits<double>::quiet_NaN());
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    rep.iterations = iteration + 1;
    const double c = std::cos(x[2]), s = std::sin(x[2]);
    PairPointsWithLines(reference, current, x, c, s, options.max_correspondence_distance_m,
                        options.incidence_weight_floor, &pairs, &abs_errors);
    if (static_cast<int>(pairs.size()) < options.min_correspondences) {
      rep.correspondences = static_cast<int>(pairs.size());
      return result;
    }
    int keep = 0;
    const double threshold = GateThreshold(&abs_errors, options, &keep, &truncation);
    const PairSums sums = SumPairs(reference, current, pairs, threshold, keep, c, s);
    sum_e2 = sums.sum_e2;
    sum_raw_e2 = sums.sum_raw_e2;
    mean_support = sums.sum_support;
    kept = sums.kept;
    rep.correspondences = kept;
    if (kept < options.min_correspondences) return result;
    mean_support /= kept;
    // Scale theta by the RMS range so that translation and rotation compare.
    scale = std::sqrt(sums.sum_r2 / kept);
    const Eigen::Vector3d unscale(1.0, 1.0, 1.0 / scale);
    const Eigen::Matrix3d scaled = unscale.asDiagonal() * sums.hessian * unscale.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
    eigen.computeDirect(scaled);
    eigenvalues = eigen.eigenvalues();  // ascending
    eigenvectors = eigen.eigenvectors();
    if (!(eigenvalues[2] > 0.0)) return result;
    weak = 0;
    while (weak < 2 && eigenvalues[weak] < options.degeneracy_ratio * eigenvalues[2]) ++weak;
    // Gauss-Newton step in scaled coordinates, without the weak directions.
    const Eigen::Vector3d scaled_gradient = unscale.asDiagonal() * sums.gradient;
    Eigen::Vector3d step = Eigen::Vector3d::Zero();
    for (int k = weak; k < 3; ++k)
      step -= eigenvectors.col(k) * (eigenvectors.col(k).dot(scaled_gradient) / eigenvalues[k]);
    step = unscale.asDiagonal() * step;
    x += step;
    x[2] = WrapAngle(x[2]);
    if (step.head<2>().norm() < options.convergence_m &&
        std::abs(step[2]) < options.convergence_rad) {
      rep.converged = true;
      break;
    }
    // A pair flipping in and out of the kept set can make the iteration
    // cycle between a few nearby states: converged, at their mean.
    int period = 0;
    for (int k = 0; k < kCycleMemory && !period; ++k)
      if ((history[k] - x).cwiseAbs().maxCoeff() < 1e-12) period = k + 1;
    if (period) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (int k = 0; k < period; ++k) mean += history[k];
      x = mean / period;
      rep.converged = true;
      break;
    }
    for (int k = kCycleMemory - 1; k > 0; --k) history[k] = history[k - 1];
    history[0] = x;
  }

  if (kept == 0) return result;
  result.delta = {x[0], x[1], x[2]};
  const double sigma2 =
      kept > 3 ? sum_e2 / (kept - 3) / truncation / (1.0 + 1.0 / mean_support) : 0.0;
  rep.sigma = std::sqrt(sigma2);
  rep.characteristic_range = scale;
  rep.eigenvalue_ratio = eigenvalues[2] > 0.0 ? eigenvalues[0] / eigenvalues[2] : 0.0;
  SetUncertainty(eigenvalues, eigenvectors, weak, sigma2, scale, options, &result);
  result.degenerate = weak > 0;
  result.inlier_fraction = double(kept) / n;
  result.rms = std::sqrt(sum_raw_e2 / kept);
  result.valid = rep.converged && result.inlier_fraction >= options.min_inlier_fraction;
  if (!result.covariance.allFinite() || !result.weak_direction.allFinite()) {
    result.covariance = Eigen::Matrix3d::Identity();
    result.weak_direction = Eigen::Vector3d::Zero();
    result.valid = false;
  }
  return result;
}

namespace {

// Jacobian of Inverse() at `a`, for carrying a covariance through it.
Eigen::Matrix3d InverseJacobian(const Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  Eigen::Matrix3d j;
  j << -c, -s, s * a.x - c * a.y,  //
      s, -c, c * a.x + s * a.y,    //
      0.0, 0.0, -1.0;
  return j;
}

}  // namespace

SensorMotion MatchScans(const PreparedScan& reference, const PreparedScan& current,
                        const Pose2& prior, const ScanMatchOptions& options,
                        ScanMatchReport* report) {
  ScanMatchReport forward_report;
  const SensorMotion forward =
      MatchPointsToLines(reference, current.points(), prior, options, &forward_report);
  if (report) *report = forward_report;
  if (!options.symmetric) return forward;

  ScanMatchReport backward_report;
  // Start the way back from the way there when it worked: fewer iterations.
  const Pose2 start = Inverse(forward.valid ? forward.delta : prior);
  const SensorMotion backward =
      MatchPointsToLines(current, reference.points(), start, options, &backward_report);
  if (report) {
    report->iterations += backward_report.iterations;
    report->converged = forward_report.converged && backward_report.converged;
  }
  // The way back, expressed as the way there.
  SensorMotion back = backward;
  back.utime_start = forward.utime_start;
  back.utime_end = forward.utime_end;
  back.delta = Inverse(backward.delta);
  const Eigen::Matrix3d jacobian = InverseJacobian(backward.delta);
  back.covariance = jacobian * backward.covariance * jacobian.transpose();
  if (backward.weak_direction.squaredNorm() > 0) {
    Eigen::Vector3d direction = (jacobian * backward.weak_direction).normalized();
    Eigen::Index largest = 0;
    direction.cwiseAbs().maxCoeff(&largest);
    back.weak_direction = direction[largest] < 0 ? -direction : direction;
  }
  if (!backward.valid) return forward;
  if (!forward.valid) return back;

  SensorMotion out = forward;
  out.delta = Interpolate(forward.delta, back.delta, 0.5);
  out.covariance = 0.5 * (forward.covariance + back.covariance);
  out.degenerate = forward.degenerate || back.degenerate;
  if (!forward.degenerate && back.degenerate) out.weak_direction = back.weak_direction;
  out.inlier_fraction = 0.5 * (forward.inlier_fraction + back.inlier_fraction);
  out.rms = std::sqrt(0.5 * (forward.rms * forward.rms + back.rms * back.rms));
  return out;
}

// --- ScanMatcher

ScanMatcher::ScanMatcher(const RobotDescription& robot, ScanMatchOptions options)
    : options_(options),
      model_(MakeDriveModel(robot)),
      num_wheels_(WheelRoles(robot.drive).size()) {
  if (!robot.lidar2d)
    throw InputError(robot.source_file, "lidar2d", "the robot has no 2D lidar to match scans of");
  mount_ = {robot.lidar2d->x, robot.lidar2d->y, robot.lidar2d->yaw};
}

ScanMatcher::~ScanMatcher() = default;

namespace {
// The median of the last few encoder intervals: the stream's own rate.
int64_t MedianInterval(std::deque<int64_t> intervals) {
  if (intervals.empty()) return 0;
  auto middle = intervals.begin() + intervals.size() / 2;
  std::nth_element(intervals.begin(), middle, intervals.end());
  return *middle;
}
}  // namespace

std::vector<ScanMatchOutcome> ScanMatcher::AddWheels(const WheelSample& sample) {
  if (sample.position.size() != num_wheels_ || sample.steer.size() != num_wheels_)
    throw std::invalid_argument("ScanMatcher::AddWheels: sample has " +
                                std::to_string(sample.position.size()) + " wheels, expected " +
                                std::to_string(num_wheels_));
  std::vector<ScanMatchOutcome> out;
  const bool had_samples = !track_.empty();
  const int64_t previous_utime = had_samples ? track_.last_utime() : 0;
  if (!track_.Append(sample)) {
    ++counts_.wheels_dropped;
    return out;
  }
  ++counts_.wheels;
  if (have_scan_) CheckClocks(last_scan_utime_, sample.utime);
  if (had_samples) {
    recent_intervals_.push_back(sample.utime - previous_utime);
    if (recent_intervals_.size() > 15) recent_intervals_.pop_front();
  }
  typical_interval_.emplace_back(sample.utime, MedianInterval(recent_intervals_));
  Process(&out);
  return out;
}

std::vector<ScanMatchOutcome> ScanMatcher::AddScan(const LaserScan& scan) {
  std::vector<ScanMatchOutcome> out;
  if (have_scan_ && scan.utime <= last_scan_utime_) {
    ++counts_.scans_dropped;
    out.push_back({ScanMatchStatus::kOutOfOrder, scan.utime, {}});
    return out;
  }
  have_scan_ = true;
  last_scan_utime_ = scan.utime;
  ++counts_.scans;
  if (!track_.empty()) CheckClocks(scan.utime, track_.last_utime());
  waiting_.push_back(scan);
  if (static_cast<int>(waiting_.size()) > std::max(options_.max_pending_scans, 1))
    SkipFirstWaiting(ScanMatchStatus::kNoWheelData, &out);
  Process(&out);
  return out;
}

void ScanMatcher::CheckClocks(int64_t scan_utime, int64_t wheel_utime) {
  if (clocks_checked_) return;
  clocks_checked_ = true;
  const double gap_s = std::abs(static_cast<double>(scan_utime - wheel_utime)) * 1e-6;
  if (gap_s <= kClockDomainGapS) return;
  clock_problem_ = Formatted(
                "scan and wheel stamps are %.0f s apart (scan at %.3f s, wheel state at %.3f s): two clock "
                "domains in one group or recording (e.g. one bridge stamping with a recording's clock, another with the "
                "host's); no scan can be matched",
                gap_s, scan_utime * 1e-6, wheel_utime * 1e-6);
}

std::vector<ScanMatchOutcome> ScanMatcher::Finish() {
  std::vector<ScanMatchOutcome> out;
  Process(&out, true /* finishing */);
  while (!waiting_.empty()) SkipFirstWaiting(ScanMatchStatus::kNoWheelData, &out);
  return out;
}

void ScanMatcher::SkipFirstWaiting(ScanMatchStatus why, std::vector<ScanMatchOutcome>* out) {
  if (why == ScanMatchStatus::kNoWheelData) ++counts_.scans_uncovered;
  if (why == ScanMatchStatus::kBetweenKeyframes) ++counts_.between_keyframes;
  out->push_back({why, waiting_.front().utime, {}});
  waiting_.pop_front();
}

void ScanMatcher::Process(std::vector<ScanMatchOutcome>* out, bool finishing) {
  bool progressed = false;
  while (!waiting_.empty() && !track_.empty()) {
    const LaserScan& scan = waiting_.front();
    if (scan.utime < track_.first_utime()) {  // wheel data began after it: never covered
      SkipFirstWaiting(ScanMatchStatus::kNoWheelData, out);
      continue;
    }
    // The de-skewing smooths the encoder readings over a margin around the
    // scan: wait for it too, so the result does not depend on when wheel data
    // arrive (at the end of the data, what there is).
    const double margin = options_.deskew ? options_.deskew_smoothing_s * 1e6 : 0.0;
    if (!track_.Covers(double(scan.utime), double(scan.end_utime()) + (finishing ? 0.0 : margin)))
      break;
    // Keyframes: a scan is matched against the last matched one once the robot has moved
    // enough. Over longer baselines the matcher's small per-pair bias (about 0.02 mm, a
    // 0.07 % scale error at 25 mm per pair) becomes negligible, and it costs fewer matches.
    if (reference_) {
      const double t0 = double(reference_->utime()), t1 = double(scan.utime);
      const Pose2 moved = PredictSensorMotion(track_, *model_, mount_, t0, t1);
      if (std::hypot(moved.x, moved.y) < options_.keyframe_translation_m &&
          std::abs(moved.theta) < options_.keyframe_rotation_rad &&
          (t1 - t0) * 1e-6 < options_.keyframe_max_interval_s) {
        SkipFirstWaiting(ScanMatchStatus::kBetweenKeyframes, out);
        continue;
      }
    }
    std::optional<PreparedScan> prepared;
    if (reference_) {
      out->push_back({ScanMatchStatus::kMatched, scan.utime, MatchWithReference(scan, &prepared)});
    } else {
      prepared.emplace(Deskewed(scan, {mount_, {}}), options_);
      out->push_back({ScanMatchStatus::kFirstKeyframe, scan.utime, {}});
    }
    reference_.emplace(std::move(*prepared));
    waiting_.pop_front();
    progressed = true;
  }
  if (progressed) ReleaseOldWheels();
}

ScanPoints ScanMatcher::Deskewed(const LaserScan& scan, const DeskewCorrection& correction) const {
  return options_.deskew ? DeskewScan(scan, track_, *model_, correction.mount, options_.deskew_smoothing_s,
                                      correction.twist)
                         : ScanToPoints(scan);
}

namespace {
// Once corrected, the de-skewing is corrected again until a pass moves a point by less than this
// share of deskew_correction_m.
constexpr double kDeskewConvergedShare = 0.05;
}  // namespace

// The match of `scan` with the reference keyframe, refused (valid = false) over an encoder gap;
// `prepared` gets the scan as de-skewed for it: with the odometry, then, while the match moves a
// point of the scan by more than deskew_correction_m over the scan's duration, with the motion
// the match says (deskew_correction.h), and matched again.
SensorMotion ScanMatcher::MatchWithReference(const LaserScan& scan, std::optional<PreparedScan>* prepared) {
  const double t0 = double(reference_->utime()), t1 = double(scan.utime), t_end = double(scan.end_utime());
  const Pose2 prior = PredictSensorMotion(track_, *model_, mount_, t0, t1);
  DeskewCorrection correction{mount_, {}};
  prepared->emplace(Deskewed(scan, correction), options_);
  SensorMotion motion = MatchScans(*reference_, **prepared, prior, options_);
  if (options_.deskew && scan.time_increment > 0.0 && t_end > t1 && t1 > t0) {
    const Pose2 pair_motion = track_.Odometry(*model_, t0, t1), scan_motion = track_.Odometry(*model_, t1, t_end);
    const double duration_s = (t_end - t1) * 1e-6;
    double range = 0.0;
    for (const Eigen::Vector2d& p : (*prepared)->points().points) range = std::max(range, p.norm());
    for (int pass = 0; pass < options_.deskew_correction_passes && motion.valid; ++pass) {
      const DeskewCorrection next = CorrectionFromMatch(pair_motion, mount_, motion.delta, (t1 - t0) * 1e-6);
      const Pose2 change = Between(CorrectedSensorMotion(correction, scan_motion, duration_s),
                                   CorrectedSensorMotion(next, scan_motion, duration_s));
      const double shift = std::hypot(change.x, change.y) + range * std::abs(change.theta);
      if (shift < options_.deskew_correction_m * (pass == 0 ? 1.0 : kDeskewConvergedShare)) break;
      correction = next;
      std::optional<PreparedScan> again;
      again.emplace(Deskewed(scan, correction), options_);
      const SensorMotion rematched = MatchScans(*reference_, *again, motion.delta, options_);
      if (!rematched.valid) break;
      motion = rematched;
      *prepared = std::move(again);
    }
  }
  // Encoder gaps over the pair: the prior and the de-skewing are guesses there.
  const std::vector<int64_t>& utime = track_.utimes();
  auto it = std::upper_bound(utime.begin(), utime.end(), t0, [](double t, int64_t u) { return t < double(u); });
  if (it != utime.begin()) --it;
  // A gap is a dropout when it is longer than max_wheel_gap_s and than
  // wheel_gap_factor times the stream's median interval before the pair
  // (a slow encoder stream is the recording's rate, not a gap). The
  // median is taken over samples before the pair only, so live and
  // offline agree whatever the interleaving.
  const int64_t typical =
      std::lower_bound(typical_interval_.begin(), typical_interval_.end(), *it,
                       [](const std::pair<int64_t, int64_t>& e, int64_t t) { return e.first < t; })
          ->second;
  const double limit_us =
      1e6 * std::max(options_.max_wheel_gap_s, options_.wheel_gap_factor * double(typical) * 1e-6);
  int64_t gap = 0;
  for (; it + 1 != utime.end() && double(*it) < double(scan.end_utime()); ++it)
    gap = std::max(gap, *(it + 1) - *it);
  if (double(gap) > limit_us) {
    motion.valid = false;
    ++counts_.wheel_gaps;
  }
  ++counts_.matches;
  if (!motion.valid) ++counts_.invalid;
  if (motion.degenerate) ++counts_.degenerate;
  return motion;
}

void ScanMatcher::ReleaseOldWheels() {
  // Keep the last sample at or before the reference scan (the prior starts
  // there) less the smoothing margin (the next scan's de-skewing reads back to there).
  const double t0 = double(reference_->utime()) - std::max(options_.deskew_smoothing_s, 0.0) * 1e6;
  const std::size_t drop = track_.IndexBefore(t0);
  if (drop < 1024 || drop < track_.size() / 2) return;  // rebuild rarely: amortised O(1)
  track_.DropBefore(drop);
  while (typical_interval_.front().first < track_.first_utime()) typical_interval_.pop_front();
}

}  // namespace calib
