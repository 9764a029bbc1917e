#pragma once
// Kinematic models of the three drive types of spec/robot.md.
//
// Forward: wheel encoder increments (and steering angles) over one interval ->
// motion of the reference point over that interval, integrated exactly along
// an arc under the assumption that wheel speeds and steering angles are
// constant over the interval (the steering angle is taken at the interval's
// middle: the mean of its start and end readings).
//
// Inverse: a body twist at the reference point -> per-wheel drive speeds and
// raw steering setpoints, what a commander or a simulator needs.
//
// Dual steer has four contact-point velocity components for three unknowns
// (vx, vy, omega); Forward and Integrate take the weighted least-squares
// solution, which is exact when the two wheels agree; when they fight, the
// sideways (cornering) components give way more than the rolling ones
// (kinematics_generic.h).
//
// Reference points and parameters (spec/robot.md):
//   differential: middle of the drive axle; left_radius, right_radius, track.
//   tricycle:     middle of the rear axle; drive wheel at (wheelbase, 0);
//                 drive_radius, wheelbase, steer_offset.
//   dual_steer:   point W; a1 at (b, 0), a2 at (0, -a); a1_radius,
//                 a1_steer_offset, b, a2_radius, a (a2 has no offset).
// True steering angle = raw reading - steer_offset.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "calib/core/robot.h"
#include "calib/core/se2.h"

namespace calib {

// What the wheels did over one interval, one entry per wheel role in
// WheelRoles() order.
struct WheelIncrement {
  std::vector<double> rotation;     // drive rotation of each wheel, rad
  std::vector<double> steer_start;  // raw steering reading at the start, rad (0 if not steered)
  std::vector<double> steer_end;    // raw steering reading at the end, rad
};

// Setpoints for each wheel role, in WheelRoles() order.
struct WheelSetpoint {
  std::vector<double> speed;  // drive speed, rad/s
  std::vector<double> steer;  // raw steering angle, rad (0 if not steered)
};

class DriveModel {
 public:
  virtual ~DriveModel() = default;

  virtual DriveType type() const = 0;
  const std::vector<std::string>& roles() const { return WheelRoles(type()); }

  // Parameter values in ParamNames(type()) order.
  virtual std::vector<double> params() const = 0;

  // Motion of the reference point over the interval, in the frame of the
  // reference point at the interval's start.
  virtual Pose2 Integrate(const WheelIncrement& increment) const = 0;

  // Wheel setpoints that realise `twist` at the reference point. Non-holonomic
  // drives ignore the part of the twist they cannot realise (vy for a
  // differential drive or a tricycle). Steering angles stay within
  // [-pi/2, pi/2] of the wheel's zero; the drive speed changes sign instead.
  virtual WheelSetpoint Inverse(const Twist2& twist) const = 0;

  // Body twist that the wheel speeds and raw steering angles produce: the
  // continuous-time counterpart of Integrate().
  virtual Twist2 Forward(const WheelSetpoint& wheels) const = 0;
};

// Builds the model of a drive type from parameter values keyed by the names of
// spec/robot.md. All of ParamNames(type) must be present; other keys are
// ignored, so a map holding sensor values too can be passed. Throws
// std::invalid_argument naming the key for a missing or non-finite value, and
// for unusable geometry: a radius <= 0, track <= 0, wheelbase == 0, or
// a == b == 0 (dual-steer wheels at one point cannot determine the rotation).
// Vectors of the wrong length passed to the model throw std::invalid_argument.
std::unique_ptr<DriveModel> MakeDriveModel(DriveType type,
                                           const std::map<std::string, double>& params);

// The model with a robot description's nominal parameters.
std::unique_ptr<DriveModel> MakeDriveModel(const RobotDescription& robot);

}  // namespace calib
