// The recording reader (calib/io/recording.h), both ways of reading (a finished log and one still
// being written), and the decoder of each event's channel (spec/messages.md) on what it reads.
#include <cstdint>

#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "fuzz_common.h"

namespace {

void DecodeEvent(const calib::LogEvent& event, const calib::RobotDescription& robot) {
  const std::string origin = "fuzz.log: event " + std::to_string(event.event_number);
  const int size = static_cast<int>(event.data.size());
  if (event.channel == calib::kWheelsChannel) {
    agvcal::wheel_state_t m;
    if (calib::Decode(event.data.data(), size, &m)) calib::WheelSampleFromMessage(m, robot, origin);
  } else if (event.channel == calib::kScanChannel) {
    agvcal::laser_scan_t m;
    if (calib::Decode(event.data.data(), size, &m)) calib::LaserScanFromMessage(m, origin);
  } else if (event.channel == calib::kImuChannel) {
    agvcal::imu_t m;
    if (calib::Decode(event.data.data(), size, &m)) calib::ImuSampleFromMessage(m, origin);
  } else if (event.channel == calib::kCloudChannel) {
    agvcal::point_cloud_t m;
    if (calib::Decode(event.data.data(), size, &m)) calib::CloudFromMessage(m);
  } else if (event.channel == calib::kDriveCmdChannel) {
    agvcal::drive_command_t m;
    if (calib::Decode(event.data.data(), size, &m)) calib::FromMessage(m, robot, origin);
  } else {
    agvcal::pose2d_t m;
    if (calib::Decode(event.data.data(), size, &m)) calib::PoseFromMessage(m);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const calib::RobotDescription robot = fuzz::Robot("forklift");
  const std::string path = fuzz::WriteFile("fuzz.log", data, size);
  fuzz::Expect([&] {
    calib::LogReader reader(path);
    calib::LogEvent event;
    while (reader.Next(&event)) fuzz::Expect([&] { DecodeEvent(event, robot); });
  });
  fuzz::Expect([&] {
    calib::LogReader reader(path);
    calib::LogEvent event;
    while (reader.NextComplete(&event)) {
    }
  });
  return 0;
}
