#pragma once
// The encoder readings of a recording as a time series, in WheelRoles() order:
// what the solver and the scan matcher's de-skewing integrate between any two
// instants (lidar beams and scans do not fall on encoder samples).

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/core/kinematics.h"
#include "calib/core/robot.h"
#include "calib/core/se2.h"
#include "calib/core/stamp_gate.h"

namespace calib {

struct WheelSample {
  int64_t utime = 0;
  std::vector<double> position;  // accumulated drive rotation per role, rad
  std::vector<double> steer;     // raw steering reading per role, rad (0 if not steered)
};

// Stored compactly, since a live solver keeps every sample of a long run (docs/live.md, "Memory
// over long runs"): one stamp and one reading per role in flat arrays, and no steering readings
// at all while every one is zero (an unsteered drive): 24 bytes per sample of a differential
// drive instead of two heap vectors each. Values are kept exactly.
class WheelTrack {
 public:
  // Appends a sample. Stamps must increase: a sample at or before the last one
  // is refused (returns false, the track is unchanged), so out-of-order and
  // duplicated messages cannot corrupt the integration. So is one whose number of
  // wheels differs from the first sample's.
  bool Append(const WheelSample& sample);
  // Forgets the samples before index `first` (a consumer that needs only recent data).
  void DropBefore(std::size_t first);

  bool empty() const { return utime_.empty(); }
  std::size_t size() const { return utime_.size(); }
  std::size_t roles() const { return roles_; }
  int64_t first_utime() const { return utime_.front(); }
  int64_t last_utime() const { return utime_.back(); }
  // Sample i's stamp, readings, or all of it.
  int64_t utime(std::size_t i) const { return utime_[i]; }
  double position(std::size_t i, std::size_t role) const { return position_[i * roles_ + role]; }
  double steer(std::size_t i, std::size_t role) const {
    return steered_ ? steer_[i * roles_ + role] : 0.0;
  }
  WheelSample sample(std::size_t i) const;
  const std::vector<int64_t>& utimes() const { return utime_; }
  // Bytes held (capacity), for the memory figures.
  std::size_t bytes() const;

  // Index of the last sample at or before `utime` (0 if it precedes the track).
  std::size_t IndexBefore(double utime) const;

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
  std::size_t roles_ = 0;
  std::vector<int64_t> utime_;
  std::vector<double> position_;  // roles_ per sample
  std::vector<double> steer_;     // roles_ per sample once steered_; empty before
  bool steered_ = false;          // a reading other than +0 has come
};

// Keeps physically impossible wheel samples out of every consumer (solve, diagnose, recal, the
// live processes all take WHEELS through io's SubscribeWheels, which applies this): the stamp
// gate of every stream (core/stamp_gate.h: out of order dropped, a lone stamp far ahead dropped
// alone) and, of the wheels' own, a wheel position that moves more than `speed_factor` times
// the robot file's limits.max_speed / the wheel's radius allows over the time since the last
// sample passed (at least the usual sample spacing): a flipped bit, not a motion.
struct WheelGateOptions {
  double speed_factor = 10.0;
  double stamp_gap_spacings = 50.0;
  double min_stamp_gap_s = 0.5;
};

class WheelSampleGate : public StampGate<WheelSample> {
 public:
  WheelSampleGate(const RobotDescription& robot, DropHandler on_drop, WheelGateOptions options = {});
};

}  // namespace calib
