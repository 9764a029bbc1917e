#include "calib/core/physics_terms.h"

#include <cmath>
#include <map>
#include <utility>

namespace calib {

const char* TermChannelName(TermChannel channel) {
  switch (channel) {
    case TermChannel::kYawRate: return "yaw_rate";
    case TermChannel::kRadius: return "radius";
    case TermChannel::kSteer: return "steer";
    case TermChannel::kTiming: return "timing";
  }
  return "yaw_rate";
}

bool ParseTermChannel(const std::string& name, TermChannel* channel) {
  for (TermChannel c : {TermChannel::kYawRate, TermChannel::kRadius, TermChannel::kSteer, TermChannel::kTiming})
    if (name == TermChannelName(c)) {
      *channel = c;
      return true;
    }
  return false;
}

const char* TermChannelUnit(TermChannel channel) {
  switch (channel) {
    case TermChannel::kYawRate: return "rad/s";
    case TermChannel::kRadius: return "1";
    case TermChannel::kSteer: return "rad";
    case TermChannel::kTiming: return "s";
  }
  return "1";
}

const std::vector<TermRegressor>& TermRegressors() {
  static const std::vector<TermRegressor> regressors = {
      {"speed", "m/s", [](const TermMotion& m) { return m.speed; }},
      {"|speed|", "m/s", [](const TermMotion& m) { return std::abs(m.speed); }},
      {"turn_rate", "rad/s", [](const TermMotion& m) { return m.turn_rate; }},
      {"|turn_rate|", "rad/s", [](const TermMotion& m) { return std::abs(m.turn_rate); }},
      {"turn_rate*|turn_rate|", "rad^2/s^2", [](const TermMotion& m) { return m.turn_rate * std::abs(m.turn_rate); }},
      {"turn_rate^3", "rad^3/s^3", [](const TermMotion& m) { return m.turn_rate * m.turn_rate * m.turn_rate; }},
      {"turn_rate*|speed|", "rad m/s^2", [](const TermMotion& m) { return m.turn_rate * std::abs(m.speed); }},
      {"speed^2", "m^2/s^2", [](const TermMotion& m) { return m.speed * m.speed; }},
      {"turn_rate^2", "rad^2/s^2", [](const TermMotion& m) { return m.turn_rate * m.turn_rate; }},
      {"steer*|steer|", "rad^2", [](const TermMotion& m) { return m.steer * std::abs(m.steer); }},
      {"steer^2", "rad^2", [](const TermMotion& m) { return m.steer * m.steer; }},
      {"steer*|speed|", "rad m/s", [](const TermMotion& m) { return m.steer * std::abs(m.speed); }},
      {"time", "s", [](const TermMotion& m) { return m.time; }},
  };
  return regressors;
}

const TermRegressor* FindTermRegressor(const std::string& name) {
  for (const TermRegressor& r : TermRegressors())
    if (name == r.name) return &r;
  return nullptr;
}

// Catalogued effects are not in the library (longitudinal slip is the radius by acceleration,
// lateral slip the sideways velocity by speed × turn rate, steering lag the steering by its
// rate, eccentricity the radius by the wheel's angle), nor what the calibration fits (the
// radius and the yaw rate by a constant factor: radii and track; a constant sideways velocity
// per speed: the mount's yaw).
std::vector<LibraryTerm> LibraryTerms(DriveType drive) {
  static const std::vector<LibraryTerm> all = {
      {TermChannel::kYawRate, "turn_rate*|turn_rate|",
       "scrub: the body turns less than the wheels say, the more so the faster it turns", false},
      {TermChannel::kYawRate, "turn_rate*|speed|",
       "understeer: the faster the robot drives, the less it turns for the same wheel motion", false},
      {TermChannel::kYawRate, "|turn_rate|",
       "asymmetric turning: the body turns further left than right for the same wheel motion (a caster's drag, "
       "a wheel that rolls differently backward, a slope)", false},
      {TermChannel::kRadius, "|speed|", "tyre growth: the rolling radius grows with speed", false},
      {TermChannel::kRadius, "turn_rate^2", "load transfer: the rolling radius changes in turns", false},
      {TermChannel::kSteer, "steer*|steer|", "steering non-linearity: the linkage turns the wheel further at large angles", true},
      {TermChannel::kSteer, "steer^2", "asymmetric steering: the linkage turns one way further than the other", true},
      {TermChannel::kSteer, "steer*|speed|", "understeer: the wheel turns less than its reading at speed", true},
      {TermChannel::kTiming, "time", "clock drift: the sensor's clock runs at another rate than the wheels'", false},
  };
  std::vector<LibraryTerm> out;
  const bool steered = drive != DriveType::kDifferential;
  for (const LibraryTerm& t : all)
    if (steered || !t.steered_only) out.push_back(t);
  return out;
}

std::string CoefficientUnit(TermChannel channel, const std::string& regressor) {
  static const std::map<std::pair<std::string, std::string>, std::string> simplified = {
      {{"rad/s", "rad^2/s^2"}, "s/rad"}, {{"rad/s", "rad m/s^2"}, "1/m"}, {{"1", "m/s"}, "s/m"},
      {{"1", "rad^2/s^2"}, "s^2/rad^2"},  {{"rad", "rad^2"}, "1/rad"},     {{"rad", "rad m/s"}, "s/m"},
      {{"s", "s"}, "1"},                  {{"rad/s", "rad/s"}, "1"},       {{"rad/s", "m/s"}, "rad/m"},
  };
  const TermRegressor* r = FindTermRegressor(regressor);
  const std::string channel_unit = TermChannelUnit(channel), regressor_unit = r ? r->unit : "1";
  const auto it = simplified.find({channel_unit, regressor_unit});
  if (it != simplified.end()) return it->second;
  return channel_unit + "/(" + regressor_unit + ")";
}

double ChannelChange(const std::vector<PhysicsTerm>& terms, TermChannel channel, const TermMotion& motion) {
  double sum = 0;
  for (const PhysicsTerm& t : terms) {
    if (t.channel != channel) continue;
    if (const TermRegressor* r = FindTermRegressor(t.regressor)) sum += t.coefficient * r->value(motion);
  }
  return sum;
}

}  // namespace calib
