// One message source for a recording and the bus (calib/io/message_source.h):
// the same subscriptions over both, and each one's policy for a bad message.
// The bus runs in-process (LCM's memq:// and file:// providers).
#include "calib/io/message_source.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "agvcal/wheel_state_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "common/bus_source.h"
#include "common/process_util.h"

namespace calib {
namespace {

const RobotDescription& Robot() {
  static const RobotDescription robot =
      LoadRobotFile(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/diff_robot.yaml");
  return robot;
}

std::vector<uint8_t> Wheels(int64_t utime, double left = 0.0) {
  return Encode(WheelStateMessage({utime, {left, 0.0}, {0.0, 0.0}}, Robot()));
}

const std::vector<uint8_t> kGarbage(40, 0xff);

// WHEELS 100, SCAN (garbage, not subscribed), WHEELS 200.
std::string WriteLog(const std::string& name, const std::vector<uint8_t>& second_wheels) {
  const std::string path = ::testing::TempDir() + "/message_source_" + name;
  LogWriter writer(path);
  writer.Publish(kWheelsChannel, 100, Wheels(100));
  writer.Publish(kScanChannel, 150, kGarbage);
  writer.Publish(kWheelsChannel, 200, second_wheels);
  writer.Close();
  return path;
}

TEST(RecordingSourceTest, DeliversItsChannelsInLogOrderUntilTheEnd) {
  // 1 mrad in 100 us: a wheel may turn that fast (WheelSampleGate drops a faster one).
  const std::string path = WriteLog("good.log", Wheels(200, 0.001));
  RecordingSource source(path);
  std::vector<int64_t> stamps;
  std::vector<std::string> origins;
  source.Subscribe<agvcal::wheel_state_t>(kWheelsChannel,
                                          [&](const agvcal::wheel_state_t& m, const std::string& origin) {
                                            stamps.push_back(m.utime);
                                            origins.push_back(origin);
                                          });
  std::vector<double> left;
  SubscribeWheels(&source, Robot(), [&](const WheelSample& s) { left.push_back(s.position[0]); });
  int events = 0;
  while (source.HandleNext(0)) ++events;
  EXPECT_EQ(events, 3);  // every event, subscribed or not
  EXPECT_TRUE(source.done());
  EXPECT_FALSE(source.HandleNext(0));
  EXPECT_EQ(stamps, (std::vector<int64_t>{100, 200}));
  EXPECT_EQ(left, (std::vector<double>{0.0, 0.001}));
  EXPECT_EQ(origins[1], path + ": event 2 (WHEELS)");
}

TEST(RecordingSourceTest, ABadMessageIsAnErrorNamingTheFileAndTheEvent) {
  const std::string path = WriteLog("bad.log", kGarbage);
  RecordingSource source(path);
  int handled = 0;
  SubscribeWheels(&source, Robot(), [&](const WheelSample&) { ++handled; });
  try {
    source.HandleAll();
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.place(), "event 2 (WHEELS)");
    // The problem says what is wrong with the bytes (calib/io/message_layout.h).
    EXPECT_EQ(e.problem().rfind("does not decode as wheel_state_t: ", 0), 0u) << e.problem();
  }
  EXPECT_EQ(handled, 1);

  // A message that decodes but does not convert: the conversion names the same place.
  agvcal::wheel_state_t unknown_wheel = WheelStateMessage({200, {0.0, 0.0}, {0.0, 0.0}}, Robot());
  unknown_wheel.name[0] = "front";
  const std::string renamed = WriteLog("renamed.log", Encode(unknown_wheel));
  RecordingSource again(renamed);
  SubscribeWheels(&again, Robot(), [](const WheelSample&) {});
  try {
    again.HandleAll();
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), renamed + ": event 2 (WHEELS)");
    EXPECT_NE(e.problem().find("no wheel named"), std::string::npos) << e.what();
  }
}

TEST(RecordingSourceTest, StopsWhenAHandlerAsks) {
  RecordingSource source(WriteLog("stop.log", Wheels(200)));
  int handled = 0;
  SubscribeWheels(&source, Robot(), [&](const WheelSample&) {
    ++handled;
    source.RequestStop();
  });
  source.HandleAll();
  EXPECT_EQ(handled, 1);
  EXPECT_TRUE(source.done());
}

TEST(BusSourceTest, SkipsAndCountsABadMessageAndGoesOn) {
  agvcal_process::BusSource bus("memq://", "message_source_test");
  std::vector<int64_t> stamps;
  SubscribeWheels(&bus, Robot(), [&](const WheelSample& s) { stamps.push_back(s.utime); });
  const std::vector<uint8_t> good = Wheels(100), later = Wheels(300);
  bus.lcm().publish(kWheelsChannel, good.data(), good.size());
  bus.lcm().publish(kWheelsChannel, kGarbage.data(), kGarbage.size());
  bus.lcm().publish(kWheelsChannel, later.data(), later.size());
  while (bus.HandleNext(0)) {
  }
  EXPECT_EQ(stamps, (std::vector<int64_t>{100, 300}));
  EXPECT_EQ(bus.skipped(), 1);
  EXPECT_EQ(bus.received(kWheelsChannel), 3);
  EXPECT_FALSE(bus.done());
}

TEST(BusSourceTest, AnotherFailureOfAHandlerStopsTheSourceOutsideTheCallback) {
  agvcal_process::BusSource bus("memq://", "message_source_test");
  SubscribeWheels(&bus, Robot(), [](const WheelSample&) { throw std::logic_error("a bug"); });
  const std::vector<uint8_t> good = Wheels(100);
  bus.lcm().publish(kWheelsChannel, good.data(), good.size());
  EXPECT_THROW(bus.HandleNext(0), std::runtime_error);
  EXPECT_TRUE(bus.done());
}

TEST(BusSourceTest, DeliversEachStampOnceWhenAsked) {
  agvcal_process::BusSource bus("memq://", "message_source_test");
  bus.DeliverOncePerStamp();
  std::vector<int64_t> stamps;
  SubscribeWheels(&bus, Robot(), [&](const WheelSample& s) { stamps.push_back(s.utime); });
  for (int64_t utime : {100, 100, 50, 200}) {
    const std::vector<uint8_t> m = Wheels(utime);
    bus.lcm().publish(kWheelsChannel, m.data(), m.size());
  }
  while (bus.HandleNext(0)) {
  }
  EXPECT_EQ(stamps, (std::vector<int64_t>{100, 200}));
  EXPECT_EQ(bus.duplicates(), 2);
}

// A process seconds behind the bus (a loaded machine) still handles, on stop, everything
// that arrived before it, and ends at the first message that came after (a source that
// goes on publishing: each handled message brings a new one).
TEST(BusSourceTest, OnStopHandlesEverythingThatArrivedBeforeItPastTheLimit) {
  agvcal_process::BusSource bus("memq://", "message_source_test");
  int64_t handled = 0;
  SubscribeWheels(&bus, Robot(), [&](const WheelSample&) {
    ++handled;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const std::vector<uint8_t> next = Wheels(1000 + handled);
    bus.lcm().publish(kWheelsChannel, next.data(), next.size());
  });
  for (int64_t utime = 1; utime <= 60; ++utime) {
    const std::vector<uint8_t> m = Wheels(utime);
    bus.lcm().publish(kWheelsChannel, m.data(), m.size());
  }
  bus.HandleQueued(0.1);  // 60 handlers take 0.6 s
  EXPECT_GE(handled, 60);
  EXPECT_LE(handled, 61);
}

TEST(BusSourceTest, TheEndOfAFileProvidersLogIsTheEnd) {
  const std::string path = WriteLog("file_provider.log", Wheels(200));
  agvcal_process::BusSource bus("file://" + path + "?speed=0", "message_source_test");
  std::vector<int64_t> stamps;
  SubscribeWheels(&bus, Robot(), [&](const WheelSample& s) { stamps.push_back(s.utime); });
  bus.HandleAll();
  EXPECT_TRUE(bus.done());
  EXPECT_EQ(stamps, (std::vector<int64_t>{100, 200}));
}

}  // namespace
}  // namespace calib
