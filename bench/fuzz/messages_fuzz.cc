// Every message decoder (calib/io/messages.h Decode) and the conversions to libcalib's data.
// Input: one byte choosing the message type, then the encoded message (with its LCM hash).
#include <cstdint>

#include "agvcal/calib_estimate_t.hpp"
#include "agvcal/calib_residual_t.hpp"
#include "agvcal/commander_status_t.hpp"
#include "agvcal/ground_estimate_t.hpp"
#include "agvcal/heartbeat_t.hpp"
#include "agvcal/operator_stop_t.hpp"
#include "calib/io/messages.h"
#include "fuzz_common.h"

namespace {

const std::vector<calib::RobotDescription>& Robots() {
  static const std::vector<calib::RobotDescription> robots = {
      fuzz::Robot("forklift"), fuzz::Robot("diff_robot"), fuzz::Robot("dual_steer_agv"),
      fuzz::Robot("imu_robot")};
  return robots;
}

template <typename Message, typename Use>
void Try(const uint8_t* data, size_t size, Use use) {
  Message message;
  if (calib::Decode(data, static_cast<int>(size), &message)) fuzz::Expect([&] { use(message); });
}

const auto NoUse = [](const auto&) {};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1 || size > (1u << 20)) return 0;
  const uint8_t type = data[0];
  ++data;
  --size;
  const std::string origin = "fuzz: event 1";
  switch (type % 14) {
    case 0:
      Try<agvcal::wheel_state_t>(data, size, [&](const agvcal::wheel_state_t& m) {
        for (const auto& robot : Robots()) fuzz::Expect([&] { calib::WheelSampleFromMessage(m, robot, origin); });
      });
      break;
    case 1:
      Try<agvcal::laser_scan_t>(data, size, [&](const agvcal::laser_scan_t& m) {
        const calib::LaserScan scan = calib::LaserScanFromMessage(m, origin);
        (void)scan;
      });
      break;
    case 2:
      Try<agvcal::imu_t>(data, size, [&](const agvcal::imu_t& m) { calib::ImuSampleFromMessage(m, origin); });
      break;
    case 3:
      Try<agvcal::pose2d_t>(data, size, [&](const agvcal::pose2d_t& m) { calib::ToMessage(calib::PoseFromMessage(m)); });
      break;
    case 4:
      Try<agvcal::point_cloud_t>(data, size, [&](const agvcal::point_cloud_t& m) { calib::CloudFromMessage(m); });
      break;
    case 5:
      Try<agvcal::mount_angle_t>(data, size, [&](const agvcal::mount_angle_t& m) { calib::MountAngleFromMessage(m); });
      break;
    case 6:
      Try<agvcal::drive_command_t>(data, size, [&](const agvcal::drive_command_t& m) {
        for (const auto& robot : Robots()) fuzz::Expect([&] { calib::FromMessage(m, robot, origin); });
      });
      break;
    case 7:
      Try<agvcal::scan_match_t>(data, size, [&](const agvcal::scan_match_t& m) { calib::FromMessage(m, origin); });
      break;
    case 8: Try<agvcal::calib_estimate_t>(data, size, NoUse); break;
    case 9: Try<agvcal::calib_residual_t>(data, size, NoUse); break;
    case 10: Try<agvcal::commander_status_t>(data, size, NoUse); break;
    case 11: Try<agvcal::ground_estimate_t>(data, size, NoUse); break;
    case 12: Try<agvcal::heartbeat_t>(data, size, NoUse); break;
    default: Try<agvcal::operator_stop_t>(data, size, NoUse); break;
  }
  return 0;
}
