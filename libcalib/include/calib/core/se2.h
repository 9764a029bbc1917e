#pragma once
// Planar rigid motions (SE(2)) used throughout libcalib.

#include <cmath>

namespace calib {

// A pose or a relative motion in the plane: translation (m) and heading (rad).
struct Pose2 {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;
};

// Body velocity at a reference point: vx, vy (m/s) in the body frame, omega (rad/s).
struct Twist2 {
  double vx = 0.0;
  double vy = 0.0;
  double omega = 0.0;
};

// Angle wrapped into (-pi, pi].
double WrapAngle(double angle);

// a ⊕ b: b expressed in a's frame, carried into a's parent frame.
Pose2 Compose(const Pose2& a, const Pose2& b);

// The inverse motion: Compose(a, Inverse(a)) is the identity.
Pose2 Inverse(const Pose2& a);

// Motion from a to b expressed in a's frame: Inverse(a) ⊕ b.
Pose2 Between(const Pose2& a, const Pose2& b);

// Exponential map: the motion after moving with a constant body twist for
// `dt` seconds, i.e. along a circular arc (a straight line when omega = 0).
// Exact, not an Euler step.
Pose2 ExpTwist(const Twist2& twist, double dt);

// Inverse of ExpTwist: the constant body twist that moves by `motion` in `dt`
// seconds (dt > 0; |motion.theta| < pi).
Twist2 LogTwist(const Pose2& motion, double dt);

// Linear interpolation between poses, shortest way round for the heading; s in [0, 1].
Pose2 Interpolate(const Pose2& a, const Pose2& b, double s);

}  // namespace calib
