// agvcal-fusion: wheel odometry fused with the gyro (calib/calibrate/fused_odometry.h) as a
// live process: WHEELS + the robot file's IMU channel in, pose2d_t on ODOM_FUSED
// out, one per wheel state. `agvcal fuse` runs the same code on a recording.
#include <iostream>
#include <string>

#include "agvcal/pose2d_t.hpp"
#include "calib/calibrate/fused_odometry.h"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "common/bus_source.h"
#include "common/process_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Fuses the WHEELS odometry with the gyro of the robot file's imu channel (a
robot file calibrated by `agvcal solve --source imu`: params and the imu block
give the model and the noise) and publishes the pose of the reference point on
ODOM_FUSED (pose2d_t; odometry frame, origin at the first wheel state), plus
HEARTBEAT. SIGINT/SIGTERM: processes what it received and exits.)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md), with imu")
      .Option("--policy", "filter|average",
              "short motions: Kalman filter (default) or the mean of\n"
              "wheel and gyro below one wheel circumference (docs/imu.md)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("Exit status: 0 stopped cleanly, 2 bad robot file (no imu, not differential) or bus,\n"
              "1 internal error.\n");
}

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-fusion");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  calib::FusedOdometryOptions options;
  const std::string policy = args.Get("--policy", "filter");
  if (policy == "average") options.policy = calib::FusionPolicy::kAverageShort;
  else if (policy != "filter") throw calib::InputError("command line", "--policy", "expected filter or average");
  calib::FusedOdometry fused(robot, options);  // throws InputError without an imu

  BusSource bus(args.Get("--lcm-url", ""), "agvcal-fusion");
  calib::SubscribeWheels(&bus, robot, [&](const calib::WheelSample& sample) { fused.AddWheels(sample); });
  calib::SubscribeImu(&bus, robot.imu->channel, [&](const calib::ImuSample& sample) { fused.AddImu(sample); });
  Heartbeat heartbeat(&bus.lcm(), "fusion");
  bus.ReportOn(&heartbeat);
  InstallStopHandlers();
  std::cerr << "agvcal-fusion: " << robot.name << ", WHEELS + " << robot.imu->channel << " -> "
            << calib::kOdomFusedChannel << "\n";
  int64_t published = 0;
  auto publish = [&]() {
    for (const calib::FusedPose& p : fused.TakePoses()) {
      const agvcal::pose2d_t msg = calib::ToMessage(calib::ToStampedPose(p));
      bus.lcm().publish(calib::kOdomFusedChannel, &msg);
      ++published;
    }
  };
  while (!bus.done()) {
    bus.HandleNext(100);
    publish();
    heartbeat.Beat("running: " + std::to_string(published) + " poses");
  }
  bus.HandleQueued();
  bus.Finish();  // a message a stream's gate still holds (after a long gap)
  fused.Finish();
  publish();
  // The counts received: compared with a recording's, they show a lost message.
  std::cerr << "agvcal-fusion: stopped; " << published << " poses from " << bus.received(calib::kWheelsChannel)
            << " wheel states and " << bus.received(robot.imu->channel) << " IMU samples, " << bus.skipped()
            << " unusable messages\n";
  heartbeat.Beat("stopped", true /* force */);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-fusion", Run, argc, argv); }
