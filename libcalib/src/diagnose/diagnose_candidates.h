#pragma once
// The catalogue the diagnosis tests on the odometry and sensing layers (spec/effects.md): each
// candidate's effect terms, its plausible size, the motion that excites it, and the pairs whose
// signatures look alike. Internal to libcalib.

#include <string>
#include <vector>

#include "calib/core/robot.h"
#include "calib/diagnose/diagnose.h"
#include "calib/diagnose/selection.h"

namespace calib::diag {

struct Candidate {
  std::string name, layer, wheel;
  std::vector<int> beta;          // its effect terms (Beta)
  std::vector<std::string> keys;  // effects.md parameter keys
  double plausible = 0;           // largest size plausible on the recording (diagnose_plausible.h)
  std::string excitation;         // motion that excites it
  std::string regressor;          // what its signature is binned by
  bool catalogued = true;         // in effects.md (else reported as unexplained structure)
};

// The candidates for `robot`'s drive and what `data` can test, in the catalogue's order; the time
// offset searched within +-`max_offset_s`.
std::vector<Candidate> Candidates(const RobotDescription& robot, const DiagnoseData& data, double max_offset_s);

// The catalogue's confusable pairs, with the motion that separates each.
const std::vector<ConfusablePair>& Confusable();

}  // namespace calib::diag
