#pragma once
// The kinematics of kinematics.h written once for any scalar type: double for
// the models, ceres::Jet for the solver's automatic derivatives. Everything
// here is the single definition of the body motion of each drive type; the
// DriveModel classes call it.

#include <cmath>

#include "calib/core/robot.h"

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

// Dual steer: the weight of a wheel's sideways velocity against its rolling
// velocity in the compromise two fighting wheels reach. A tire resists slip
// along its rolling direction much more than sideways (cornering), and the
// ratio must be well below 1: with equal weights the compromise depends on a
// and b only through one combination, and no motion could separate them.
constexpr double kDualSteerCorneringCompliance = 0.1;

// x = n⁻¹ rhs for a symmetric positive definite 3×3 n, by cofactors (any scalar type).
template <typename T>
void SolveSymmetric3(const T (&n)[3][3], const T (&rhs)[3], T* x0, T* x1, T* x2) {
  const T c00 = n[1][1] * n[2][2] - n[1][2] * n[2][1];
  const T c01 = n[1][2] * n[2][0] - n[1][0] * n[2][2];
  const T c02 = n[1][0] * n[2][1] - n[1][1] * n[2][0];
  const T c11 = n[0][0] * n[2][2] - n[0][2] * n[2][0];
  const T c12 = n[0][1] * n[2][0] - n[0][0] * n[2][1];
  const T c22 = n[0][0] * n[1][1] - n[0][1] * n[1][0];
  const T det = n[0][0] * c00 + n[0][1] * c01 + n[0][2] * c02;
  *x0 = (c00 * rhs[0] + c01 * rhs[1] + c02 * rhs[2]) / det;
  *x1 = (c01 * rhs[0] + c11 * rhs[1] + c12 * rhs[2]) / det;
  *x2 = (c02 * rhs[0] + c12 * rhs[1] + c22 * rhs[2]) / det;
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
      // Two driven wheels over-determine the body motion (four equations, three unknowns);
      // when they disagree they fight and the body takes the compromise their tires allow:
      // the weighted least squares over the contact-point velocities, each wheel's rolling
      // (longitudinal) component stiff and its sideways (cornering) component compliant
      // (research/mismatch.md 1.11). a1 at (b, 0), a2 at (0, -a).
      const T alpha[2] = {steer[0] - params[1], steer[1]};
      const T rolled[2] = {params[0] * rotation[0], params[3] * rotation[1]};
      const T px[2] = {params[2], T(0.0)}, py[2] = {T(0.0), -params[4]};
      T n[3][3] = {{T(0.0), T(0.0), T(0.0)}, {T(0.0), T(0.0), T(0.0)}, {T(0.0), T(0.0), T(0.0)}};
      T rhs[3] = {T(0.0), T(0.0), T(0.0)};
      for (int i = 0; i < 2; ++i) {
        const T c = cos(alpha[i]), s = sin(alpha[i]);
        // Rows: velocity of the contact point along the wheel (= rolled) and across it (= 0).
        const T along[3] = {c, s, c * -py[i] + s * px[i]};
        const T across[3] = {-s, c, -s * -py[i] + c * px[i]};
        for (int r = 0; r < 3; ++r) {
          rhs[r] += along[r] * rolled[i];
          for (int k = 0; k < 3; ++k)
            n[r][k] += along[r] * along[k] + kDualSteerCorneringCompliance * across[r] * across[k];
        }
      }
      SolveSymmetric3(n, rhs, dx, dy, dtheta);
      return;
    }
  }
}

}  // namespace calib::generic
