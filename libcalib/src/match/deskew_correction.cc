#include "match/deskew_correction.h"

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace calib {

namespace {
// Turn (rad) below which a pair says little about the mount's position: the damping of its fit.
constexpr double kMountTurnRad = 0.05;
}  // namespace

DeskewCorrection CorrectionFromMatch(const Pose2& robot_motion, const Pose2& mount, const Pose2& matched,
                                     double duration_s) {
  // The sensor's translation over the pair is R(-yaw) ((R_turn - I) p + t) for a mount at p:
  // linear in p, so the position that fits the match is a damped least-squares step.
  const Pose2 predicted = Between(mount, Compose(robot_motion, mount));
  const Eigen::Vector2d miss(matched.x - predicted.x, matched.y - predicted.y);
  const Eigen::Matrix2d turn = Eigen::Rotation2Dd(robot_motion.theta).toRotationMatrix();
  const Eigen::Matrix2d a =
      Eigen::Rotation2Dd(-mount.theta).toRotationMatrix() * (turn - Eigen::Matrix2d::Identity());
  const double ata = 2.0 - 2.0 * std::cos(robot_motion.theta);  // aᵀa = ata · I
  const Eigen::Vector2d step = a.transpose() * miss / (ata + kMountTurnRad * kMountTurnRad);
  DeskewCorrection out;
  out.mount = {mount.x + step.x(), mount.y + step.y(), mount.theta};
  out.twist = LogTwist(Between(Between(out.mount, Compose(robot_motion, out.mount)), matched), duration_s);
  return out;
}

Pose2 CorrectedSensorMotion(const DeskewCorrection& correction, const Pose2& robot_motion, double duration_s) {
  return Compose(Between(correction.mount, Compose(robot_motion, correction.mount)),
                 ExpTwist(correction.twist, duration_s));
}

}  // namespace calib
