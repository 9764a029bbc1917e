#include "live/segment_motion.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "calib/core/errors.h"
#include "calib/core/units.h"

namespace calib {
namespace {

// Below this, a speed (m/s per unit progress rate) counts as zero.
constexpr double kTiny = 1e-9;

double PointSpeed(const Twist2& t, double x, double y) {
  return std::hypot(t.vx - t.omega * y, t.vy + t.omega * x);
}

// The direction of a steered drive's motion for the segment's steering angles (any scale,
// signed by the segment's speed): the twist both wheels' rolling constraints allow.
Twist2 SteeredDirection(const TrajectorySegment& seg, const CommandedWheels& wheels, const Limits& lim,
                        const std::string& origin, const std::string& place) {
  const size_t n = WheelRoles(wheels.drive).size();
  if (seg.steer.size() != n) {
    throw InputError(origin, place, "needs one steering angle per wheel role");
  }
  for (double a : seg.steer) {
    if (!(std::abs(a) <= lim.max_steer)) {
      throw InputError(origin, place,
                       Formatted("steering angle %.3f rad beyond max_steer %.3f rad", a,
                           lim.max_steer));
    }
  }
  if (seg.speed == 0.0) throw InputError(origin, place, "needs a non-zero speed");
  Row r[2];
  if (wheels.drive == DriveType::kTricycle) {
    r[0] = {0.0, 1.0, 0.0};  // the rear axle does not slide sideways
    r[1] = RollingConstraint(wheels.contacts[0].first, wheels.contacts[0].second, seg.steer[0]);
  } else {
    r[0] = RollingConstraint(wheels.contacts[0].first, wheels.contacts[0].second, seg.steer[0]);
    r[1] = RollingConstraint(wheels.contacts[1].first, wheels.contacts[1].second, seg.steer[1]);
  }
  // The twist both constraints allow: their cross product.
  Twist2 dir = {r[0].b * r[1].c - r[0].c * r[1].b, r[0].c * r[1].a - r[0].a * r[1].c,
                r[0].a * r[1].b - r[0].b * r[1].a};
  const double norm = std::hypot(dir.vx, dir.vy, dir.omega);
  const double scale = std::hypot(r[0].a, r[0].b, r[0].c) * std::hypot(r[1].a, r[1].b, r[1].c);
  if (norm < 1e-3 * scale) {
    throw InputError(origin, place,
                     "the steering angles do not determine the motion (degenerate geometry)");
  }
  // Orient it so that the first steered wheel rolls forwards, then apply the sign of travel.
  const double wx = wheels.contacts[0].first, wy = wheels.contacts[0].second;
  double along = (dir.vx - dir.omega * wy) * std::cos(seg.steer[0]) +
                 (dir.vy + dir.omega * wx) * std::sin(seg.steer[0]);
  if (std::abs(along) < 1e-9 * norm && wheels.drive == DriveType::kDualSteer) {
    const double x2 = wheels.contacts[1].first, y2 = wheels.contacts[1].second;
    along = (dir.vx - dir.omega * y2) * std::cos(seg.steer[1]) +
            (dir.vy + dir.omega * x2) * std::sin(seg.steer[1]);
  }
  const double sign = (along < 0 ? -1.0 : 1.0) * (seg.speed < 0 ? -1.0 : 1.0);
  return {sign * dir.vx, sign * dir.vy, sign * dir.omega};
}

}  // namespace

CommandedWheels CommandedWheelsOf(const RobotDescription& robot) {
  CommandedWheels w;
  w.drive = robot.drive;
  switch (w.drive) {
    case DriveType::kDifferential: {
      const double half = 0.5 * robot.param("track");
      w.contacts = {{0.0, half}, {0.0, -half}};
      w.offsets = {0.0, 0.0};
      break;
    }
    case DriveType::kTricycle:
      w.contacts = {{robot.param("wheelbase"), 0.0}};
      w.offsets = {robot.param("steer_offset")};
      break;
    case DriveType::kDualSteer:
      w.contacts = {{robot.param("b"), 0.0}, {0.0, -robot.param("a")}};
      w.offsets = {robot.param("a1_steer_offset"), 0.0};
      w.progress_point = w.contacts[0];
      break;
  }
  return w;
}

Row RollingConstraint(double x, double y, double steer) {
  const double s = std::sin(steer), c = std::cos(steer);
  return {-s, c, s * y + c * x};
}

// The motion of one segment per unit progress rate, within the robot's limits.
Motion SegmentMotion(const TrajectorySegment& seg, const CommandedWheels& wheels, const DriveModel& model,
                     const Limits& lim, const std::string& origin, const std::string& place) {
  const size_t n = WheelRoles(wheels.drive).size();
  const bool by_angle = seg.angle > 0.0;
  if (!(seg.distance >= 0.0 && seg.angle >= 0.0 && seg.pause_s >= 0.0) ||
      (!by_angle && seg.distance <= 0.0)) {
    throw InputError(origin, place, "needs a positive distance or angle and a pause >= 0");
  }
  Motion m;
  m.length = by_angle ? seg.angle : seg.distance;
  // Direction of the motion (any scale) and the requested peak of its progress rate.
  Twist2 dir;
  double request = std::abs(seg.speed);
  if (wheels.drive == DriveType::kDifferential) {
    dir = {seg.speed, 0.0, seg.omega};
    if (by_angle) request = std::abs(seg.omega);
  } else {
    dir = SteeredDirection(seg, wheels, lim, origin, place);
  }
  // Normalise to one unit of progress per second.
  const double unit = by_angle ? std::abs(dir.omega)
                               : PointSpeed(dir, wheels.progress_point.first, wheels.progress_point.second);
  if (!(unit > kTiny * std::max(1.0, std::hypot(dir.vx, dir.vy, dir.omega)))) {
    throw InputError(origin, place,
                     by_angle ? "an angle segment must turn" : "a distance segment must move");
  }
  m.xi = {dir.vx / unit, dir.vy / unit, dir.omega / unit};
  if (wheels.drive != DriveType::kDifferential && by_angle) {
    // The requested speed is of the progress point; express it as a turn rate.
    request *= std::abs(m.xi.omega) /
               std::max(kTiny, PointSpeed(m.xi, wheels.progress_point.first, wheels.progress_point.second));
  }
  // The fastest point (reference point or a wheel) bounds speed and acceleration.
  double fastest = PointSpeed(m.xi, 0.0, 0.0);
  for (const auto& c : wheels.contacts) fastest = std::max(fastest, PointSpeed(m.xi, c.first, c.second));
  double peak = request;
  if (fastest > kTiny) peak = std::min(peak, lim.max_speed / fastest);
  if (std::abs(m.xi.omega) > kTiny) peak = std::min(peak, lim.max_omega / std::abs(m.xi.omega));
  m.peak = peak * (1.0 - kLimitMargin);
  m.accel = lim.max_accel / std::max(fastest, kTiny) * (1.0 - kLimitMargin);
  if (!(m.peak > 0.0)) throw InputError(origin, place, "has no speed");
  if (wheels.drive != DriveType::kDifferential) {
    m.steer = seg.steer;
    const WheelSetpoint ws = model.Inverse(m.xi);
    m.wheel_speed = ws.speed;
    for (size_t i = 0; i < n; ++i) {
      // Inverse() may point a wheel the other way round and reverse its drive instead.
      const double diff = ws.steer[i] - wheels.offsets[i] - seg.steer[i];
      if (std::cos(diff) < 0.0) m.wheel_speed[i] = -m.wheel_speed[i];
      const double contact = PointSpeed(m.xi, wheels.contacts[i].first, wheels.contacts[i].second);
      if (contact > 1e-6 && std::abs(std::sin(diff)) > 1e-6) {
        throw std::logic_error(origin + ": " + place +
                               ": kinematic model disagrees with the steering geometry");
      }
    }
  }
  return m;
}

}  // namespace calib
