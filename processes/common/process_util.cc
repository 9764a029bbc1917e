#include "common/process_util.h"

#include <chrono>
#include <csignal>
#include <cstdlib>
#include <iostream>
#include <unistd.h>

#include "agvcal/heartbeat_t.hpp"
#include "calib/core/errors.h"
#include "calib/io/messages.h"
#include "calib/live/commander.h"

namespace agvcal_process {

std::atomic<bool> g_stop_requested{false};

namespace {
void OnStopSignal(int) { g_stop_requested = true; }
}  // namespace

void InstallStopHandlers() {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

void RequireGoodBus(lcm::LCM& lcm, const std::string& url) {
  if (!lcm.good()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    const std::string shown = !url.empty() ? url : env ? env : "LCM default URL";
    throw calib::InputError(shown, "", "cannot open the LCM bus (network down, no multicast route?)");
  }
}

int64_t WallMicros() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

void Heartbeat::Beat(const std::string& state, bool force) {
  const int64_t now = WallMicros();
  if (!force && now - last_ < 1000000) return;
  last_ = now;
  agvcal::heartbeat_t msg;
  msg.utime = now;
  msg.process = process_;
  msg.pid = static_cast<int32_t>(getpid());
  msg.state = note_ ? state + note_() : state;
  lcm_->publish(calib::kHeartbeatChannel, &msg);
}

std::string Args::Get(const std::string& key, const std::string& fallback) const {
  auto it = options.find(key);
  return it == options.end() ? fallback : it->second;
}

double Args::GetDouble(const std::string& key, double fallback) const {
  auto it = options.find(key);
  if (it == options.end()) return fallback;
  char* end = nullptr;
  const double v = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0')
    throw calib::InputError("command line", key, "expected a number, got '" + it->second + "'");
  return v;
}

Args ParseArgs(int argc, char** argv, int first, const std::vector<std::string>& with_value,
               const std::vector<std::string>& flags) {
  auto contains = [](const std::vector<std::string>& v, const std::string& s) {
    for (const auto& x : v)
      if (x == s) return true;
    return false;
  };
  Args args;
  for (int i = first; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      args.options["--help"] = "1";
    } else if (a.rfind("--", 0) == 0) {
      if (contains(with_value, a)) {
        if (i + 1 >= argc) throw calib::InputError("command line", a, "needs a value");
        args.options[a] = argv[++i];
      } else if (contains(flags, a)) {
        args.options[a] = "1";
      } else {
        throw calib::InputError("command line", a, "unknown option (see --help)");
      }
    } else {
      args.positional.push_back(a);
    }
  }
  return args;
}

std::optional<int> CheckUsage(const Args& args, const char* usage, size_t positional_count) {
  if (args.Has("--help")) {
    std::cout << usage;
    return calib::kExitOk;
  }
  if (args.positional.size() != positional_count) {
    std::cerr << usage;
    return calib::kExitBadInput;
  }
  return std::nullopt;
}

std::optional<calib::MotionSource> MotionSourceOption(const Args& args,
                                                      const std::vector<calib::MotionSource>& allowed,
                                                      std::optional<calib::MotionSource> fallback) {
  if (!args.Has("--source")) return fallback;
  const std::string name = args.Get("--source", "");
  std::string choices;
  for (size_t i = 0; i < allowed.size(); ++i) {
    choices += (i == 0 ? "" : i + 1 == allowed.size() ? " or " : ", ");
    choices += calib::MotionSourceName(allowed[i]);
    if (name == calib::MotionSourceName(allowed[i])) return allowed[i];
  }
  throw calib::InputError("command line", "--source", "expected " + choices + ", got '" + name + "'");
}

std::optional<calib::MotionSource> MotionSourceOption(const CommandLine& args,
                                                      const std::vector<calib::MotionSource>& allowed,
                                                      std::optional<calib::MotionSource> fallback) {
  if (!args.Has("--source")) return fallback;
  const std::string name = args.Get("--source", "");
  std::string choices;
  for (size_t i = 0; i < allowed.size(); ++i) {
    choices += (i == 0 ? "" : i + 1 == allowed.size() ? " or " : ", ");
    choices += calib::MotionSourceName(allowed[i]);
    if (name == calib::MotionSourceName(allowed[i])) return allowed[i];
  }
  throw calib::InputError("command line", "--source", "expected " + choices + ", got '" + name + "'");
}

std::string TrajectoryNamesText() {
  std::string text;
  for (const calib::DriveType type :
       {calib::DriveType::kDifferential, calib::DriveType::kTricycle, calib::DriveType::kDualSteer}) {
    std::string line = std::string("  ") + calib::DriveTypeName(type) + ":";
    line.resize(16, ' ');
    for (const std::string& trajectory : calib::TrajectoryNames(type)) line += trajectory + " ";
    line.pop_back();
    text += (text.empty() ? "" : "\n") + line;
  }
  return text;
}

calib::MotionSource LiveMotionSource(const calib::RobotDescription& robot) {
  return robot.lidar2d ? calib::MotionSource::kLidar2d : calib::MotionSource::kPose;
}

}  // namespace agvcal_process
