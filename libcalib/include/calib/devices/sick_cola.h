#pragma once
// Lidar bridge for SICK 2D lidars (LMS1xx, LMS5xx, TiM5xx/7xx) over Ethernet,
// CoLa-A protocol: ASCII telegrams framed by STX (0x02) and ETX (0x03), numbers
// in hex. The client sends "sEN LMDscandata 1" and the device streams one
// "sSN LMDscandata ..." telegram per scan (a poll "sRN LMDscandata" is answered
// with "sRA LMDscandata ..."). Plain data; agvcal-lidarbridge owns the socket.
//
// Telegram fields used (SICK telegram listing, LMDscandata): telegram and scan
// counters; "time since start up" (us, device clock, at the start of the scan)
// and "time of transmission" (us, device clock); scan frequency (1/100 Hz);
// the 16-bit channels DIST1 (scale factor and offset as IEEE floats, start
// angle in 1/10000 deg, signed, angular step in 1/10000 deg, the distances in mm
// times the scale) and RSSI1 (intensities), and the 8-bit channel RSSI1.
//
// Timing: the scan's first beam is at device time "time since start up" +
// first_beam_offset_s. DeviceClock maps device time to host time from the
// pairs (time of transmission, arrival), so the stamp of a scan carries no
// network or scheduling jitter. Both counters are 32-bit and wrap (71.6 min).
//
// Bridge config file (YAML; unknown keys are errors):
//   protocol: sick_cola_a
//   channel: SCAN                    # optional
//   angle_offset_deg: -90            # sensor-frame angle = device angle + this (SICK: 90 deg = ahead)
//   range_min: 0.05                  # m
//   range_max: 25.0                  # m
//   first_beam_offset_s: 0.0         # device time of the first beam after "time since start up"
//   clock: {window_s: 60, max_drift_ppm: 1000}   # optional, DeviceClockOptions

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "agvcal/laser_scan_t.hpp"
#include "calib/devices/device_clock.h"

namespace calib {

inline constexpr char kStx = 0x02;
inline constexpr char kEtx = 0x03;

// The content of one LMDscandata telegram (DIST1 channel, optional RSSI1).
struct SickScan {
  std::string command = "sSN";          // sSN (stream) or sRA (poll answer)
  int version = 1, device_number = 1;
  uint32_t serial_number = 0;
  int telegram_counter = 0, scan_counter = 0;
  uint32_t time_since_startup_us = 0, time_of_transmission_us = 0;
  uint32_t scan_frequency = 0;          // 1/100 Hz
  uint32_t measurement_frequency = 0;   // 100 Hz
  float dist_scale = 1.0f, dist_offset = 0.0f;
  int32_t start_angle = 0;              // 1/10000 deg
  uint32_t angular_step = 0;            // 1/10000 deg
  std::vector<uint32_t> distances;      // raw; mm = raw * scale + offset; 0 = no return
  std::vector<uint32_t> rssi;           // empty or one per distance
};

// Parses the text of one telegram (between STX and ETX). Throws InputError with
// `origin` and "telegram N, field K (name)" naming the first bad field.
SickScan ParseLmdScandata(const std::string& telegram, const std::string& origin, int64_t telegram_number);

// The telegram text of a scan (without STX/ETX): the inverse of ParseLmdScandata.
std::string FormatLmdScandata(const SickScan& scan);

// The telegram content a SICK scanner would send for a scan message (for the
// emulator and tests): device angle = sensor angle - angle_offset_deg, ranges
// in whole mm (0 for no return), device timestamps left 0 for the caller.
SickScan SickScanFromMessage(const agvcal::laser_scan_t& scan, double angle_offset_deg);

// True for the text of an LMDscandata scan telegram (sSN or sRA).
bool IsLmdScandata(const std::string& telegram);

// STX + text + ETX.
inline std::string FrameTelegram(const std::string& text) { return kStx + text + kEtx; }

// Splits a TCP byte stream into telegrams: bytes outside STX..ETX are dropped
// (counted), a frame longer than max_bytes without ETX is dropped.
class StxEtxFramer {
 public:
  explicit StxEtxFramer(std::size_t max_bytes = 1 << 20) : max_bytes_(max_bytes) {}
  void Append(const char* data, std::size_t size);
  // The next complete telegram (without STX/ETX); false when none is complete.
  bool Next(std::string* telegram);
  int64_t dropped_bytes() const { return dropped_; }

 private:
  std::string buffer_;
  std::size_t max_bytes_;
  int64_t dropped_ = 0;
};

struct SickBridgeConfig {
  std::string channel = "SCAN";
  double angle_offset_deg = -90.0;
  double range_min = 0.05, range_max = 25.0;
  double first_beam_offset_s = 0.0;
  DeviceClockOptions clock;
  std::string source_file;
};

SickBridgeConfig LoadSickBridgeConfig(const std::string& path);
SickBridgeConfig ParseSickBridgeConfig(const std::string& yaml_text, const std::string& origin);

// Scans with host-clock stamps from telegrams and their arrival times.
class SickScanDecoder {
 public:
  explicit SickScanDecoder(SickBridgeConfig config) : config_(std::move(config)), clock_(config_.clock) {}
  // The scan message of a parsed telegram that arrived at `arrival_utime` (host
  // clock, us). Throws InputError(origin, telegram N, ...) for an unusable scan
  // (no DIST1, zero scan frequency or step, mismatched RSSI count).
  agvcal::laser_scan_t Decode(const SickScan& scan, int64_t arrival_utime, const std::string& origin,
                              int64_t telegram_number);
  // Forget the device's clock (after a reconnect: the device may have rebooted).
  void Reset();
  const DeviceClock& clock() const { return clock_; }
  int64_t scans_lost() const { return scans_lost_; }

 private:
  SickBridgeConfig config_;
  DeviceClock clock_;
  CounterUnwrapper transmission_{32};
  int last_scan_counter_ = -1;
  int64_t scans_lost_ = 0, last_utime_ = 0;
  bool any_ = false;
};

}  // namespace calib
