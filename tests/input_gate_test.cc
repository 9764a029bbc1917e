// Every message stream goes through one stamp gate (core/stamp_gate.h, applied by io's Subscribe*
// functions, live and offline): a lone stamp far ahead (one flipped bit) is dropped alone and
// named, not every message after it; a DRIVE_CMD setpoint no robot can mean is dropped and named;
// a stamp beyond any clock is a bad message.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "agvcal/drive_command_t.hpp"
#include "agvcal/imu_t.hpp"
#include "agvcal/laser_scan_t.hpp"
#include "agvcal/point_cloud_t.hpp"
#include "agvcal/pose2d_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "common/bus_source.h"

namespace calib {
namespace {

const RobotDescription& Forklift() {
  static const RobotDescription robot =
      LoadRobotFile(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/forklift.yaml");
  return robot;
}

constexpr int64_t kFlippedBit = int64_t(1) << 23;  // +8.4 s
constexpr int kMessages = 200;
constexpr int kDamaged = 60;

std::vector<uint8_t> ScanBytes(int64_t utime) {
  agvcal::laser_scan_t m{};
  m.utime = utime;
  m.angle_min = -1.0f, m.angle_increment = 0.01f, m.scan_time = 0.1f, m.range_min = 0.1f, m.range_max = 30.0f;
  m.nranges = 200;
  m.ranges.assign(200, 5.0f);
  return Encode(m);
}

std::vector<uint8_t> ImuBytes(int64_t utime) {
  agvcal::imu_t m{};
  m.utime = utime;
  m.linear_acceleration[2] = 9.81;
  return Encode(m);
}

std::vector<uint8_t> PoseBytes(int64_t utime) {
  StampedPose pose;
  pose.utime = utime;
  return Encode(ToMessage(pose));
}

std::vector<uint8_t> CloudBytes(int64_t utime) {
  PointCloud cloud;
  cloud.utime = utime;
  cloud.xyz = {1.0f, 2.0f, 3.0f};
  return Encode(ToMessage(cloud));
}

std::vector<uint8_t> CommandBytes(int64_t utime, double speed = 1.0, double steer = 0.1) {
  DriveCommand c;
  c.utime = utime;
  c.mode = DriveMode::kWheels;
  c.wheels.speed = {speed};
  c.wheels.steer = {steer};
  return Encode(ToMessage(c, Forklift(), 0));
}

// `channel` at 10 Hz, message kDamaged stamped one flipped bit late.
std::string StreamLog(const std::string& channel, std::vector<uint8_t> (*bytes)(int64_t)) {
  const std::string path = ::testing::TempDir() + "/input_gate_" + channel + ".log";
  LogWriter writer(path);
  for (int i = 0; i < kMessages; ++i) {
    const int64_t utime = 1000000 + i * 100000 + (i == kDamaged ? kFlippedBit : 0);
    writer.Publish(channel, utime, bytes(utime));
  }
  writer.Close();
  return path;
}

std::vector<uint8_t> CommandBytesDefault(int64_t utime) { return CommandBytes(utime); }

struct Run {
  std::vector<int64_t> stamps;
  std::vector<std::string> notes;
};

TEST(InputGate, ALoneLateStampIsDroppedAloneOnEveryStream) {
  struct Stream {
    std::string channel;
    std::vector<uint8_t> (*bytes)(int64_t);
    void (*subscribe)(MessageSource*, std::vector<int64_t>*);
  };
  const std::vector<Stream> streams{
      {"SCAN", ScanBytes,
       [](MessageSource* s, std::vector<int64_t>* out) {
         SubscribeScans(s, "SCAN", [out](LaserScan scan) { out->push_back(scan.utime); });
       }},
      {"POSE", PoseBytes,
       [](MessageSource* s, std::vector<int64_t>* out) {
         SubscribePoses(s, "POSE", [out](const StampedPose& p) { out->push_back(p.utime); });
       }},
      {"IMU", ImuBytes,
       [](MessageSource* s, std::vector<int64_t>* out) {
         SubscribeImu(s, "IMU", [out](const ImuSample& m) { out->push_back(m.utime); });
       }},
      {"DRIVE_CMD", CommandBytesDefault,
       [](MessageSource* s, std::vector<int64_t>* out) {
         SubscribeDriveCommands(s, Forklift(), [out](const DriveCommand& c) { out->push_back(c.utime); });
       }},
      {"CLOUD", CloudBytes,
       [](MessageSource* s, std::vector<int64_t>* out) {
         SubscribeClouds(s, "CLOUD", [out](const PointCloud& c) { out->push_back(c.utime); });
       }},
  };
  for (const Stream& stream : streams) {
    const std::string path = StreamLog(stream.channel, stream.bytes);
    RecordingSource source(path);
    std::vector<int64_t> stamps;
    stream.subscribe(&source, &stamps);
    source.HandleAll();
    EXPECT_EQ(stamps.size(), size_t(kMessages - 1)) << stream.channel;  // was: kDamaged, the rest lost
    ASSERT_EQ(source.drop_notes().size(), 1u) << stream.channel;
    const std::string& note = source.drop_notes()[0];
    EXPECT_NE(note.find(path + ": event " + std::to_string(kDamaged) + " (" + stream.channel + "): stamp 8.4"),
              std::string::npos)
        << note;
    EXPECT_NE(note.find("dropped alone"), std::string::npos) << note;
  }
}

TEST(InputGate, TheLiveBusGatesTheSameWay) {
  agvcal_process::BusSource bus("memq://", "input_gate_test");
  std::vector<int64_t> stamps;
  SubscribeScans(&bus, "SCAN", [&](LaserScan scan) { stamps.push_back(scan.utime); });
  for (int i = 0; i < 100; ++i) {
    const std::vector<uint8_t> bytes = ScanBytes(1000000 + i * 100000 + (i == 50 ? kFlippedBit : 0));
    bus.lcm().publish("SCAN", bytes.data(), bytes.size());
    while (bus.HandleNext(0)) {
    }
  }
  bus.Finish();
  EXPECT_EQ(stamps.size(), 99u);
  EXPECT_EQ(bus.dropped(), 1);
}

TEST(InputGate, ACommandNoRobotCanMeanIsDroppedAndNamed) {
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::string path = ::testing::TempDir() + "/input_gate_bad_commands.log";
  LogWriter writer(path);
  const std::vector<std::pair<double, double>> bad{{nan, 0.1}, {inf, 0.1}, {-1e300, 0.1}, {1.0, nan},
                                                   {1.0, -inf}, {1.0, 1e300}, {600.0, 0.1}, {1.0, 3.5}};
  int64_t utime = 1000000;
  for (int i = 0; i < 50; ++i) {
    writer.Publish(kDriveCmdChannel, utime, CommandBytes(utime));
    utime += 50000;
    if (i < int(bad.size())) {
      writer.Publish(kDriveCmdChannel, utime, CommandBytes(utime, bad[i].first, bad[i].second));
      utime += 50000;
    }
  }
  writer.Close();
  RecordingSource source(path);
  std::vector<DriveCommand> commands;
  SubscribeDriveCommands(&source, Forklift(), [&](const DriveCommand& c) { commands.push_back(c); });
  source.HandleAll();
  EXPECT_EQ(commands.size(), 50u);
  for (const DriveCommand& c : commands) EXPECT_TRUE(DriveCommandProblem(c, Forklift()).empty());
  ASSERT_EQ(source.drop_notes().size(), bad.size());
  EXPECT_NE(source.drop_notes()[0].find("(DRIVE_CMD): wheel 'drive' speed setpoint nan rad/s, more than"),
            std::string::npos)
      << source.drop_notes()[0];
  EXPECT_NE(source.drop_notes()[5].find("steering setpoint 1e+300 rad, beyond"), std::string::npos)
      << source.drop_notes()[5];
  // A command at the robot's limits passes.
  DriveCommand fast;
  fast.mode = DriveMode::kWheels;
  fast.wheels.speed = {Forklift().limits.max_speed / Forklift().param("drive_radius")};
  fast.wheels.steer = {Forklift().limits.max_steer};
  EXPECT_EQ(DriveCommandProblem(fast, Forklift()), "");
  DriveCommand twist;
  twist.mode = DriveMode::kTwist;
  twist.twist.omega = nan;
  EXPECT_NE(DriveCommandProblem(twist, Forklift()).find("omega"), std::string::npos);
}

TEST(InputGate, AStampBeyondAnyClockIsABadMessage) {
  const std::string path = ::testing::TempDir() + "/input_gate_int64_max.log";
  LogWriter writer(path);
  writer.Publish("SCAN", 1000000, ScanBytes(1000000));
  writer.Publish("SCAN", 1100000, ScanBytes(std::numeric_limits<int64_t>::max()));
  writer.Close();
  RecordingSource source(path);
  SubscribeScans(&source, "SCAN", [](LaserScan) {});
  try {
    source.HandleAll();
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.place(), "event 1 (SCAN)");
    EXPECT_NE(e.problem().find("utime 9223372036854775807 us is beyond"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace calib
