#include "sim/sim_terms.h"

#include <string>

#include "calib/core/physics_terms.h"

namespace calib {

Twist2 WithTerms(const DriveModel& true_model, const SimConfig& config, const std::vector<bool>& steered, double time,
                 std::vector<double> effective_omega, std::vector<double> true_raw, const Twist2& kinematic) {
  const auto& roles = WheelRoles(config.robot.drive);
  TermMotion motion;
  motion.speed = kinematic.vx;
  motion.turn_rate = kinematic.omega;
  motion.time = time;
  for (size_t i = 0; i < roles.size(); ++i) {
    if (!steered[i]) continue;
    const std::string offset_name = SteerOffsetParamName(roles[i]);
    motion.steer = true_raw[i] - (offset_name.empty() ? 0.0 : config.true_params.at(offset_name));
    break;
  }
  const double radius = ChannelChange(config.terms, TermChannel::kRadius, motion);
  const double steer = ChannelChange(config.terms, TermChannel::kSteer, motion);
  for (size_t i = 0; i < roles.size(); ++i) {
    effective_omega[i] *= 1.0 + radius;
    if (steered[i]) true_raw[i] += steer;
  }
  Twist2 twist = true_model.Forward({effective_omega, true_raw});
  twist.omega += ChannelChange(config.terms, TermChannel::kYawRate, motion);
  return twist;
}

}  // namespace calib
