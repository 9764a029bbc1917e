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

RecordingSource::RecordingSource(const std::string& path, Mode mode) : reader_(path), mode_(mode) {
  // A stretch the reader skipped (a torn event) is data the result lacks: said like a dropped message.
  reader_.set_on_skip([this](const LogSkip& skip) { Drop(reader_.path(), skip.Describe()); });
}

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
  return "event " + std::to_string(event_.event_number) + " (" + PrintableChannel(event_.channel) + ")";
}

namespace {

// A stream's converted messages through its gate (core/stamp_gate.h) to `handler`: what the gate
// drops goes to the source's Drop, what it holds at the end is passed on at the source's Finish.
template <typename T, typename Handler>
std::function<void(T, const std::string&)> Gated(MessageSource* source, std::shared_ptr<StampGate<T>> gate,
                                                 Handler handler) {
  auto shared_handler = std::make_shared<Handler>(std::move(handler));
  source->AtFinish([gate, shared_handler]() {
    for (T& item : gate->Finish()) (*shared_handler)(std::move(item));
  });
  return [source, gate, shared_handler](T item, const std::string& origin) {
    // Beyond 2^53 us (the year 2255) a time is no clock reading and loses precision as the double
    // every consumer computes with (a scan stamped INT64_MAX).
    constexpr int64_t kMaxStamp = int64_t(1) << 53;
    if (item.utime > kMaxStamp || item.utime < -kMaxStamp)
      throw InputError(source->file(), source->place(),
                       "utime " + std::to_string(item.utime) + " us is beyond +-2^53 us (the year 2255): not a clock reading");
    for (T& passed : gate->Add(std::move(item), origin)) (*shared_handler)(std::move(passed));
  };
}

template <typename T, typename Handler>
std::function<void(T, const std::string&)> Gated(MessageSource* source, Handler handler) {
  auto gate = std::make_shared<StampGate<T>>(
      [source](const std::string& origin, const std::string& problem) { source->Drop(origin, problem); });
  return Gated<T>(source, std::move(gate), std::move(handler));
}

}  // namespace

void SubscribeWheels(MessageSource* source, const RobotDescription& robot,
                     std::function<void(const WheelSample&)> handler) {
  auto gate = std::make_shared<WheelSampleGate>(
      robot, [source](const std::string& origin, const std::string& problem) { source->Drop(origin, problem); });
  auto gated = Gated<WheelSample>(source, std::shared_ptr<StampGate<WheelSample>>(gate), std::move(handler));
  source->Subscribe<agvcal::wheel_state_t>(
      kWheelsChannel, [robot, gated](const agvcal::wheel_state_t& m, const std::string& origin) {
        gated(WheelSampleFromMessage(m, robot, origin), origin);
      });
}

void SubscribeScans(MessageSource* source, const std::string& channel, std::function<void(LaserScan)> handler) {
  auto gated = Gated<LaserScan>(source, std::move(handler));
  source->Subscribe<agvcal::laser_scan_t>(
      channel, [gated](const agvcal::laser_scan_t& m, const std::string& origin) {
        gated(LaserScanFromMessage(m, origin), origin);
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
  auto gated = Gated<StampedPose>(source, std::move(handler));
  source->Subscribe<agvcal::pose2d_t>(
      channel, [gated](const agvcal::pose2d_t& m, const std::string& origin) { gated(PoseFromMessage(m), origin); });
}

void SubscribeImu(MessageSource* source, const std::string& channel, std::function<void(const ImuSample&)> handler) {
  auto gated = Gated<ImuSample>(source, std::move(handler));
  source->Subscribe<agvcal::imu_t>(
      channel, [gated](const agvcal::imu_t& m, const std::string& origin) {
        gated(ImuSampleFromMessage(m, origin), origin);
      });
}

void SubscribeDriveCommands(MessageSource* source, const RobotDescription& robot,
                            std::function<void(const DriveCommand&)> handler) {
  auto gated = Gated<DriveCommand>(source, std::move(handler));
  source->Subscribe<agvcal::drive_command_t>(
      kDriveCmdChannel, [source, robot, gated](const agvcal::drive_command_t& m, const std::string& origin) {
        DriveCommand command = FromMessage(m, robot, origin);
        const std::string problem = DriveCommandProblem(command, robot);
        if (!problem.empty()) {
          source->Drop(origin, problem);
          return;
        }
        gated(std::move(command), origin);
      });
}

void SubscribeClouds(MessageSource* source, const std::string& channel,
                     std::function<void(const PointCloud&)> handler) {
  auto gated = Gated<PointCloud>(source, std::move(handler));
  source->Subscribe<agvcal::point_cloud_t>(
      channel, [gated](const agvcal::point_cloud_t& m, const std::string& origin) { gated(CloudFromMessage(m), origin); });
}

void SubscribeMountAngles(MessageSource* source, const std::string& channel,
                          std::function<void(const MountAngle&)> handler) {
  source->Subscribe<agvcal::mount_angle_t>(
      channel, [handler = std::move(handler)](const agvcal::mount_angle_t& m, const std::string&) {
        handler(MountAngleFromMessage(m));
      });
}

}  // namespace calib
