#pragma once
// One simulated wheel over one physics step: its actuation (drive lag, steering rate limit,
// steering lag and backlash) and its rolling over the ground (eccentricity, longitudinal slip),
// as spec/effects.md describes them. The simulator turns the wheels' motion into the body's.

#include <array>
#include <optional>
#include <string>

#include "calib/core/se2.h"
#include "calib/sim/simulator.h"

namespace calib {

// True steering angle dynamics of one wheel (spec/effects.md: steering_lag,
// steering_backlash act between the encoder and the wheel).
struct WheelState {
  double phi = 0.0;           // true accumulated rotation, rad
  double omega = 0.0;         // actual angular speed, rad/s
  double rolling_speed = 0.0; // r * omega over the previous physics step, m/s
  double steer_reading = 0.0; // raw steering encoder angle (actuator position), rad
  double steer_lagged = 0.0;  // reading after the steering lag, rad
  // steering_backlash: sign(last steering motion); none yet, so the wheel sits at the
  // reading until the steering first moves (the side of the play is unknown before).
  double last_motion_sign = 0.0;
  double omega_target = 0.0, steer_target = 0.0;  // setpoints in force (after any ramp)
  double omega_from = 0.0, steer_from = 0.0;      // commands.between ramp: setpoints when the command came
};

// What a wheel did over a step, as the true kinematic model takes it.
struct WheelMotion {
  double effective_omega = 0.0;  // rad/s: the contact point's mean speed over ground / radius
  double true_raw = 0.0;         // the wheel's true raw steering angle over the step, rad (0 unsteered)
};

// Advances `wheel` (of role `role`, wheel radius `radius` m, steered or not) by `dt` s towards
// its setpoints, with the effects `fx`; `pose` is the robot's for the slip regions.
WheelMotion StepWheel(WheelState* wheel, const SimEffects& fx, const std::string& role, bool steered,
                      double radius, const Pose2& pose, double dt);

// Whether `p` lies in an effect's region ([x0, y0, x1, y1], world); no region: everywhere.
bool Inside(const std::optional<std::array<double, 4>>& region, const Pose2& p);

}  // namespace calib
