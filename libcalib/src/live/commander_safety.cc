#include "calib/live/commander_safety.h"

#include <cmath>
#include <cstdio>

#include "calib/core/units.h"

namespace calib {

void CommanderSafety::Watch(const std::string& input, double timeout_s) {
  inputs_[input].timeout_us = std::llround(timeout_s * 1e6);
}

void CommanderSafety::Seen(const std::string& input, int64_t wall_us) {
  const auto it = inputs_.find(input);
  if (it != inputs_.end()) it->second.last_us = wall_us;
}

void CommanderSafety::SetOperatorStop(bool engaged, const std::string& reason) {
  if (engaged)
    operator_stop_ = reason;
  else
    operator_stop_.reset();
}

std::optional<std::string> CommanderSafety::StaleReason(int64_t wall_us) const {
  for (const auto& [name, input] : inputs_) {
    if (!input.last_us) return "waiting for " + name;
    const int64_t silent = wall_us - *input.last_us;
    if (silent > input.timeout_us) {
      return Formatted("no %s for %.1f s", name.c_str(), silent * 1e-6);
    }
  }
  return std::nullopt;
}

std::optional<std::string> CommanderSafety::HoldReason(int64_t wall_us) const {
  if (operator_stop_)
    return "operator stop" + (operator_stop_->empty() ? "" : " (" + *operator_stop_ + ")");
  return StaleReason(wall_us);
}

bool CommanderSafety::InputsStale(int64_t wall_us) const { return StaleReason(wall_us).has_value(); }

}  // namespace calib
