#pragma once
// Encoder bridge for CANopen motor drives and steering encoders: raw CAN frames
// (live from SocketCAN, or from a `candump -l` log) -> wheel_state_t of
// spec/messages.md. Plain data; the process agvcal-canbridge owns the socket.
//
// Timing: the drives sample their encoders when the SYNC frame arrives and send
// their synchronous TPDOs after it, so a wheel state's time is the SYNC's time.
// SYNC k of the producer is sent at k * sync.period_s on the producer's clock;
// DeviceClock maps that clock to the host's from the SYNC arrival times, so the
// stamps carry no arrival jitter (and follow the producer's drift). Lost SYNCs
// are counted from the SYNC counter byte (when configured) or the arrival gap.
//
// Bridge config file (YAML; unknown keys are errors; COB-IDs may be hex):
//   channel: WHEELS                       # optional
//   sync: {cob_id: 0x080, period_s: 0.01, counter_overflow: 0}   # 0: no counter byte
//   clock: {window_s: 60, max_drift_ppm: 1000}                    # optional, DeviceClockOptions
//   wheels:                               # wheel name (as in the robot file) -> its objects
//     drive:
//       node: 1                           # CANopen node ID of the drive (1..127)
//       position: {tpdo: 1, offset: 0, length: 4, signed: true, ticks_per_rev: 4096}
//       velocity: {tpdo: 1, offset: 4, length: 4, signed: true, rad_s_per_unit: 0.001}  # optional
//       steer:    {node: 2, tpdo: 1, offset: 0, length: 2, signed: true,
//                  counts_per_rev: 16384, zero: 0}                # optional; raw, before calibration
// Each object is read little-endian (CANopen) from bytes [offset, offset+length)
// of the TPDO whose COB-ID is 0x180 + 0x100 * (tpdo - 1) + node (the CiA 301
// default), or of `cob_id` when given. Position counters are unwrapped (the
// counter may wrap between SYNCs by less than half its range); position is
// ticks * 2 pi / ticks_per_rev, steer (raw - zero) * 2 pi / counts_per_rev,
// velocity raw * rad_s_per_unit (NaN without a velocity object).

#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "agvcal/wheel_state_t.hpp"
#include "calib/devices/device_clock.h"
#include "calib/io/text_reader.h"

namespace calib {

struct CanFrame {
  int64_t utime = 0;          // host receive time, us
  uint32_t id = 0;            // 11-bit, or 29-bit when extended
  bool extended = false;
  bool remote = false;        // RTR: no data
  std::vector<uint8_t> data;  // 0..8 bytes
};

// Reads `candump -l` log files: "(1700000000.123456) can0 181#0011223344556677",
// "... 12345678#..." (extended), "... 181#R" (remote), an optional trailing T/R.
class CandumpReader {
 public:
  explicit CandumpReader(const std::string& path) : reader_(path) {}
  // The next frame; false at the end. Throws InputError naming the file, the
  // line and the problem for a malformed line (CAN FD frames included).
  bool Next(CanFrame* frame);
  std::string place() const { return reader_.place(); }
  const std::string& path() const { return reader_.path(); }

 private:
  TextReader reader_;
};

// One candump -l line (without the newline), the inverse of CandumpReader.
std::string FormatCandumpLine(const CanFrame& frame, const std::string& interface);

// Where an object sits in a PDO.
struct PdoField {
  uint32_t cob_id = 0;
  int offset = 0;       // first byte
  int length = 4;       // bytes, 1..8
  bool is_signed = true;
};

struct CanWheelConfig {
  std::string name;
  int node = 0;
  PdoField position;
  double ticks_per_rev = 0.0;
  std::optional<PdoField> velocity;
  double velocity_rad_s_per_unit = 1.0;
  std::optional<PdoField> steer;
  double steer_counts_per_rev = 0.0;
  int64_t steer_zero = 0;
};

struct CanBridgeConfig {
  std::string channel = "WHEELS";
  uint32_t sync_cob_id = 0x80;
  double sync_period_s = 0.01;
  int sync_counter_overflow = 0;  // 2..240 when the SYNC carries a counter byte, else 0
  DeviceClockOptions clock;
  std::vector<CanWheelConfig> wheels;
  std::string source_file;
};

// Reads and validates a bridge config. Throws InputError naming the file, the
// line and the key (unknown key, bad COB-ID, overlapping objects, ...).
CanBridgeConfig LoadCanBridgeConfig(const std::string& path);
CanBridgeConfig ParseCanBridgeConfig(const std::string& yaml_text, const std::string& origin);

// The default COB-ID of transmit PDO `tpdo` (1..4) of node `node`.
uint32_t TpdoCobId(int tpdo, int node);

// Writes `value` little-endian into field's bytes of `data` (for emulators and tests).
void PutPdoValue(const PdoField& field, int64_t value, std::vector<uint8_t>* data);

// Emulation, for tests and demos without a bus: the frames a CANopen bus would
// carry for `states` (one SYNC per state, sent at the state's utime, then each
// configured TPDO), with host arrival times late by a uniform random delay in
// [0, jitter_s] (seeded), in arrival order. Objects are quantised as the
// config's scales say; a missing velocity is sent as 0.
struct CanEmulation {
  double jitter_s = 0.002;
  double pdo_spacing_s = 0.0002;  // between the TPDOs that follow one SYNC
  uint32_t seed = 1;
};
std::vector<CanFrame> EmulateCanBus(const CanBridgeConfig& config,
                                    const std::vector<agvcal::wheel_state_t>& states,
                                    const CanEmulation& options);

struct CanDecoderStats {
  int64_t frames = 0, syncs = 0, syncs_lost = 0, published = 0, incomplete_cycles = 0,
          ignored = 0, pdos_before_sync = 0;
};

class CanopenDecoder {
 public:
  explicit CanopenDecoder(CanBridgeConfig config);

  // Feeds one frame, in receive order; appends the wheel state of a SYNC cycle
  // to `out` once every configured PDO of that cycle has arrived. Throws
  // InputError(file, place, problem) for a configured PDO too short for its
  // objects (a layout that does not match the drive).
  void Feed(const CanFrame& frame, const std::string& file, const std::string& place,
            std::vector<agvcal::wheel_state_t>* out);

  const CanDecoderStats& stats() const { return stats_; }
  const CanBridgeConfig& config() const { return config_; }

 private:
  struct Pdo {
    uint32_t cob_id;
    std::vector<uint8_t> data;
    bool received = false;
  };
  void Publish(std::vector<agvcal::wheel_state_t>* out);
  const std::vector<uint8_t>& PdoData(uint32_t cob_id) const;

  CanBridgeConfig config_;
  std::vector<Pdo> pdos_;
  std::vector<CounterUnwrapper> unwrappers_;  // one per wheel's position
  DeviceClock clock_;
  bool in_cycle_ = false, cycle_done_ = false;
  int64_t sync_index_ = 0, last_sync_utime_ = 0, cycle_utime_ = 0, last_published_ = 0;
  int last_counter_ = -1;
  CanDecoderStats stats_;
};

}  // namespace calib
