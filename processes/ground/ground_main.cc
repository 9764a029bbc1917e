// agvcal-ground: the 3D lidar's height, pitch and roll above the floor, live.
// Wires LCM to calib::GroundSession (the same code as `agvcal ground`) and
// publishes the estimate after every cloud.
#include <lcm/lcm-cpp.hpp>

#include <exception>
#include <iostream>
#include <string>

#include "agvcal/ground_estimate_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/ground/ground.h"
#include "calib/ground/ground_session.h"
#include "calib/io/atomic_file.h"
#include "calib/io/messages.h"
#include "common/process_util.h"

namespace {

const char* kUsage =
    R"(usage: agvcal-ground ROBOT.yaml [--config GROUND.yaml] [--out RESULT.json] [--grid]
                     [--window N] [--lcm-url URL]

Calibrates the 3D lidar of ROBOT.yaml (lidar3d) from the floor while the robot
runs: subscribes lidar3d.channel (CLOUD) and, for a lidar that turns on its
mount, lidar3d.rotation.channel (mount_angle_t); publishes GROUND_ESTIMATE
(ground_estimate_t: the estimate so far, or why there is none yet) after every
cloud and HEARTBEAT every second. On SIGINT/SIGTERM, or at the end of the log
of a file:// provider, it writes RESULT.json (--out) as `agvcal ground` would
from the same messages, and exits.
  --config FILE   options (config/ground.yaml)
  --out FILE      result at the end (nothing is written when the floor did not
                  determine the answer: exit 3)
  --grid          keep points for the grid search and add it to RESULT.json
  --window N      use only the newest N clouds (default: all since the start)
  --lcm-url URL   LCM provider (default: $LCM_DEFAULT_URL or LCM's default)
Exit status: 0 stopped (and the result written), 2 bad robot file, options or
bus, 3 the floor did not determine the answer (with --out), 1 internal error.
)";

// LCM calls this from C: nothing may throw past it (STYLE.md); a corrupt
// message is reported and skipped, as a live process must go on.
class Node {
 public:
  Node(lcm::LCM* lcm, calib::GroundSession* session) : lcm_(lcm), session_(session) {}

  void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    try {
      const bool cloud = channel == session_->cloud_channel();
      session_->OnMessage(channel, rbuf->data, static_cast<int>(rbuf->data_size), "bus",
                          "message at " + std::to_string(rbuf->recv_utime) + " us");
      if (!cloud) return;
      const agvcal::ground_estimate_t msg = session_->EstimateMessage();
      lcm_->publish(calib::kGroundEstimateChannel, &msg);
      state_ = msg.status.substr(0, msg.status.find(':'));
    } catch (const calib::InputError& e) {
      ++corrupt_;
      std::cerr << "agvcal-ground: skipped: " << e.what() << "\n";
    } catch (const std::exception& e) {
      error_ = e.what();
    }
  }
  const std::string& error() const { return error_; }
  std::string state() const {
    return std::to_string(session_->clouds()) + " clouds, " + (state_.empty() ? "waiting" : state_);
  }

 private:
  lcm::LCM* lcm_;
  calib::GroundSession* session_;
  std::string error_, state_;
  int corrupt_ = 0;
};

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  const Args args = ParseArgs(argc, argv, 1, {"--config", "--out", "--window", "--lcm-url"}, {"--grid"});
  if (const auto status = CheckUsage(args, kUsage, 1)) return *status;
  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  calib::GroundOptions options =
      args.Has("--config") ? calib::LoadGroundOptions(args.Get("--config", "")) : calib::GroundOptions{};
  if (args.Has("--window")) {
    const double window = args.GetDouble("--window", 0);
    if (!(window >= 1) || window != static_cast<double>(static_cast<int>(window)))
      throw calib::InputError("command line", "--window", "expected a whole number >= 1");
    options.frames.max_frames = static_cast<int>(window);
  }
  const bool grid = args.Has("--grid");
  if (!grid) options.grid.max_points = 0;  // keeps no points: memory stays flat on a long run
  calib::GroundSession session(robot, options);

  const std::string url = args.Get("--lcm-url", "");
  lcm::LCM lcm(url);
  RequireGoodBus(lcm, url);
  Node node(&lcm, &session);
  SubscribeEveryMessage(lcm, session.cloud_channel(), &Node::OnMessage, &node);
  if (!session.angle_channel().empty()) SubscribeEveryMessage(lcm, session.angle_channel(), &Node::OnMessage, &node);
  Heartbeat heartbeat(&lcm, "ground");
  InstallStopHandlers();
  std::cerr << "agvcal-ground: " << robot.name << ", listening on " << session.cloud_channel()
            << (session.angle_channel().empty() ? "" : " and " + session.angle_channel()) << "\n";

  const bool from_file = url.rfind("file://", 0) == 0;
  while (!g_stop_requested) {
    const int handled = lcm.handleTimeout(200);
    if (!node.error().empty()) throw std::runtime_error(node.error());
    if (handled < 0) {
      if (from_file) break;  // the file provider's log has ended
      if (!g_stop_requested) throw std::runtime_error("receiving from the LCM bus failed");
    }
    heartbeat.Beat(node.state());
  }
  heartbeat.Beat("stopped: " + node.state(), true /* force */);

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
