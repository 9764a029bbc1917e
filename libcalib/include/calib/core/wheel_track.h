#pragma once
// The encoder readings of a recording as a time series, in WheelRoles() order:
// what the solver and the scan matcher's de-skewing integrate between any two
// instants (lidar beams and scans do not fall on encoder samples).

#include <cstdint>
#include <string>
#include <vector>

#include "calib/core/kinematics.h"
#include "calib/core/robot.h"
#include "calib/core/se2.h"

namespace calib {

struct WheelSample {
  int64_t utime = 0;
  std::vector<double> position;  // accumulated drive rotation per role, rad
  std::vector<double> steer;     // raw steering reading per role, rad (0 if not steered)
};

class WheelTrack {
 public:
  // Appends a sample. Stamps must increase: a sample at or before the last one
  // is refused (returns false, the track is unchanged), so out-of-order and
  // duplicated messages cannot corrupt the integration.
  bool Append(const WheelSample& sample);

  bool empty() const { return samples_.empty(); }
  std::size_t size() const { return samples_.size(); }
  int64_t first_utime() const { return samples_.front().utime; }
  int64_t last_utime() const { return samples_.back().utime; }
  const std::vector<WheelSample>& samples() const { return samples_; }

  // True when [t0, t1] lies within the recorded span.
  bool Covers(double t0, double t1) const;

  // Readings at `utime` (us, fractional allowed), linearly interpolated; clamped
  // to the ends outside the span.
  WheelSample At(double utime) const;

  // The encoder increments over [t0, t1], one per encoder sample interval, the
  // first and last cut at t0 and t1 by interpolation. Empty when t1 <= t0.
  std::vector<WheelIncrement> Increments(double t0, double t1) const;

  // Motion of the reference point over [t0, t1] predicted by `model`, in the
  // frame of the reference point at t0.
  Pose2 Odometry(const DriveModel& model, double t0, double t1) const;

 private:
  std::vector<WheelSample> samples_;
};

}  // namespace calib
