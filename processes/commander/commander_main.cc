// agvcal-commander: drives the excitation trajectory of a robot file on the
// LCM bus. Its clock is the newest WHEELS time (robot clock); it publishes
// DRIVE_CMD at a fixed rate of robot time, COMMANDER_STATUS with each command
// and a HEARTBEAT each wall-clock second. It holds the robot still (stop
// commands, calib/live/commander_safety.h) while WHEELS, the lidar's scans or its own
// HEARTBEAT are stale (wall clock) and while the operator's STOP is engaged,
// and stops it on SIGINT/SIGTERM and at the end; if it crashes, the timeout of
// its last command stops the robot.
#include <algorithm>
#include <climits>
#include <cmath>
#include <iostream>
#include <map>
#include <optional>

#include <unistd.h>

#include "agvcal/commander_status_t.hpp"
#include "agvcal/drive_command_t.hpp"
#include "agvcal/heartbeat_t.hpp"
#include "agvcal/operator_stop_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/io/messages.h"
#include "calib/live/commander.h"
#include "calib/live/commander_safety.h"
#include "common/bus_source.h"
#include "common/process_util.h"

namespace {

// The command line: arguments, options and the help made from them.
void Declare(agvcal_process::CommandLine* args) {
  args->Description(R"(Drives the robot of ROBOT.yaml through an excitation trajectory within the
limits of the robot file: publishes DRIVE_CMD, using the time of the newest
WHEELS message as its clock, and COMMANDER_STATUS and HEARTBEAT. The robot is
held still (stop commands; the trajectory resumes from rest afterwards) while
WHEELS or the lidar's scans (lidar2d channel of ROBOT.yaml) are stale, while its
own HEARTBEAT does not come back from the bus, and from an operator stop on
STOP (`agvcal stop`) until its release (`agvcal stop --release`).)")
      .Positional("ROBOT.yaml", "the robot file (docs/spec/robot.md)")
      .Option("--trajectory", "NAME",
              "excitation trajectory (default \"default\"); per drive type:\n" +
                  agvcal_process::TrajectoryNamesText())
      .Option("--stale-timeout", "S",
              "wall-clock seconds without WHEELS (or scans) after which the\n"
              "robot is told to stop (default 0.5); it resumes when they return")
      .Option("--heartbeat-timeout", "S", "the same for its own HEARTBEAT, back from the bus (default 3)")
      .Flag("--ignore-scans", "do not watch the lidar's scans (a robot driven without its lidar)")
      .Option("--rate", "HZ", "commands per second of robot time (default 20)")
      .Option("--lcm-url", "URL", agvcal_process::kLcmUrlHelp)
      .Footer("Exit status: 0 trajectory finished or stopped by SIGINT/SIGTERM (a stop command\n"
              "is sent first), 2 bad robot file, trajectory or bus, 1 internal error.\n");
}

constexpr int kFinalStops = 5;  // stop commands sent after the trajectory ends

// Keeps the newest wheel state's time; the first message's steering readings
// seed the commander's first steering ramp.
class WheelListener {
 public:
  void OnWheels(const agvcal::wheel_state_t& msg) {
    fresh_ = true;
    utime_ = msg.utime;
    if (first_steer_.empty()) {
      const size_t n = std::min({static_cast<size_t>(std::max(msg.num_wheels, 0)),
                                 msg.name.size(), msg.steer.size()});
      for (size_t i = 0; i < n; ++i) first_steer_[msg.name[i]] = msg.steer[i];
    }
  }
  // True once per message received since the last call.
  bool TakeFresh() {
    const bool f = fresh_;
    fresh_ = false;
    return f;
  }
  int64_t utime() const { return utime_; }
  const std::map<std::string, double>& first_steer() const { return first_steer_; }

 private:
  bool fresh_ = false;
  int64_t utime_ = 0;
  std::map<std::string, double> first_steer_;
};

// Tells the safety monitor when scans, its own heartbeats and operator stops arrive.
class SafetyListener {
 public:
  explicit SafetyListener(calib::CommanderSafety* safety) : safety_(safety) {}
  void OnScan(const std::string& channel) { safety_->Seen(channel, agvcal_process::WallMicros()); }
  void OnHeartbeat(const agvcal::heartbeat_t& msg) {
    if (msg.process == "commander" && msg.pid == getpid())
      safety_->Seen(kOwnHeartbeat, agvcal_process::WallMicros());
  }
  void OnStop(const agvcal::operator_stop_t& msg) {
    if (msg.stop != safety_->operator_stop())
      std::cerr << "agvcal-commander: operator " << (msg.stop ? "stop" : "release") << " from "
                << msg.source << (msg.reason.empty() ? "" : ": " + msg.reason) << "\n";
    safety_->SetOperatorStop(msg.stop, msg.source + (msg.reason.empty() ? "" : ": " + msg.reason));
  }
  static constexpr const char* kOwnHeartbeat = "own HEARTBEAT";

 private:
  calib::CommanderSafety* safety_;
};

// True steering angle of each wheel role from raw readings keyed by wheel name (0 where missing).
std::vector<double> TrueSteer(const calib::RobotDescription& robot,
                              const std::map<std::string, double>& raw) {
  std::vector<double> out;
  for (const std::string& role : calib::WheelRoles(robot.drive)) {
    double offset = 0.0;
    if (robot.drive == calib::DriveType::kTricycle) offset = robot.param("steer_offset");
    if (robot.drive == calib::DriveType::kDualSteer && role == "a1")
      offset = robot.param("a1_steer_offset");
    const auto it = raw.find(robot.wheel_name(role));
    const double angle = it == raw.end() || !std::isfinite(it->second) ? 0.0 : it->second - offset;
    out.push_back(std::clamp(angle, -robot.limits.max_steer, robot.limits.max_steer));
  }
  return out;
}

const char* StateName(calib::CommanderState s) {
  return s == calib::CommanderState::kFinished ? "finished" : "running";
}

int Run(int argc, char** argv) {
  using namespace agvcal_process;
  CommandLine args("agvcal-commander");
  Declare(&args);
  if (const auto status = args.Parse(argc, argv, 1)) return *status;
  const double stale_timeout_s = args.GetDouble("--stale-timeout", 0.5);
  const double heartbeat_timeout_s = args.GetDouble("--heartbeat-timeout", 3.0);
  const double rate_hz = args.GetDouble("--rate", 20.0);
  if (!(stale_timeout_s > 0)) throw calib::InputError("command line", "--stale-timeout", "must be > 0");
  if (!(heartbeat_timeout_s >= 1.5))  // heartbeats come once a second
    throw calib::InputError("command line", "--heartbeat-timeout", "must be >= 1.5");
  if (!(rate_hz > 0 && rate_hz <= 1000)) {
    throw calib::InputError("command line", "--rate", "must be in (0, 1000]");
  }
  const std::string trajectory_name = args.Get("--trajectory", "default");

  const calib::RobotDescription robot = calib::LoadRobotFile(args.positional[0]);
  const calib::Trajectory trajectory = calib::MakeTrajectory(robot, trajectory_name);
  calib::CommanderOptions options;
  options.command_timeout_s = std::max(0.5, 3.0 / rate_hz);  // outlives a few command periods
  const calib::Commander plan(robot, trajectory, options);  // validates before touching the bus

  calib::CommanderSafety safety;
  safety.Watch(calib::kWheelsChannel, stale_timeout_s);
  const bool watch_scans = robot.lidar2d && !args.Has("--ignore-scans");
  if (watch_scans) safety.Watch(robot.lidar2d->channel, stale_timeout_s);
  safety.Watch(SafetyListener::kOwnHeartbeat, heartbeat_timeout_s);

  BusSource bus(args.Get("--lcm-url", ""), "agvcal-commander");
  lcm::LCM& lcm = bus.lcm();
  WheelListener wheels;
  SafetyListener safety_listener(&safety);
  bus.Subscribe<agvcal::wheel_state_t>(
      calib::kWheelsChannel, [&](const agvcal::wheel_state_t& m, const std::string&) { wheels.OnWheels(m); });
  if (watch_scans) {
    bus.SubscribeRaw(robot.lidar2d->channel,
                     [&](const std::string& channel, const uint8_t*, size_t) { safety_listener.OnScan(channel); });
  }
  bus.Subscribe<agvcal::heartbeat_t>(
      calib::kHeartbeatChannel, [&](const agvcal::heartbeat_t& m, const std::string&) { safety_listener.OnHeartbeat(m); });
  bus.Subscribe<agvcal::operator_stop_t>(
      calib::kStopChannel, [&](const agvcal::operator_stop_t& m, const std::string&) { safety_listener.OnStop(m); });
  Heartbeat heartbeat(&lcm, "commander");
  InstallStopHandlers();

  std::optional<calib::Commander> commander;
  const int64_t period_us = std::max<int64_t>(1, std::llround(1e6 / rate_hz));
  int64_t seq = 0;
  int64_t last_utime = 0;         // newest wheel-state time (robot clock)
  bool robot_time_known = false;  // a wheel state has arrived
  int64_t next_command_utime = 0;
  int64_t last_hold_stop_wall = 0;
  std::optional<std::string> held;  // why the robot is being held still
  int final_stops = 0;

  // Stamps are the wheel-state time; a stop sent without a newer wheel state (stale inputs, the
  // end) gets 1 us more than the previous command, so stamps stay strictly increasing.
  int64_t last_stamp = INT64_MIN;
  auto publish_command = [&](calib::DriveCommand command) {
    if (last_stamp != INT64_MIN) command.utime = std::max(command.utime, last_stamp + 1);
    last_stamp = command.utime;
    const agvcal::drive_command_t msg = calib::ToMessage(command, robot, seq++);
    lcm.publish(calib::kDriveCmdChannel, &msg);
  };
  auto publish_stop = [&]() {
    // Before the first wheel state nothing has been commanded, and a stop would have no robot
    // time to carry (a stamp of 0 amid robot-clock stamps): the status alone says why we wait.
    if (!robot_time_known) return;
    calib::DriveCommand stop;
    stop.mode = calib::DriveMode::kStop;
    stop.utime = last_utime;
    stop.timeout_s = options.command_timeout_s;
    publish_command(stop);
  };
  auto publish_status = [&](const std::string& state) {
    agvcal::commander_status_t msg;
    msg.utime = last_utime;
    msg.trajectory = trajectory_name;
    const calib::CommanderStatus st =
        commander ? commander->status() : calib::CommanderStatus{};
    msg.segment = st.segment;
    msg.num_segments = static_cast<int32_t>(trajectory.segments.size());
    msg.segment_name = held ? *held : commander ? st.segment_description : "waiting for WHEELS";
    msg.state = state;
    lcm.publish(calib::kCommanderStatusChannel, &msg);
  };
  auto finish = [&](const std::string& state) {
    publish_stop();
    publish_status(state);
    heartbeat.Beat(state, true /* force */);
    return calib::kExitOk;
  };

  std::cerr << "agvcal-commander: " << robot.name << " (" << calib::DriveTypeName(robot.drive)
            << "), trajectory '" << trajectory_name << "', " << trajectory.segments.size()
            << " segments, about "
            << std::lround(plan.nominal_duration_s())
            << " s; waiting for WHEELS\n";

  while (true) {
    if (bus.done()) {
      std::cerr << "agvcal-commander: stop requested, robot told to stop\n";
      return finish("stopped");
    }
    bus.HandleNext(static_cast<int>(std::clamp<int64_t>(period_us / 4000, 1, 20)));
    heartbeat.Beat(held ? "held: " + *held
                   : !commander ? "waiting for WHEELS"
                                : std::string(StateName(commander->status().state)) + " segment " +
                                      std::to_string(commander->status().segment + 1) + "/" +
                                      std::to_string(commander->status().num_segments));

    const bool fresh = wheels.TakeFresh();
    if (fresh) {
      safety.Seen(calib::kWheelsChannel, WallMicros());
      const int64_t utime = wheels.utime();
      if (commander && utime < last_utime) continue;  // older than what we have: ignore
      last_utime = utime;
      robot_time_known = true;
    }
    const std::optional<std::string> reason = safety.HoldReason(WallMicros());
    if (reason) {
      if (!held || *held != *reason) {
        if (!held && commander) commander->Interrupt(last_utime);
        if (!held || reason->rfind("no ", 0) != 0)  // the seconds of a stale input keep counting
          std::cerr << "agvcal-commander: " << *reason << ", robot told to stop\n";
        held = reason;
      }
      if (WallMicros() - last_hold_stop_wall >= period_us) {
        last_hold_stop_wall = WallMicros();
        publish_stop();
        publish_status(safety.operator_stop() ? "operator_stop" : "stale_inputs");
      }
      if (commander && commander->status().state == calib::CommanderState::kFinished) {
        for (int k = 1; k < kFinalStops; ++k) publish_stop();
        return finish("finished");
      }
      continue;
    }
    if (held) {
      std::cerr << "agvcal-commander: " << (commander ? "inputs back, resuming" : "inputs arriving, starting")
                << "\n";
      held.reset();
    }
    if (!fresh) continue;
    if (!commander) {
      calib::CommanderOptions opts = options;
      if (robot.drive != calib::DriveType::kDifferential)
        opts.initial_steer = TrueSteer(robot, wheels.first_steer());
      commander.emplace(robot, trajectory, opts);
      next_command_utime = last_utime;
    }
    if (last_utime >= next_command_utime) {
      calib::DriveCommand command = commander->Step(last_utime);
      command.utime = last_utime;
      publish_command(command);
      const calib::CommanderStatus st = commander->status();
      publish_status(StateName(st.state));
      next_command_utime += period_us;
      if (next_command_utime <= last_utime) next_command_utime = last_utime + period_us;
      if (st.state == calib::CommanderState::kFinished && ++final_stops >= kFinalStops) {
        std::cerr << "agvcal-commander: trajectory finished\n";
        return finish("finished");
      }
    }
  }
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-commander", Run, argc, argv); }
