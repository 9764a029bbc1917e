#pragma once
// When the trajectory commander must hold the robot still. The commander
// process tells the monitor, in wall-clock time, when each watched input last
// arrived (WHEELS, the 2D lidar's scans, and its own HEARTBEAT coming back from
// the bus, which shows that its messages reach the bus at all) and what the
// operator asked on the STOP channel; HoldReason() says whether it may drive.
// While a reason holds, the process sends stop commands and interrupts the
// commander (Commander::Interrupt), which resumes from rest when none is left.
// A crash of the commander needs nothing here: every command carries a timeout
// after which the robot stops by itself.
//
// Plain data and times passed in: tested without a bus or a clock.

#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace calib {

class CommanderSafety {
 public:
  // Watches `input` (e.g. "WHEELS"): the robot is held until it first
  // arrives and whenever it has been silent for more than `timeout_s`.
  void Watch(const std::string& input, double timeout_s);
  // `input` arrived at wall-clock time `wall_us`; unwatched inputs are ignored.
  void Seen(const std::string& input, int64_t wall_us);
  // The operator's stop: latched until released (engaged = false).
  void SetOperatorStop(bool engaged, const std::string& reason);
  bool operator_stop() const { return operator_stop_.has_value(); }

  // Why the robot must stand still at `wall_us`, or nothing: the operator's
  // stop first, then the first input not seen yet or silent too long, e.g.
  // "operator stop (dashboard: key s)", "no SCAN for 0.7 s", "waiting for WHEELS".
  std::optional<std::string> HoldReason(int64_t wall_us) const;
  // True if the reason is stale or missing inputs (not the operator).
  bool InputsStale(int64_t wall_us) const;

 private:
  struct Input {
    int64_t timeout_us = 0;
    std::optional<int64_t> last_us;
  };
  std::optional<std::string> StaleReason(int64_t wall_us) const;
  std::map<std::string, Input> inputs_;
  std::optional<std::string> operator_stop_;
};

}  // namespace calib
