// agvcal-ground: the 3D lidar's height, pitch and roll above the floor, live.
// Wires LCM to calib::GroundSession (the same code as `agvcal ground`) and
// publishes the estimate after every cloud.
#include <iostream>
#include <string>

#include "agvcal/ground_estimate_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/ground/ground.h"
#include "calib/ground/ground_session.h"
#include "calib/io/atomic_file.h"
#include "calib/io/messages.h"
#include "common/bus_source.h"
#include "common/process_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Calibrates the 3D lidar of ROBOT.yaml (lidar3d) from the floor while the robot
runs: subscribes lidar3d.channel (CLOUD) and, for a lidar that turns on its
mount, lidar3d.rotation.channel (mount_angle_t); publishes GROUND_ESTIMATE
(ground_estimate_t: the estimate so far, or why there is none yet) after every
cloud and HEARTBEAT every second. On SIGINT/SIGTERM, or at the end of the log
of a file:// provider, it writes RESULT.json (--out) as `agvcal ground` would
from the same messages, and exits.)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md), with lidar3d")
      .Option("--config", "FILE", "options (config/ground.yaml)")
      .Option("--out", "FILE",
              "result at the end (nothing is written when the floor did not\n"
              "determine the answer: exit 3)")
      .Flag("--grid", "keep points for the grid search and add it to RESULT.json")
      .Option("--window", "N", "use only the newest N clouds (default: all since the start)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("Exit status: 0 stopped (and the result written), 2 bad robot file, options or\n"
              "bus, 3 the floor did not determine the answer (with --out), 1 internal error.\n");
}

// The message of a session's state (GROUND_ESTIMATE).
agvcal::ground_estimate_t ToMessage(const calib::GroundEstimate& e) {
  agvcal::ground_estimate_t msg{};
  msg.utime = e.utime;
  msg.status = e.status;
  msg.frames_seen = e.frames_seen;
  msg.frames = e.frames;
  msg.inliers = e.inliers;
  msg.z = e.z, msg.pitch = e.pitch, msg.roll = e.roll;
  msg.z_std = e.z_std, msg.pitch_std = e.pitch_std, msg.roll_std = e.roll_std;
  msg.sector = e.sector;
  msg.angle = e.angle;
  msg.sectors_done = e.sectors_done;
  msg.num_sectors = e.num_sectors;
  return msg;
}

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-ground");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  calib::GroundOptions options =
      args.Has("--config") ? calib::LoadGroundOptions(args.Get("--config", "")) : calib::GroundOptions{};
  if (args.Has("--window")) {
    const double window = args.GetDouble("--window", 0);
    if (!(window >= 1) || window != static_cast<double>(static_cast<int>(window)))
      throw calib::InputError("command line", "--window", "expected a whole number >= 1");
    options.frames.max_frames = static_cast<int>(window);
  }
  calib::CheckOutputs({args.positional[0], args.Get("--config", "")}, {{"--out", args.Get("--out", "")}});
  const bool grid = args.Has("--grid");
  if (!grid) options.grid.max_points = 0;  // keeps no points: memory stays flat on a long run
  calib::GroundSession session(robot, options);

  const std::string url = args.Get("--lcm-url", "");
  BusSource bus(url, "agvcal-ground");
  std::string state;  // of the newest estimate: "ok", "waiting", "refused"
  session.Subscribe(&bus, [&]() {
    const agvcal::ground_estimate_t msg = ToMessage(session.CurrentEstimate());
    bus.lcm().publish(calib::kGroundEstimateChannel, &msg);
    state = msg.status.substr(0, msg.status.find(':'));
  });
  auto state_line = [&]() {
    return std::to_string(session.clouds()) + " clouds, " + (state.empty() ? "waiting" : state);
  };
  Heartbeat heartbeat(&bus.lcm(), "ground");
  bus.ReportOn(&heartbeat);
  InstallStopHandlers();
  std::cerr << "agvcal-ground: " << robot.name << ", listening on " << session.cloud_channel()
            << (session.angle_channel().empty() ? "" : " and " + session.angle_channel()) << "\n";

  while (!bus.done()) {  // SIGINT/SIGTERM, or the end of a file:// provider's log
    bus.HandleNext(200);
    heartbeat.Beat(state_line());
  }
  bus.HandleQueued();
  bus.Finish();  // a cloud the stream's gate still holds (after a long gap)
  heartbeat.Beat("stopped: " + state_line(), true /* force */);

  if (!args.Has("--out")) return calib::kExitOk;
  calib::GroundInput input;
  input.path = url.empty() ? "lcm" : url;
  input.kind = "live";
  input.clouds = session.clouds();
  const calib::GroundResult result = session.calibrator().Result(grid);  // may refuse: exit 3
  calib::WriteFileAtomically(args.Get("--out", ""), calib::GroundResultJson(result, input));
  std::cerr << calib::GroundResultText(result, input);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-ground", Run, argc, argv); }
