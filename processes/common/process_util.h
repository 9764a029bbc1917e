#pragma once
// What every agvcal process needs around libcalib: publishing encoded
// messages on the bus, heartbeats, a stop flag set by SIGINT/SIGTERM. Nothing
// here computes. Listening to the bus: bus_source.h; the command line:
// command_line.h.

#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "calib/calibrate/calibration.h"
#include "calib/core/robot.h"
#include "calib/io/recording.h"
#include "common/command_line.h"

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

// Set by SIGINT or SIGTERM once InstallStopHandlers() has run.
extern std::atomic<bool> g_stop_requested;
void InstallStopHandlers();

// Wall-clock microseconds (heartbeats and pacing only; data carry robot time).
int64_t WallMicros();

// Publishes agvcal::heartbeat_t on HEARTBEAT at most once per second.
class Heartbeat {
 public:
  Heartbeat(lcm::LCM* lcm, std::string process) : lcm_(lcm), process_(std::move(process)) {}
  void Beat(const std::string& state, bool force = false);
  // Appended to every state ("; 1 bad message skipped"): BusSource::ReportOn.
  void set_note(std::function<std::string()> note) { note_ = std::move(note); }

 private:
  lcm::LCM* lcm_;
  std::string process_;
  std::function<std::string()> note_;
  int64_t last_ = 0;
};

// The --source option: the sensor whose motion calibrates, one of `allowed` (named as
// calib::MotionSourceName: lidar2d, pose, imu), or `fallback` when it is not given.
// InputError naming the choices for any other name.
std::optional<calib::MotionSource> MotionSourceOption(const CommandLine& args,
                                                      const std::vector<calib::MotionSource>& allowed,
                                                      std::optional<calib::MotionSource> fallback);

// The excitation trajectories the commander knows, one line per drive type
// ("differential: default umbmark ..."): for --help.
std::string TrajectoryNamesText();

// The live calibrations' default sensor: the robot file's 2D lidar if it has one, else
// its external pose source.
calib::MotionSource LiveMotionSource(const calib::RobotDescription& robot);

}  // namespace agvcal_process
