// Checks a recording made by the live process group, for the end-to-end tests:
//   e2e_log_check rates LOG CHANNEL=HZ...     every channel present at its rate (±10 %)
//   e2e_log_check tracking LOG ROBOT.yaml     the true motion followed the commanded one
//   e2e_log_check same LOG_A LOG_B            same messages (bytes) per channel, in order; LOG_B
//                                             may have HEARTBEAT besides (the group's own marks)
//   e2e_log_check intervals LOG               prints the intervals of LOG's last CALIB_ESTIMATE
//                                             (0 if none; LOG may be still being written)
//   e2e_log_check estimates LOG               prints "STATUS INTERVALS" of each CALIB_ESTIMATE of LOG
//   e2e_log_check stale LOG                   the commander reported stale inputs and stopped the robot
//   e2e_log_check scanmatch LOG ROBOT.yaml LIVE  SCAN_MATCH in LIVE equals the offline pipeline
//                                             run over LOG's WHEELS and scans, bit for bit
//   e2e_log_check limits LOG ROBOT.yaml       no DRIVE_CMD exceeds the robot file's limits
//   e2e_log_check held LOG STATE [CHANNEL]    from the commander's first STATE status (after it
//                                             has driven) until it runs
//                                             again, only stop commands (CHANNEL still arriving),
//                                             and the true robot at rest
//   e2e_log_check halted LOG                  after the last DRIVE_CMD (commander killed), the
//                                             true robot comes to rest by itself
// Times between processes are the logger's receive times (wall clock).
// Prints one line per check and exits 1 if any fails.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "agvcal/calib_estimate_t.hpp"
#include "agvcal/commander_status_t.hpp"
#include "agvcal/drive_command_t.hpp"
#include "agvcal/laser_scan_t.hpp"
#include "agvcal/pose2d_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/calibrate/fused_odometry.h"
#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/wheel_track.h"
#include "calib/io/log_summary.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "calib/match/scan_match.h"

namespace {

int failures = 0;
void Check(bool ok, const std::string& what) {
  std::cout << (ok ? "PASS " : "FAIL ") << what << "\n";
  if (!ok) ++failures;
}

int Rates(int argc, char** argv) {
  const calib::LogSummary summary = calib::SummarizeLog(argv[2]);
  for (int i = 3; i < argc; ++i) {
    const std::string spec = argv[i];
    const std::string channel = spec.substr(0, spec.find('='));
    const double expected = std::stod(spec.substr(spec.find('=') + 1));
    const auto it = summary.channels.find(channel);
    const double rate = it == summary.channels.end() ? 0.0 : it->second.rate_hz;
    Check(std::abs(rate - expected) <= 0.1 * expected,
          channel + " rate " + std::to_string(rate) + " Hz, expected " + std::to_string(expected));
    if (it != summary.channels.end())
      Check(it->second.out_of_order == 0 && it->second.duplicated == 0,
            channel + " stamps strictly increasing");
  }
  return failures ? 1 : 0;
}

// Commanded body twist over time (nominal model, as the robot's controller
// sees it) against the true twist from GROUND_TRUTH differences.
int Tracking(const std::string& log, const std::string& robot_file) {
  const calib::RobotDescription robot = calib::LoadRobotFile(robot_file);
  const auto model = calib::MakeDriveModel(robot);
  std::vector<std::pair<int64_t, calib::Twist2>> commands;
  std::vector<agvcal::pose2d_t> truth;
  calib::LogReader reader(log);
  calib::LogEvent e;
  while (reader.Next(&e)) {
    if (e.channel == calib::kDriveCmdChannel) {
      agvcal::drive_command_t m;
      calib::Decode(e.data.data(), int(e.data.size()), &m);
      const calib::DriveCommand c = calib::FromMessage(m, robot, log);
      calib::Twist2 t;
      if (c.mode == calib::DriveMode::kTwist) t = c.twist;
      if (c.mode == calib::DriveMode::kWheels) t = model->Forward(c.wheels);
      commands.push_back({m.utime, t});
    } else if (e.channel == calib::kGroundTruthChannel) {
      agvcal::pose2d_t m;
      calib::Decode(e.data.data(), int(e.data.size()), &m);
      truth.push_back(m);
    }
  }
  Check(commands.size() > 100, "DRIVE_CMD recorded (" + std::to_string(commands.size()) + ")");
  Check(truth.size() > 100, "GROUND_TRUTH recorded (" + std::to_string(truth.size()) + ")");
  if (failures) return 1;
  // Live, a command reaches the simulator some time after the stamp it carries (more on a loaded
  // machine, and times --speed in simulated time): the truth is compared with the command in force
  // a delivery delay earlier, the delay that fits best, which must itself be short.
  struct Fit {
    double rms_v = 0, rms_w = 0, path = 0, commanded_path = 0;
    int n = 0;
  };
  auto fit_with_delay = [&](int64_t delay_us) {
    // The command in force at each ground-truth sample, delay_us before it.
    std::vector<calib::Twist2> commanded(truth.size());
    for (size_t i = 0, k = 0; i < truth.size(); ++i) {
      while (k < commands.size() && commands[k].first <= truth[i].utime - delay_us) ++k;
      if (k > 0) commanded[i] = commands[k - 1].second;
    }
    Fit f;
    double sum_v = 0, sum_w = 0;
    const int stride = 10;  // compare mean velocities over 0.1 s windows at 100 Hz
    for (size_t i = stride; i < truth.size(); i += stride) {
      const auto& a = truth[i - stride];
      const auto& b = truth[i];
      if (a.utime < commands.front().first + delay_us) continue;
      const calib::Pose2 d = calib::Between({a.x, a.y, a.theta}, {b.x, b.y, b.theta});
      const double dt = (b.utime - a.utime) * 1e-6;
      calib::Twist2 mean;
      for (size_t j = i - stride; j < i; ++j) {
        mean.vx += commanded[j].vx / stride;
        mean.omega += commanded[j].omega / stride;
      }
      sum_v += std::pow(d.x / dt - mean.vx, 2);
      sum_w += std::pow(d.theta / dt - mean.omega, 2);
      ++f.n;
      f.path += std::hypot(d.x, d.y);
      f.commanded_path += std::abs(mean.vx) * dt;
    }
    f.rms_v = std::sqrt(sum_v / std::max(f.n, 1));
    f.rms_w = std::sqrt(sum_w / std::max(f.n, 1));
    return f;
  };
  const int64_t kMaxDelayUs = 300000, kDelayStepUs = 10000;
  int64_t delay_us = 0;
  Fit fit = fit_with_delay(0);
  for (int64_t d = kDelayStepUs; d <= kMaxDelayUs; d += kDelayStepUs) {
    const Fit f = fit_with_delay(d);
    if (f.rms_v * f.rms_v + f.rms_w * f.rms_w < fit.rms_v * fit.rms_v + fit.rms_w * fit.rms_w) fit = f, delay_us = d;
  }
  std::cout << "e2e_log_check: " << log << ": the truth follows the commands " << delay_us / 1000
            << " ms after their stamps\n";
  Check(delay_us < kMaxDelayUs, "commands take effect within " + std::to_string(kMaxDelayUs / 1000) + " ms");
  Check(fit.n > 100, "compared " + std::to_string(fit.n) + " velocity samples");
  Check(fit.path > 2.0, "the robot moved " + std::to_string(fit.path) + " m");
  Check(std::abs(fit.path - fit.commanded_path) < 0.05 * fit.commanded_path,
        "true path " + std::to_string(fit.path) + " m vs commanded " + std::to_string(fit.commanded_path) + " m (5 %)");
  Check(fit.rms_v < 0.03, "forward speed follows the command: rms error " + std::to_string(fit.rms_v) + " m/s (< 0.03)");
  Check(fit.rms_w < 0.03, "turn rate follows the command: rms error " + std::to_string(fit.rms_w) + " rad/s (< 0.03)");
  return failures ? 1 : 0;
}

int Same(const std::string& a, const std::string& b) {
  auto read = [](const std::string& path) {
    std::map<std::string, std::vector<std::vector<uint8_t>>> by_channel;
    calib::LogReader reader(path);
    calib::LogEvent e;
    while (reader.Next(&e)) by_channel[e.channel].push_back(e.data);
    return by_channel;
  };
  const auto x = read(a), y = read(b);
  for (const auto& [channel, messages] : x) {
    const auto it = y.find(channel);
    const size_t other = it == y.end() ? 0 : it->second.size();
    Check(other == messages.size(), channel + ": " + std::to_string(messages.size()) + " vs " +
                                        std::to_string(other) + " messages");
    if (other == messages.size()) Check(it->second == messages, channel + ": identical bytes");
  }
  for (const auto& [channel, messages] : y)
    if (!x.count(channel) && channel != calib::kHeartbeatChannel)
      Check(false, channel + ": " + std::to_string(messages.size()) + " messages not in " + a);
  return failures ? 1 : 0;
}

int Intervals(const std::string& log) {
  calib::LogReader reader(log);
  calib::LogEvent e;
  int intervals = 0;
  while (reader.NextComplete(&e)) {
    agvcal::calib_estimate_t m;
    if (e.channel == calib::kCalibEstimateChannel && calib::Decode(e.data.data(), int(e.data.size()), &m))
      intervals = m.intervals;
  }
  std::cout << intervals << "\n";
  return 0;
}

// One line per CALIB_ESTIMATE: its status and intervals ("ok 20"), in recording order.
int Estimates(const std::string& log) {
  calib::LogReader reader(log);
  calib::LogEvent e;
  while (reader.NextComplete(&e)) {
    agvcal::calib_estimate_t m;
    if (e.channel == calib::kCalibEstimateChannel && calib::Decode(e.data.data(), int(e.data.size()), &m))
      std::cout << m.status << " " << m.intervals << "\n";
  }
  return 0;
}

int Stale(const std::string& log) {
  calib::LogReader reader(log);
  calib::LogEvent e;
  int moving = 0, stale_reports = 0, last_mode = -1;
  while (reader.Next(&e)) {
    if (e.channel == calib::kDriveCmdChannel) {
      agvcal::drive_command_t m;
      calib::Decode(e.data.data(), int(e.data.size()), &m);
      last_mode = m.mode;
      if (m.mode != agvcal::drive_command_t::MODE_STOP) ++moving;
    } else if (e.channel == calib::kCommanderStatusChannel) {
      agvcal::commander_status_t m;
      calib::Decode(e.data.data(), int(e.data.size()), &m);
      if (m.state == "stale_inputs") ++stale_reports;
    }
  }
  Check(moving > 10, "the commander drove while wheel states came (" + std::to_string(moving) + " commands)");
  Check(stale_reports > 0, "it reported stale inputs");
  Check(last_mode == agvcal::drive_command_t::MODE_STOP, "its last command is a stop");
  return failures ? 1 : 0;
}

// The live scan matcher against the same front end run offline on the
// recording that was replayed into it.
int ScanMatch(const std::string& log, const std::string& robot_file, const std::string& live) {
  const calib::RobotDescription robot = calib::LoadRobotFile(robot_file);
  calib::ScanMatcher matcher(robot);
  std::vector<calib::SensorMotion> offline;
  auto keep_matches = [&](const std::vector<calib::ScanMatchOutcome>& outcomes) {
    for (const calib::ScanMatchOutcome& outcome : outcomes)
      if (outcome.matched()) offline.push_back(outcome.motion);
  };
  calib::RecordingSource recording(log);
  calib::SubscribeWheels(&recording, robot, [&](const calib::WheelSample& s) { keep_matches(matcher.AddWheels(s)); });
  calib::SubscribeScans(&recording, robot.lidar2d->channel, [&](calib::LaserScan s) { keep_matches(matcher.AddScan(s)); });
  recording.HandleAll();
  keep_matches(matcher.Finish());
  std::vector<std::vector<uint8_t>> live_messages;
  calib::LogReader live_reader(live);
  calib::LogEvent e;
  while (live_reader.Next(&e))
    if (e.channel == calib::kScanMatchChannel) live_messages.push_back(e.data);
  Check(offline.size() > 20, "offline: " + std::to_string(offline.size()) + " keyframe matches");
  Check(live_messages.size() == offline.size(),
        "live: " + std::to_string(live_messages.size()) + " SCAN_MATCH messages, offline " +
            std::to_string(offline.size()));
  size_t same = 0;
  for (size_t i = 0; i < std::min(offline.size(), live_messages.size()); ++i)
    same += calib::Encode(calib::ToMessage(offline[i])) == live_messages[i];
  Check(same == offline.size(), std::to_string(same) + " identical to the offline result");
  return failures ? 1 : 0;
}

// The live fusion process against FuseLog on the recording replayed into it.
int Fusion(const std::string& log, const std::string& robot_file, const std::string& live) {
  const calib::RobotDescription robot = calib::LoadRobotFile(robot_file);
  const std::vector<calib::FusedPose> offline = calib::FuseLog(robot, log, calib::FusedOdometryOptions{});
  std::vector<std::vector<uint8_t>> live_messages;
  calib::LogReader live_reader(live);
  calib::LogEvent e;
  while (live_reader.Next(&e))
    if (e.channel == calib::kOdomFusedChannel) live_messages.push_back(e.data);
  Check(offline.size() > 1000, "offline: " + std::to_string(offline.size()) + " fused poses");
  Check(live_messages.size() == offline.size(), "live: " + std::to_string(live_messages.size()) +
                                                    " ODOM_FUSED messages, offline " + std::to_string(offline.size()));
  size_t same = 0;
  for (size_t i = 0; i < std::min(offline.size(), live_messages.size()); ++i)
    same += calib::Encode(calib::ToMessage(calib::ToStampedPose(offline[i]))) == live_messages[i];
  Check(same == offline.size(), std::to_string(same) + " identical to the offline result");
  return failures ? 1 : 0;
}

struct Event {
  int64_t wall;  // logger receive time, us
  calib::LogEvent e;
};

std::vector<Event> ReadAll(const std::string& log) {
  std::vector<Event> out;
  calib::LogReader reader(log);
  calib::LogEvent e;
  while (reader.Next(&e)) out.push_back({e.timestamp, e});
  return out;
}

template <typename Message>
Message As(const calib::LogEvent& e) {
  Message m;
  if (!calib::Decode(e.data.data(), int(e.data.size()), &m)) throw std::runtime_error("undecodable " + e.channel);
  return m;
}

int Limits(const std::string& log, const std::string& robot_file) {
  const calib::RobotDescription robot = calib::LoadRobotFile(robot_file);
  const auto model = calib::MakeDriveModel(robot);
  const calib::Limits& lim = robot.limits;
  const std::vector<std::string> roles = calib::WheelRoles(robot.drive);
  std::vector<double> radii, offsets;
  for (const std::string& role : roles) {
    radii.push_back(robot.param(role + "_radius"));
    double offset = 0.0;
    if (robot.drive == calib::DriveType::kTricycle) offset = robot.param("steer_offset");
    if (robot.drive == calib::DriveType::kDualSteer && role == "a1") offset = robot.param("a1_steer_offset");
    offsets.push_back(offset);
  }
  constexpr double kTol = 1e-6;
  int motion = 0, stops = 0, over = 0;
  std::string first_over;
  auto exceed = [&](bool bad, const std::string& what, int64_t utime) {
    if (!bad) return;
    if (over++ == 0) first_over = what + " at utime " + std::to_string(utime);
  };
  std::optional<calib::DriveCommand> prev;  // previous command
  std::optional<calib::DriveCommand> prev_motion;
  for (const Event& ev : ReadAll(log)) {
    if (ev.e.channel != calib::kDriveCmdChannel) continue;
    const auto m = As<agvcal::drive_command_t>(ev.e);
    exceed(!(m.timeout > 0), "no timeout", m.utime);
    const calib::DriveCommand c = calib::FromMessage(m, robot, log);
    if (c.mode == calib::DriveMode::kStop) {
      ++stops;
      prev = c;
      continue;
    }
    ++motion;
    const calib::Twist2 tw = c.mode == calib::DriveMode::kTwist ? c.twist : model->Forward(c.wheels);
    const calib::WheelSetpoint w = c.mode == calib::DriveMode::kTwist ? model->Inverse(c.twist) : c.wheels;
    exceed(std::hypot(tw.vx, tw.vy) > lim.max_speed + kTol, "speed", m.utime);
    exceed(std::abs(tw.omega) > lim.max_omega + kTol, "turn rate", m.utime);
    for (size_t i = 0; i < roles.size(); ++i) {
      exceed(std::abs(w.speed[i] * radii[i]) > lim.max_speed + kTol, roles[i] + " wheel speed", m.utime);
      if (c.mode == calib::DriveMode::kWheels)
        exceed(std::abs(c.wheels.steer[i] - offsets[i]) > lim.max_steer + kTol, roles[i] + " steering angle", m.utime);
    }
    if (prev && prev->mode == calib::DriveMode::kStop) {
      // From the robot's own brake: the first command after a stop starts from rest.
      exceed(std::hypot(tw.vx, tw.vy) > lim.max_accel * 0.05 + kTol, "restart speed", m.utime);
    } else if (prev) {
      const double dt = (c.utime - prev->utime) * 1e-6;
      const calib::Twist2 p = prev->mode == calib::DriveMode::kTwist ? prev->twist : model->Forward(prev->wheels);
      exceed(std::hypot(tw.vx - p.vx, tw.vy - p.vy) > lim.max_accel * dt + kTol, "acceleration", m.utime);
    }
    if (prev_motion && c.mode == calib::DriveMode::kWheels && prev_motion->mode == calib::DriveMode::kWheels) {
      const double dt = (c.utime - prev_motion->utime) * 1e-6;
      for (size_t i = 0; i < roles.size(); ++i)
        exceed(std::abs(c.wheels.steer[i] - prev_motion->wheels.steer[i]) > lim.max_steer_rate * dt + kTol,
               roles[i] + " steering rate", m.utime);
    }
    prev = c;
    prev_motion = c;
  }
  Check(motion > 100, std::to_string(motion) + " motion commands, " + std::to_string(stops) + " stops");
  Check(over == 0, std::to_string(over) + " limits exceeded" + (over ? " (first: " + first_over + ")" : ""));
  return failures ? 1 : 0;
}

// The true robot's largest speed over GROUND_TRUTH events received in (from, to), and their count.
std::pair<double, int> TrueSpeed(const std::vector<Event>& events, int64_t from, int64_t to) {
  double fastest = 0.0;
  int n = 0;
  std::optional<agvcal::pose2d_t> last;
  for (const Event& ev : events) {
    if (ev.e.channel != calib::kGroundTruthChannel || ev.wall <= from || ev.wall >= to) continue;
    const auto p = As<agvcal::pose2d_t>(ev.e);
    if (last && p.utime > last->utime)
      fastest = std::max(fastest, std::hypot(p.x - last->x, p.y - last->y) / ((p.utime - last->utime) * 1e-6));
    last = p;
    ++n;
  }
  return {fastest, n};
}

int Held(const std::string& log, const std::string& state, const std::string& flowing) {
  const std::vector<Event> events = ReadAll(log);
  int64_t start = -1, end = INT64_MAX;
  bool ran = false;  // a hold while driving, not the wait for inputs at the start
  for (const Event& ev : events) {
    if (ev.e.channel != calib::kCommanderStatusChannel) continue;
    const auto st = As<agvcal::commander_status_t>(ev.e);
    if (start < 0 && ran && st.state == state) start = ev.wall;
    ran = ran || st.state == "running";
    if (start >= 0 && st.state == "running") {
      end = ev.wall;
      break;
    }
  }
  Check(start >= 0, "the commander reported " + state);
  if (start < 0) return 1;
  const int64_t from = start + 150000;  // commands already on the way
  int stops = 0, motion = 0, flowed = 0, after = 0;
  for (const Event& ev : events) {
    if (ev.e.channel == calib::kDriveCmdChannel) {
      const auto m = As<agvcal::drive_command_t>(ev.e);
      // The first command after the release goes out just before its "running" status.
      if (ev.wall > from && ev.wall < end - 50000) (m.mode == agvcal::drive_command_t::MODE_STOP ? stops : motion)++;
      if (ev.wall > end && m.mode != agvcal::drive_command_t::MODE_STOP) ++after;
    }
    if (!flowing.empty() && ev.e.channel == flowing && ev.wall > from && ev.wall < end) ++flowed;
  }
  Check(motion == 0 && stops >= 5, "while held: " + std::to_string(stops) + " stop commands, " +
                                       std::to_string(motion) + " motion commands");
  if (!flowing.empty()) Check(flowed >= 10, flowing + " kept arriving (" + std::to_string(flowed) + ")");
  if (end != INT64_MAX) Check(after > 10, "released: it drove on (" + std::to_string(after) + " motion commands)");
  const auto [speed, n] = TrueSpeed(events, start + 1000000, end);
  if (n > 0) Check(n >= 10 && speed < 0.01, "the robot stood still from 1 s after the hold: " +
                                                 std::to_string(n) + " poses, fastest " + std::to_string(speed) + " m/s");
  return failures ? 1 : 0;
}

int Halted(const std::string& log) {
  const std::vector<Event> events = ReadAll(log);
  int64_t last = -1;
  int last_mode = -1;
  for (const Event& ev : events)
    if (ev.e.channel == calib::kDriveCmdChannel) {
      last = ev.wall;
      last_mode = As<agvcal::drive_command_t>(ev.e).mode;
    }
  Check(last >= 0, "DRIVE_CMD recorded");
  if (last < 0) return 1;
  const auto [before, nb] = TrueSpeed(events, last - 500000, last);
  std::cout << "info: last command mode " << last_mode << ", true speed before it up to " << before << " m/s (" << nb
            << " poses)\n";
  const auto [speed, n] = TrueSpeed(events, last + 1000000, INT64_MAX);
  Check(n >= 10 && speed < 0.01, "from 1 s after the last command the robot stood still: " + std::to_string(n) +
                                     " poses, fastest " + std::to_string(speed) + " m/s");
  return failures ? 1 : 0;
}

int Run(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "";
  if (mode == "rates" && argc >= 4) return Rates(argc, argv);
  if (mode == "tracking" && argc == 4) return Tracking(argv[2], argv[3]);
  if (mode == "same" && argc == 4) return Same(argv[2], argv[3]);
  if (mode == "stale" && argc == 3) return Stale(argv[2]);
  if (mode == "intervals" && argc == 3) return Intervals(argv[2]);
  if (mode == "estimates" && argc == 3) return Estimates(argv[2]);
  if (mode == "scanmatch" && argc == 5) return ScanMatch(argv[2], argv[3], argv[4]);
  if (mode == "fusion" && argc == 5) return Fusion(argv[2], argv[3], argv[4]);
  if (mode == "limits" && argc == 4) return Limits(argv[2], argv[3]);
  if (mode == "held" && (argc == 4 || argc == 5)) return Held(argv[2], argv[3], argc == 5 ? argv[4] : "");
  if (mode == "halted" && argc == 3) return Halted(argv[2]);
  std::cerr << "usage: e2e_log_check rates LOG CHANNEL=HZ... | tracking LOG ROBOT.yaml | same A B |"
               " stale LOG | estimates LOG | scanmatch LOG ROBOT.yaml LIVE | fusion LOG ROBOT.yaml LIVE |"
               " limits LOG ROBOT.yaml | held LOG STATE [CHANNEL] | halted LOG\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("e2e_log_check", Run, argc, argv); }
