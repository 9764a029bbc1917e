#include <cmath>
#include <cstdio>
#include <sstream>

#include "calib/calibrate/fused_odometry.h"
#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"
#include "commands.h"
#include "common/command_line.h"

namespace agvcal_cli {

namespace {
// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Wheel odometry fused with the gyro (the code of agvcal-fusion, on a recording;
the same numbers as a live replay). ROBOT.yaml: calibrated by `agvcal solve
--source imu`. Prints the final pose; --out writes one line per wheel state:
utime,x,y,theta,heading_std,gyro_bias (theta unwrapped, rad).)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md), with imu")
      .Positional("LOG", "the recording (lcm-logger)")
      .Option("--out", "POSES.csv", "write the fused poses (atomically)")
      .Option("--policy", "filter|average",
              "short motions: Kalman filter (default) or the mean of\n"
              "wheel and gyro below one wheel circumference (docs/imu.md)")
      .Footer("Exit status: 0 done; 2 unusable input (one line naming the file, the place and the\n"
              "problem); 1 internal error.\n");
}
}  // namespace

int Fuse(int argc, char** argv) {
  agvcal_process::CommandLine args("agvcal fuse");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 2)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  calib::FusedOdometryOptions options;
  const std::string policy = args.Get("--policy", "filter");
  if (policy == "average") options.policy = calib::FusionPolicy::kAverageShort;
  else if (policy != "filter") throw calib::InputError("command line", "--policy", "expected filter or average");
  calib::CheckOutputs({args.positional[0], args.positional[1]}, {{"--out", args.Get("--out", "")}});
  const std::vector<calib::FusedPose> poses = calib::FuseLog(robot, args.positional[1], options);
  if (poses.empty()) throw calib::InputError(args.positional[1], "channel WHEELS", "no wheel states");
  const calib::FusedPose& last = poses.back();
  std::printf("%zu poses; final x %.4f m, y %.4f m, heading %.3f deg (± %.3f), gyro bias %.6f rad/s\n",
              poses.size(), last.pose.x, last.pose.y, last.pose.theta * 180 / M_PI,
              last.heading_std * 180 / M_PI, last.gyro_bias);
  if (args.Has("--out")) {
    std::ostringstream csv;
    csv.precision(17);
    csv << "utime,x,y,theta,heading_std,gyro_bias\n";
    for (const calib::FusedPose& p : poses)
      csv << p.utime << "," << p.pose.x << "," << p.pose.y << "," << p.pose.theta << "," << p.heading_std << ","
          << p.gyro_bias << "\n";
    calib::WriteFileAtomically(args.Get("--out", ""), csv.str());
  }
  return calib::kExitOk;
}

}  // namespace agvcal_cli
