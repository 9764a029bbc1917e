// Hardware bridges: the device clock fit, the CANopen encoder decoder (candump
// files, PDO layouts, wrap-around, SYNC timing) and the SICK CoLa-A decoder.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <random>

#include "agvcal/laser_scan_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/core/errors.h"
#include "calib/devices/canopen.h"
#include "calib/devices/device_clock.h"
#include "calib/devices/sick_cola.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"

namespace calib {
namespace {

std::string Source(const std::string& relative) { return std::string(AGVCAL_SOURCE_DIR) + "/" + relative; }

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

// The exception's message (file: place: problem), or "" if none was thrown.
template <typename F>
std::string InputErrorOf(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// --- DeviceClock

// A device whose clock runs 80 ppm fast and started 1234 s before the host's
// epoch; each arrival is late by an exponential delay of mean 2 ms.
TEST(DeviceClock, RemovesArrivalJitterAndFollowsDrift) {
  DeviceClock clock;
  std::mt19937 rng(7);
  std::exponential_distribution<double> delay(1.0 / 2000.0);
  const double drift = 80e-6;
  double worst_start = 0.0, worst_settling = 0.0, worst_late = 0.0, worst_arrival = 0.0;
  for (int i = 0; i < 20 * 120; ++i) {  // 20 Hz for 120 s
    const double host_true = 1.7e15 + i * 50000.0;
    const int64_t device = int64_t(1234e6 + (host_true - 1.7e15) * (1.0 + drift));
    const double late = delay(rng);
    const int64_t stamp = clock.Add(device, int64_t(host_true + late));
    worst_arrival = std::max(worst_arrival, late);
    double& worst = i < 40 ? worst_start : i < 200 ? worst_settling : worst_late;
    worst = std::max(worst, std::abs(stamp - host_true));
  }
  // us from the true send time: the first 2 s at nominal rate, then the fit settles.
  EXPECT_LT(worst_start, 1000.0);
  EXPECT_LT(worst_settling, 400.0);
  EXPECT_LT(worst_late, 30.0) << "after 10 s";
  EXPECT_GT(worst_arrival, 5000.0) << "the arrivals did carry jitter";
  EXPECT_NEAR(clock.rate(), 1.0 / (1.0 + drift), 2e-6);
}

TEST(DeviceClock, NominalRateUntilSpanAndRestartOnReboot) {
  DeviceClock clock;
  EXPECT_EQ(clock.Add(1000, 5000), 5000);
  EXPECT_EQ(clock.Add(2000, 6500), 6000);  // 500 us late: the earlier arrival fixes the line
  EXPECT_EQ(clock.Add(3000, 6900), 6900);  // earlier than the line: the line moves down
  EXPECT_EQ(clock.Add(4000, 7950), 7900);
  EXPECT_EQ(clock.rate(), 1.0);
  EXPECT_EQ(clock.Add(10, 9000), 9000);  // device time went back: a reboot
  EXPECT_EQ(clock.restarts(), 1);
}

TEST(DeviceClock, ImplausibleRateIsClamped) {
  DeviceClock clock;  // max_drift_ppm 1000
  for (int i = 0; i <= 100; ++i) clock.Add(i * 100000, int64_t(i * 100000 * 1.01));  // 1 %
  EXPECT_NEAR(clock.rate(), 1.001, 1e-12);
}

TEST(CounterUnwrapper, SixteenBitsBothWays) {
  CounterUnwrapper u(16);
  EXPECT_EQ(u.Unwrap(uint64_t(int64_t(-3))), -3);  // sign-extended first reading kept
  EXPECT_EQ(u.Unwrap(0xFFFE & 0xFFFF), -2);
  EXPECT_EQ(u.Unwrap(0x0005), 5);
  EXPECT_EQ(u.Unwrap(0x7FFF), 0x7FFF);
  EXPECT_EQ(u.Unwrap(0x8002), 0x8002);  // past the signed limit
  EXPECT_EQ(u.Unwrap(0x0001), 0x10001);  // wrapped forward
  EXPECT_EQ(u.Unwrap(0xFFF0), 0xFFF0);   // and back
}

// --- candump files

TEST(Candump, ReadsStandardExtendedRemoteAndDirection) {
  const std::string path = WriteTemp("ok.candump",
                                     "(1700000000.123456) can0 181#0011223344556677\n"
                                     "\n"
                                     "(1700000000.200000) can0 12345678#AB R\n"
                                     "(1700000000.300001) vcan1 080#R\n"
                                     "(1700000000.4) can0 701#\n");
  CandumpReader reader(path);
  CanFrame f;
  ASSERT_TRUE(reader.Next(&f));
  EXPECT_EQ(f.utime, 1700000000123456);
  EXPECT_EQ(f.id, 0x181u);
  EXPECT_FALSE(f.extended);
  EXPECT_EQ(f.data, (std::vector<uint8_t>{0x00, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77}));
  EXPECT_EQ(FormatCandumpLine(f, "can0"), "(1700000000.123456) can0 181#0011223344556677");
  ASSERT_TRUE(reader.Next(&f));
  EXPECT_TRUE(f.extended);
  EXPECT_EQ(f.id, 0x12345678u);
  EXPECT_EQ(f.data, std::vector<uint8_t>{0xAB});
  ASSERT_TRUE(reader.Next(&f));
  EXPECT_TRUE(f.remote);
  EXPECT_EQ(f.id, 0x80u);
  ASSERT_TRUE(reader.Next(&f));
  EXPECT_EQ(f.utime, 1700000000400000);
  EXPECT_TRUE(f.data.empty());
  EXPECT_FALSE(reader.Next(&f));
}

TEST(Candump, BadLinesNameFileLineAndProblem) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"1700000000.1 can0 181#00\n", "must be '(seconds)'"},
      {"(17000x0000.1) can0 181#00\n", "field 1 (time)"},
      {"(1700000000.1) can0 18100\n", "has no '#'"},
      {"(1700000000.1) can0 1811#00\n", "3 (standard) or 8 (extended) hex digits"},
      {"(1700000000.1) can0 181#001\n", "pairs of hex digits"},
      {"(1700000000.1) can0 181#00112233445566778899\n", "0 to 8 bytes"},
      {"(1700000000.1) can0 181#0G\n", "is not hex"},
      {"(1700000000.1) can0 181##100\n", "CAN FD"},
      {"(1700000000.1) can0 800#00\n", "exceeds 7FF"},
  };
  for (const auto& [line, problem] : cases) {
    const std::string path = WriteTemp("bad.candump", "(1700000000.0) can0 080#\n" + line);
    const std::string message = InputErrorOf([&] {
      CandumpReader reader(path);
      CanFrame f;
      while (reader.Next(&f)) {
      }
    });
    EXPECT_NE(message.find(path + ": line 2"), std::string::npos) << line << " -> " << message;
    EXPECT_NE(message.find(problem), std::string::npos) << line << " -> " << message;
  }
}

// --- bridge config

TEST(CanBridgeConfig, ExampleFilesLoad) {
  const CanBridgeConfig c = LoadCanBridgeConfig(Source("config/bridges/forklift_can.yaml"));
  ASSERT_EQ(c.wheels.size(), 1u);
  EXPECT_EQ(c.wheels[0].name, "drive");
  EXPECT_EQ(c.wheels[0].position.cob_id, 0x181u);
  ASSERT_TRUE(c.wheels[0].steer);
  EXPECT_EQ(c.wheels[0].steer->cob_id, 0x182u);  // the steering encoder's own node
  EXPECT_EQ(c.wheels[0].steer->length, 2);
  EXPECT_EQ(c.sync_cob_id, 0x80u);
  EXPECT_DOUBLE_EQ(c.sync_period_s, 0.01);
  const CanBridgeConfig d = LoadCanBridgeConfig(Source("config/bridges/diff_robot_can.yaml"));
  ASSERT_EQ(d.wheels.size(), 2u);
  EXPECT_EQ(d.wheels[1].name, "right_wheel");
  EXPECT_EQ(d.wheels[1].velocity->cob_id, 0x182u);
  EXPECT_EQ(TpdoCobId(3, 5), 0x385u);
}

TEST(CanBridgeConfig, ErrorsNameLineKeyAndProblem) {
  const std::string head = "sync: {cob_id: 0x080, period_s: 0.01}\nwheels:\n  drive:\n    node: 1\n";
  const std::vector<std::pair<std::string, std::string>> cases{
      {head + "    position: {tpdo: 1, length: 4, ticks_per_rev: 4096, sigend: true}\n",
       "line 5, key wheels.drive.position.sigend: unknown key (did you mean signed?)"},
      {head + "    position: {tpdo: 1, offset: 6, length: 4, ticks_per_rev: 4096}\n",
       "key wheels.drive.position.length: offset + length = 10 bytes exceeds the 8 bytes"},
      {head + "    position: {tpdo: 1, length: 4}\n", "key wheels.drive.position.ticks_per_rev: missing"},
      {head + "    position: {tpdo: 5, length: 4, ticks_per_rev: 1}\n", "must be within 1..4"},
      {head + "    position: {tpdo: 1, length: 4, ticks_per_rev: 1}\n"
              "    velocity: {tpdo: 1, offset: 2, length: 4, rad_s_per_unit: 1}\n",
       "byte 2 of COB-ID 385 is also wheels.drive.position"},
      {head + "    position: {cob_id: 0x80, length: 4, ticks_per_rev: 1}\n", "uses the SYNC COB-ID"},
      {head + "    position: {cob_id: zz, length: 4, ticks_per_rev: 1}\n", "expected an integer"},
      {"wheels: {}\n", "key sync: missing required key"},
  };
  for (const auto& [text, problem] : cases) {
    const std::string message = InputErrorOf([&] { ParseCanBridgeConfig(text, "bridge.yaml"); });
    EXPECT_NE(message.find("bridge.yaml: "), std::string::npos) << message;
    EXPECT_NE(message.find(problem), std::string::npos) << text << " -> " << message;
  }
}

// --- decoder on hand-built frames

CanBridgeConfig SmallConfig(int counter_overflow = 0) {
  return ParseCanBridgeConfig(
      "sync: {cob_id: 0x080, period_s: 0.01, counter_overflow: " + std::to_string(counter_overflow) +
          "}\n"
          "wheels:\n"
          "  drive:\n"
          "    node: 1\n"
          "    position: {tpdo: 1, offset: 0, length: 4, signed: true, ticks_per_rev: 4096}\n"
          "    velocity: {tpdo: 1, offset: 4, length: 2, signed: true, rad_s_per_unit: 0.01}\n"
          "    steer: {node: 2, tpdo: 2, offset: 1, length: 2, signed: true, counts_per_rev: 4000, zero: 10}\n",
      "small.yaml");
}

CanFrame Frame(int64_t utime, uint32_t id, std::vector<uint8_t> data) {
  CanFrame f;
  f.utime = utime;
  f.id = id;
  f.data = std::move(data);
  return f;
}

TEST(CanopenDecoder, HandBuiltFramesWrapAroundAndSyncTiming) {
  CanopenDecoder decoder(SmallConfig());
  std::vector<agvcal::wheel_state_t> out;
  auto feed = [&](const CanFrame& f) { decoder.Feed(f, "test", "frame", &out); };
  const int64_t t0 = 1700000000000000;
  feed(Frame(t0 - 5000, 0x181, {1, 0, 0, 0, 0, 0}));  // before any SYNC: not a cycle
  // Cycle 0: position 0x7FFFFFF0 (near the int32 limit), velocity -250 (-2.5 rad/s), steer 1010.
  feed(Frame(t0, 0x80, {}));
  feed(Frame(t0 + 300, 0x181, {0xF0, 0xFF, 0xFF, 0x7F, 0x06, 0xFF}));
  EXPECT_TRUE(out.empty()) << "steer PDO still missing";
  feed(Frame(t0 + 500, 0x282, {0x00, 0xF2, 0x03}));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].utime, t0);
  EXPECT_EQ(out[0].name, std::vector<std::string>{"drive"});
  EXPECT_DOUBLE_EQ(out[0].position[0], double(0x7FFFFFF0) * 2 * M_PI / 4096);
  EXPECT_DOUBLE_EQ(out[0].velocity[0], -2.5);
  EXPECT_DOUBLE_EQ(out[0].steer[0], (1010.0 - 10.0) * 2 * M_PI / 4000);
  // Cycle 1, 1.2 ms late: position wraps to 0x80000010 (negative as int32) = +32 ticks.
  feed(Frame(t0 + 11200, 0x80, {}));
  feed(Frame(t0 + 11300, 0x181, {0x10, 0x00, 0x00, 0x80, 0x00, 0x00}));
  feed(Frame(t0 + 11400, 0x282, {0x00, 0x0A, 0x00}));
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].utime, t0 + 10000) << "the late SYNC is stamped on the producer's clock";
  EXPECT_DOUBLE_EQ(out[1].position[0], (double(0x7FFFFFF0) + 32) * 2 * M_PI / 4096);
  // Two SYNCs lost (found from the gap), the third cycle incomplete.
  feed(Frame(t0 + 40100, 0x80, {}));
  feed(Frame(t0 + 40300, 0x181, {0x20, 0x00, 0x00, 0x80, 0x00, 0x00}));
  feed(Frame(t0 + 50000, 0x80, {}));
  feed(Frame(t0 + 50100, 0x701, {0x05}));  // a heartbeat: not ours
  EXPECT_EQ(decoder.stats().syncs, 4);
  EXPECT_EQ(decoder.stats().syncs_lost, 2);
  EXPECT_EQ(decoder.stats().incomplete_cycles, 1);
  EXPECT_EQ(decoder.stats().ignored, 1);
  EXPECT_EQ(decoder.stats().pdos_before_sync, 1);
  EXPECT_EQ(out.size(), 2u);
  // A PDO shorter than its layout: the error names the place and the mapping.
  const std::string message = InputErrorOf(
      [&] { decoder.Feed(Frame(t0 + 50200, 0x181, {1, 2, 3}), "trace.candump", "line 12", &out); });
  EXPECT_NE(message.find("trace.candump: line 12: PDO 181 has 3 data bytes"), std::string::npos) << message;
  EXPECT_NE(message.find("bytes 0..3"), std::string::npos) << message;
}

TEST(CanopenDecoder, SyncCounterCountsLostSyncs) {
  CanopenDecoder decoder(SmallConfig(240));
  std::vector<agvcal::wheel_state_t> out;
  const int64_t t0 = 1700000000000000;
  // Counters 239, 240, 1, 2 (6 ms late: the gap would say one SYNC was lost), then 5 (3 and 4 lost).
  const std::vector<std::pair<int64_t, int>> syncs{
      {t0, 239}, {t0 + 10000, 240}, {t0 + 20000, 1}, {t0 + 36000, 2}, {t0 + 60000, 5}};
  for (const auto& [t, counter] : syncs) {
    decoder.Feed(Frame(t, 0x80, {uint8_t(counter)}), "test", "frame", &out);
    decoder.Feed(Frame(t + 100, 0x181, {0, 0, 0, 0, 0, 0}), "test", "frame", &out);
    decoder.Feed(Frame(t + 200, 0x282, {0, 0, 0}), "test", "frame", &out);
  }
  ASSERT_EQ(out.size(), 5u);
  EXPECT_EQ(decoder.stats().syncs_lost, 2);
  EXPECT_EQ(out[3].utime - out[0].utime, 30000);
  EXPECT_EQ(out[4].utime - out[0].utime, 60000);
}

// --- decoder on a candump made from a simulated recording: the numbers are known

std::vector<agvcal::wheel_state_t> SimulatedWheels(const std::string& log) {
  std::vector<agvcal::wheel_state_t> states;
  LogReader reader(log);
  LogEvent e;
  while (reader.Next(&e)) {
    if (e.channel != kWheelsChannel) continue;
    agvcal::wheel_state_t m;
    EXPECT_TRUE(Decode(e.data.data(), int(e.data.size()), &m));
    states.push_back(m);
  }
  return states;
}

TEST(CanopenDecoder, CandumpOfSimulatedForkliftGivesItsWheelStates) {
  // An 8-bit position counter wraps every 1/16 turn of the drive wheel: many wraps.
  CanBridgeConfig config = LoadCanBridgeConfig(Source("config/bridges/forklift_can.yaml"));
  config.wheels[0].position.length = 1;
  const std::vector<agvcal::wheel_state_t> truth = SimulatedWheels(Source("logs/forklift_demo.log"));
  ASSERT_GT(truth.size(), 2000u);
  const std::vector<CanFrame> frames = EmulateCanBus(config, truth, CanEmulation{0.002, 0.0002, 3});
  // Through a candump file, as the bridge replays it.
  const std::string path = ::testing::TempDir() + "forklift.candump";
  {
    std::ofstream file(path);
    for (const CanFrame& f : frames) file << FormatCandumpLine(f, "can0") << "\n";
  }
  CandumpReader reader(path);
  CanopenDecoder decoder(config);
  std::vector<agvcal::wheel_state_t> out;
  CanFrame f;
  while (reader.Next(&f)) decoder.Feed(f, path, reader.place(), &out);
  ASSERT_EQ(out.size(), truth.size());
  double max_position = 0, max_steer = 0, max_velocity = 0, max_stamp_late = 0, max_stamp_early = 0;
  double max_turns = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    max_position = std::max(max_position, std::abs(out[i].position[0] - truth[i].position[0]));
    max_steer = std::max(max_steer, std::abs(out[i].steer[0] - truth[i].steer[0]));
    max_velocity = std::max(max_velocity, std::abs(out[i].velocity[0] - truth[i].velocity[0]));
    max_turns = std::max(max_turns, std::abs(truth[i].position[0]) / (2 * M_PI));
    if (i >= 1000) {  // after 10 s
      max_stamp_late = std::max(max_stamp_late, double(out[i].utime - truth[i].utime));
      max_stamp_early = std::max(max_stamp_early, double(truth[i].utime - out[i].utime));
    }
  }
  EXPECT_GT(max_turns, 1.0) << "the 8-bit position wrapped more than 16 times";
  EXPECT_LT(max_position, 1e-9) << "rad: positions are whole ticks";
  EXPECT_LT(max_steer, 1e-9) << "rad: steer is whole counts of 0.0002 rad";
  EXPECT_LE(max_velocity, 0.5 * 2 * M_PI / 4096 + 1e-12) << "rad/s: one increment/s quantisation";
  // Arrivals are up to 2 ms late; after 10 s the SYNC-clock stamps are within 50 us of the
  // sample times (measured: 31 us).
  std::cout << "stamp error after 10 s: " << max_stamp_late << " us late, " << max_stamp_early << " us early\n";
  EXPECT_LT(max_stamp_late, 50.0);
  EXPECT_LT(max_stamp_early, 50.0);
  EXPECT_EQ(decoder.stats().syncs_lost, 0);
  EXPECT_EQ(decoder.stats().incomplete_cycles, 0);
}

// --- SICK CoLa-A

SickScan SampleScan() {
  SickScan s;
  s.serial_number = 0x89A5D2;
  s.telegram_counter = 0x1234;
  s.scan_counter = 0xFFFF;
  s.time_since_startup_us = 0xFFFFF000;  // wraps before the transmission
  s.time_of_transmission_us = 0x00001000;
  s.scan_frequency = 2500;               // 25 Hz
  s.measurement_frequency = 135;
  s.start_angle = -450000;               // -45 deg
  s.angular_step = 5000;                 // 0.5 deg
  s.distances = {0, 1000, 65535, 2500};
  s.rssi = {0, 200, 10, 255};
  return s;
}

TEST(SickCola, TelegramRoundTripAndKnownText) {
  const SickScan s = SampleScan();
  const std::string text = FormatLmdScandata(s);
  EXPECT_EQ(text.substr(0, 60), "sSN LMDscandata 1 1 89A5D2 0 0 1234 FFFF FFFFF000 1000 0 0 0");
  EXPECT_NE(text.find(" DIST1 3F800000 00000000 FFF92230 1388 4 0 3E8 FFFF 9C4 RSSI1 "), std::string::npos)
      << text;
  const SickScan p = ParseLmdScandata(text, "t", 1);
  EXPECT_EQ(p.distances, s.distances);
  EXPECT_EQ(p.rssi, s.rssi);
  EXPECT_EQ(p.start_angle, -450000);
  EXPECT_EQ(p.angular_step, 5000u);
  EXPECT_EQ(p.time_since_startup_us, 0xFFFFF000u);
  EXPECT_EQ(p.scan_counter, 0xFFFF);
}

TEST(SickCola, DecodesGeometryRangesAndTiming) {
  SickBridgeConfig config;
  config.range_max = 60.0;
  SickScanDecoder decoder(config);
  const agvcal::laser_scan_t m = decoder.Decode(SampleScan(), 1700000000000000, "t", 1);
  EXPECT_NEAR(m.angle_min, -135.0 * M_PI / 180, 1e-6);
  EXPECT_NEAR(m.angle_increment, 0.5 * M_PI / 180, 1e-7);
  EXPECT_NEAR(m.scan_time, 0.04, 1e-7);
  EXPECT_NEAR(m.time_increment, 0.04 / 720, 1e-9);
  ASSERT_EQ(m.nranges, 4);
  EXPECT_TRUE(std::isnan(m.ranges[0]));
  EXPECT_FLOAT_EQ(m.ranges[1], 1.0f);
  EXPECT_FLOAT_EQ(m.ranges[2], 65.535f);
  EXPECT_EQ(m.nintensities, 4);
  EXPECT_FLOAT_EQ(m.intensities[3], 255.0f);
  // The first beam is 0x2000 us of device time before the transmission, across the wrap.
  EXPECT_EQ(m.utime, 1700000000000000 - 0x2000);
}

TEST(SickCola, CorruptTelegramNamesTheField) {
  std::string text = FormatLmdScandata(SampleScan());
  const std::vector<std::pair<std::string, std::string>> cases{
      {"sSN LMDscandata 1 1 89A5D2 0 0 1234 FFFF FFFFFG00", "telegram 9, field 10 (time since start up)"},
      {text.substr(0, text.find(" DIST1")), "field 20 (16-bit channel content): missing"},
      {"sSN LMDscandatX 1", "field 2 (command): expected LMDscandata"},
      {"sSN LMDscandata 1 1 89A5D2 0 0 1234 FFFF 1 2 0 0 0 0 0 9C4 87 0 0 0", "no DIST1 channel"},
  };
  for (const auto& [telegram, problem] : cases) {
    const std::string message = InputErrorOf([&] { ParseLmdScandata(telegram, "192.0.2.1:2111", 9); });
    EXPECT_NE(message.find("192.0.2.1:2111: "), std::string::npos) << message;
    EXPECT_NE(message.find(problem), std::string::npos) << telegram << " -> " << message;
  }
  SickScan bad = SampleScan();
  bad.rssi.pop_back();
  SickScanDecoder decoder{SickBridgeConfig{}};
  EXPECT_NE(InputErrorOf([&] { decoder.Decode(bad, 0, "dev", 3); }).find("dev: telegram 3: RSSI1 has 3 values for 4"),
            std::string::npos);
}

TEST(SickCola, FramerSplitsStreamAndDropsGarbage) {
  StxEtxFramer framer;
  const std::string stream = std::string("xx") + kStx + "sEA LMDscandata 1" + kEtx + kStx + "sSN LMD" +
                             kStx + "sSN A" + kEtx + kStx + "part";
  std::string t;
  framer.Append(stream.data(), 21);
  ASSERT_TRUE(framer.Next(&t));
  EXPECT_EQ(t, "sEA LMDscandata 1");
  EXPECT_FALSE(framer.Next(&t));
  framer.Append(stream.data() + 21, stream.size() - 21);
  ASSERT_TRUE(framer.Next(&t));
  EXPECT_EQ(t, "sSN A");  // the frame cut short by the next STX is dropped
  EXPECT_FALSE(framer.Next(&t));
  framer.Append("ial\x03", 4);
  ASSERT_TRUE(framer.Next(&t));
  EXPECT_EQ(t, "partial");
  EXPECT_EQ(framer.dropped_bytes(), 2 + 8);
}

TEST(SickBridgeConfig, ExampleLoadsAndErrorsNameTheKey) {
  const SickBridgeConfig c = LoadSickBridgeConfig(Source("config/bridges/sick_lms1xx.yaml"));
  EXPECT_EQ(c.channel, "SCAN");
  EXPECT_DOUBLE_EQ(c.angle_offset_deg, -90.0);
  EXPECT_DOUBLE_EQ(c.clock.window_s, 60.0);
  EXPECT_NE(InputErrorOf([] { ParseSickBridgeConfig("protocol: scip2\n", "l.yaml"); })
                .find("l.yaml: line 1, key protocol: unsupported protocol 'scip2'"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([] { ParseSickBridgeConfig("protocol: sick_cola_a\nrange_mx: 3\n", "l.yaml"); })
                .find("line 2, key range_mx: unknown key (did you mean range_max?)"),
            std::string::npos);
}

}  // namespace
}  // namespace calib
