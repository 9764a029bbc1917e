// The catalogue of odometry and sensing candidates (diagnose_candidates.h).

#include "diagnose/diagnose_candidates.h"

#include "diagnose/diagnose_model.h"
#include "diagnose/diagnose_plausible.h"

namespace calib::diag {

std::vector<Candidate> Candidates(const RobotDescription& robot, const DiagnoseData& data, double max_offset_s) {
  std::vector<Candidate> out;
  const PlausibleSizes plausible = Plausible(robot, data, max_offset_s);
  const bool steered = robot.drive != DriveType::kDifferential;
  out.push_back({"time_offset", "sensing", "", {kTimeOffset}, {"offset_s"}, plausible.time_offset,
                 "starts, stops and changes of turn rate", "accel", true});
  out.push_back({"longitudinal_slip", "odometry", "", {kSlip}, {"slip_per_accel"}, plausible.slip,
                 "hard accelerations and braking at speed", "speed_x_accel", true});
  out.push_back({"lateral_slip", "odometry", "", {kLateral}, {"gain"}, plausible.lateral,
                 "fast turns: the same curvature at several speeds, both ways", "centripetal", true});
  if (steered) {
    out.push_back({"steering_lag", "odometry", "", {kLag}, {"tau_s"}, plausible.steering_lag,
                   "steering changes while driving (slalom, steering steps)", "speed_x_steer_rate", true});
    out.push_back({"steering_backlash", "odometry", "", {kBacklash}, {"width_rad"}, plausible.steering_angle,
                   "straights entered after a left and after a right steering correction",
                   "steer_direction", true});
    out.push_back({"travel_direction_offset", "odometry", "", {kTravelOffset}, {"offset_rad"}, plausible.steering_angle,
                   "the same path forward and in reverse", "travel_direction", false});
  }
  if (data.scan_period_s > 0) {
    out.push_back({"scan_distortion", "sensing", "", {kDistortion}, {"scan_period_s"}, plausible.scan_period,
                   "fast turns in place and fast straights", "turn_rate", true});
  }
  const auto& roles = WheelRoles(robot.drive);
  for (std::size_t w = 0; w < roles.size(); ++w) {
    out.push_back({"wheel_eccentricity", "odometry", roles[w],
                   {int(kEcc0C + 2 * w), int(kEcc0S + 2 * w)}, {"amplitude", "phase"}, plausible.eccentricity,
                   "long straight runs (many wheel turns)", "wheel_angle_" + std::to_string(w), true});
  }
  return out;
}

// The catalogue's confusable pairs, with the motion that separates each.
const std::vector<ConfusablePair>& Confusable() {
  static const auto* const kConfusable = new std::vector<ConfusablePair>{
      {"time_offset", "steering_lag",
       "speed changes while driving straight (a time offset shows there, steering lag does not), and steering "
       "changes at constant speed"},
      {"time_offset", "longitudinal_slip",
       "the same accelerations at two different speeds (slip grows with speed, a time offset does not), and "
       "changes of turn rate"},
      {"steering_backlash", "travel_direction_offset",
       "straights entered after a left and after a right steering correction, in both travel directions"},
  };
  return *kConfusable;
}

}  // namespace calib::diag
