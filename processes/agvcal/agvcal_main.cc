// agvcal: the offline front end (spec/cli.md). Each sub-command runs the same
// libcalib code as the live processes, on files, as fast as the machine allows.
#include <iostream>
#include <map>
#include <string>

#include "calib/core/errors.h"
#include "commands.h"

namespace {

const char* kUsage = R"(usage: agvcal COMMAND [ARGS] [--help]

Commands:
  simulate SIM.yaml OUT.log   write a simulated recording (commander + simulator, offline)
  info LOG                    channels, message counts, rates and time span of a recording
  solve ROBOT.yaml LOG        calibrate drive parameters and sensor mount from a recording
  import FORMAT INPUT OUT.log turn a dataset (carmen, mines, lego, optiodom, pose-csv) into a recording
  ground ROBOT.yaml LOG|CLOUD_FILE [--out RESULT.json]
                              3D lidar height, pitch and roll above the floor
  fuse ROBOT.yaml LOG         wheel odometry fused with the gyro (docs/imu.md)
  stop [--release]            the operator's stop on the bus: the commander holds the robot
  recal ROBOT.yaml LOG --config RECAL.yaml
                              recalibration during normal operation, on a recording
  diagnose ROBOT.yaml LOG     name the physics the calibrated model leaves out, and prove the fix
Run 'agvcal COMMAND --help' for a command's options.

Exit status: 0 success, 2 unusable input (names the file, place and problem),
3 the data cannot determine the answer, 1 internal error.
)";

int Run(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    (argc < 2 ? std::cerr : std::cout) << kUsage;
    return argc < 2 ? calib::kExitBadInput : calib::kExitOk;
  }
  static const std::map<std::string, int (*)(int, char**)> kCommands{
      {"simulate", agvcal_cli::Simulate},
      {"info", agvcal_cli::Info},
      {"solve", agvcal_cli::Solve},
      {"import", agvcal_cli::Import},
      {"ground", agvcal_cli::Ground},
      {"fuse", agvcal_cli::Fuse},
      {"stop", agvcal_cli::Stop},
      {"recal", agvcal_cli::Recal},
      {"diagnose", agvcal_cli::Diagnose},
  };
  const auto it = kCommands.find(argv[1]);
  if (it == kCommands.end())
    throw calib::InputError("command line", argv[1], "unknown command (see agvcal --help)");
  return it->second(argc, argv);
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal", Run, argc, argv); }
