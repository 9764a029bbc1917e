#include "sim/wheel_physics.h"

#include <algorithm>
#include <cmath>

namespace calib {
namespace {

// One step of a first-order lag towards `target`, held over the step: the exact solution, its
// value at the step's end (returned) and its mean over the step (`mean`), which is what moves
// the robot during the step.
double StepFirstOrderLag(double from, double target, double dt, double tau, double* mean) {
  const double decay = std::exp(-dt / tau);
  *mean = target + (from - target) * (tau / dt) * (1.0 - decay);
  return target + (from - target) * decay;
}

}  // namespace

bool Inside(const std::optional<std::array<double, 4>>& region, const Pose2& p) {
  return !region || (p.x >= (*region)[0] && p.x <= (*region)[2] && p.y >= (*region)[1] && p.y <= (*region)[3]);
}

WheelMotion StepWheel(WheelState* wheel, const SimEffects& fx, const std::string& role, bool steered,
                      double radius, const Pose2& pose, double dt) {
  WheelState& w = *wheel;
  WheelMotion out;
  const bool this_wheel_steer = fx.steering_wheel.empty() || fx.steering_wheel == role;
  // Actuation: drive_lag and steering_rate_limit. The wheel turns over the step at the lag's
  // mean speed, not its end speed: with the end speed a lag as short as the step reads as
  // dt e^(-dt/tau) / (1 - e^(-dt/tau)), 1.7 ms for tau 4.4 ms at a 7.2 ms step.
  double mean_omega = w.omega_target;
  if (fx.drive_lag_tau_s > 0) {
    const double from = w.omega;
    w.omega = StepFirstOrderLag(from, w.omega_target, dt, fx.drive_lag_tau_s, &mean_omega);
  } else {
    w.omega = w.omega_target;
  }
  double steer_over_step = w.steer_lagged;  // the wheel's mean angle over the step
  if (steered) {
    double step = w.steer_target - w.steer_reading;
    if (fx.steering_rate_limit_rad_s > 0 && this_wheel_steer) {
      const double max_step = fx.steering_rate_limit_rad_s * dt;
      step = std::clamp(step, -max_step, max_step);
    }
    if (step != 0.0) w.last_motion_sign = step > 0 ? 1.0 : -1.0;
    w.steer_reading += step;
    // Between encoder and wheel: steering_lag, steering_backlash.
    steer_over_step = w.steer_reading;
    if (fx.steering_lag_tau_s > 0 && this_wheel_steer)
      w.steer_lagged = StepFirstOrderLag(w.steer_lagged, w.steer_reading, dt, fx.steering_lag_tau_s,
                                         &steer_over_step);
    else
      w.steer_lagged = w.steer_reading;
  }
  double wheel_angle_raw = steer_over_step;
  if (steered && this_wheel_steer)
    wheel_angle_raw -= w.last_motion_sign * fx.steering_backlash_width_rad / 2.0;
  out.true_raw = steered ? wheel_angle_raw : 0.0;

  // Rolling: wheel_eccentricity and longitudinal_slip change the contact
  // point's speed over ground, r w (1 + A cos(phi - phase)) (1 - k a).
  const double v = radius * w.omega;  // at the step's end
  double eccentric = 1.0;
  if (fx.eccentricity_amplitude != 0 &&
      (fx.eccentricity_wheel.empty() || fx.eccentricity_wheel == role))
    eccentric += fx.eccentricity_amplitude * std::cos(w.phi - fx.eccentricity_phase);
  double slip = 0.0;  // k a v, m/s
  if (fx.longitudinal_slip_per_accel != 0 && Inside(fx.longitudinal_slip_region, pose) &&
      (fx.longitudinal_slip_wheel.empty() || fx.longitudinal_slip_wheel == role)) {
    // a = d(r w)/dt. A speed change happens at the start of a step, so the
    // distance slipped over the step, k * integral(a v dt), is k (v^2 - v_prev^2) / 2:
    // the slip term takes the step's mean speed. (With the new speed alone a ramp of
    // n command steps loses (1 + 1/n) times too much while accelerating, and a
    // start-stop run does not get its slip back while braking.)
    const double accel = (v - w.rolling_speed) / dt;
    slip = fx.longitudinal_slip_per_accel * accel * 0.5 * (v + w.rolling_speed);
  }
  w.rolling_speed = v;
  const double ground = eccentric * (radius * mean_omega - slip);
  out.effective_omega = ground / radius;
  w.phi += mean_omega * dt;
  return out;
}

}  // namespace calib
