#pragma once
// What every agvcal process needs around libcalib: publishing encoded
// messages on the bus, heartbeats, a stop flag set by SIGINT/SIGTERM, and a
// small command-line reader. Nothing here computes.

#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <cstdint>
#include <exception>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/core/robot.h"
#include "calib/io/recording.h"
#include "calib/live/catch_up.h"

namespace agvcal_process {

// Publishes encoded messages on an LCM bus (the simulator's live output).
class LcmSink : public calib::MessageSink {
 public:
  explicit LcmSink(lcm::LCM* lcm) : lcm_(lcm) {}
  void Publish(const std::string& channel, int64_t utime,
               const std::vector<uint8_t>& data) override {
    lcm_->publish(channel, data.data(), static_cast<unsigned int>(data.size()));
  }

 private:
  lcm::LCM* lcm_;
};

// Throws calib::InputError naming the URL if the bus did not open. `url` is
// the --lcm-url given ("" = LCM_DEFAULT_URL or LCM's default).
void RequireGoodBus(lcm::LCM& lcm, const std::string& url);

// lcm.subscribe(args...) keeping every message. LCM queues at most 30 messages per
// subscription by default and silently drops the rest while the process is busy (a slow
// scan match, a loaded machine: 60 ms of WHEELS at a 5x replay), and one lost WHEELS message
// changes every later live result (DESIGN.md: live = offline). Displays may keep the default.
template <typename... SubscribeArgs>
lcm::Subscription* SubscribeEveryMessage(lcm::LCM& lcm, SubscribeArgs&&... args) {
  lcm::Subscription* subscription = lcm.subscribe(std::forward<SubscribeArgs>(args)...);
  if (subscription) subscription->setQueueCapacity(0);  // 0: no limit
  return subscription;
}

// On stop: handles the messages already received or still arriving (until 50 ms pass
// without one, at most `limit_s` wall seconds), so what was sent before the stop is not
// lost with the queue.
void HandleQueued(lcm::LCM& lcm, double limit_s = 2.0);

// Set by SIGINT or SIGTERM once InstallStopHandlers() has run.
extern std::atomic<bool> g_stop_requested;
void InstallStopHandlers();

// Exceptions must not cross LCM's C callbacks: Run(f) keeps the first one's
// message and requests the stop; the process reports it after its loop.
class FirstError {
 public:
  template <typename F>
  void Run(F f) {
    try {
      f();
    } catch (const std::exception& e) {
      if (!message_) message_ = e.what();
      g_stop_requested = true;
    }
  }
  const std::optional<std::string>& message() const { return message_; }

 private:
  std::optional<std::string> message_;
};

// Wall-clock microseconds (heartbeats and pacing only; data carry robot time).
int64_t WallMicros();

// Publishes agvcal::heartbeat_t on HEARTBEAT at most once per second.
class Heartbeat {
 public:
  Heartbeat(lcm::LCM* lcm, std::string process) : lcm_(lcm), process_(std::move(process)) {}
  void Beat(const std::string& state, bool force = false);

 private:
  lcm::LCM* lcm_;
  std::string process_;
  int64_t last_ = 0;
};

// Raw subscription to `channels` that delivers each message once, in stamp
// order per channel (calib/live/catch_up.h); with CatchUp(), first what the group's
// recording holds of what was published before this process subscribed, so a
// process restarted mid-run ends with the inputs of an undisturbed one.
class CatchUpInput {
 public:
  using Deliver = std::function<void(const std::string& channel, const uint8_t* data, size_t size)>;
  CatchUpInput(lcm::LCM* lcm, const std::vector<std::string>& channels, Deliver deliver);

  // Reads `recording` (lcm-logger's file, still being written; waited for if
  // it does not exist yet) until it reaches the first live message of every
  // channel, at most `limit_s` wall seconds, then delivers the live messages
  // held meanwhile. Progress and any gap left are reported on stderr under
  // `program`. Returns the number of messages taken from the recording.
  int64_t CatchUp(const std::string& recording, const std::string& program, Heartbeat* heartbeat,
                  double limit_s = 10.0);
  // Messages dropped as already delivered (the recording and live overlap).
  int64_t duplicates() const { return filter_.rejected(); }

 private:
  void OnMessage(const lcm::ReceiveBuffer* buffer, const std::string& channel);
  void Offer(const std::string& channel, const uint8_t* data, size_t size);

  lcm::LCM* lcm_;
  std::vector<std::string> channels_;
  Deliver deliver_;
  calib::StampFilter filter_;
  bool holding_ = false;
  std::optional<calib::CatchUpTracker> tracker_;
  std::vector<std::pair<std::string, std::vector<uint8_t>>> held_;
};

// Command line: positional arguments and --key value / --flag options.
// Unknown options are errors (exit 2) naming the option.
struct Args {
  std::vector<std::string> positional;
  std::map<std::string, std::string> options;  // "--speed" -> "2"; flags -> "1"
  bool Has(const std::string& key) const { return options.count(key) > 0; }
  std::string Get(const std::string& key, const std::string& fallback) const;
  double GetDouble(const std::string& key, double fallback) const;
};

// `with_value` lists options that take a value, `flags` those that do not.
// --help is always a flag. Throws calib::InputError for an unknown option or a
// missing value.
Args ParseArgs(int argc, char** argv, int first, const std::vector<std::string>& with_value,
               const std::vector<std::string>& flags);

// Handles --help (usage on stdout, exit 0) and a wrong number of positional
// arguments (usage on stderr, exit 2): the exit status to return at once, or
// nothing to go on.
std::optional<int> CheckUsage(const Args& args, const char* usage, size_t positional_count);

// The --source option (lidar2d or pose): the sensor whose motion calibrates; by default the
// robot file's 2D lidar if it has one, else its external pose source. InputError otherwise.
calib::MotionSource MotionSourceOption(const Args& args, const calib::RobotDescription& robot);

}  // namespace agvcal_process
