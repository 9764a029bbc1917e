// agvcal-sim: the simulator as a live process. Publishes WHEELS, SCAN, IMU,
// CLOUD, POSE and GROUND_TRUTH as configured, and follows DRIVE_CMD.
#include <algorithm>
#include <iostream>

#include "calib/core/errors.h"
#include "calib/io/message_source.h"
#include "calib/sim/simulator.h"
#include "common/bus_source.h"
#include "common/process_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Runs the simulated robot of SIM.yaml (see config/sims/) live on the LCM bus:
publishes WHEELS, SCAN, IMU, CLOUD, POSE and GROUND_TRUTH as configured and
follows DRIVE_CMD (the robot stops when a command's timeout expires; a command
that does not decode or names no setpoint for a wheel is ignored, and reported once).)")
      .Positional("SIM.yaml", "the simulation config (config/sims/README.md)")
      .Option("--speed", "X", "simulated seconds per wall-clock second (default 1)")
      .Option("--duration", "S", "stop after S simulated seconds (default: until Ctrl-C)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Flag("--print-robot", "print the path of the robot file SIM.yaml simulates, and exit")
      .Footer("Exit status: 0 stopped cleanly, 2 bad config or bus, 1 internal error.\n");
}

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-sim");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  const double speed = args.GetDouble("--speed", 1.0);
  const double duration = args.GetDouble("--duration", 0.0);
  if (!(speed > 0)) throw calib::InputError("command line", "--speed", "must be > 0");

  calib::SimConfig config = calib::LoadSimConfig(args.positional[0]);
  if (args.Has("--print-robot")) {
    std::cout << config.robot.source_file << "\n";
    return calib::kExitOk;
  }
  calib::Simulator sim(std::move(config));
  BusSource bus(args.Get("--lcm-url", ""), "agvcal-sim");
  LcmSink sink(&bus.lcm());
  calib::SubscribeDriveCommands(&bus, sim.config().robot,
                                [&sim](const calib::DriveCommand& command) { sim.ApplyCommand(command); });
  Heartbeat heartbeat(&bus.lcm(), "sim");
  bus.ReportOn(&heartbeat);
  InstallStopHandlers();

  // Simulated time follows the wall clock (times `speed`); commands are
  // handled between 10 ms slices of simulation.
  const int64_t sim_start = sim.utime();
  const int64_t wall_start = WallMicros();
  const int64_t end = duration > 0 ? sim_start + static_cast<int64_t>(duration * 1e6) : INT64_MAX;
  while (!bus.done() && sim.utime() < end) {
    const int64_t target =
        std::min(end, sim_start + static_cast<int64_t>((WallMicros() - wall_start) * speed));
    if (target > sim.utime()) sim.AdvanceTo(target, &sink);
    heartbeat.Beat("running t=" + std::to_string((sim.utime() - sim_start) / 1000000) + " s");
    bus.HandleNext(10);
    while (bus.HandleNext(0)) {
    }
  }
  heartbeat.Beat("stopped", true);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-sim", Run, argc, argv); }
