#include "calib/core/kinematics.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <utility>

#include "calib/core/kinematics_generic.h"

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

// Mean raw steering reading of each wheel over an interval (0 for wheels that do not steer).
std::vector<double> MeanSteer(const WheelIncrement& inc) {
  std::vector<double> steer(inc.rotation.size(), 0.0);
  for (std::size_t i = 0; i < steer.size() && i < inc.steer_start.size(); ++i)
    steer[i] = 0.5 * (inc.steer_start[i] + inc.steer_end[i]);
  return steer;
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

// Integrate and Forward of every drive type: the body motion of kinematics_generic.h.
// Subclasses add the inverse, which differs per type.
class GenericModel : public DriveModel {
 public:
  GenericModel(DriveType type, std::vector<double> params)
      : type_(type), params_(std::move(params)) {}

  DriveType type() const override { return type_; }
  std::vector<double> params() const override { return params_; }

  Pose2 Integrate(const WheelIncrement& inc) const override {
    const std::size_t n = roles().size();
    CheckSize(inc.rotation, n, "rotation");
    if (type_ != DriveType::kDifferential) {
      CheckSize(inc.steer_start, n, "steer_start");
      CheckSize(inc.steer_end, n, "steer_end");
    }
    const Twist2 body = Body(inc.rotation, MeanSteer(inc));
    return ExpTwist(body, 1.0 /* interval */);
  }

  Twist2 Forward(const WheelSetpoint& w) const override {
    const std::size_t n = roles().size();
    CheckSize(w.speed, n, "speed");
    if (type_ != DriveType::kDifferential) CheckSize(w.steer, n, "steer");
    return Body(w.speed, w.steer.size() == n ? w.steer : std::vector<double>(n, 0.0));
  }

 protected:
  double p(std::size_t i) const { return params_[i]; }

 private:
  Twist2 Body(const std::vector<double>& rotation, const std::vector<double>& steer) const {
    Twist2 t;
    generic::BodyDisplacement(type_, params_.data(), rotation.data(), steer.data(), &t.vx, &t.vy,
                              &t.omega);
    return t;
  }

  DriveType type_;
  std::vector<double> params_;
};

// left_radius, right_radius, track
class DifferentialModel : public GenericModel {
 public:
  using GenericModel::GenericModel;
  WheelSetpoint Inverse(const Twist2& t) const override {
    const double half = 0.5 * p(2) * t.omega;
    return {{(t.vx - half) / p(0), (t.vx + half) / p(1)}, {0.0, 0.0}};
  }
};

// drive_radius, wheelbase, steer_offset
class TricycleModel : public GenericModel {
 public:
  using GenericModel::GenericModel;
  // The rear axle cannot slide sideways, so vy is dropped; the drive wheel's contact point
  // then moves with (vx, omega * wheelbase).
  WheelSetpoint Inverse(const Twist2& t) const override {
    const SteeredWheel w = SteerFor(t.vx, t.omega * p(1));
    return {{w.speed / p(0)}, {w.angle + p(2)}};
  }
};

// a1_radius, a1_steer_offset, b, a2_radius, a
class DualSteerModel : public GenericModel {
 public:
  using GenericModel::GenericModel;
  WheelSetpoint Inverse(const Twist2& t) const override {
    const SteeredWheel w1 = SteerFor(t.vx, t.vy + t.omega * p(2));
    const SteeredWheel w2 = SteerFor(t.vx + t.omega * p(4), t.vy);
    return {{w1.speed / p(0), w2.speed / p(3)}, {w1.angle + p(1), w2.angle}};
  }
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
      return std::make_unique<DifferentialModel>(type, p);
    case DriveType::kTricycle:
      Require(p[0] > 0, type, "drive_radius must be positive");
      Require(p[1] != 0, type, "wheelbase must not be zero");
      return std::make_unique<TricycleModel>(type, p);
    case DriveType::kDualSteer:
      Require(p[0] > 0 && p[3] > 0, type, "wheel radii must be positive");
      Require(p[2] != 0 || p[4] != 0, type,
              "a and b are both zero: the wheels coincide and cannot determine the rotation");
      return std::make_unique<DualSteerModel>(type, p);
  }
  throw std::logic_error("unknown drive type");
}

std::unique_ptr<DriveModel> MakeDriveModel(const RobotDescription& robot) {
  return MakeDriveModel(robot.drive, robot.params);
}

}  // namespace calib
