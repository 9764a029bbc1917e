#include <iostream>
#include <optional>

#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"
#include "calib/core/robot.h"
#include "calib/import/importers.h"
#include "commands.h"
#include "common/process_util.h"

namespace agvcal_cli {

namespace {
const char* kUsage = R"(usage: agvcal import FORMAT INPUT OUT.log [--robot ROBOT.yaml] [--quiet]

Turns a dataset recorded elsewhere into an lcm-logger recording of the messages
of spec/messages.md (WHEELS, SCAN, POSE), so that it can be calibrated like a
live recording. INPUT may be gzip-compressed. OUT.log is written atomically.
FORMAT:
  carmen    CARMEN log: FLASER/RAWLASER1 -> SCAN; ODOM (or the odometry in the
            FLASER lines) -> WHEELS of a differential drive, inverted with the
            robot file's nominal radii and track
  mines     Mines rover log (CoreSLAM exp*.dat): ticks -> WHEELS, URG -> SCAN
  lego      Brenner's Lego robot: INPUT = the motor file; the scan file beside
            it (motors -> scan in the name) -> SCAN
  optiodom  OptiOdom run <id>_run-NN.csv (metadata file beside it): ticks and
            steering -> WHEELS, OptiTrack ground truth -> POSE
  pose-csv  external poses: time,x,y,theta[,3 variances | 9 covariances];
            integer time = us, decimal = s; '#' comments, optional header
  --robot ROBOT.yaml  robot file (spec/robot.md): wheel names, nominal values,
                      channels; required except for pose-csv. Bundled:
                      config/robots/datasets/*.yaml (docs/datasets.md)
  --quiet             no summary on stderr
Records repeating their predecessor's stamp are dropped and counted; a stamp
going backwards, a malformed line or a truncated file is an error naming the
file and line (exit 2).
)";
}  // namespace

int Import(int argc, char** argv) {
  const auto args = agvcal_process::ParseArgs(argc, argv, 2, {"--robot"}, {"--quiet"});
  if (const auto status = agvcal_process::CheckUsage(args, kUsage, 3)) return *status;
  const std::string& format = args.positional[0];
  std::optional<calib::RobotDescription> robot;
  if (args.Has("--robot")) robot = calib::LoadRobotFile(args.Get("--robot", ""));
  // On any error the writer's destructor removes the partial output.
  calib::CheckOutputs({args.positional[1], args.Get("--robot", "")}, {{"OUT.log", args.positional[2]}});
  calib::LogWriter writer(args.positional[2]);
  const calib::ImportSummary summary =
      calib::Import(format, args.positional[1], robot ? &*robot : nullptr, &writer);
  writer.Close();
  if (!args.Has("--quiet")) {
    std::cerr << "imported " << summary.lines << " lines of " << args.positional[1] << " -> "
              << args.positional[2] << " (" << (summary.last_utime - summary.first_utime) * 1e-6
              << " s)\n";
    for (const auto& [channel, count] : summary.messages)
      std::cerr << "  " << channel << ": " << count << " messages\n";
    if (summary.duplicates_dropped)
      std::cerr << "  warning: dropped " << summary.duplicates_dropped
                << " records repeating their predecessor's stamp\n";
    for (const auto& note : summary.notes) std::cerr << "  note: " << note << "\n";
  }
  return calib::kExitOk;
}

}  // namespace agvcal_cli
