#include "calib/calibrate/imu_calibration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>

#include <Eigen/Dense>

#include "calib/core/errors.h"
#include "calib/core/kinematics.h"

namespace calib {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Standstills are shrunk by this at both ends (the gyro may lag the encoders).
constexpr double kStillMargin_s = 0.1;

double Deg(double rad) { return rad * 180.0 / M_PI; }

// The integral of the gyro rate from the first sample, for any span. A sample is
// taken as the mean rate since the previous one (what an IMU's decimation filter
// reports; the trapezoid rule would lag a rate step by half a sample period).
class GyroIntegral {
 public:
  explicit GyroIntegral(const std::vector<ImuSample>& imu) : imu_(imu) {
    cumulative_.resize(imu.size(), 0.0);
    for (size_t i = 1; i < imu.size(); ++i) {
      const double dt = (imu[i].utime - imu[i - 1].utime) * 1e-6;
      cumulative_[i] = cumulative_[i - 1] + imu[i].rate * dt;
    }
  }
  bool Covers(double t0, double t1) const {
    return t0 >= double(imu_.front().utime) && t1 <= double(imu_.back().utime);
  }
  double Angle(double t0, double t1) const { return At(t1) - At(t0); }
  double Rate(double t) const {
    const size_t i = Index(t);
    const double s = Fraction(i, t);
    return imu_[i].rate + s * (imu_[i + 1].rate - imu_[i].rate);
  }

 private:
  size_t Index(double t) const {
    const auto it = std::upper_bound(imu_.begin(), imu_.end(), t,
                                     [](double u, const ImuSample& s) { return u < double(s.utime); });
    const size_t after = static_cast<size_t>(it - imu_.begin());
    return std::min(std::max<size_t>(after, 1), imu_.size() - 1) - 1;
  }
  double Fraction(size_t i, double t) const {
    return std::clamp((t - double(imu_[i].utime)) / double(imu_[i + 1].utime - imu_[i].utime), 0.0, 1.0);
  }
  double At(double t) const {
    const size_t i = Index(t);
    return cumulative_[i] + imu_[i + 1].rate * (imu_[i + 1].utime - imu_[i].utime) * 1e-6 * Fraction(i, t);
  }
  const std::vector<ImuSample>& imu_;
  std::vector<double> cumulative_;
};

// Smallest non-zero encoder step of each wheel: the tick (rad).
std::vector<double> EncoderTicks(const WheelTrack& wheels) {
  std::vector<double> tick(2, kInf);
  for (size_t i = 1; i < wheels.size(); ++i)
    for (size_t w = 0; w < 2; ++w) {
      const double d = std::abs(wheels.position(i, w) - wheels.position(i - 1, w));
      if (d > 1e-12) tick[w] = std::min(tick[w], d);
    }
  for (double& t : tick)
    if (!std::isfinite(t)) t = 0.0;
  return tick;
}

// Standstills and motions, alternating, covering the track.
std::vector<ImuSpan> CutSpans(const WheelTrack& wheels, double standstill_s) {
  std::vector<std::pair<double, double>> still;  // [start, end], us
  size_t run = 0;
  auto close_run = [&](size_t end) {
    const double t0 = double(wheels.utime(run)), t1 = double(wheels.utime(end));
    if ((t1 - t0) * 1e-6 >= standstill_s) still.push_back({t0 + kStillMargin_s * 1e6, t1 - kStillMargin_s * 1e6});
  };
  const auto moved = [&](size_t i) {
    for (size_t w = 0; w < wheels.roles(); ++w)
      if (wheels.position(i, w) != wheels.position(run, w)) return true;
    return false;
  };
  for (size_t i = 1; i < wheels.size(); ++i) {
    if (moved(i)) {
      close_run(i - 1);
      run = i;
    }
  }
  close_run(wheels.size() - 1);
  std::vector<ImuSpan> spans;
  double cursor = double(wheels.first_utime());
  auto rotation = [&](double t0, double t1, ImuSpan* span) {
    const WheelSample a = wheels.At(t0), b = wheels.At(t1);
    span->left_rad = b.position[0] - a.position[0];
    span->right_rad = b.position[1] - a.position[1];
  };
  for (const auto& [t0, t1] : still) {
    if (t0 > cursor) {
      ImuSpan m;
      m.moving = true;
      m.utime_start = std::llround(cursor);
      m.utime_end = std::llround(t0);
      rotation(cursor, t0, &m);
      if (m.left_rad != 0.0 || m.right_rad != 0.0) spans.push_back(m);
    }
    ImuSpan st;
    st.utime_start = std::llround(t0);
    st.utime_end = std::llround(t1);
    spans.push_back(st);
    cursor = t1;
  }
  if (double(wheels.last_utime()) > cursor) {
    ImuSpan m;
    m.moving = true;
    m.utime_start = std::llround(cursor);
    m.utime_end = wheels.last_utime();
    rotation(cursor, double(wheels.last_utime()), &m);
    if (m.left_rad != 0.0 || m.right_rad != 0.0) spans.push_back(m);
  }
  return spans;
}

double Sinc(double x) { return std::abs(x) < 1e-6 ? 1.0 - x * x / 6.0 : std::sin(x) / x; }

struct Fit {
  Eigen::VectorXd p;  // rL, rR, b, bias, [scale]
  Eigen::MatrixXd information;
  double chi2 = 0.0;
  int rows = 0;
};

// Gauss-Newton on residuals r(p) (already divided by their sigma); numeric Jacobian.
Fit GaussNewton(const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& residuals,
                Eigen::VectorXd p) {
  Fit fit;
  Eigen::MatrixXd J;
  for (int iteration = 0; iteration < 30; ++iteration) {
    const Eigen::VectorXd r = residuals(p);
    J.resize(r.size(), p.size());
    for (int k = 0; k < p.size(); ++k) {
      const double h = 1e-6 * std::max(std::abs(p[k]), 1e-4);
      Eigen::VectorXd plus = p, minus = p;
      plus[k] += h;
      minus[k] -= h;
      J.col(k) = (residuals(plus) - residuals(minus)) / (2 * h);
    }
    const Eigen::MatrixXd H = J.transpose() * J;
    const Eigen::VectorXd step = H.ldlt().solve(-J.transpose() * r);
    p += step;
    bool done = true;
    for (int k = 0; k < p.size(); ++k)
      if (std::abs(step[k]) > 1e-12 * std::max(std::abs(p[k]), 1e-4)) done = false;
    if (done) break;
  }
  const Eigen::VectorXd r = residuals(p);
  fit.p = p;
  fit.information = J.transpose() * J;
  fit.chi2 = r.squaredNorm();
  fit.rows = static_cast<int>(r.size());
  return fit;
}

Estimate MakeEstimate(double value, double std, double nominal) {
  Estimate e;
  e.value = value;
  e.std = std;
  e.nominal = nominal;
  return e;
}

// Gyro bias and noise from the standstills: white noise of density N has per-sample
// std N sqrt(rate). `bias` and `noise` keep their values where the standstills do not tell.
void StandstillGyro(const std::vector<ImuSpan>& spans, const std::vector<ImuSample>& imu,
                    const GyroIntegral& gyro, double imu_rate_hz, double* bias, double* noise) {
  double still_time = 0.0, still_angle = 0.0;
  for (const ImuSpan& s : spans)
    if (!s.moving) {
      still_time += (s.utime_end - s.utime_start) * 1e-6;
      still_angle += gyro.Angle(s.utime_start, s.utime_end);
    }
  if (still_time > 0) *bias = still_angle / still_time;
  const double bias0 = *bias;
  double sum = 0.0;
  int count = 0;
  for (const ImuSpan& s : spans) {
    if (s.moving) continue;
    for (const ImuSample& m : imu)
      if (m.utime >= s.utime_start && m.utime <= s.utime_end) {
        sum += (m.rate - bias0) * (m.rate - bias0);
        ++count;
      }
  }
  if (count >= 20) *noise = std::sqrt(sum / (count - 1)) / std::sqrt(imu_rate_hz);
}

// The measured straight (the first straight run) and turn (the first turn in place) among
// the spans, by the nominal (rL0, rR0, b0), into result->straight_span and turn_span;
// throws when the recording has no straight run or no turn.
void FindStraightAndTurn(const std::vector<ImuSpan>& spans, double rL0, double rR0, double b0,
                         const ImuCalibrationOptions& options, ImuCalibrationResult* result) {
  auto nominal_turn = [&](const ImuSpan& s) {
    return (rR0 * s.right_rad - rL0 * s.left_rad) / b0;
  };
  double largest_turn = 0.0;
  for (size_t k = 0; k < spans.size(); ++k) {
    const ImuSpan& s = spans[k];
    if (!s.moving) continue;
    const double turn = std::abs(nominal_turn(s));
    largest_turn = std::max(largest_turn, turn);
    const double travel = 0.5 * (rL0 * s.left_rad + rR0 * s.right_rad);
    if (result->straight_span < 0 && turn < options.straight_max_rad && std::abs(travel) > 0.2)
      result->straight_span = static_cast<int>(k);
    if (result->turn_span < 0 && turn >= options.turn_min_rad && s.left_rad * s.right_rad < 0)
      result->turn_span = static_cast<int>(k);
  }
  if (result->straight_span < 0) {
    throw UnobservableError("scale (left_radius, right_radius): no straight run in the recording",
                            "drive a straight run (turning less than " +
                                std::to_string(Deg(options.straight_max_rad)).substr(0, 3) +
                                " deg) and measure its length");
  }
  if (largest_turn < options.turn_min_rad) {
    throw UnobservableError("track: the recording has no turn (largest " +
                                std::to_string(Deg(largest_turn)).substr(0, 5) + " deg)",
                            "turn in place both ways, several whole turns each (e.g. the "
                            "commander's imu trajectory)");
  }
}

// The spans' gyro angles against the wheels' turn, each divided by its sigma, then the
// measured straight distance against the wheels' chord and (with_scale) the measured turn
// angle against the wheels'; p = (rL, rR, b, bias[, scale]).
struct SpanResiduals {
  const GyroIntegral& gyro;
  const std::vector<ImuSpan>& spans;
  const std::vector<double>& tick;
  double noise;
  bool with_scale;
  double s_held;  // the gyro scale when not estimated
  int straight_span, turn_span;
  double distance;
  const ImuCalibrationOptions& options;

  // With the gyro shifted by offset_us; the spans with their angles, sigmas and residuals in *out.
  Eigen::VectorXd operator()(const Eigen::VectorXd& p, double offset_us, std::vector<ImuSpan>* out) const {
    const double rL = p[0], rR = p[1], b = p[2], bias = p[3], scale = with_scale ? p[4] : s_held;
    const double q2 = (tick[0] * tick[0] * rL * rL + tick[1] * tick[1] * rR * rR) / (6.0 * b * b);
    Eigen::VectorXd r(spans.size() + 1 + (with_scale ? 1 : 0));
    for (size_t k = 0; k < spans.size(); ++k) {
      ImuSpan& s = (*out)[k];
      const double T = (s.utime_end - s.utime_start) * 1e-6;
      s.gyro_rad = gyro.Angle(s.utime_start + offset_us, s.utime_end + offset_us);
      const double turn = s.moving ? (rR * s.right_rad - rL * s.left_rad) / b : 0.0;
      s.sigma_rad = std::sqrt(noise * noise * T + (s.moving ? scale * scale * q2 : 0.0));
      s.residual_rad = s.gyro_rad - (scale * turn + bias * T);
      r[k] = s.residual_rad / s.sigma_rad;
    }
    const ImuSpan& st = spans[straight_span];
    const double turn = (rR * st.right_rad - rL * st.left_rad) / b;
    const double chord = 0.5 * std::abs(rL * st.left_rad + rR * st.right_rad) * Sinc(0.5 * turn);
    r[spans.size()] = (distance - chord) / options.distance_std_m;
    if (with_scale) {
      const ImuSpan& tu = spans[turn_span];
      const double angle = std::abs((rR * tu.right_rad - rL * tu.left_rad) / b);
      r[spans.size() + 1] = (*options.turn_angle_rad - angle) / options.turn_angle_std_rad;
    }
    return r;
  }
};

// Time offset: the gyro angle over short windows against the wheels', shifted by tau, under
// p = (rL, rR, b, bias, ...) and the gyro `scale`. Taken, into *offset_us, only where the
// data determine it; otherwise no shift.
Estimate TimeOffset(const std::vector<ImuSpan>& spans, const WheelTrack& wheels, const GyroIntegral& gyro,
                    const Eigen::VectorXd& p, double scale, const ImuCalibrationOptions& options,
                    double nominal, double* offset_us) {
  const double rL = p[0], rR = p[1], b = p[2], bias = p[3];
  struct Window {
    double t0, t1, wheel;
  };
  std::vector<Window> windows;
  const double w = 0.1e6;
  for (const ImuSpan& s : spans) {
    if (!s.moving) continue;
    for (double t = s.utime_start; t + w <= s.utime_end; t += w) {
      const WheelSample a = wheels.At(t), c = wheels.At(t + w);
      windows.push_back({t, t + w,
                         (rR * (c.position[1] - a.position[1]) - rL * (c.position[0] - a.position[0])) / b});
    }
  }
  auto cost = [&](double tau_us) {
    double sum = 0.0;
    for (const Window& win : windows) {
      const double e = gyro.Angle(win.t0 + tau_us, win.t1 + tau_us) - bias * w * 1e-6 - scale * win.wheel;
      sum += e * e;
    }
    return sum;
  };
  double sensitivity = 0.0;  // sum over windows of (d residual / d tau)^2, per s^2
  for (const Window& win : windows) {
    const double d = gyro.Rate(win.t1) - gyro.Rate(win.t0);
    sensitivity += d * d;
  }
  if (windows.size() < 10) return MakeEstimate(0.0, kInf, nominal);
  const double range = options.max_time_offset_s * 1e6, step = 1000.0;
  double best = 0.0, best_cost = kInf;
  for (double tau = -range; tau <= range; tau += step) {
    const double c = cost(tau);
    if (c < best_cost) best_cost = c, best = tau;
  }
  // Parabola through the neighbours.
  const double cm = cost(best - step), cp = cost(best + step);
  const double curvature = cm + cp - 2 * best_cost;
  if (curvature > 0) best += 0.5 * step * (cm - cp) / curvature;
  const double residual_var = cost(best) / std::max<double>(1.0, windows.size() - 1.0);
  // A rate change d over a window changes its angle by d * tau.
  const double sigma_s = sensitivity > 0 ? std::sqrt(residual_var / sensitivity) : kInf;
  if (!(sigma_s < 0.01)) return MakeEstimate(0.0, kInf, nominal);
  *offset_us = best;
  return MakeEstimate(best * 1e-6, sigma_s, nominal);
}

// Wheel heading noise: the motions' residual variance beyond the gyro's, per metre of wheel
// travel under the radii p[0], p[1].
double WheelNoise(const std::vector<ImuSpan>& spans, const Eigen::VectorXd& p) {
  double excess = 0.0, travel = 0.0;
  for (const ImuSpan& s : spans) {
    if (!s.moving) continue;
    excess += s.residual_rad * s.residual_rad - s.sigma_rad * s.sigma_rad;
    travel += 0.5 * (std::abs(p[0] * s.left_rad) + std::abs(p[1] * s.right_rad));
  }
  return std::max(2e-4, travel > 0 ? std::sqrt(std::max(0.0, excess) / travel) : 0.0);
}

// Mount yaw: the accelerometer against the wheels' acceleration on straight runs, in
// windows, under p = (rL, rR, b, bias, ...); unknown (infinite std) without enough of them.
Estimate MountYaw(const std::vector<ImuSpan>& spans, const std::vector<ImuSample>& imu,
                  const WheelTrack& wheels, const Eigen::VectorXd& p, double nominal) {
  const auto model = MakeDriveModel(DriveType::kDifferential,
                                    {{"left_radius", p[0]}, {"right_radius", p[1]}, {"track", p[2]}});
  const double h = 0.05e6, w = 0.25e6;
  auto speed = [&](double t) { return wheels.Odometry(*model, t - h, t + h).x / (2 * h * 1e-6); };
  Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
  Eigen::Vector2d bx = Eigen::Vector2d::Zero(), by = Eigen::Vector2d::Zero();
  std::vector<std::array<double, 3>> rows;  // dv, integrated ax, integrated ay
  size_t i = 0;
  for (const ImuSpan& s : spans) {
    if (!s.moving || std::abs(s.gyro_rad - p[3] * (s.utime_end - s.utime_start) * 1e-6) > 0.1) continue;
    for (double t = s.utime_start + h; t + w + h <= s.utime_end; t += w) {
      double ix = 0.0, iy = 0.0;
      while (i < imu.size() && double(imu[i].utime) < t) ++i;
      size_t j = i;
      for (; j + 1 < imu.size() && double(imu[j + 1].utime) <= t + w; ++j) {
        const double dt = (imu[j + 1].utime - imu[j].utime) * 1e-6;
        ix += 0.5 * (imu[j].accel_x + imu[j + 1].accel_x) * dt;
        iy += 0.5 * (imu[j].accel_y + imu[j + 1].accel_y) * dt;
      }
      const double span_s = j > i ? (imu[j].utime - imu[i].utime) * 1e-6 : 0.0;
      if (span_s < 0.5 * w * 1e-6) continue;
      const double dv = speed(double(imu[j].utime)) - speed(double(imu[i].utime));
      rows.push_back({dv, ix, iy});
      A += Eigen::Vector2d(dv, span_s) * Eigen::RowVector2d(dv, span_s);
      bx += Eigen::Vector2d(dv, span_s) * ix;
      by += Eigen::Vector2d(dv, span_s) * iy;
    }
  }
  const double excitation = A(0, 0);  // sum of dv^2, (m/s)^2
  if (!(rows.size() >= 6 && excitation > 1e-3 && std::abs(A.determinant()) > 1e-12))
    return MakeEstimate(nominal, kInf, nominal);
  const Eigen::Vector2d cx = A.ldlt().solve(bx), cy = A.ldlt().solve(by);
  const double c = cx[0], sn = -cy[0];
  double rss = 0.0;
  for (const auto& row : rows) {
    const double ex = row[1] - (cx[0] * row[0]);
    const double ey = row[2] - (cy[0] * row[0]);
    rss += ex * ex + ey * ey;
  }
  // Bias columns are absorbed approximately: residuals about the dv fit.
  const double var = rss / std::max<double>(1.0, 2.0 * rows.size() - 4.0);
  const double coefficient_var = var * A.inverse()(0, 0);
  const double norm2 = c * c + sn * sn;
  return MakeEstimate(std::atan2(sn, c), std::sqrt(coefficient_var / norm2), nominal);
}

}  // namespace

ImuCalibrationResult CalibrateWithImu(const RobotDescription& robot, const WheelTrack& wheels,
                                      std::vector<ImuSample> imu,
                                      const ImuCalibrationOptions& options,
                                      const std::string& origin) {
  if (robot.drive != DriveType::kDifferential)
    throw InputError(robot.source_file, "drive", "the IMU calibration is for differential drives");
  const ImuMount mount = robot.imu.value_or(ImuMount{});
  std::stable_sort(imu.begin(), imu.end(),
                   [](const ImuSample& a, const ImuSample& b) { return a.utime < b.utime; });
  imu.erase(std::unique(imu.begin(), imu.end(),
                        [](const ImuSample& a, const ImuSample& b) { return a.utime == b.utime; }),
            imu.end());
  if (imu.size() < 2) throw InputError(origin, "channel " + mount.channel, "fewer than 2 IMU samples");
  if (wheels.size() < 2) throw InputError(origin, "channel WHEELS", "fewer than 2 wheel states");
  for (const ImuSample& s : imu)
    if (!std::isfinite(s.rate) || !std::isfinite(s.accel_x) || !std::isfinite(s.accel_y))
      throw InputError(origin, "IMU sample at utime " + std::to_string(s.utime), "not finite");

  const GyroIntegral gyro(imu);
  const double imu_rate_hz = (imu.size() - 1) / ((imu.back().utime - imu.front().utime) * 1e-6);
  const std::vector<double> tick = EncoderTicks(wheels);

  ImuCalibrationResult result;
  std::vector<ImuSpan> all = CutSpans(wheels, options.standstill_s);
  for (const ImuSpan& s : all)
    if (gyro.Covers(s.utime_start + options.max_time_offset_s * 1e6,
                    s.utime_end + options.max_time_offset_s * 1e6) &&
        gyro.Covers(s.utime_start - options.max_time_offset_s * 1e6,
                    s.utime_end - options.max_time_offset_s * 1e6))
      result.spans.push_back(s);
  std::vector<ImuSpan>& spans = result.spans;

  double bias0 = mount.gyro_bias, noise = mount.gyro_noise;
  StandstillGyro(spans, imu, gyro, imu_rate_hz, &bias0, &noise);
  result.gyro_noise = noise;

  const double rL0 = robot.param("left_radius"), rR0 = robot.param("right_radius"),
               b0 = robot.param("track");
  // The measured straight and turn.
  const double distance = options.distance_m ? *options.distance_m : mount.distance.value_or(0.0);
  if (!(distance > 0.0)) {
    throw UnobservableError(
        "scale (left_radius, right_radius): no measured straight distance",
        "measure the length of the first straight run and give it with --distance METRES "
        "(or imu.distance in the robot file)");
  }
  FindStraightAndTurn(spans, rL0, rR0, b0, options, &result);
  const bool with_scale = options.turn_angle_rad.has_value();
  if (with_scale && result.turn_span < 0) {
    throw UnobservableError("gyro_scale: a turn angle was given but the recording has no turn in place",
                            "turn in place by the measured angle");
  }
  result.distance_m = distance;

  const double s_held = mount.gyro_scale;
  const SpanResiduals span_residuals{gyro, spans, tick, noise, with_scale, s_held,
                                     result.straight_span, result.turn_span, distance, options};
  Eigen::VectorXd p(with_scale ? 5 : 4);
  p[0] = rL0, p[1] = rR0, p[2] = b0, p[3] = bias0;
  if (with_scale) p[4] = s_held;
  double offset_us = 0.0;
  std::vector<ImuSpan> work = spans;
  Fit fit;
  for (int round = 0; round < (options.estimate_time_offset ? 2 : 1); ++round) {
    fit = GaussNewton([&](const Eigen::VectorXd& q) { return span_residuals(q, offset_us, &work); }, p);
    p = fit.p;
    if (!options.estimate_time_offset || round == 1) break;
    result.time_offset = TimeOffset(spans, wheels, gyro, p, with_scale ? p[4] : s_held, options,
                                    mount.time_offset, &offset_us);
  }
  if (!options.estimate_time_offset) result.time_offset = MakeEstimate(mount.time_offset, 0.0, mount.time_offset);
  spans = work;

  const int n = static_cast<int>(p.size());
  const int dof = fit.rows - n;
  result.variance_factor = dof > 0 ? fit.chi2 / dof : 1.0;
  Eigen::MatrixXd cov = fit.information.inverse();
  if (dof > 0) cov *= std::max(1.0, result.variance_factor);
  const Eigen::VectorXd sd = cov.diagonal().cwiseSqrt();
  const Eigen::VectorXd scale = fit.information.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd corr_info = scale.asDiagonal() * fit.information * scale.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(corr_info);
  result.condition = eig.eigenvalues().maxCoeff() / std::max(eig.eigenvalues().minCoeff(), 1e-300);
  result.covariance = cov;
  result.estimated_names = {"left_radius", "right_radius", "track", "gyro_bias"};
  if (with_scale) result.estimated_names.push_back("gyro_scale");
  result.params["left_radius"] = MakeEstimate(p[0], sd[0], rL0);
  result.params["right_radius"] = MakeEstimate(p[1], sd[1], rR0);
  result.params["track"] = MakeEstimate(p[2], sd[2], b0);
  result.gyro_bias = MakeEstimate(p[3], sd[3], mount.gyro_bias);
  result.gyro_scale_estimated = with_scale;
  result.gyro_scale = with_scale ? MakeEstimate(p[4], sd[4], s_held) : MakeEstimate(s_held, 0.0, s_held);

  result.wheel_noise = WheelNoise(spans, p);
  result.yaw = MountYaw(spans, imu, wheels, p, mount.yaw);
  return result;
}

CalibrationResult ToCalibrationResult(const RobotDescription& robot, const ImuCalibrationResult& r) {
  CalibrationResult out;
  out.drive = robot.drive;
  out.source = MotionSource::kImu;
  out.param_names = ParamNames(robot.drive);
  out.params = r.params;
  ImuEstimates imu;
  imu.gyro_bias = r.gyro_bias;
  imu.gyro_scale = r.gyro_scale;
  imu.gyro_scale_estimated = r.gyro_scale_estimated;
  imu.yaw = r.yaw;
  imu.time_offset = r.time_offset;
  imu.gyro_noise = r.gyro_noise;
  imu.wheel_noise = r.wheel_noise;
  imu.distance_m = r.distance_m;
  out.imu = imu;
  int moving = 0;
  double sum2 = 0.0;
  for (const ImuSpan& s : r.spans) {
    if (!s.moving) continue;
    ++moving;
    sum2 += s.residual_rad * s.residual_rad;
  }
  out.residual.intervals = static_cast<int>(r.spans.size());
  out.residual.rms_yaw = moving ? std::sqrt(sum2 / moving) : 0.0;
  out.residual.variance_factor = r.variance_factor;
  out.condition = r.condition;
  out.estimated_names = r.estimated_names;
  out.covariance = r.covariance;
  for (const auto& [name, e] : r.params)
    if (!(e.std < 0.01 * e.value)) out.weak.push_back(name);
  if (!std::isfinite(r.yaw.std)) out.weak.push_back("imu.yaw");
  if (!std::isfinite(r.time_offset.std)) out.weak.push_back("imu.time_offset");
  return out;
}

}  // namespace calib
