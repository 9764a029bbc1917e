#pragma once
// The held-out proofs of the diagnosis (internal to libcalib): an effect fitted on the fit blocks
// must also explain the held-out blocks, the data the fit never saw. Per interval where the
// effect acts (Localize), as dead reckoning chained over windows (HeldoutDrift), over the stretch
// of a held-out block where it predicts most (HeldoutStretches), and as a score test.

#include <vector>

#include "calib/calibrate/heldout.h"
#include "calib/diagnose/diagnose.h"
#include "diagnose/diagnose_candidates.h"
#include "diagnose/diagnose_fit.h"

namespace calib::diag {

// Where an effect's contribution stands out, and the held-out residual there.
struct Localized {
  int comp = 0;               // the residual component it shows most in (x, y, yaw)
  std::vector<bool> flagged;  // per interval: the effect's contribution stands out
  double rms_before = 0, rms_after = 0, rms_all_before = 0, rms_all_after = 0;  // held-out
  double span_gain() const { return rms_before > 0 ? 1.0 - rms_after / rms_before : 0.0; }
};

// Where the effect `c` contributes beyond the noise (at least 10 held-out intervals), in the
// component it shows most, and the held-out residual there without (`without`) and with (`with`).
Localized Localize(const Recording& recording, const Candidate& c, const Model& with, const Model& without);

// The model's dead reckoning over held-out windows (outliers break the chain).
OdometryError HeldoutDrift(const Recording& recording, const Model& m);

// In each run of consecutive held-out intervals, the stretch over which the effect `c` changes the
// chained motion most in `comp` (chosen from the models' predictions, never from the measurement),
// with the chained error there without and with it.
std::vector<HeldoutStretch> HeldoutStretches(const Recording& recording, const Candidate& c, const Model& with,
                                             const Model& without, int comp);

// The effect terms `after` adds to `before` explain the held-out residual left without them (score test).
bool ScoreConfirmed(const Recording& recording, const Fit& before, const Fit& after);
// The held-out drift (heading or translation) is lower with them, window by window.
bool DriftConfirmed(const Recording& recording, const Fit& before, const Fit& after, bool heading);
// Either of the two, the drift in the component the effect `c` shows most.
bool HeldoutConfirms(const Recording& recording, const Candidate& c, const Fit& before, const Fit& after);

}  // namespace calib::diag
