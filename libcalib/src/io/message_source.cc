#include "calib/io/message_source.h"

#include <memory>
#include <utility>

#include "calib/core/wheel_track.h"

namespace calib {

void MessageSource::HandleAll() {
  constexpr int kWaitMs = 100;  // the bus: how long one wait lasts before done() is asked again
  while (!done()) HandleNext(kWaitMs);
}

std::string MessageSource::origin() const {
  const std::string where = place();
  return where.empty() ? file() : file() + ": " + where;
}

void MessageSource::Drop(const std::string& origin, const std::string& problem) {
  ++dropped_;
  const std::string note = origin + ": " + problem;
  if (drop_notes_.size() < kMaxDropNotes) drop_notes_.push_back(note);
  if (on_drop_) on_drop_(note);
}

void MessageSource::Finish() {
  if (finished_) return;
  finished_ = true;
  for (const auto& flush : finishers_) flush();
}

RecordingSource::RecordingSource(const std::string& path, Mode mode) : reader_(path), mode_(mode) {}

void RecordingSource::SubscribeRaw(const std::string& channel, RawHandler handler) {
  handlers_[channel].push_back(std::move(handler));
}

bool RecordingSource::HandleNext(int) {
  if (done()) return false;
  const bool read = mode_ == Mode::kGrowing ? reader_.NextComplete(&event_) : reader_.Next(&event_);
  if (!read) {
    ended_ = mode_ == Mode::kComplete;
    if (ended_) Finish();
    return false;
  }
  const auto it = handlers_.find(event_.channel);
  if (it != handlers_.end()) {
    for (const RawHandler& handler : it->second) handler(event_.channel, event_.data.data(), event_.data.size());
  }
  return true;
}

std::string RecordingSource::place() const {
  return "event " + std::to_string(event_.event_number) + " (" + event_.channel + ")";
}

void SubscribeWheels(MessageSource* source, const RobotDescription& robot,
                     std::function<void(const WheelSample&)> handler) {
  auto gate = std::make_shared<WheelSampleGate>(
      robot, [source](const std::string& origin, const std::string& problem) { source->Drop(origin, problem); });
  auto shared_handler = std::make_shared<std::function<void(const WheelSample&)>>(std::move(handler));
  source->Subscribe<agvcal::wheel_state_t>(
      kWheelsChannel, [robot, gate, shared_handler](const agvcal::wheel_state_t& m, const std::string& origin) {
        for (const WheelSample& s : gate->Add(WheelSampleFromMessage(m, robot, origin), origin)) (*shared_handler)(s);
      });
  source->AtFinish([gate, shared_handler]() {
    for (const WheelSample& s : gate->Finish()) (*shared_handler)(s);
  });
}

void SubscribeScans(MessageSource* source, const std::string& channel, std::function<void(LaserScan)> handler) {
  source->Subscribe<agvcal::laser_scan_t>(
      channel, [handler = std::move(handler)](const agvcal::laser_scan_t& m, const std::string& origin) {
        handler(LaserScanFromMessage(m, origin));
      });
}

void SubscribeScanMatches(MessageSource* source, std::function<void(const SensorMotion&)> handler) {
  source->Subscribe<agvcal::scan_match_t>(
      kScanMatchChannel, [handler = std::move(handler)](const agvcal::scan_match_t& m, const std::string& origin) {
        handler(FromMessage(m, origin));
      });
}

void SubscribePoses(MessageSource* source, const std::string& channel,
                    std::function<void(const StampedPose&)> handler) {
  source->Subscribe<agvcal::pose2d_t>(
      channel, [handler = std::move(handler)](const agvcal::pose2d_t& m, const std::string&) {
        handler(PoseFromMessage(m));
      });
}

void SubscribeImu(MessageSource* source, const std::string& channel, std::function<void(const ImuSample&)> handler) {
  source->Subscribe<agvcal::imu_t>(
      channel, [handler = std::move(handler)](const agvcal::imu_t& m, const std::string& origin) {
        handler(ImuSampleFromMessage(m, origin));
      });
}

void SubscribeDriveCommands(MessageSource* source, const RobotDescription& robot,
                            std::function<void(const DriveCommand&)> handler) {
  source->Subscribe<agvcal::drive_command_t>(
      kDriveCmdChannel,
      [robot, handler = std::move(handler)](const agvcal::drive_command_t& m, const std::string& origin) {
        handler(FromMessage(m, robot, origin));
      });
}

void SubscribeClouds(MessageSource* source, const std::string& channel,
                     std::function<void(const PointCloud&)> handler) {
  source->Subscribe<agvcal::point_cloud_t>(
      channel, [handler = std::move(handler)](const agvcal::point_cloud_t& m, const std::string&) {
        handler(CloudFromMessage(m));
      });
}

void SubscribeMountAngles(MessageSource* source, const std::string& channel,
                          std::function<void(const MountAngle&)> handler) {
  source->Subscribe<agvcal::mount_angle_t>(
      channel, [handler = std::move(handler)](const agvcal::mount_angle_t& m, const std::string&) {
        handler(MountAngleFromMessage(m));
      });
}

}  // namespace calib
