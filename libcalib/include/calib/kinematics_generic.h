#pragma once
// The kinematics of kinematics.h written once for any scalar type: double for
// the models, ceres::Jet for the solver's automatic derivatives. Everything
// here is the single definition of the body motion of each drive type; the
// DriveModel classes call it.

#include <cmath>

#include "calib/robot.h"

namespace calib::generic {

template <typename T>
struct Pose {
  T x, y, theta;
};

// a ⊕ b without wrapping (the solver differentiates through it).
template <typename T>
Pose<T> Compose(const Pose<T>& a, const Pose<T>& b) {
  using std::cos;
  using std::sin;
  const T c = cos(a.theta), s = sin(a.theta);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, a.theta + b.theta};
}

template <typename T>
Pose<T> Inverse(const Pose<T>& a) {
  using std::cos;
  using std::sin;
  const T c = cos(a.theta), s = sin(a.theta);
  return {-c * a.x - s * a.y, s * a.x - c * a.y, -a.theta};
}

// Motion along the arc of body displacement (dx, dy, dtheta) travelled at a
// constant rate: the exponential map of se(2).
template <typename T>
Pose<T> Exp(const T& dx, const T& dy, const T& dtheta) {
  using std::abs;
  using std::cos;
  using std::sin;
  T a, b;  // sin(t)/t and (1 - cos t)/t, with their series near t = 0
  if (abs(dtheta) < 1e-6) {
    a = T(1.0) - dtheta * dtheta / 6.0;
    b = dtheta / 2.0;
  } else {
    a = sin(dtheta) / dtheta;
    b = (T(1.0) - cos(dtheta)) / dtheta;
  }
  return {a * dx - b * dy, b * dx + a * dy, dtheta};
}

// Body displacement (dx, dy, dtheta) of the reference point for one encoder
// step: `params` in ParamNames(type) order, `rotation` the drive rotation of
// each wheel over the step (rad), `steer` each wheel's raw steering reading
// over the step (its mean). Also works for rates (speeds in, twist out).
template <typename T>
void BodyDisplacement(DriveType type, const T* params, const T* rotation, const T* steer,
                      T* dx, T* dy, T* dtheta) {
  using std::cos;
  using std::sin;
  switch (type) {
    case DriveType::kDifferential: {  // left_radius, right_radius, track
      const T left = params[0] * rotation[0], right = params[1] * rotation[1];
      *dx = 0.5 * (left + right);
      *dy = T(0.0);
      *dtheta = (right - left) / params[2];
      return;
    }
    case DriveType::kTricycle: {  // drive_radius, wheelbase, steer_offset
      // The rear axle follows the drive wheel's x component; its y component swings the body.
      const T d = params[0] * rotation[0], alpha = steer[0] - params[2];
      *dx = d * cos(alpha);
      *dy = T(0.0);
      *dtheta = d * sin(alpha) / params[1];
      return;
    }
    case DriveType::kDualSteer: {  // a1_radius, a1_steer_offset, b, a2_radius, a
      // Least squares over the four contact-point components, a1 at (b, 0), a2 at (0, -a):
      // v1 = (vx, vy + w b), v2 = (vx + w a, vy). The normal equations solve in closed form.
      const T b = params[2], a = params[4];
      const T s1 = params[0] * rotation[0], alpha1 = steer[0] - params[1];
      const T s2 = params[3] * rotation[1], alpha2 = steer[1];
      const T v1x = s1 * cos(alpha1), v1y = s1 * sin(alpha1);
      const T v2x = s2 * cos(alpha2), v2y = s2 * sin(alpha2);
      const T sum_x = v1x + v2x, sum_y = v1y + v2y;
      *dtheta = (2.0 * (b * v1y + a * v2x) - a * sum_x - b * sum_y) / (a * a + b * b);
      *dx = 0.5 * (sum_x - a * *dtheta);
      *dy = 0.5 * (sum_y - b * *dtheta);
      return;
    }
  }
}

}  // namespace calib::generic
