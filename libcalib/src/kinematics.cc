#include "calib/kinematics.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Dense>

namespace calib {
namespace {

// Below this contact-point speed (m/s) a wheel's direction is noise; it keeps its zero steering.
constexpr double kStillSpeed = 1e-12;

void CheckSize(const std::vector<double>& values, std::size_t expected, const char* what) {
  if (values.size() != expected) {
    throw std::invalid_argument(std::string(what) + " has " + std::to_string(values.size()) +
                                " entries, expected one per wheel (" +
                                std::to_string(expected) + ")");
  }
}

// Steering angle of wheel i over an interval: the middle of its start and end readings, minus
// its offset (spec/robot.md).
double MeanSteer(const WheelIncrement& inc, std::size_t i, double offset) {
  return 0.5 * (inc.steer_start[i] + inc.steer_end[i]) - offset;
}

// A steered wheel that must move its contact point with velocity (vx, vy): true steering
// angle within [-pi/2, pi/2] and signed contact-point speed (m/s). Reversing the drive is
// always cheaper than swinging the wheel round by more than a quarter turn.
struct SteeredWheel {
  double speed = 0.0;
  double angle = 0.0;
};

SteeredWheel SteerFor(double vx, double vy) {
  if (std::hypot(vx, vy) < kStillSpeed) return {};
  SteeredWheel w{std::hypot(vx, vy), std::atan2(vy, vx)};
  if (w.angle > M_PI_2) {
    w.angle -= M_PI;
    w.speed = -w.speed;
  } else if (w.angle < -M_PI_2) {
    w.angle += M_PI;
    w.speed = -w.speed;
  }
  return w;
}

// --- differential ---------------------------------------------------------------------------

class DifferentialModel : public DriveModel {
 public:
  DifferentialModel(double left_radius, double right_radius, double track)
      : left_radius_(left_radius), right_radius_(right_radius), track_(track) {}

  DriveType type() const override { return DriveType::kDifferential; }
  std::vector<double> params() const override { return {left_radius_, right_radius_, track_}; }

  Pose2 Integrate(const WheelIncrement& inc) const override {
    CheckSize(inc.rotation, 2, "rotation");
    return ExpTwist(Body(left_radius_ * inc.rotation[0], right_radius_ * inc.rotation[1]),
                    1.0 /* interval */);
  }

  WheelSetpoint Inverse(const Twist2& t) const override {
    const double half = 0.5 * track_ * t.omega;
    return {{(t.vx - half) / left_radius_, (t.vx + half) / right_radius_}, {0.0, 0.0}};
  }

  Twist2 Forward(const WheelSetpoint& w) const override {
    CheckSize(w.speed, 2, "speed");
    return Body(left_radius_ * w.speed[0], right_radius_ * w.speed[1]);
  }

 private:
  // Body motion from the left and right contact-point travel (or speed).
  Twist2 Body(double left, double right) const {
    return {0.5 * (left + right), 0.0, (right - left) / track_};
  }

  double left_radius_, right_radius_, track_;
};

// --- tricycle -------------------------------------------------------------------------------

class TricycleModel : public DriveModel {
 public:
  TricycleModel(double drive_radius, double wheelbase, double steer_offset)
      : drive_radius_(drive_radius), wheelbase_(wheelbase), steer_offset_(steer_offset) {}

  DriveType type() const override { return DriveType::kTricycle; }
  std::vector<double> params() const override {
    return {drive_radius_, wheelbase_, steer_offset_};
  }

  Pose2 Integrate(const WheelIncrement& inc) const override {
    CheckSize(inc.rotation, 1, "rotation");
    CheckSize(inc.steer_start, 1, "steer_start");
    CheckSize(inc.steer_end, 1, "steer_end");
    return ExpTwist(Body(drive_radius_ * inc.rotation[0], MeanSteer(inc, 0, steer_offset_)),
                    1.0 /* interval */);
  }

  // The rear axle cannot slide sideways, so vy is dropped; the drive wheel's contact point
  // then moves with (vx, omega * wheelbase).
  WheelSetpoint Inverse(const Twist2& t) const override {
    const SteeredWheel w = SteerFor(t.vx, t.omega * wheelbase_);
    return {{w.speed / drive_radius_}, {w.angle + steer_offset_}};
  }

  Twist2 Forward(const WheelSetpoint& w) const override {
    CheckSize(w.speed, 1, "speed");
    CheckSize(w.steer, 1, "steer");
    return Body(drive_radius_ * w.speed[0], w.steer[0] - steer_offset_);
  }

 private:
  // Drive wheel travel d at true steering angle alpha: the rear axle point follows the wheel's
  // x component, and the wheel's y component swings the body about the rear axle.
  Twist2 Body(double d, double alpha) const {
    return {d * std::cos(alpha), 0.0, d * std::sin(alpha) / wheelbase_};
  }

  double drive_radius_, wheelbase_, steer_offset_;
};

// --- dual steer -----------------------------------------------------------------------------

class DualSteerModel : public DriveModel {
 public:
  DualSteerModel(double a1_radius, double a1_steer_offset, double b, double a2_radius, double a)
      : a1_radius_(a1_radius), a1_steer_offset_(a1_steer_offset), b_(b), a2_radius_(a2_radius),
        a_(a) {
    // Contact-point velocities (v1x, v1y, v2x, v2y) = A (vx, vy, omega), with a1 at (b, 0) and
    // a2 at (0, -a) and v_p = (vx - omega p_y, vy + omega p_x). det(A^T A) = 2 (a^2 + b^2).
    Eigen::Matrix<double, 4, 3> A;
    A << 1, 0, 0,
         0, 1, b_,
         1, 0, a_,
         0, 1, 0;
    pseudo_inverse_ = (A.transpose() * A).inverse() * A.transpose();
  }

  DriveType type() const override { return DriveType::kDualSteer; }
  std::vector<double> params() const override {
    return {a1_radius_, a1_steer_offset_, b_, a2_radius_, a_};
  }

  Pose2 Integrate(const WheelIncrement& inc) const override {
    CheckSize(inc.rotation, 2, "rotation");
    CheckSize(inc.steer_start, 2, "steer_start");
    CheckSize(inc.steer_end, 2, "steer_end");
    return ExpTwist(Body(a1_radius_ * inc.rotation[0], MeanSteer(inc, 0, a1_steer_offset_),
                         a2_radius_ * inc.rotation[1], MeanSteer(inc, 1, 0.0 /* no offset */)),
                    1.0 /* interval */);
  }

  WheelSetpoint Inverse(const Twist2& t) const override {
    const SteeredWheel w1 = SteerFor(t.vx, t.vy + t.omega * b_);
    const SteeredWheel w2 = SteerFor(t.vx + t.omega * a_, t.vy);
    return {{w1.speed / a1_radius_, w2.speed / a2_radius_},
            {w1.angle + a1_steer_offset_, w2.angle}};
  }

  Twist2 Forward(const WheelSetpoint& w) const override {
    CheckSize(w.speed, 2, "speed");
    CheckSize(w.steer, 2, "steer");
    return Body(a1_radius_ * w.speed[0], w.steer[0] - a1_steer_offset_, a2_radius_ * w.speed[1],
                w.steer[1]);
  }

 private:
  // Least-squares body motion from the two wheels' travel (or speed) s_i at true angle alpha_i:
  // four contact-point components, three unknowns; exact when the wheels agree.
  Twist2 Body(double s1, double alpha1, double s2, double alpha2) const {
    const Eigen::Vector4d v(s1 * std::cos(alpha1), s1 * std::sin(alpha1), s2 * std::cos(alpha2),
                            s2 * std::sin(alpha2));
    const Eigen::Vector3d twist = pseudo_inverse_ * v;
    return {twist[0], twist[1], twist[2]};
  }

  double a1_radius_, a1_steer_offset_, b_, a2_radius_, a_;
  Eigen::Matrix<double, 3, 4> pseudo_inverse_;
};

// --- construction ---------------------------------------------------------------------------

double Get(const std::map<std::string, double>& params, DriveType type, const std::string& key) {
  const auto it = params.find(key);
  if (it == params.end()) {
    throw std::invalid_argument(std::string("drive model ") + DriveTypeName(type) +
                                ": missing parameter " + key);
  }
  if (!std::isfinite(it->second)) {
    throw std::invalid_argument(std::string("drive model ") + DriveTypeName(type) +
                                ": parameter " + key + " is not finite");
  }
  return it->second;
}

void Require(bool ok, DriveType type, const std::string& problem) {
  if (!ok) {
    throw std::invalid_argument(std::string("drive model ") + DriveTypeName(type) + ": " + problem);
  }
}

}  // namespace

std::unique_ptr<DriveModel> MakeDriveModel(DriveType type,
                                           const std::map<std::string, double>& params) {
  std::vector<double> p;
  for (const std::string& key : ParamNames(type)) p.push_back(Get(params, type, key));
  switch (type) {
    case DriveType::kDifferential:
      Require(p[0] > 0 && p[1] > 0, type, "wheel radii must be positive");
      Require(p[2] > 0, type, "track must be positive");
      return std::make_unique<DifferentialModel>(p[0], p[1], p[2]);
    case DriveType::kTricycle:
      Require(p[0] > 0, type, "drive_radius must be positive");
      Require(p[1] != 0, type, "wheelbase must not be zero");
      return std::make_unique<TricycleModel>(p[0], p[1], p[2]);
    case DriveType::kDualSteer:
      Require(p[0] > 0 && p[3] > 0, type, "wheel radii must be positive");
      Require(p[2] != 0 || p[4] != 0, type,
              "a and b are both zero: the wheels coincide and cannot determine the rotation");
      return std::make_unique<DualSteerModel>(p[0], p[1], p[2], p[3], p[4]);
  }
  throw std::logic_error("unknown drive type");
}

std::unique_ptr<DriveModel> MakeDriveModel(const RobotDescription& robot) {
  return MakeDriveModel(robot.drive, robot.params);
}

}  // namespace calib
