// agvcal-scanmatch: the scan matcher as a live process. Feeds WHEELS and the
// robot file's 2D lidar channel into calib::ScanMatchPipeline (the same front
// end `agvcal solve` runs offline) and publishes each completed match on
// SCAN_MATCH. Time comes from the messages, never the wall clock.
#include <lcm/lcm-cpp.hpp>

#include <iostream>
#include <string>

#include "agvcal/laser_scan_t.hpp"
#include "agvcal/scan_match_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/core/wheel_track.h"
#include "calib/io/messages.h"
#include "calib/match/laser_scan.h"
#include "calib/match/scan_match.h"
#include "common/process_util.h"

namespace {

const char* kUsage = R"(usage: agvcal-scanmatch ROBOT.yaml [--lcm-url URL]

Matches consecutive 2D lidar scans (the lidar2d channel of ROBOT.yaml, SCAN by
default), de-skewed with the WHEELS odometry of the robot file's nominal
model, and publishes the lidar's motion between them with its covariance on
SCAN_MATCH (agvcal::scan_match_t), plus HEARTBEAT. A match is published once
the wheel data cover both scans. SIGINT/SIGTERM: matches what it can of the
data received, publishes it, and exits.
  --lcm-url URL  LCM provider (default: $LCM_DEFAULT_URL or LCM's default)
Exit status: 0 stopped cleanly, 2 bad robot file (or no lidar2d) or bus,
1 internal error.
)";

// Decodes and feeds the pipeline. Handlers are called from C: nothing throws
// past them; an unusable message is counted and reported once.
class Feeder {
 public:
  Feeder(const calib::RobotDescription& robot, calib::ScanMatchPipeline* pipeline)
      : robot_(robot), pipeline_(pipeline) {}

  void OnWheels(const lcm::ReceiveBuffer*, const std::string& channel,
                const agvcal::wheel_state_t* msg) {
    ++wheel_states_;
    try {
      pipeline_->AddWheels(calib::WheelSampleFromMessage(*msg, robot_, channel));
    } catch (const std::exception& e) {
      Reject(e);
    }
  }

  void OnScan(const lcm::ReceiveBuffer*, const std::string& channel,
              const agvcal::laser_scan_t* msg) {
    try {
      pipeline_->AddScan(calib::LaserScanFromMessage(*msg, channel));
    } catch (const std::exception& e) {
      Reject(e);
    }
  }

  int64_t rejected() const { return rejected_; }
  int64_t wheel_states() const { return wheel_states_; }

 private:
  void Reject(const std::exception& e) {
    if (rejected_++ == 0)
      std::cerr << "agvcal-scanmatch: ignoring a message (reported once): " << e.what() << "\n";
  }

  const calib::RobotDescription& robot_;
  calib::ScanMatchPipeline* pipeline_;
  int64_t rejected_ = 0, wheel_states_ = 0;
};

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  const Args args = ParseArgs(argc, argv, 1, {"--lcm-url"}, {});
  if (const auto status = CheckUsage(args, kUsage, 1)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  calib::ScanMatchPipeline pipeline(robot);  // throws InputError without a lidar2d

  const std::string url = args.Get("--lcm-url", "");
  lcm::LCM lcm(url);
  RequireGoodBus(lcm, url);
  Feeder feeder(robot, &pipeline);
  SubscribeEveryMessage(lcm, calib::kWheelsChannel, &Feeder::OnWheels, &feeder);
  SubscribeEveryMessage(lcm, robot.lidar2d->channel, &Feeder::OnScan, &feeder);
  Heartbeat heartbeat(&lcm, "scanmatch");
  InstallStopHandlers();
  std::cerr << "agvcal-scanmatch: " << robot.name << ", matching " << robot.lidar2d->channel
            << " with WHEELS, publishing " << calib::kScanMatchChannel << "\n";

  auto publish = [&]() {
    for (const calib::SensorMotion& motion : pipeline.TakeResults()) {
      const agvcal::scan_match_t msg = calib::ToMessage(motion);
      lcm.publish(calib::kScanMatchChannel, &msg);
    }
  };
  auto state = [&](const char* what) {
    const calib::ScanMatchCounts& c = pipeline.counts();
    return std::string(what) + ": " + std::to_string(c.matches) + " matches (" +
           std::to_string(c.invalid) + " failed, " + std::to_string(c.degenerate) +
           " degenerate), " + std::to_string(c.scans_dropped + c.wheels_dropped) + " out of order";
  };

  while (!g_stop_requested) {
    if (lcm.handleTimeout(100) < 0 && !g_stop_requested)
      throw std::runtime_error("receiving from the LCM bus failed");
    publish();
    heartbeat.Beat(state("running"));
  }
  HandleQueued(lcm);
  pipeline.Finish();
  publish();
  const calib::ScanMatchCounts& c = pipeline.counts();
  std::cerr << "agvcal-scanmatch: stopped; received " << c.scans << " scans and " << feeder.wheel_states()
            << " wheel states; " << c.matches << " matches ("
            << c.invalid << " failed, " << c.degenerate
            << " degenerate); dropped: " << c.scans_dropped << " scans and " << c.wheels_dropped
            << " wheel states out of order, " << c.scans_uncovered << " scans without wheel data, "
            << feeder.rejected() << " unusable messages\n";
  heartbeat.Beat(state("stopped"), true /* force */);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-scanmatch", Run, argc, argv); }
