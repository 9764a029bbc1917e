#include "calib/io/log_summary.h"

#include <functional>

#include "agvcal/commander_status_t.hpp"
#include "agvcal/drive_command_t.hpp"
#include "agvcal/ground_estimate_t.hpp"
#include "agvcal/heartbeat_t.hpp"
#include "agvcal/imu_t.hpp"
#include "agvcal/laser_scan_t.hpp"
#include "agvcal/mount_angle_t.hpp"
#include "agvcal/point_cloud_t.hpp"
#include "agvcal/pose2d_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/core/errors.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"

namespace calib {

namespace {

// Decodes a message of type M and returns its utime; false (and why) if it does not decode.
template <typename M>
bool DecodeUtime(const uint8_t* data, size_t size, int64_t* utime, std::string* why) {
  M msg{};
  if (!Decode(data, static_cast<int>(size), &msg, why)) return false;
  *utime = msg.utime;
  return true;
}

struct ChannelType {
  const char* type;
  bool (*decode)(const uint8_t*, size_t, int64_t*, std::string*);
};

const std::map<std::string, ChannelType>& KnownChannels() {
  static const std::map<std::string, ChannelType> kChannels{
      {kWheelsChannel, {"wheel_state_t", DecodeUtime<agvcal::wheel_state_t>}},
      {kScanChannel, {"laser_scan_t", DecodeUtime<agvcal::laser_scan_t>}},
      {kCloudChannel, {"point_cloud_t", DecodeUtime<agvcal::point_cloud_t>}},
      {kImuChannel, {"imu_t", DecodeUtime<agvcal::imu_t>}},
      {kDriveCmdChannel, {"drive_command_t", DecodeUtime<agvcal::drive_command_t>}},
      {kPoseChannel, {"pose2d_t", DecodeUtime<agvcal::pose2d_t>}},
      {kGroundTruthChannel, {"pose2d_t", DecodeUtime<agvcal::pose2d_t>}},
      {kHeartbeatChannel, {"heartbeat_t", DecodeUtime<agvcal::heartbeat_t>}},
      {kCommanderStatusChannel, {"commander_status_t", DecodeUtime<agvcal::commander_status_t>}},
      {kGroundEstimateChannel, {"ground_estimate_t", DecodeUtime<agvcal::ground_estimate_t>}},
      {kMountAngleChannel, {"mount_angle_t", DecodeUtime<agvcal::mount_angle_t>}},
  };
  return kChannels;
}

}  // namespace

std::optional<ChannelStamp> StampOf(const std::string& channel, const uint8_t* data, size_t size) {
  const auto known = KnownChannels().find(channel);
  if (known == KnownChannels().end()) return std::nullopt;
  ChannelStamp stamp;
  stamp.type = known->second.type;
  stamp.decoded = known->second.decode(data, size, &stamp.utime, &stamp.why);
  return stamp;
}

LogSummary SummarizeLog(const std::string& path) {
  LogReader reader(path);
  LogSummary summary;
  LogEvent event;
  while (reader.Next(&event)) {
    ++summary.events;
    ChannelSummary& ch = summary.channels[event.channel];
    int64_t utime = event.timestamp;  // unknown channels: the logger's time
    if (const auto stamp = StampOf(event.channel, event.data.data(), event.data.size())) {
      ch.type = stamp->type;
      if (!stamp->decoded)
        throw InputError(path, "event " + std::to_string(event.event_number) + " at byte " +
                                   std::to_string(event.offset) + " (" + PrintableChannel(event.channel) + ")",
                         std::string("does not decode as ") + stamp->type + ": " + stamp->why);
      utime = stamp->utime;
    }
    if (ch.count == 0) {
      ch.first_utime = utime;
    } else if (utime < ch.last_utime) {
      ++ch.out_of_order;
    } else if (utime == ch.last_utime) {
      ++ch.duplicated;
    }
    ch.last_utime = ch.count == 0 ? utime : std::max(ch.last_utime, utime);
    ++ch.count;
  }
  summary.skipped = reader.skips();
  for (auto& [name, ch] : summary.channels)
    if (ch.count > 1 && ch.last_utime > ch.first_utime)
      ch.rate_hz = (ch.count - 1) / ((ch.last_utime - ch.first_utime) * 1e-6);
  return summary;
}

int64_t RecordingStartUtime(const LogSummary& summary) {
  int64_t first = 0;
  for (const auto& [name, channel] : summary.channels)
    if (channel.count > 0 && channel.first_utime > 0 && (first == 0 || channel.first_utime < first))
      first = channel.first_utime;
  return first;
}

}  // namespace calib
