#pragma once
// The largest size of each candidate a recording can plausibly show, from the recording and the
// robot file (no fixed sizes): beyond it the effect's own model stops describing a robot that
// drives as recorded. A candidate whose detectable size exceeds it is not identifiable on the
// recording. Internal to libcalib.

#include "calib/core/robot.h"
#include "calib/diagnose/diagnose.h"

namespace calib::diag {

struct PlausibleSizes {
  double time_offset = 0;     // s: the bound the offset is searched within (the data's reach)
  double slip = 0;            // s^2/m: slip_per_accel * a reaches 1 at the recording's hard accelerations
  double lateral = 0;         // s: the sideways skid reaches the forward speed at its fast turns
  double steering_lag = 0;    // s: the lag spans the (long) times between its steering reversals
  double steering_angle = 0;  // rad: play or offset as wide as the steering travel it shows
  double scan_period = 0;     // s: the beams spread over the time between scans
  double eccentricity = 1.0;  // the hub at the tyre (amplitude 1 turns the wheel backwards)
};

// Sizes for `robot` on `data`, the time offset searched within +-`max_offset_s`.
PlausibleSizes Plausible(const RobotDescription& robot, const DiagnoseData& data, double max_offset_s);

}  // namespace calib::diag
