// Plausible sizes of the candidates from the recording and the robot file (diagnose_plausible.h).

#include "diagnose/diagnose_plausible.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "diagnose/diagnose_fit.h"
#include "diagnose/diagnose_model.h"

namespace calib::diag {
namespace {

// A high quantile, not the largest value: one encoder glitch or failed match must not set it.
constexpr double kQuantile = 0.95;

double HighQuantile(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(kQuantile * double(v.size())));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// 1 / x, or infinity (nothing bounds the size) when the recording never shows x.
double Reciprocal(double x) { return x > 0 ? 1.0 / x : INFINITY; }

}  // namespace

PlausibleSizes Plausible(const RobotDescription& robot, const DiagnoseData& data, double max_offset_s) {
  PlausibleSizes out;
  out.time_offset = max_offset_s;
  const Track tr = MakeTrack(robot, data.wheels);
  // The wheels' rim accelerations (the slip model's a), from the diagnosis's own speeds.
  std::vector<double> accel, reversal_gaps;
  double steer_lo = INFINITY, steer_hi = -INFINITY;
  const std::size_t k = std::size_t(std::max(1, tr.speed_window.k));
  for (int w = 0; w < tr.wheels; ++w) {
    const double r = robot.params.at(RadiusParamName(WheelRoles(robot.drive)[w]));
    for (std::size_t i = k; i + k < tr.size(); ++i) {
      const double span = (tr.utime(i + k) - tr.utime(i - k)) * 1e-6;
      if (span > 0) accel.push_back(std::abs(r * (tr.speed[i + k][w] - tr.speed[i - k][w]) / span));
    }
    if (!tr.steered[w]) continue;
    double last_reversal = NAN;
    for (std::size_t i = 0; i < tr.size(); ++i) {
      steer_lo = std::min(steer_lo, tr.steer(i, w)), steer_hi = std::max(steer_hi, tr.steer(i, w));
      if (i > 0 && tr.steer_sign[i][w] != tr.steer_sign[i - 1][w] && tr.steer_sign[i - 1][w] != 0) {
        const double t = tr.utime(i) * 1e-6;
        if (std::isfinite(last_reversal)) reversal_gaps.push_back(t - last_reversal);
        last_reversal = t;
      }
    }
  }
  out.slip = Reciprocal(HighQuantile(accel));
  // The sensor's turn rates (any drive, any source).
  std::vector<double> turn_rate;
  for (const SensorMotion& m : data.motions) {
    const double dt = (m.utime_end - m.utime_start) * 1e-6;
    if (m.valid && dt > 0) turn_rate.push_back(std::abs(m.delta.theta) / dt);
  }
  out.lateral = Reciprocal(HighQuantile(turn_rate));
  // A steering that never reverses bounds no lag.
  out.steering_lag = reversal_gaps.empty() ? INFINITY : HighQuantile(reversal_gaps);
  out.steering_angle = steer_hi > steer_lo ? steer_hi - steer_lo : 0.0;
  out.scan_period = data.scan_period_s;
  return out;
}

}  // namespace calib::diag
