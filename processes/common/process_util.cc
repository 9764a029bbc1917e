#include "common/process_util.h"

#include <chrono>
#include <csignal>
#include <cstdlib>
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
