#include "calib/se2.h"

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
  const double dtheta = twist.omega * dt;
  const double dx = twist.vx * dt, dy = twist.vy * dt;
  // sin(t)/t and (1 - cos t)/t, with their series near t = 0.
  double a, b;
  if (std::abs(dtheta) < 1e-6) {
    a = 1.0 - dtheta * dtheta / 6.0;
    b = dtheta / 2.0;
  } else {
    a = std::sin(dtheta) / dtheta;
    b = (1.0 - std::cos(dtheta)) / dtheta;
  }
  return {a * dx - b * dy, b * dx + a * dy, WrapAngle(dtheta)};
}

Twist2 LogTwist(const Pose2& motion, double dt) {
  const double t = WrapAngle(motion.theta);
  double a, b;
  if (std::abs(t) < 1e-6) {
    a = 1.0 - t * t / 6.0;
    b = t / 2.0;
  } else {
    a = std::sin(t) / t;
    b = (1.0 - std::cos(t)) / t;
  }
  // [x; y] = [a -b; b a] [vx; vy] dt.
  const double k = 1.0 / ((a * a + b * b) * dt);
  return {k * (a * motion.x + b * motion.y), k * (-b * motion.x + a * motion.y), t / dt};
}

Pose2 Interpolate(const Pose2& a, const Pose2& b, double s) {
  return {a.x + s * (b.x - a.x), a.y + s * (b.y - a.y),
          WrapAngle(a.theta + s * WrapAngle(b.theta - a.theta))};
}

}  // namespace calib
