#pragma once
// The terms of a sim config's `terms:` block (core/physics_terms.h) acting on the simulated body
// through their channels (the timing channel acts on the scans' stamps, in the simulator).

#include <vector>

#include "calib/core/kinematics.h"
#include "calib/sim/simulator.h"

namespace calib {

// The body's twist over a physics step with the terms of `config`: the wheels' effective speeds
// `effective_omega` and true steering angles `true_raw` (the wheels of `steered`) changed through
// the radius and steering channels, the yaw rate through its own; `kinematic` is the twist
// without them, `time` s since the start.
Twist2 WithTerms(const DriveModel& true_model, const SimConfig& config, const std::vector<bool>& steered, double time,
                 std::vector<double> effective_omega, std::vector<double> true_raw, const Twist2& kinematic);

}  // namespace calib
