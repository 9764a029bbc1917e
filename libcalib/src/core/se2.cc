#include "calib/core/se2.h"

#include "calib/core/kinematics_generic.h"

namespace calib {

double WrapAngle(double angle) {
  double a = std::remainder(angle, 2.0 * M_PI);  // in [-pi, pi]
  return a <= -M_PI ? a + 2.0 * M_PI : a;
}

Pose2 Compose(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, WrapAngle(a.theta + b.theta)};
}

Pose2 Inverse(const Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, WrapAngle(-a.theta)};
}

Pose2 Between(const Pose2& a, const Pose2& b) { return Compose(Inverse(a), b); }

Pose2 ExpTwist(const Twist2& twist, double dt) {
  const generic::Pose<double> p = generic::Exp(twist.vx * dt, twist.vy * dt, twist.omega * dt);
  return {p.x, p.y, WrapAngle(p.theta)};
}

Twist2 LogTwist(const Pose2& motion, double dt) {
  const double t = WrapAngle(motion.theta);
  // Exp maps (vx, vy) dt through [a -b; b a], with (a, b) its image of a unit step along x.
  const generic::Pose<double> unit = generic::Exp(1.0, 0.0, t);
  const double a = unit.x, b = unit.y;
  const double k = 1.0 / ((a * a + b * b) * dt);
  return {k * (a * motion.x + b * motion.y), k * (-b * motion.x + a * motion.y), t / dt};
}

Pose2 Interpolate(const Pose2& a, const Pose2& b, double s) {
  return {a.x + s * (b.x - a.x), a.y + s * (b.y - a.y),
          WrapAngle(a.theta + s * WrapAngle(b.theta - a.theta))};
}

}  // namespace calib
