#pragma once
// Mapping a device's clock (a lidar's microsecond counter, the count of CANopen
// SYNC periods) to the host's clock without baking in the jitter of packet
// arrival. Every arrival is late by a delay d >= 0 (transmission, scheduling):
//   host_arrival_i = offset + rate * device_i + d_i.
// The estimate is the line below every arrival of a sliding window that is
// highest at the window's mean device time (the linear-programming clock fit
// of Moon, Skelly and Towsley, 1999): it touches the least-delayed arrivals,
// so it follows the device clock's drift and offset, and a late packet moves
// it not at all. The line is an edge of the window's lower convex hull.
//
// Causal (a stamp depends only on arrivals so far) and deterministic: replaying
// the same (device, arrival) pairs gives the same stamps.

#include <cstdint>
#include <deque>

namespace calib {

struct DeviceClockOptions {
  double window_s = 60.0;          // arrivals kept for the fit (device time span)
  double min_span_s = 2.0;         // below this span the rate is taken as nominal (1)
  double max_drift_ppm = 1000.0;   // a fitted rate further from 1 is clamped
  double max_gap_s = 10.0;         // a device time jump larger than this (or backwards) restarts the fit
};

class DeviceClock {
 public:
  explicit DeviceClock(DeviceClockOptions options = {}) : options_(options) {}

  // Adds an arrival (device time and host arrival time, us) and returns the
  // host time of `device_us` on the updated line. Restarts (forgets the
  // window) when the device time goes back or jumps (device reboot).
  int64_t Add(int64_t device_us, int64_t host_arrival_us);

  // Host time of a device time on the current line (after at least one Add).
  int64_t ToHost(int64_t device_us) const;

  double rate() const { return rate_; }      // host us per device us
  int64_t restarts() const { return restarts_; }
  bool empty() const { return points_.empty(); }

 private:
  struct Point {
    int64_t device, host;
  };
  void Fit();

  DeviceClockOptions options_;
  std::deque<Point> points_;
  // Line: host = origin_host_ + rate_ * (device - origin_device_), in doubles
  // relative to an origin so that 1e15-us stamps keep sub-us precision.
  int64_t origin_device_ = 0, origin_host_ = 0;
  double offset_ = 0.0, rate_ = 1.0;
  int64_t restarts_ = 0;
};

// Unwraps a counter of `bits` bits (<= 63) into an unbounded one: each raw
// value is taken as the nearest to the previous unwrapped value, so a counter
// may move by less than half its range between two readings.
class CounterUnwrapper {
 public:
  explicit CounterUnwrapper(int bits) : bits_(bits) {}
  int64_t Unwrap(uint64_t raw);
  void Reset() { any_ = false; }

 private:
  int bits_;
  bool any_ = false;
  int64_t last_ = 0;
};

}  // namespace calib
