// agvcal-recal: recalibration during normal operation, live. Feeds WHEELS, SCAN_MATCH (or the
// pose source's motions) and POSE into calib::SegmentRecorder; each batch of segments is
// decided by calib::Decide on a worker thread (the bus keeps being read meanwhile), one batch
// at a time, in order; the outcome is written by calib::RecordDecision. `agvcal recal` runs the
// same code on a recording and makes the same decisions.
#include <chrono>
#include <future>
#include <iostream>
#include <optional>
#include <string>

#include "calib/calibrate/recalibration.h"
#include "calib/core/errors.h"
#include "calib/io/atomic_file.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "common/bus_source.h"
#include "common/process_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Recalibrates the robot of ROBOT.yaml while it works (no commander): records the
segments of its route that the config names (zones in the POSE frame, or odometry
distance windows) from WHEELS with SCAN_MATCH (from agvcal-scanmatch) or POSE;
every `decision.segments` segments it calibrates on some and compares with the
calibration in use on the others, and accepts the new calibration only when it is
significantly better there and consistent with the one in use
(docs/recalibration.md). Publishes HEARTBEAT.)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md)")
      .Option("--config", "RECAL.yaml", "zones or distance windows, decision levels, prior\n"
              "uncertainties (required)")
      .Option("--out-robot", "CAL.yaml",
              "the accepted calibration, as a robot file (written atomically);\n"
              "when it exists at the start, the calibration in use starts from it")
      .Option("--decisions", "FILE", "every decision appended as a JSON line (atomically)")
      .Option("--source", "lidar2d|pose",
              "the sensor whose motion calibrates (default lidar2d if the robot\n"
              "file has one, else pose)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("SIGINT/SIGTERM: a decision under way is finished and written, then it exits. A\n"
              "message that does not decode or convert is skipped, counted and reported once.\n"
              "Exit status: 0 stopped; 2 bad robot file, config or bus; 1 internal error.\n");
}

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-recal");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  if (!args.Has("--config")) throw calib::InputError("command line", "--config", "missing (the recalibration config)");
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const calib::RecalConfig config = calib::LoadRecalConfig(args.Get("--config", ""));
  const calib::MotionSource source =
      MotionSourceOption(args, {calib::MotionSource::kLidar2d, calib::MotionSource::kPose}, LiveMotionSource(robot))
          .value();
  const std::string robot_out = args.Get("--out-robot", ""), decisions_path = args.Get("--decisions", "");
  calib::CheckOutputs({args.positional[0], args.Get("--config", "")}, {{"--out-robot", robot_out}, {"--decisions", decisions_path}});
  calib::CalibrationInUse in_use = calib::StartingCalibration(robot, robot_out, source, config);
  std::cerr << "agvcal-recal: calibration in use: " << in_use.origin << "\n";

  BusSource bus(args.Get("--lcm-url", ""), "agvcal-recal");
  calib::SegmentRecorder recorder(config, robot, source);
  calib::SubscribeWheels(&bus, robot, [&](const calib::WheelSample& sample) { recorder.AddWheels(sample); });
  if (source == calib::MotionSource::kLidar2d)
    calib::SubscribeScanMatches(&bus, [&](const calib::SensorMotion& motion) { recorder.AddMotion(motion); });
  const std::string pose_channel = calib::PoseChannel(robot);
  calib::SubscribePoses(&bus, pose_channel, [&](const calib::StampedPose& pose) { recorder.AddPose(pose); });
  Heartbeat heartbeat(&bus.lcm(), "recal");
  bus.ReportOn(&heartbeat);
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
  while (!bus.done()) {
    bus.HandleNext(50);
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
  bus.HandleQueued();
  bus.Finish();  // a message a stream's gate still holds (after a long gap)
  if (pending.valid()) finish();  // a decision under way is written whole
  heartbeat.Beat("stopped", true);
  // What was received: a shortfall against the recording means lost messages.
  std::cerr << "agvcal-recal: stopped; received " << bus.received(calib::kWheelsChannel) << " wheel states, "
            << bus.received(calib::kScanMatchChannel) << " scan matches, " << bus.received(pose_channel)
            << " poses, " << bus.skipped() << " unusable messages; " << recorder.segments_complete() << " segments ("
            << recorder.segments_dropped() << " dropped), " << accepted << " accepted, " << rejected
            << " rejected, " << no_fit << " no fit\n";
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-recal", Run, argc, argv); }
