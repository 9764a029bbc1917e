#include <unistd.h>

#include <cstdio>
#include <iostream>

#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"
#include "calib/live/sim_run.h"
#include "commands.h"
#include "common/process_util.h"

namespace agvcal_cli {

namespace {
// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Runs the trajectory commander against the simulated robot of SIM.yaml faster
than real time and writes every message (DRIVE_CMD, WHEELS, SCAN, IMU, CLOUD,
POSE, GROUND_TRUTH) to OUT.log, an lcm-logger recording. The same config and
seed give the same bytes.)")
      .Positional("SIM.yaml", "the simulation config (config/sims/README.md)")
      .Positional("OUT.log", "the recording to write")
      .Option("--trajectory", "NAME",
              "excitation trajectory (default \"default\"); per drive type:\n" +
                  agvcal_process::TrajectoryNamesText())
      .Option("--seed", "N", "overrides the config's seed")
      .Flag("--quiet", "no progress on stderr")
      .Footer("Exit status: 0 written; 2 unusable input (the config, robot or world file: one line\n"
              "naming the file, the place and the problem); 1 internal error.\n");
}
}  // namespace

int Simulate(int argc, char** argv) {
  agvcal_process::CommandLine args("agvcal simulate");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 2)) return *status;
  calib::SimConfig config = calib::LoadSimConfig(args.positional[0]);
  if (args.Has("--seed")) {
    const double seed = args.GetDouble("--seed", 0);
    if (seed < 0 || seed != static_cast<double>(static_cast<uint64_t>(seed)))
      throw calib::InputError("command line", "--seed", "expected a whole number >= 0");
    config.seed = static_cast<uint64_t>(seed);
  }
  calib::OfflineRunOptions options;
  options.trajectory = args.Get("--trajectory", "default");
  const bool quiet = args.Has("--quiet");
  // On a terminal one line rewritten in place (\r); into a file or a pipe a line per minute of
  // simulated time, so that a log holds readable lines, not one line of carriage returns.
  const bool terminal = isatty(fileno(stderr)) != 0;
  if (!quiet)
    options.progress = [terminal](double t, double) {
      const int s = static_cast<int>(t);
      if (terminal && s % 10 == 0) std::cerr << "\rsimulated " << s << " s" << std::flush;
      if (!terminal && s > 0 && s % 60 == 0) std::cerr << "simulated " << s << " s\n";
    };
  calib::CheckOutputs({args.positional[0], config.robot.source_file, config.world}, {{"OUT.log", args.positional[1]}});
  calib::LogWriter writer(args.positional[1]);
  const calib::OfflineRunSummary summary = calib::RunOffline(config, options, &writer);
  writer.Close();
  if (!quiet)
    std::cerr << (terminal ? "\r" : "") << "simulated " << summary.duration_s << " s, " << writer.events()
              << " messages -> " << args.positional[1] << "\n";
  return calib::kExitOk;
}

}  // namespace agvcal_cli
