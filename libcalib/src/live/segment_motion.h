#pragma once
// The motion of one trajectory segment as the commander drives it: the body twist and wheel
// speeds per unit of progress, scaled to the robot's limits, and the speed profile that covers
// the segment. Kept apart from the commander's phase plan and its execution (commander.cc).

#include <string>
#include <utility>
#include <vector>

#include "calib/core/kinematics.h"
#include "calib/core/robot.h"
#include "calib/live/commander.h"

namespace calib {

// Commands stay this far (relative) inside the limits, so rounding never crosses them.
constexpr double kLimitMargin = 1e-9;

// Trapezoidal (or triangular) profile of a progress rate: accelerate at `accel` to `peak`,
// cruise, decelerate to rest, covering `length`.
struct Profile {
  double length = 0.0, peak = 0.0, accel = 1.0;
  double t_ramp = 0.0, t_cruise = 0.0;

  static Profile Make(double length, double peak, double accel) {
    Profile p;
    p.length = std::max(length, 0.0);
    p.accel = accel;
    p.peak = peak;
    if (p.length <= 0.0) {
      p.peak = 0.0;
      return p;
    }
    if (p.length < peak * peak / accel) p.peak = std::sqrt(p.length * accel);
    p.t_ramp = p.peak / accel;
    p.t_cruise = std::max(0.0, (p.length - p.peak * p.peak / accel) / p.peak);
    return p;
  }
  double duration() const { return 2.0 * t_ramp + t_cruise; }
  double Rate(double t) const {
    if (t <= 0.0 || t >= duration()) return 0.0;
    if (t < t_ramp) return std::min(peak, accel * t);
    if (t < t_ramp + t_cruise) return peak;
    return std::min(peak, accel * (duration() - t));
  }
  double Progress(double t) const {
    if (t <= 0.0) return 0.0;
    if (t >= duration()) return length;
    if (t < t_ramp) return 0.5 * accel * t * t;
    if (t < t_ramp + t_cruise) return 0.5 * peak * t_ramp + peak * (t - t_ramp);
    const double left = duration() - t;
    return std::max(0.0, length - 0.5 * accel * left * left);
  }
};

// The motion of one segment per unit progress rate (1 m/s of the progress point, or 1 rad/s
// of turning for an angle segment), and its limits in progress units.
struct Motion {
  Twist2 xi;                        // body twist at the reference point
  std::vector<double> wheel_speed;  // rad/s (steered drives)
  std::vector<double> steer;        // true steering angle per role (steered drives)
  double length = 0.0;              // m or rad
  double peak = 0.0;                // progress units per s
  double accel = 0.0;               // progress units per s^2
};

// The wheels the commander drives (robot frame): contact points, steering offsets, and the
// point whose travel measures a distance segment.
struct CommandedWheels {
  DriveType drive = DriveType::kDifferential;
  std::vector<std::pair<double, double>> contacts;     // wheel contact points (x, y)
  std::vector<double> offsets;                         // raw = true + offset, per role
  std::pair<double, double> progress_point{0.0, 0.0};  // the reference point; wheel a1 for dual steer
};
CommandedWheels CommandedWheelsOf(const RobotDescription& robot);

// Row of the rolling constraint of a wheel at (x, y) with true steering angle `steer`: the
// contact-point velocity (vx - w y, vy + w x) has no component across the wheel.
struct Row {
  double a, b, c;
};
Row RollingConstraint(double x, double y, double steer);

// The motion of one segment per unit progress rate, within the robot's limits. Throws
// InputError (`origin`, `place`) for a segment the robot cannot drive.
Motion SegmentMotion(const TrajectorySegment& seg, const CommandedWheels& wheels, const DriveModel& model,
                     const Limits& lim, const std::string& origin, const std::string& place);

}  // namespace calib
