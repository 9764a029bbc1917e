#pragma once
// A 2D lidar scan as plain data (laser_scan_t of spec/messages.md, validated by
// LaserScanFromMessage in calib/io/messages.h).

#include <cmath>
#include <cstdint>
#include <vector>

namespace calib {

// Longest plausible time from the first to the last beam of a scan, s.
inline constexpr double kMaxScanDuration = 5.0;

struct LaserScan {
  int64_t utime = 0;                        // time of the first beam, us (robot clock)
  double angle_min = 0.0;                   // angle of beam 0 in the sensor frame, rad
  double angle_increment = 0.0;             // rad between beams (negative: clockwise scanner)
  double time_increment = 0.0;              // s between beams; 0 = every beam at utime
  double scan_time = 0.0;                   // s between the starts of consecutive scans
  double range_min = 0.0, range_max = 0.0;  // valid range interval, m
  std::vector<float> ranges;                // m, one per beam

  int size() const { return static_cast<int>(ranges.size()); }
  double BeamAngle(int i) const { return angle_min + i * angle_increment; }
  // Time of beam i, us (fractional).
  double BeamTime(int i) const { return double(utime) + i * time_increment * 1e6; }
  // Time of the last beam, us, rounded up.
  int64_t end_utime() const;
  // False for no return: outside [range_min, range_max], NaN or inf.
  bool HasReturn(int i) const {
    const float r = ranges[i];
    return std::isfinite(r) && r >= range_min && r <= range_max;
  }
};

}  // namespace calib
