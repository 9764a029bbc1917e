#include "calib/calibrate/closed_form.h"

#include <cmath>

#include <Eigen/Dense>

#include "calib/core/kinematics_generic.h"

namespace calib {
namespace {

// Beyond this condition number of the (column-normalised) 2x2 normal matrix the
// rotation step is not excited: all intervals turn at one curvature.
constexpr double kMaxRotationCondition = 1e4;
// Dual steer: intervals where a2 stands within this of zero steering, rad.
constexpr double kA2StraightRad = 0.02;

double MeanSteer(const WheelIncrement& step, std::size_t wheel) {
  return 0.5 * (step.steer_start[wheel] + step.steer_end[wheel]);
}

// The two regressors of the rotation step of an interval (see closed_form.h).
Eigen::Vector2d RotationRegressors(DriveType type, const MotionInterval& interval) {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  for (const WheelIncrement& step : interval.steps()) {
    if (type == DriveType::kDifferential) {
      a += Eigen::Vector2d(step.rotation[0], step.rotation[1]);
    } else {  // the steered (drive / a1) wheel
      const double alpha = MeanSteer(step, 0);
      a += step.rotation[0] * Eigen::Vector2d(std::sin(alpha), -std::cos(alpha));
    }
  }
  return a;
}

// Motion of the reference point over an interval under a single-wheel model:
// differential with (r_L, r_R, b), or a tricycle on the first wheel with
// (r, L, offset). `forward` accumulates the path's x component (for dual steer).
Pose2 IntegrateSteps(DriveType type, const double* params, const MotionInterval& interval,
                     double* forward) {
  generic::Pose<double> pose{0.0, 0.0, 0.0};
  *forward = 0.0;
  for (const WheelIncrement& step : interval.steps()) {
    double dx, dy, dtheta;
    const double steer = step.steer_start.empty() ? 0.0 : MeanSteer(step, 0);
    generic::BodyDisplacement(type, params, step.rotation.data(), &steer, &dx, &dy, &dtheta);
    pose = generic::Compose(pose, generic::Exp(dx, dy, dtheta));
    *forward += dx;
  }
  return {pose.x, pose.y, pose.theta};
}

double Condition(const Eigen::Matrix2d& normal) {
  const Eigen::Vector2d d = normal.diagonal().cwiseSqrt();
  if (d.minCoeff() <= 0) return INFINITY;
  const Eigen::Matrix2d c = d.asDiagonal().inverse() * normal * d.asDiagonal().inverse();
  const Eigen::Vector2d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(c).eigenvalues();
  return ev[0] <= 0 ? INFINITY : ev[1] / ev[0];
}

// Dual steer: only where a2 points straight ahead does the a1 tricycle model hold.
std::vector<const MotionInterval*> UsableIntervals(DriveType type, const std::vector<MotionInterval>& all) {
  std::vector<const MotionInterval*> intervals;
  for (const MotionInterval& m : all) {
    const std::vector<WheelIncrement> steps = m.steps();
    if (steps.empty()) continue;
    bool use = true;
    if (type == DriveType::kDualSteer) {
      for (const WheelIncrement& s : steps) use = use && std::abs(MeanSteer(s, 1)) < kA2StraightRad;
    }
    if (use) intervals.push_back(&m);
  }
  return intervals;
}

// 3. (dual steer) a2 travels W's forward path plus a times the rotation: x = (a2_radius, a)
// from the intervals, their `forward` paths at unit scale and the scale `s`; false when the
// travel does not separate the two.
bool SecondWheel(const std::vector<const MotionInterval*>& intervals, const std::vector<double>& forward,
                 double s, Eigen::Vector2d* x) {
  Eigen::Matrix2d n2 = Eigen::Matrix2d::Zero();
  Eigen::Vector2d r2 = Eigen::Vector2d::Zero();
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    double phi2 = 0.0;
    for (const WheelIncrement& st : intervals[k]->steps()) phi2 += st.rotation[1];
    const Eigen::Vector2d row(phi2, -intervals[k]->sensor_motion.theta);
    n2 += row * row.transpose();
    r2 += row * (s * forward[k]);
  }
  if (!(Condition(n2) < kMaxRotationCondition)) return false;
  *x = n2.ldlt().solve(r2);
  return true;
}

}  // namespace

ClosedFormEstimate ClosedFormCalibration(DriveType type,
                                         const std::map<std::string, double>& nominal,
                                         const std::vector<MotionInterval>& all) {
  ClosedFormEstimate out;
  const std::vector<const MotionInterval*> intervals = UsableIntervals(type, all);
  if (intervals.size() < 10) {
    out.problem = type == DriveType::kDualSteer
                      ? "fewer than 10 intervals with a2 at zero steering"
                      : "fewer than 10 intervals";
    return out;
  }

  // 1. Rotation.
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  for (const MotionInterval* m : intervals) {
    const Eigen::Vector2d a = RotationRegressors(type, *m);
    normal += a * a.transpose();
    rhs += a * m->sensor_motion.theta;
  }
  out.rotation_condition = Condition(normal);
  if (!(out.rotation_condition < kMaxRotationCondition)) {
    out.problem = "the heading changes do not separate the rotation parameters (condition " +
                  std::to_string(out.rotation_condition) + ")";
    return out;
  }
  Eigen::Vector2d p = normal.ldlt().solve(rhs);

  // Unit-scale parameters: the translation is then the scale s times the integrated motion.
  double unit[3];
  double ratio = 0.0, offset = 0.0;
  if (type == DriveType::kDifferential) {
    unit[0] = -p[0];  // r_L / b
    unit[1] = p[1];   // r_R / b
    unit[2] = 1.0;
  } else {
    // p = (r/L) (cos offset, sin offset); the sign of L (or b) comes from the nominal values.
    const double nominal_base = type == DriveType::kTricycle ? nominal.at("wheelbase") : nominal.at("b");
    if (nominal_base < 0) p = -p;
    offset = std::atan2(p[1], p[0]);
    ratio = p.norm() * (nominal_base < 0 ? -1.0 : 1.0);
    unit[0] = 1.0;
    unit[1] = 1.0 / ratio;
    unit[2] = offset;
  }
  const DriveType step_type = type == DriveType::kDifferential ? type : DriveType::kTricycle;

  // 2. Translation: rows of M_k x = 0, x = (s, l_x, l_y, cos l_theta, sin l_theta).
  Eigen::Matrix<double, 5, 5> Q = Eigen::Matrix<double, 5, 5>::Zero();
  std::vector<double> forward(intervals.size());
  for (std::size_t k = 0; k < intervals.size(); ++k) {
    const MotionInterval& m = *intervals[k];
    const Pose2 c = IntegrateSteps(step_type, unit, m, &forward[k]);
    const double th = m.sensor_motion.theta, zx = m.sensor_motion.x, zy = m.sensor_motion.y;
    Eigen::Matrix<double, 2, 5> M;
    M << c.x, -(1 - std::cos(th)), -std::sin(th), -zx, zy,
         c.y, std::sin(th), -(1 - std::cos(th)), -zy, -zx;
    Q += M.transpose() * M;
  }
  const Eigen::Matrix3d A = Q.topLeftCorner<3, 3>();
  const Eigen::Matrix<double, 3, 2> B = Q.topRightCorner<3, 2>();
  const Eigen::Matrix2d C = Q.bottomRightCorner<2, 2>();
  Eigen::FullPivLU<Eigen::Matrix3d> lu(A);
  if (!lu.isInvertible()) {
    out.problem = "the translations do not determine the scale and the sensor position";
    return out;
  }
  const Eigen::Matrix<double, 3, 2> AinvB = lu.solve(B);
  const Eigen::Matrix2d S = C - B.transpose() * AinvB;
  Eigen::Vector2d w = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(S).eigenvectors().col(0);
  Eigen::Vector3d u = -AinvB * w;
  if (u[0] < 0) {  // the scale (track or radius) is positive
    u = -u;
    w = -w;
  }
  const double s = u[0];
  out.mount = {u[1], u[2], std::atan2(w[1], w[0])};

  switch (type) {
    case DriveType::kDifferential:
      out.params = {{"left_radius", unit[0] * s}, {"right_radius", unit[1] * s}, {"track", s}};
      break;
    case DriveType::kTricycle:
      out.params = {{"drive_radius", s}, {"wheelbase", s / ratio}, {"steer_offset", offset}};
      break;
    case DriveType::kDualSteer: {
      // 3. The a2 wheel's radius and position a.
      Eigen::Vector2d x;
      if (!SecondWheel(intervals, forward, s, &x)) {
        out.problem = "the a2 wheel's travel does not separate its radius from a";
        return out;
      }
      out.params = {{"a1_radius", s}, {"a1_steer_offset", offset}, {"b", s / ratio},
                    {"a2_radius", x[0]}, {"a", x[1]}};
      break;
    }
  }
  for (const auto& [name, value] : out.params) {
    if (!std::isfinite(value)) {
      out.problem = name + " came out non-finite";
      return out;
    }
  }
  out.ok = true;
  return out;
}

}  // namespace calib
