// agvcal-recal: recalibration during normal operation, live. Feeds WHEELS, SCAN_MATCH (or the
// pose source's motions) and POSE into calib::SegmentRecorder; each batch of segments is
// decided by calib::Decide on a worker thread (the bus keeps being read meanwhile), one batch
// at a time, in order; the outcome is written by calib::RecordDecision. `agvcal recal` runs the
// same code on a recording and makes the same decisions.
#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <future>
#include <iostream>
#include <optional>
#include <string>

#include "agvcal/pose2d_t.hpp"
#include "agvcal/scan_match_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/calibrate/recalibration.h"
#include "calib/core/errors.h"
#include "calib/core/wheel_track.h"
#include "calib/io/messages.h"
#include "common/process_util.h"

namespace {

const char* kUsage = R"(usage: agvcal-recal ROBOT.yaml --config RECAL.yaml [--out-robot CAL.yaml]
                    [--decisions DECISIONS.jsonl] [--source lidar2d|pose] [--lcm-url URL]

Recalibrates the robot of ROBOT.yaml while it works (no commander): records the
segments of its route that the config names (zones in the POSE frame, or odometry
distance windows) from WHEELS with SCAN_MATCH (from agvcal-scanmatch) or POSE;
every `decision.segments` segments it calibrates on some and compares with the
calibration in use on the others, and accepts the new calibration only when it is
significantly better there and consistent with the one in use
(docs/recalibration.md). Publishes HEARTBEAT.
  --config RECAL.yaml      zones or distance windows, decision levels, prior uncertainties
  --out-robot CAL.yaml     the accepted calibration, as a robot file (written atomically);
                           when it exists at the start, the calibration in use starts from it
  --decisions FILE         every decision appended as a JSON line (atomically)
  --source lidar2d|pose    the sensor whose motion calibrates (default lidar2d if the robot
                           file has one, else pose)
  --lcm-url URL            LCM provider (default: $LCM_DEFAULT_URL or LCM's default)
SIGINT/SIGTERM: a decision under way is finished and written, then it exits.
Exit status: 0 stopped; 2 bad robot file, config, bus or message; 1 internal error.
)";

// Decodes and feeds the recorder. Handlers are called from C: nothing throws past them.
class Feeder {
 public:
  Feeder(const calib::RobotDescription& robot, calib::SegmentRecorder* recorder)
      : robot_(robot), recorder_(recorder) {}

  void OnWheels(const lcm::ReceiveBuffer*, const std::string& channel, const agvcal::wheel_state_t* msg) {
    ++wheel_states_;
    error_.Run([&] { recorder_->AddWheels(calib::WheelSampleFromMessage(*msg, robot_, channel)); });
  }
  void OnScanMatch(const lcm::ReceiveBuffer*, const std::string& channel, const agvcal::scan_match_t* msg) {
    ++scan_matches_;
    error_.Run([&] { recorder_->AddMotion(calib::FromMessage(*msg, channel)); });
  }
  void OnPose(const lcm::ReceiveBuffer*, const std::string&, const agvcal::pose2d_t* msg) {
    ++poses_;
    error_.Run([&] { recorder_->AddPose(*msg); });
  }
  const std::optional<std::string>& error() const { return error_.message(); }
  // What was received, for the stop line: a shortfall against the recording means lost messages.
  std::string Received() const {
    return std::to_string(wheel_states_) + " wheel states, " + std::to_string(scan_matches_) + " scan matches, " +
           std::to_string(poses_) + " poses";
  }

 private:
  const calib::RobotDescription& robot_;
  calib::SegmentRecorder* recorder_;
  agvcal_process::FirstError error_;
  int64_t wheel_states_ = 0, scan_matches_ = 0, poses_ = 0;
};

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  const Args args = ParseArgs(argc, argv, 1, {"--config", "--out-robot", "--decisions", "--source", "--lcm-url"}, {});
  if (const auto status = CheckUsage(args, kUsage, 1)) return *status;
  if (!args.Has("--config")) throw calib::InputError("command line", "--config", "missing (the recalibration config)");
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const calib::RecalConfig config = calib::LoadRecalConfig(args.Get("--config", ""));
  const calib::MotionSource source = MotionSourceOption(args, robot);
  const std::string robot_out = args.Get("--out-robot", ""), decisions_path = args.Get("--decisions", "");
  calib::CalibrationInUse in_use = calib::StartingCalibration(robot, robot_out, source, config);
  std::cerr << "agvcal-recal: calibration in use: " << in_use.origin << "\n";

  const std::string url = args.Get("--lcm-url", "");
  lcm::LCM lcm(url);
  RequireGoodBus(lcm, url);
  calib::SegmentRecorder recorder(config, robot, source);
  Feeder feeder(robot, &recorder);
  SubscribeEveryMessage(lcm, calib::kWheelsChannel, &Feeder::OnWheels, &feeder);
  if (source == calib::MotionSource::kLidar2d) SubscribeEveryMessage(lcm, calib::kScanMatchChannel, &Feeder::OnScanMatch, &feeder);
  SubscribeEveryMessage(lcm, robot.pose ? robot.pose->channel : calib::kPoseChannel, &Feeder::OnPose, &feeder);
  Heartbeat heartbeat(&lcm, "recal");
  InstallStopHandlers();

  std::future<calib::RecalDecision> pending;
  int accepted = 0, rejected = 0, no_fit = 0;
  auto finish = [&]() {
    const calib::RecalDecision d = pending.get();
    calib::RecordDecision(d, robot_out, decisions_path);
    in_use = d.after;
    (d.verdict == calib::Verdict::kAccepted ? accepted : d.verdict == calib::Verdict::kRejected ? rejected : no_fit)++;
    std::cerr << "agvcal-recal: decision " << d.number << ": " << calib::VerdictName(d.verdict) << ": "
              << d.reason << "\n";
  };
  while (!g_stop_requested) {
    lcm.handleTimeout(50);
    if (pending.valid() && pending.wait_for(std::chrono::seconds(0)) == std::future_status::ready) finish();
    if (!pending.valid()) {
      if (std::optional<calib::SegmentBatch> batch = recorder.TakeBatch()) {
        pending = std::async(std::launch::async, [batch = std::move(*batch), in_use, source, &config]() {
          return calib::Decide(batch, in_use, source, config);
        });
      }
    }
    heartbeat.Beat("segments " + std::to_string(recorder.segments_waiting()) + "/" +
                   std::to_string(config.segments_per_decision) + ", decisions: " + std::to_string(accepted) +
                   " accepted, " + std::to_string(rejected) + " rejected, " + std::to_string(no_fit) + " no fit" +
                   (pending.valid() ? ", deciding" : ""));
  }
  HandleQueued(lcm);
  if (pending.valid()) finish();  // a decision under way is written whole
  heartbeat.Beat("stopped", true);
  if (feeder.error()) throw calib::InputError("bus", "message", *feeder.error());
  std::cerr << "agvcal-recal: stopped; received " << feeder.Received() << "; " << recorder.segments_complete() << " segments ("
            << recorder.segments_dropped() << " dropped), " << accepted << " accepted, " << rejected
            << " rejected, " << no_fit << " no fit\n";
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-recal", Run, argc, argv); }
