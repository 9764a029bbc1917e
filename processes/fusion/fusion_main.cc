// agvcal-fusion: wheel odometry fused with the gyro (calib/calibrate/fused_odometry.h) as a
// live process: WHEELS + the robot file's IMU channel in, pose2d_t on ODOM_FUSED
// out, one per wheel state. `agvcal fuse` runs the same code on a recording.
#include <lcm/lcm-cpp.hpp>

#include <iostream>
#include <string>

#include "agvcal/imu_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/calibrate/fused_odometry.h"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/io/messages.h"
#include "common/process_util.h"

namespace {

const char* kUsage = R"(usage: agvcal-fusion ROBOT.yaml [--policy filter|average] [--lcm-url URL]

Fuses the WHEELS odometry with the gyro of the robot file's imu channel (a
robot file calibrated by `agvcal solve --source imu`: params and the imu block
give the model and the noise) and publishes the pose of the reference point on
ODOM_FUSED (pose2d_t; odometry frame, origin at the first wheel state), plus
HEARTBEAT. SIGINT/SIGTERM: processes what it received and exits.
  --policy filter|average  short motions: Kalman filter (default) or the mean of
                           wheel and gyro below one wheel circumference (docs/imu.md)
  --lcm-url URL            LCM provider (default: $LCM_DEFAULT_URL or LCM's default)
Exit status: 0 stopped cleanly, 2 bad robot file (no imu, not differential) or bus,
1 internal error.
)";

class Feeder {
 public:
  Feeder(const calib::RobotDescription& robot, calib::FusedOdometry* fused) : robot_(robot), fused_(fused) {}
  void OnWheels(const lcm::ReceiveBuffer*, const std::string& channel, const agvcal::wheel_state_t* msg) {
    ++wheels_;
    try {
      fused_->AddWheels(calib::WheelSampleFromMessage(*msg, robot_, channel));
    } catch (const std::exception& e) {
      Reject(e);
    }
  }
  void OnImu(const lcm::ReceiveBuffer*, const std::string& channel, const agvcal::imu_t* msg) {
    ++imu_;
    try {
      fused_->AddImu(calib::ImuSampleFromMessage(*msg, channel));
    } catch (const std::exception& e) {
      Reject(e);
    }
  }
  int64_t rejected() const { return rejected_; }
  int64_t wheels() const { return wheels_; }
  int64_t imu() const { return imu_; }

 private:
  void Reject(const std::exception& e) {
    if (rejected_++ == 0) std::cerr << "agvcal-fusion: ignoring a message (reported once): " << e.what() << "\n";
  }
  const calib::RobotDescription& robot_;
  calib::FusedOdometry* fused_;
  int64_t rejected_ = 0, wheels_ = 0, imu_ = 0;
};

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  const Args args = ParseArgs(argc, argv, 1, {"--lcm-url", "--policy"}, {});
  if (const auto status = CheckUsage(args, kUsage, 1)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  calib::FusedOdometryOptions options;
  const std::string policy = args.Get("--policy", "filter");
  if (policy == "average") options.policy = calib::FusionPolicy::kAverageShort;
  else if (policy != "filter") throw calib::InputError("command line", "--policy", "expected filter or average");
  calib::FusedOdometry fused(robot, options);  // throws InputError without an imu

  const std::string url = args.Get("--lcm-url", "");
  lcm::LCM lcm(url);
  RequireGoodBus(lcm, url);
  Feeder feeder(robot, &fused);
  SubscribeEveryMessage(lcm, calib::kWheelsChannel, &Feeder::OnWheels, &feeder);
  SubscribeEveryMessage(lcm, robot.imu->channel, &Feeder::OnImu, &feeder);
  Heartbeat heartbeat(&lcm, "fusion");
  InstallStopHandlers();
  std::cerr << "agvcal-fusion: " << robot.name << ", WHEELS + " << robot.imu->channel << " -> "
            << calib::kOdomFusedChannel << "\n";
  int64_t published = 0;
  auto publish = [&]() {
    for (const calib::FusedPose& p : fused.TakePoses()) {
      const agvcal::pose2d_t msg = calib::FusedPoseMessage(p);
      lcm.publish(calib::kOdomFusedChannel, &msg);
      ++published;
    }
  };
  while (!g_stop_requested) {
    if (lcm.handleTimeout(100) < 0 && !g_stop_requested)
      throw std::runtime_error("receiving from the LCM bus failed");
    publish();
    heartbeat.Beat("running: " + std::to_string(published) + " poses");
  }
  HandleQueued(lcm);
  fused.Finish();
  publish();
  // The counts received: compared with a recording's, they show a lost message.
  std::cerr << "agvcal-fusion: stopped; " << published << " poses from " << feeder.wheels() << " wheel states and "
            << feeder.imu() << " IMU samples, " << feeder.rejected() << " unusable messages\n";
  heartbeat.Beat("stopped", true /* force */);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-fusion", Run, argc, argv); }
