#include "calib/live/sim_run.h"

#include <algorithm>
#include <cmath>

#include "calib/io/messages.h"

namespace calib {

OfflineRunSummary RunOffline(const SimConfig& config, const OfflineRunOptions& options,
                             MessageSink* sink) {
  Simulator sim(config);
  Commander commander(config.robot, options.custom_trajectory
                                        ? *options.custom_trajectory
                                        : MakeTrajectory(config.robot, options.trajectory));
  const double rate = options.command_rate_hz > 0 ? options.command_rate_hz : config.command_rate_hz;
  const int64_t period = std::llround(1e6 / rate);
  const int64_t start = sim.utime();
  const int64_t cap = start + std::llround(options.max_duration_s * 1e6);
  OfflineRunSummary summary;
  int64_t finished_at = -1;
  int64_t next_progress = start;
  // commands.between continuous: the controller takes the commander's setpoint anew every
  // physics step, and the DRIVE_CMD messages are its samples, each the setpoint at its stamp.
  const bool continuous = config.command_between == CommandsBetween::kContinuous;
  const int64_t physics_step = std::max<int64_t>(1, std::llround(1e6 / config.physics_rate_hz));
  for (int64_t t = start; t < cap; t += period) {
    if (continuous) {
      while (t > start && sim.utime() + physics_step < t) {
        sim.AdvanceTo(sim.utime() + physics_step, sink);
        sim.ApplyCommand(commander.Step(sim.utime()));
      }
    }
    sim.AdvanceTo(t, sink);
    if (finished_at >= 0 && t - finished_at >= std::llround(options.tail_s * 1e6)) break;
    // The commander's clock is the newest wheel state, as in the live process (continuous: the
    // setpoint's own time).
    DriveCommand command = commander.Step(continuous ? sim.utime() : sim.last_wheels_utime());
    // Stamped when the robot takes it: the simulator's time after the physics step that
    // reached t (later than the newest wheel state when the command and encoder rates or
    // the physics step do not line up; a stamp before that would read as a drive lag).
    command.utime = sim.utime();
    sink->Publish(kDriveCmdChannel, sim.utime(), Encode(ToMessage(command, config.robot, summary.commands)));
    ++summary.commands;
    sim.ApplyCommand(command);
    if (finished_at < 0 && commander.status().state == CommanderState::kFinished) finished_at = t;
    if (options.progress && t >= next_progress) {
      options.progress((t - start) * 1e-6, 0.0);
      next_progress += 1000000;
    }
  }
  summary.duration_s = (sim.utime() - start) * 1e-6;
  summary.final_true_pose = sim.true_pose();
  return summary;
}

}  // namespace calib
