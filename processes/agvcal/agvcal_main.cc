// agvcal: the offline front end (docs/spec/cli.md). Each sub-command runs the same
// libcalib code as the live processes, on files, as fast as the machine allows.
#include <string>

#include "calib/core/errors.h"
#include "commands.h"
#include "common/command_line.h"

namespace {

struct Command {
  const char* name;
  int (*run)(int, char**);
  const char* summary;  // the line `agvcal --help` shows
};

const Command kCommands[] = {
    {"simulate", agvcal_cli::Simulate, "write a simulated recording (commander + simulator, offline)"},
    {"info", agvcal_cli::Info, "channels, message counts, rates and time span of a recording"},
    {"solve", agvcal_cli::Solve, "calibrate drive parameters and sensor mount from a recording"},
    {"import", agvcal_cli::Import, "turn a dataset (carmen, mines, lego, optiodom, pose-csv) or a ROS bag into a recording"},
    {"ground", agvcal_cli::Ground, "3D lidar height, pitch and roll above the floor"},
    {"fuse", agvcal_cli::Fuse, "wheel odometry fused with the gyro (docs/imu.md)"},
    {"stop", agvcal_cli::Stop, "the operator's stop on the bus: the commander holds the robot"},
    {"recal", agvcal_cli::Recal, "recalibration during normal operation, on a recording"},
    {"diagnose", agvcal_cli::Diagnose, "name the physics the calibrated model leaves out, and prove the fix"},
};

int Run(int argc, char** argv) {
  for (const Command& command : kCommands)
    if (argc > 1 && argv[1] == std::string(command.name)) return command.run(argc, argv);
  agvcal_process::CommandLine args("agvcal");
  args.Description("The offline front end: each command runs the code of the live processes on files.");
  for (const Command& command : kCommands) args.Command(command.name, command.summary);
  args.Footer(R"(Run 'agvcal COMMAND --help' for a command's arguments and options.
Exit status: 0 success, 2 unusable input (names the file, place and problem),
3 the data cannot determine the answer, 1 internal error.
)");
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  return calib::kExitInternal;  // Parse refuses a command line without a known command
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal", Run, argc, argv); }
