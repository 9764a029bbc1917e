#pragma once
// Physics outside spec/effects.md, as terms "coefficient × regressor" acting through a physical
// channel (docs/effects.md, "Discovered physics"). The simulator plants them (sim config
// `terms:`), the diagnosis discovers them (diagnose/discover_*.h) and writes them back for the
// simulator (`diagnose --write-sim`), all through this one library.
//
// Channels (what one unit of "coefficient × regressor" changes):
//   yaw_rate  the body's yaw rate, rad/s, added to the kinematic one
//   radius    every driven wheel's effective rolling radius, relative (r_eff = r (1 + c g))
//   steer     every steered wheel's angle, rad, added to the kinematic one
//   timing    the motion sensor's clock: its offset grows by c g seconds (g = time since start)
// Regressors are computed from the kinematic motion (the drive model over the wheels).
// Adding a candidate to the library is one entry of LibraryTerms() (physics_terms.cc).

#include <string>
#include <vector>

#include "calib/core/robot.h"

namespace calib {

enum class TermChannel { kYawRate, kRadius, kSteer, kTiming };

// "yaw_rate", "radius", "steer", "timing"; and back (false for an unknown name).
const char* TermChannelName(TermChannel channel);
bool ParseTermChannel(const std::string& name, TermChannel* channel);
// The unit of what the channel changes ("rad/s", "1", "rad", "s").
const char* TermChannelUnit(TermChannel channel);

// The kinematic motion at one instant, what every regressor is computed from.
struct TermMotion {
  double speed = 0;       // m/s, forward velocity of the reference point
  double turn_rate = 0;   // rad/s
  double steer = 0;       // rad, first steered wheel's angle (0 without steering)
  double time = 0;        // s since the recording's start
};

struct TermRegressor {
  const char* name;  // as written in REPORT.json and sim configs: "turn_rate*|turn_rate|"
  const char* unit;  // of its value: "rad^2/s^2"
  double (*value)(const TermMotion&);
};

// Every regressor the library knows; nullptr for an unknown name.
const std::vector<TermRegressor>& TermRegressors();
const TermRegressor* FindTermRegressor(const std::string& name);

// One candidate of the library: a regressor through a channel, with what it means physically.
struct LibraryTerm {
  TermChannel channel;
  const char* regressor;
  const char* interpretation;  // the plain reading of a positive coefficient
  bool steered_only;           // only for drives with steering
};

// The library of candidates tried on a drive (those that apply to it).
std::vector<LibraryTerm> LibraryTerms(DriveType drive);

// One planted or discovered term.
struct PhysicsTerm {
  TermChannel channel = TermChannel::kYawRate;
  std::string regressor;  // a TermRegressor name
  double coefficient = 0;
};

// The unit of a term's coefficient: the channel's unit over the regressor's ("s/rad" ...).
std::string CoefficientUnit(TermChannel channel, const std::string& regressor);

// The sum of `terms` through `channel` at `motion` (0 without one).
double ChannelChange(const std::vector<PhysicsTerm>& terms, TermChannel channel, const TermMotion& motion);

}  // namespace calib
