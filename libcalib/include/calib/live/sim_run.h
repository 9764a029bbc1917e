#pragma once
// Offline closed loop: the commander drives the simulator faster than real
// time, exactly as the live processes would (commands issued at wheel-state
// times, at a fixed rate on the robot clock), and every message, the commands
// included, goes into a sink (normally a LogWriter).

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "calib/io/recording.h"
#include "calib/live/commander.h"
#include "calib/sim/simulator.h"

namespace calib {

struct OfflineRunOptions {
  std::string trajectory = "default";
  std::optional<Trajectory> custom_trajectory;  // used instead of the named one when set
  double command_rate_hz = 0.0;  // 0: the config's commands.rate
  double tail_s = 1.0;           // standstill recorded after the final stop
  double max_duration_s = 3600;  // safety cap on simulated time
  // Called about once per simulated second with (simulated s, total estimate s).
  std::function<void(double, double)> progress;
};

struct OfflineRunSummary {
  double duration_s = 0.0;
  int64_t commands = 0;
  Pose2 final_true_pose;
};

OfflineRunSummary RunOffline(const SimConfig& config, const OfflineRunOptions& options,
                             MessageSink* sink);

}  // namespace calib
