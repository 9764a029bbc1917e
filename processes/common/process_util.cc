#include "common/process_util.h"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <unistd.h>

#include "agvcal/heartbeat_t.hpp"
#include "calib/core/errors.h"
#include "calib/io/messages.h"

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
  msg.state = state;
  lcm_->publish(calib::kHeartbeatChannel, &msg);
}

void HandleQueued(lcm::LCM& lcm, double limit_s) {
  const int64_t until = WallMicros() + static_cast<int64_t>(limit_s * 1e6);
  while (WallMicros() < until && lcm.handleTimeout(50) > 0) {
  }
}

CatchUpInput::CatchUpInput(lcm::LCM* lcm, const std::vector<std::string>& channels, Deliver deliver)
    : lcm_(lcm), channels_(channels), deliver_(std::move(deliver)) {
  for (const std::string& c : channels_) SubscribeEveryMessage(*lcm_, c, &CatchUpInput::OnMessage, this);
}

void CatchUpInput::OnMessage(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
  const auto* data = static_cast<const uint8_t*>(buffer->data);
  if (!holding_) return Offer(channel, data, buffer->data_size);
  if (const auto stamp = calib::LeadingStamp(data, buffer->data_size)) tracker_->Live(channel, *stamp);
  held_.emplace_back(channel, std::vector<uint8_t>(data, data + buffer->data_size));
}

void CatchUpInput::Offer(const std::string& channel, const uint8_t* data, size_t size) {
  const auto stamp = calib::LeadingStamp(data, size);
  if (stamp && !filter_.Accept(channel, *stamp)) return;
  deliver_(channel, data, size);  // a message too short for a stamp: the decoder rejects it
}

int64_t CatchUpInput::CatchUp(const std::string& recording, const std::string& program,
                              Heartbeat* heartbeat, double limit_s) {
  constexpr int64_t kQuietUs = 2000000;  // a channel silent this long live has nothing missing
  holding_ = true;
  tracker_.emplace(channels_, kQuietUs);
  const int64_t start = WallMicros();
  std::optional<calib::LogReader> reader;
  int64_t recovered = 0;
  calib::LogEvent event;
  while (!g_stop_requested) {
    lcm_->handleTimeout(20);
    if (!reader && std::filesystem::exists(recording)) reader.emplace(recording);
    while (reader && reader->NextComplete(&event)) {
      if (std::find(channels_.begin(), channels_.end(), event.channel) == channels_.end()) continue;
      if (const auto stamp = calib::LeadingStamp(event.data.data(), event.data.size()))
        tracker_->Recorded(event.channel, *stamp);
      Offer(event.channel, event.data.data(), event.data.size());
      ++recovered;
    }
    const int64_t elapsed = WallMicros() - start;
    if (reader && tracker_->Complete(elapsed)) break;
    if (elapsed > limit_s * 1e6) {
      std::cerr << program << ": catching up from " << recording << " took over " << limit_s
                << " s; messages may be missing on " << tracker_->Pending(elapsed) << "\n";
      break;
    }
    if (heartbeat) heartbeat->Beat("catching up");
  }
  holding_ = false;
  for (const auto& [channel, bytes] : held_) Offer(channel, bytes.data(), bytes.size());
  held_.clear();
  std::cerr << program << ": caught up: " << recovered << " messages from " << recording << ", "
            << duplicates() << " duplicates dropped\n";
  return recovered;
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

calib::MotionSource MotionSourceOption(const Args& args, const calib::RobotDescription& robot) {
  const std::string name = args.Get("--source", robot.lidar2d ? "lidar2d" : "pose");
  if (name != "lidar2d" && name != "pose")
    throw calib::InputError("command line", "--source", "expected lidar2d or pose, got '" + name + "'");
  return name == "pose" ? calib::MotionSource::kPose : calib::MotionSource::kLidar2d;
}

}  // namespace agvcal_process
