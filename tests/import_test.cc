// Importers (importers.h) on the real datasets of ../shared/data: message counts equal the
// record counts of each SOURCE.md, units and geometry of single records against the raw
// text, the CARMEN odometry inversion against the log's own poses, OptiOdom wheels against
// the OptiTrack ground truth; and every kind of bad input as an InputError naming the file
// and line. Tolerances are stated at each check. Tests on the real data are skipped when
// the data directory is absent (AGVCAL_DATA_DIR overrides its place).
#include "calib/import/importers.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "agvcal/laser_scan_t.hpp"
#include "agvcal/pose2d_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/robot.h"
#include "calib/core/se2.h"
#include "calib/core/wheel_track.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"
#include "calib/io/text_reader.h"

namespace calib {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::string DataDir() {
  const char* env = std::getenv("AGVCAL_DATA_DIR");
  return env ? env : std::string(AGVCAL_SOURCE_DIR) + "/../shared/data";
}

#define REQUIRE_DATA(relative)                                                          \
  const std::string data_path = DataDir() + "/" + (relative);                           \
  if (!std::filesystem::exists(data_path)) GTEST_SKIP() << "no dataset at " << data_path

RobotDescription DatasetRobot(const std::string& name) {
  return LoadRobotFile(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/datasets/" + name);
}

std::string TempFile(const std::string& name, const std::string& text) {
  const std::string path = testing::TempDir() + "/import_test_" + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

template <typename Message>
std::vector<Message> Messages(const MemorySink& sink, const std::string& channel) {
  std::vector<Message> out;
  for (const LogEvent& e : sink.events) {
    if (e.channel != channel) continue;
    Message m;
    EXPECT_TRUE(Decode(e.data.data(), static_cast<int>(e.data.size()), &m)) << channel;
    EXPECT_EQ(m.utime, e.timestamp);
    out.push_back(m);
  }
  return out;
}

// Events are published in time order.
void ExpectTimeOrder(const MemorySink& sink) {
  for (std::size_t i = 1; i < sink.events.size(); ++i)
    ASSERT_LE(sink.events[i - 1].timestamp, sink.events[i].timestamp) << "event " << i;
}

WheelTrack Track(const MemorySink& sink, const RobotDescription& robot) {
  WheelTrack track;
  for (const auto& m : Messages<agvcal::wheel_state_t>(sink, kWheelsChannel))
    EXPECT_TRUE(track.Append(WheelSampleFromMessage(m, robot, "test")));
  return track;
}

// Expects `body` to throw an InputError naming `file`, "line N" (N > 0) and `problem`.
template <typename Body>
void ExpectInputError(Body body, const std::string& file, int line, const std::string& problem) {
  try {
    body();
    ADD_FAILURE() << "no InputError (expected line " << line << ": " << problem << ")";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.file(), file) << what;
    if (line > 0) {
      EXPECT_EQ(e.place(), "line " + std::to_string(line)) << what;
    }
    EXPECT_NE(what.find(problem), std::string::npos) << what;
  }
}

// Fields of a line of a (possibly compressed) data file, read independently of the importer.
std::vector<std::vector<std::string>> ReadRecords(const std::string& path, char separator = ' ') {
  std::vector<std::vector<std::string>> records;
  TextReader reader(path);
  std::string line;
  while (reader.Next(&line)) records.push_back(SplitFields(line, separator));
  return records;
}

// --- building blocks -------------------------------------------------------------------------

TEST(ImportTest, LogTwistInvertsExpTwist) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 1000; ++i) {
    const Pose2 motion{2 * u(rng), 2 * u(rng), 3.1 * u(rng) * (i % 3 == 0 ? 1e-8 : 1.0)};
    const Pose2 back = ExpTwist(LogTwist(motion, 1.0), 1.0);
    EXPECT_NEAR(back.x, motion.x, 1e-12);
    EXPECT_NEAR(back.y, motion.y, 1e-12);
    EXPECT_NEAR(WrapAngle(back.theta - motion.theta), 0.0, 1e-12);
  }
  // An arc tangent to x has no sideways part.
  const Twist2 arc = LogTwist(ExpTwist({0.7, 0.0, -0.9}, 1.0), 1.0);
  EXPECT_NEAR(arc.vx, 0.7, 1e-12);
  EXPECT_NEAR(arc.vy, 0.0, 1e-12);
  EXPECT_NEAR(arc.omega, -0.9, 1e-12);
}

TEST(ImportTest, TextReaderReadsPlainAndGzipTheSame) {
  const std::string text = "a b\r\nc,d\n\nlast";
  const std::string plain = TempFile("plain.txt", "\xEF\xBB\xBF" + text);
  const std::string packed = testing::TempDir() + "/import_test_packed.txt.gz";
  gzFile gz = gzopen(packed.c_str(), "wb");
  gzwrite(gz, text.data(), static_cast<unsigned>(text.size()));
  gzclose(gz);
  for (const std::string& path : {plain, packed}) {
    TextReader reader(path);
    std::string line;
    std::vector<std::string> lines;
    while (reader.Next(&line)) lines.push_back(line);
    EXPECT_EQ(lines, (std::vector<std::string>{"a b", "c,d", "", "last"})) << path;
    EXPECT_EQ(reader.line_number(), 4);
  }
  EXPECT_EQ(SplitFields(" 1  2\t3 "), (std::vector<std::string>{"1", "2", "3"}));
  EXPECT_EQ(SplitFields("1, 2,,3 ", ','), (std::vector<std::string>{"1", "2", "", "3"}));
}

TEST(ImportTest, SecondsBecomeMicrosecondsExactly) {
  const std::string path = TempFile("seconds.txt", "x\n");
  TextReader reader(path);
  EXPECT_EQ(ParseSecondsAsMicros(reader, "1134864629.895182", "t"), 1134864629895182);
  EXPECT_EQ(ParseSecondsAsMicros(reader, "0.0499999999999972", "t"), 50000);
  EXPECT_EQ(ParseSecondsAsMicros(reader, "97.85", "t"), 97850000);
  EXPECT_EQ(ParseSecondsAsMicros(reader, "-1.5", "t"), -1500000);
  EXPECT_EQ(ParseSecondsAsMicros(reader, "1.5e2", "t"), 150000000);
  EXPECT_THROW(ParseSecondsAsMicros(reader, "12.3s", "t"), InputError);
  EXPECT_THROW(ParseNumber(reader, "nan", "x"), InputError);
  EXPECT_THROW(ParseInteger(reader, "3.0", "n"), InputError);
}

// --- CARMEN ----------------------------------------------------------------------------------

TEST(ImportTest, CarmenMitCsail) {
  REQUIRE_DATA("mit-csail-carmen/mit-csail.clf.gz");
  const RobotDescription robot = DatasetRobot("mit_csail.yaml");
  MemorySink sink;
  const ImportSummary summary = ImportCarmen(data_path, robot, &sink);
  ExpectTimeOrder(sink);
  // SOURCE.md: 3 comment lines + 1988 FLASER lines, ipc stamps 1134864629.90 .. 1134865053.89.
  EXPECT_EQ(summary.lines, 1991);
  EXPECT_EQ(summary.skipped, 3);
  EXPECT_EQ(summary.duplicates_dropped, 0);
  EXPECT_EQ(summary.messages.at("WHEELS"), 1988);
  EXPECT_EQ(summary.messages.at("SCAN"), 1988);
  EXPECT_EQ(summary.first_utime, 1134864629895182);
  EXPECT_EQ(summary.last_utime, 1134865053892206);

  // One record against the raw text: 361 beams over 180 deg from -90 deg, 81.91 = no return.
  std::vector<std::vector<std::string>> lines;
  for (auto& f : ReadRecords(data_path))
    if (!f.empty() && f[0] == "FLASER") lines.push_back(std::move(f));
  ASSERT_EQ(lines.size(), 1988u);
  const auto scans = Messages<agvcal::laser_scan_t>(sink, "SCAN");
  const agvcal::laser_scan_t& scan = scans[100];
  ASSERT_EQ(scan.nranges, 361);
  EXPECT_NEAR(scan.angle_min, -90 * kDeg, 1e-6);
  EXPECT_NEAR(scan.angle_increment, 0.5 * kDeg, 1e-7);
  EXPECT_NEAR(scan.scan_time, 0.21, 0.01);  // median interval of the log's laser lines
  int no_return = 0;
  for (int i = 0; i < 361; ++i) {
    const double raw = std::stod(lines[100][2 + i]);
    if (raw >= 81.9) {
      EXPECT_TRUE(std::isinf(scan.ranges[i]));
      ++no_return;
    } else {
      EXPECT_FLOAT_EQ(scan.ranges[i], static_cast<float>(raw));
      EXPECT_GE(scan.ranges[i], scan.range_min);
      EXPECT_LE(scan.ranges[i], scan.range_max);
    }
  }
  EXPECT_GT(no_return, 0);

  // The inversion: integrating WHEELS with the nominal model between consecutive laser lines
  // gives back the log's odometry increment. The heading change and the part of the
  // translation along the arc's chord are exact (1e-9); what is lost is the sideways part no
  // arc can hold (odometry steps that turn and translate in separate phases).
  const auto model = MakeDriveModel(robot);
  const WheelTrack track = Track(sink, robot);
  std::vector<double> sideways;
  double log_length = 0.0, wheel_length = 0.0;
  Pose2 composed;  // the whole log, integrated step by step
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto pose = [&](std::size_t k) {
      return Pose2{std::stod(lines[k][2 + 361 + 3]), std::stod(lines[k][2 + 361 + 4]),
                   std::stod(lines[k][2 + 361 + 5])};
    };
    const Pose2 actual = Between(pose(i - 1), pose(i));
    const Pose2 predicted = track.Odometry(*model, scans[i - 1].utime, scans[i].utime);
    composed = Compose(composed, predicted);
    EXPECT_NEAR(WrapAngle(predicted.theta - actual.theta), 0.0, 1e-9) << "step " << i;
    const double c = std::cos(actual.theta / 2), s = std::sin(actual.theta / 2);
    const double ex = predicted.x - actual.x, ey = predicted.y - actual.y;
    EXPECT_NEAR(ex * c + ey * s, 0.0, 1e-9) << "step " << i;
    sideways.push_back(std::abs(-ex * s + ey * c));
    log_length += std::hypot(actual.x, actual.y);
    wheel_length += std::hypot(predicted.x, predicted.y);
  }
  std::sort(sideways.begin(), sideways.end());
  const double median = sideways[sideways.size() / 2];
  const double p95 = sideways[sideways.size() * 95 / 100];
  std::printf("CARMEN sideways loss per step: median %.2g m, 95%% %.3g m, max %.3g m; "
              "path %.3f m (log) vs %.3f m (wheels)\n",
              median, p95, sideways.back(), log_length, wheel_length);
  // Measured: median 1.4 mm, 95th percentile 15.5 mm, max 0.339 m (one step of 0.85 m in
  // 0.21 s turning 0.87 rad), path 373.625 vs 373.189 m.
  EXPECT_LT(median, 0.003);
  EXPECT_LT(p95, 0.025);
  EXPECT_LT(sideways.back(), 0.4);
  EXPECT_NEAR(wheel_length / log_length, 1.0, 0.003);
  EXPECT_EQ(summary.notes.size(), 3u);

  // The whole log (424 s, 374 m): measured 0.034 m apart, heading exact.
  const auto odometry = [](const std::vector<std::string>& f) {
    return Pose2{std::stod(f[366]), std::stod(f[367]), std::stod(f[368])};
  };
  const Pose2 log_total = Between(odometry(lines.front()), odometry(lines.back()));
  const Pose2 wheel_total = track.Odometry(*model, scans.front().utime, scans.back().utime);
  EXPECT_NEAR(WrapAngle(wheel_total.theta - log_total.theta), 0.0, 1e-6);
  EXPECT_LT(std::hypot(wheel_total.x - log_total.x, wheel_total.y - log_total.y), 0.1)
      << "log (" << log_total.x << ", " << log_total.y << ") wheels (" << wheel_total.x << ", "
      << wheel_total.y << ")";
}

// ODOM lines (newer logs) take precedence over the odometry in the laser lines and carry
// velocities; RAWLASER1 carries its own geometry; other records are skipped and counted.
TEST(ImportTest, CarmenOdomAndRawLaser) {
  const RobotDescription robot = DatasetRobot("mit_csail.yaml");  // r 0.1 m, track 0.5 m
  const std::string path = TempFile(
      "odom.clf",
      "# CARMEN log\n"
      "PARAM robot_length 0.5 nohost 0\n"
      "ODOM 1.0 2.0 0.0 0.5 0.1 0.0 100.000000 host 0.1\n"
      "RAWLASER1 0 -1.5 3.0 1.0 5.0 0.01 0 4 1.0 2.0 5.0 6.0 4 10 20 30 40 100.010000 host 0.11\n"
      "ODOM 1.1 2.0 0.0 0.5 0.1 0.0 100.100000 host 0.2\n"
      "RAWLASER2 0 -1.5 3.0 1.0 5.0 0.01 0 1 1.0 0 100.020000 host 0.12\n"
      "ODOM 1.1 2.0 0.1 0.5 0.1 0.0 100.200000 host 0.3\n");
  MemorySink sink;
  const ImportSummary summary = ImportCarmen(path, robot, &sink);
  EXPECT_EQ(summary.messages.at("WHEELS"), 3);
  EXPECT_EQ(summary.messages.at("SCAN"), 1);
  EXPECT_EQ(summary.skipped, 3);  // comment, PARAM, RAWLASER2
  const auto wheels = Messages<agvcal::wheel_state_t>(sink, "WHEELS");
  ASSERT_EQ(wheels.size(), 3u);
  EXPECT_EQ(wheels[0].utime, 100000000);
  EXPECT_EQ(wheels[0].name, (std::vector<std::string>{"left", "right"}));
  // tv 0.5, rv 0.1: wheels (0.5 -+ 0.1 * 0.25) / 0.1 rad/s.
  EXPECT_NEAR(wheels[0].velocity[0], 4.75, 1e-12);
  EXPECT_NEAR(wheels[0].velocity[1], 5.25, 1e-12);
  // 0.1 m straight: both wheels 1 rad; then 0.1 rad in place: -+0.1 * 0.25 / 0.1 rad.
  EXPECT_NEAR(wheels[1].position[0], 1.0, 1e-9);
  EXPECT_NEAR(wheels[1].position[1], 1.0, 1e-9);
  EXPECT_NEAR(wheels[2].position[0], 1.0 - 0.25, 1e-9);
  EXPECT_NEAR(wheels[2].position[1], 1.0 + 0.25, 1e-9);
  const auto scan = Messages<agvcal::laser_scan_t>(sink, "SCAN").at(0);
  EXPECT_EQ(scan.utime, 100010000);
  EXPECT_FLOAT_EQ(scan.angle_min, -1.5f);
  EXPECT_FLOAT_EQ(scan.angle_increment, 1.0f);
  EXPECT_FLOAT_EQ(scan.range_max, 5.0f);
  ASSERT_EQ(scan.nranges, 4);
  EXPECT_FLOAT_EQ(scan.ranges[1], 2.0f);
  EXPECT_TRUE(std::isinf(scan.ranges[2]));  // >= maximum_range
  ASSERT_EQ(scan.nintensities, 4);
  EXPECT_FLOAT_EQ(scan.intensities[3], 40.0f);
}

TEST(ImportTest, CarmenBadInput) {
  const RobotDescription robot = DatasetRobot("mit_csail.yaml");
  MemorySink sink;
  const std::string good = "ODOM 1.0 2.0 0.0 0.5 0.1 0.0 100.0 host 0.1\n";
  std::string path = TempFile("short.clf", good + "ODOM 1.0 2.0 0.0 0.5 0.1 100.1 host 0.2\n");
  ExpectInputError([&] { ImportCarmen(path, robot, &sink); }, path, 2, "has 9 fields, expected 10");
  path = TempFile("nan.clf", good + good + "ODOM 1.0 x 0.0 0.5 0.1 0.0 100.2 host 0.2\n");
  ExpectInputError([&] { ImportCarmen(path, robot, &sink); }, path, 3, "field 3 (y)");
  path = TempFile("back.clf", good + "ODOM 1.0 2.0 0.0 0.5 0.1 0.0 99.9 host 0.2\n");
  ExpectInputError([&] { ImportCarmen(path, robot, &sink); }, path, 2, "goes back");
  path = TempFile("garbage.clf", good + "12 13 14\n");
  ExpectInputError([&] { ImportCarmen(path, robot, &sink); }, path, 2, "not a CARMEN record");
  path = TempFile("beams.clf", "FLASER 3 1 1 1 0 0 0 0 0 0 100.0 host 0.1\n");
  ExpectInputError([&] { ImportCarmen(path, robot, &sink); }, path, 1, "180, 181, 361 and 401");
  path = TempFile("noodom.clf", "# nothing\n");
  ExpectInputError([&] { ImportCarmen(path, robot, &sink); }, path, 0, "no odometry");
  // A tricycle cannot take differential odometry.
  const RobotDescription tricycle = DatasetRobot("optiodom_tricycle.yaml");
  ExpectInputError([&] { ImportCarmen(path, tricycle, &sink); }, tricycle.source_file, 0,
                   "describes a tricycle drive");
  EXPECT_TRUE(sink.events.empty()) << "nothing is published on error";
  // A repeated stamp is dropped and counted.
  path = TempFile("dup.clf", good + good + "ODOM 1.1 2.0 0.0 0.5 0.1 0.0 100.1 host 0.2\n");
  const ImportSummary summary = ImportCarmen(path, robot, &sink);
  EXPECT_EQ(summary.duplicates_dropped, 1);
  EXPECT_EQ(summary.messages.at("WHEELS"), 2);
}

// --- Mines rover -----------------------------------------------------------------------------

TEST(ImportTest, MinesRover) {
  REQUIRE_DATA("mines-rover-coreslam");
  const RobotDescription robot = DatasetRobot("mines_rover.yaml");
  for (const auto& [name, lines] : std::vector<std::pair<std::string, int>>{{"exp1", 756}, {"exp2", 641}}) {
    SCOPED_TRACE(name);
    const std::string path = data_path + "/" + name + ".dat.gz";
    MemorySink sink;
    const ImportSummary summary = ImportMines(path, robot, &sink);
    ExpectTimeOrder(sink);
    EXPECT_EQ(summary.lines, lines);  // SOURCE.md
    EXPECT_EQ(summary.messages.at("WHEELS"), lines);
    EXPECT_EQ(summary.messages.at("SCAN"), lines);
    const auto records = ReadRecords(path);
    // Span: SOURCE.md ~74.6 s and ~63.2 s.
    EXPECT_NEAR((summary.last_utime - summary.first_utime) * 1e-6, name == "exp1" ? 74.6 : 63.2, 0.05);
    // Cumulative ticks -> rad at 2000 ticks per revolution, from 0 at the first line.
    const auto wheels = Messages<agvcal::wheel_state_t>(sink, "WHEELS");
    const double tick = 2 * M_PI / 2000;
    EXPECT_NEAR(wheels.back().position[0],
                (std::stoll(records.back()[2]) - std::stoll(records.front()[2])) * tick, 1e-9);
    EXPECT_NEAR(wheels.back().position[1],
                (std::stoll(records.back()[3]) - std::stoll(records.front()[3])) * tick, 1e-9);
    EXPECT_TRUE(std::isnan(wheels.back().velocity[0]));
    // Ranges mm -> m, 682 beams over 240 deg.
    const auto scans = Messages<agvcal::laser_scan_t>(sink, "SCAN");
    const agvcal::laser_scan_t& scan = scans[300];
    ASSERT_EQ(scan.nranges, 682);
    EXPECT_NEAR(scan.angle_min, -120 * kDeg, 1e-6);
    EXPECT_NEAR(scan.angle_min + 681 * scan.angle_increment, 120 * kDeg, 1e-5);
    EXPECT_FLOAT_EQ(scan.scan_time, 0.1f);
    EXPECT_EQ(scan.utime, std::stoll(records[300][0]));
    int valid = 0;
    for (int j = 0; j < 682; ++j) {
      EXPECT_FLOAT_EQ(scan.ranges[j], std::stoi(records[300][24 + j]) * 1e-3f);
      valid += scan.ranges[j] >= scan.range_min && scan.ranges[j] <= scan.range_max;
    }
    EXPECT_GT(valid, 90);  // the logs are sparse: 96 (exp1) and 103 (exp2) returns here
  }
}

TEST(ImportTest, MinesBadInput) {
  const RobotDescription robot = DatasetRobot("mines_rover.yaml");
  const auto line = [](int64_t t, const std::string& range0) {
    std::string s = std::to_string(t) + " 1 100 200";
    for (int i = 0; i < 20; ++i) s += " 0";
    s += " " + range0;
    for (int i = 1; i < 682; ++i) s += " 1000";
    return s + " 0\n";
  };
  MemorySink sink;
  std::string path = TempFile("mines_bad.dat", line(1000, "500") + line(2000, "500") + line(3000, "12x"));
  ExpectInputError([&] { ImportMines(path, robot, &sink); }, path, 3, "field 25 (range mm)");
  path = TempFile("mines_short.dat", line(1000, "500") + "1000 1 100 200 0\n");
  ExpectInputError([&] { ImportMines(path, robot, &sink); }, path, 2, "expected 707 fields");
  path = TempFile("mines_back.dat", line(1000, "500") + line(3000, "500") + line(2000, "500"));
  ExpectInputError([&] { ImportMines(path, robot, &sink); }, path, 3, "goes back");
  EXPECT_TRUE(sink.events.empty());
}

// A .gz cut short: the lines before the cut are read, then an error names the next line.
TEST(ImportTest, TruncatedGzipNamesTheLine) {
  REQUIRE_DATA("mines-rover-coreslam/exp1.dat.gz");
  const RobotDescription robot = DatasetRobot("mines_rover.yaml");
  const std::string path = testing::TempDir() + "/import_test_cut.dat.gz";
  std::vector<std::string> lines;
  {
    TextReader reader(data_path);
    std::string line;
    while (lines.size() < 100 && reader.Next(&line)) lines.push_back(line + "\n");
  }
  // Write 100 lines, flushing the compressor after line 60, and cut the file there plus a
  // few bytes of line 61's compressed data.
  gzFile gz = gzopen(path.c_str(), "wb9");
  long cut = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    gzwrite(gz, lines[i].data(), static_cast<unsigned>(lines[i].size()));
    if (i + 1 == 60) {
      gzflush(gz, Z_FULL_FLUSH);
      cut = gzoffset(gz) + 40;
    }
  }
  gzclose(gz);
  std::filesystem::resize_file(path, static_cast<std::uintmax_t>(cut));
  MemorySink sink;
  ExpectInputError([&] { ImportMines(path, robot, &sink); }, path, 61, "truncated .gz");
  // Corrupt compressed data (a gzip header, then a reserved deflate block type) is told
  // apart from a cut.
  const std::string corrupt = TempFile("corrupt.dat.gz", std::string("\x1f\x8b\x08\0\0\0\0\0\0\x03", 10) +
                                                             std::string(64, '\xff'));
  ExpectInputError([&] { ImportMines(corrupt, robot, &sink); }, corrupt, 1, "corrupt compressed data");
  EXPECT_TRUE(sink.events.empty());
}

// --- Lego robot ------------------------------------------------------------------------------

TEST(ImportTest, LegoRobot) {
  REQUIRE_DATA("lego-robot-brenner");
  const RobotDescription robot = DatasetRobot("lego_robot.yaml");
  const std::string motors = data_path + "/robot4_motors.txt";
  EXPECT_EQ(LegoScanPathFor(motors), data_path + "/robot4_scan.txt.gz");
  MemorySink sink;
  const ImportSummary summary = Import("lego", motors, &robot, &sink);
  ExpectTimeOrder(sink);
  // SOURCE.md: 278 records in each file; the motor file repeats 61 records (same stamp, same
  // values), which are dropped.
  EXPECT_EQ(summary.lines, 2 * 278);
  EXPECT_EQ(summary.duplicates_dropped, 61);
  EXPECT_EQ(summary.messages.at("WHEELS"), 278 - 61);
  EXPECT_EQ(summary.messages.at("SCAN"), 278);
  // The nominal radius reproduces the lecture's ticks_to_mm = 0.349 mm: r * position equals
  // 0.349 mm per tick of the raw counts (fields 3 and 7).
  const auto records = ReadRecords(motors);
  const auto wheels = Messages<agvcal::wheel_state_t>(sink, "WHEELS");
  const double r = robot.param("left_radius");
  EXPECT_NEAR(r * wheels.back().position[0],
              (std::stoll(records.back()[2]) - std::stoll(records.front()[2])) * 0.349e-3, 1e-9);
  EXPECT_NEAR(r * wheels.back().position[1],
              (std::stoll(records.back()[6]) - std::stoll(records.front()[6])) * 0.349e-3, 1e-9);
  // Scans in the scanner's frame: beam i at (i - 330) * 0.0061359 rad, mm -> m.
  const auto scans = Messages<agvcal::laser_scan_t>(sink, "SCAN");
  ASSERT_EQ(scans[0].nranges, 660);
  EXPECT_NEAR(scans[0].angle_min, -330 * 0.006135923151543, 1e-6);
  EXPECT_NEAR(scans[0].angle_increment, 0.006135923151543, 1e-9);
  EXPECT_EQ(scans[0].utime, 315000);
  EXPECT_FLOAT_EQ(scans[0].ranges[0], 0.189f);
  EXPECT_NEAR(robot.lidar2d->yaw, -4 * kDeg, 1e-12);

  // The reference positions (no heading) stay out of the recording; the reader gives them.
  const auto reference = ReadLegoReference(data_path + "/robot4_reference.txt");
  ASSERT_EQ(reference.size(), 278u);
  EXPECT_EQ(reference[0].utime, 378000);
  EXPECT_DOUBLE_EQ(reference[0].x, 1.850);
  EXPECT_DOUBLE_EQ(reference[0].y, 1.897);
  // Nominal odometry against the tracked positions: travelled distance, stated tolerance 10%
  // (the tracked point is not documented; measured below).
  const auto model = MakeDriveModel(robot);
  const WheelTrack track = Track(sink, robot);
  double wheel_length = 0.0, reference_length = 0.0;
  for (std::size_t i = 1; i < reference.size(); ++i) {
    reference_length += std::hypot(reference[i].x - reference[i - 1].x, reference[i].y - reference[i - 1].y);
    if (track.Covers(reference[i - 1].utime, reference[i].utime)) {
      const Pose2 step = track.Odometry(*model, reference[i - 1].utime, reference[i].utime);
      wheel_length += std::hypot(step.x, step.y);
    }
  }
  std::printf("Lego path: wheels %.3f m, reference %.3f m\n", wheel_length, reference_length);
  EXPECT_NEAR(wheel_length / reference_length, 1.0, 0.1);  // measured 8.730 / 9.354 m
}

// --- OptiOdom --------------------------------------------------------------------------------

struct OptiOdomRun {
  std::string run;
  const char* robot;
  int rows;
};

TEST(ImportTest, OptiOdomRuns) {
  REQUIRE_DATA("optiodom-sousa");
  const std::vector<OptiOdomRun> runs{
      {"tricyc/circular/140120211415/140120211415_run-01", "optiodom_tricycle.yaml", 1896},
      {"tricyc/circular/140120211415/140120211415_run-02", "optiodom_tricycle.yaml", 1958},
      {"tricyc/square/140120211430/140120211430_run-01", "optiodom_tricycle.yaml", 2937},
      {"tricyc/square/140120211430/140120211430_run-02", "optiodom_tricycle.yaml", 3138},
      {"tricyc/free/140120211508/140120211508_run-01", "optiodom_tricycle.yaml", 3671},
      {"diff/free/020120212354/020120212354_run-01", "optiodom_diff.yaml", 3183}};
  for (const OptiOdomRun& run : runs) {
    SCOPED_TRACE(run.run);
    const std::string path = data_path + "/" + run.run + ".csv.gz";
    const RobotDescription robot = DatasetRobot(run.robot);
    MemorySink sink;
    const ImportSummary summary = ImportOptiOdom(path, robot, &sink);
    ExpectTimeOrder(sink);
    // Only the tick-scale note: the robot file's nominal values equal the metadata's.
    std::string notes;
    for (const auto& note : summary.notes) notes += note + "\n";
    EXPECT_EQ(summary.notes.size(), 1u) << notes;
    EXPECT_EQ(summary.messages.at("WHEELS"), run.rows);  // SOURCE.md row counts
    EXPECT_EQ(summary.messages.at("POSE"), run.rows);
    const auto poses = Messages<agvcal::pose2d_t>(sink, "POSE");
    const auto records = ReadRecords(path, ',');
    EXPECT_EQ(poses.back().utime, std::llround(std::stod(records.back()[0]) * 1e6));
    EXPECT_DOUBLE_EQ(poses.back().x, std::stod(records.back()[1]));
    for (double c : poses.back().cov) EXPECT_EQ(c, 0.0);

    // Nominal odometry against the OptiTrack ground truth over the run: travelled distance
    // and net heading change (th_gt is unwrapped in the file). Both are sampled every 10 rows
    // (0.5 s) so that tracker jitter does not lengthen the ground-truth path.
    const auto model = MakeDriveModel(robot);
    const WheelTrack track = Track(sink, robot);
    double wheel_length = 0.0, truth_length = 0.0, wheel_turn = 0.0;
    for (std::size_t i = 10; i < poses.size(); i += 10) {
      const Pose2 step = track.Odometry(*model, poses[i - 10].utime, poses[i].utime);
      wheel_length += std::hypot(step.x, step.y);
      wheel_turn += step.theta;
      truth_length += std::hypot(poses[i].x - poses[i - 10].x, poses[i].y - poses[i - 10].y);
    }
    const std::size_t last = (poses.size() - 1) / 10 * 10;
    const double truth_turn = std::stod(records[last][3]) - std::stod(records[0][3]);
    std::printf("%s: path wheels %.3f m, truth %.3f m (%.2f%%); turn wheels %.3f, truth %.3f rad\n",
                run.run.c_str(), wheel_length, truth_length, 100 * (wheel_length / truth_length - 1),
                wheel_turn, truth_turn);
    // Measured: -0.53% .. +1.12%.
    EXPECT_NEAR(wheel_length / truth_length, 1.0, 0.02);
    if (run.run.rfind("diff", 0) == 0) {
      // Measured 5.615 vs 5.509 rad. The robot's own odometry (the session file, same nominal
      // model) ends at 5.615 rad too, which pins the left/right columns and the tick scale.
      EXPECT_NEAR(wheel_turn / truth_turn, 1.0, 0.03);
      const auto session = ReadRecords(data_path + "/diff/free/020120212354/020120212354.csv.gz", ',');
      EXPECT_NEAR(wheel_turn, std::stod(session.back()[5]), 0.005);
    } else if (run.run.find("circular") != std::string::npos) {
      // Two turns each way; the nominal model turns 5% less (clockwise) and 16% more
      // (counterclockwise) than the truth: the steering offset that calibration is for.
      EXPECT_NEAR(wheel_turn / truth_turn, 1.0, 0.2);
    }
  }
}

TEST(ImportTest, OptiOdomBadInput) {
  const std::string dir = testing::TempDir() + "/import_test_optiodom";
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/42_metadata.csv") << "type,tricyc,\nngear,1,\nencRes,1600,\nLi,0.15,\n"
                                             "Di,0.065,\nThi,0,\nN,1,\n";
  const RobotDescription tricycle = DatasetRobot("optiodom_tricycle.yaml");
  const RobotDescription diff = DatasetRobot("optiodom_diff.yaml");
  MemorySink sink;
  const std::string run = dir + "/42_run-01.csv";
  std::ofstream(run) << "0,0,0,0,0,0\n0.05,0.001,0,0,16,0.00785398\n0.1,0.002,0\n";
  ExpectInputError([&] { ImportOptiOdom(run, tricycle, &sink); }, run, 3, "expected 6 comma-separated");
  ExpectInputError([&] { ImportOptiOdom(run, diff, &sink); }, diff.source_file, 0,
                   "describes a differential drive");
  std::ofstream(run) << "0,0,0,0,0,0\n0.05,0.001,0,0,16,0.00785398\n0.05,0.002,0,0,16,0\n"
                        "0.1,0.002,0,0,1600,0.1\n";
  const ImportSummary summary = ImportOptiOdom(run, tricycle, &sink);
  EXPECT_EQ(summary.duplicates_dropped, 1);
  const auto wheels = Messages<agvcal::wheel_state_t>(sink, "WHEELS");
  ASSERT_EQ(wheels.size(), 3u);
  EXPECT_NEAR(wheels[1].position[0], 16 * 2 * M_PI / 1600, 1e-12);
  EXPECT_NEAR(wheels[2].position[0], 1616 * 2 * M_PI / 1600, 1e-12);
  EXPECT_DOUBLE_EQ(wheels[2].steer[0], 0.1);
  const std::string orphan = dir + "/43_run-01.csv";
  std::ofstream(orphan) << "0,0,0,0,0,0\n";
  ExpectInputError([&] { ImportOptiOdom(orphan, tricycle, &sink); }, orphan, 0, "no metadata file");
  std::ofstream(dir + "/44_metadata.csv") << "type,omni3,\n";
  const std::string omni = dir + "/44_run-01.csv";
  std::ofstream(omni) << "0,0,0,0,0,0\n";
  ExpectInputError([&] { ImportOptiOdom(omni, tricycle, &sink); }, dir + "/44_metadata.csv", -1,
                   "'omni3' is not imported");
}

// --- pose CSV --------------------------------------------------------------------------------

TEST(ImportTest, PoseCsvGrammar) {
  const std::string path = TempFile("poses.csv",
                                    "# tracker export\n"
                                    "time,x,y,theta,var_x,var_y,var_theta\n"
                                    "1700000000.5, 1.0, 2.0, 3.5, 0.01, 0.02, 0.001\n"
                                    "\n"
                                    "1700000000.6, 1.1, 2.0, 0.1, 0.01, 0.02, 0.001\n"
                                    "1700000000.6, 1.2, 2.0, 0.1, 0.01, 0.02, 0.001\n");
  MemorySink sink;
  const ImportSummary summary = ImportPoseCsv(path, "POSE", &sink);
  EXPECT_EQ(summary.skipped, 2);
  EXPECT_EQ(summary.duplicates_dropped, 1);
  const auto poses = Messages<agvcal::pose2d_t>(sink, "POSE");
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].utime, 1700000000500000);
  EXPECT_DOUBLE_EQ(poses[0].x, 1.0);
  EXPECT_NEAR(poses[0].theta, 3.5 - 2 * M_PI, 1e-12);  // wrapped
  EXPECT_DOUBLE_EQ(poses[0].cov[4], 0.02);
  EXPECT_DOUBLE_EQ(poses[0].cov[1], 0.0);

  // Microseconds, a full covariance, no header.
  const std::string full = TempFile("poses_us.csv", "5000000,1,2,0.5,1,0.1,0,0.1,2,0,0,0,3\n");
  MemorySink full_sink;
  ImportPoseCsv(full, "MOCAP", &full_sink);
  const auto pose = Messages<agvcal::pose2d_t>(full_sink, "MOCAP").at(0);
  EXPECT_EQ(pose.utime, 5000000);
  EXPECT_DOUBLE_EQ(pose.cov[1], 0.1);
  EXPECT_DOUBLE_EQ(pose.cov[8], 3.0);

  MemorySink bad;
  std::string p = TempFile("mixed.csv", "1.5,0,0,0\n2000000,0,0,0\n");
  ExpectInputError([&] { ImportPoseCsv(p, "POSE", &bad); }, p, 2, "earlier lines were in seconds");
  p = TempFile("fields.csv", "1.5,0,0,0\n1.6,0,0,0,1\n");
  ExpectInputError([&] { ImportPoseCsv(p, "POSE", &bad); }, p, 2, "4, 7 or 13");
  p = TempFile("asym.csv", "1.5,0,0,0,1,0.1,0,0.2,1,0,0,0,1\n");
  ExpectInputError([&] { ImportPoseCsv(p, "POSE", &bad); }, p, 1, "not symmetric");
  p = TempFile("negvar.csv", "1.5,0,0,0,1,-1,1\n");
  ExpectInputError([&] { ImportPoseCsv(p, "POSE", &bad); }, p, 1, "negative variance");
  p = TempFile("back.csv", "1.5,0,0,0\n1.4,0,0,0\n");
  ExpectInputError([&] { ImportPoseCsv(p, "POSE", &bad); }, p, 2, "goes back");
  EXPECT_TRUE(bad.events.empty());
}

// --- dispatch --------------------------------------------------------------------------------

TEST(ImportTest, DispatchChecksFormatAndRobot) {
  MemorySink sink;
  ExpectInputError([&] { Import("bagfile", "x", nullptr, &sink); }, "command line", -1,
                   "unknown format 'bagfile' (known: carmen, mines, lego, optiodom, pose-csv, rosbag2, rosbag)");
  ExpectInputError([&] { Import("mines", "x", nullptr, &sink); }, "command line", -1,
                   "--robot config/robots/datasets/mines_rover.yaml");
  const RobotDescription robot = DatasetRobot("mines_rover.yaml");
  ExpectInputError([&] { Import("mines", "/nonexistent/exp1.dat", &robot, &sink); },
                   "/nonexistent/exp1.dat", -1, "cannot open");
  ExpectInputError([&] { LegoScanPathFor("/nonexistent/robot4_motors.txt"); },
                   "/nonexistent/robot4_motors.txt", -1, "cannot open");
  const std::string motors = TempFile("robot9_motors.txt", "M 1 0 0 0 0 0 0 0 0 0 0 0 0\n");
  ExpectInputError([&] { LegoScanPathFor(motors); }, motors, -1,
                   "tried import_test_robot9_scan.txt and import_test_robot9_scan.txt.gz");
  // Found by the fuzzer: a time in ms whose microseconds overflow int64.
  const std::string far = TempFile("robot8_motors.txt", "M 26666666666666604 0 0 0 0 0 0 0 0 0 0 0 0\n");
  const std::string far_scan = TempFile("robot8_scan.txt", "");
  const RobotDescription lego = DatasetRobot("lego_robot.yaml");
  ExpectInputError([&] { ImportLego(far, far_scan, lego, &sink); }, far, 1, "time out of range");
  for (const std::string& format : ImportFormats())
    EXPECT_EQ(ImportNeedsRobot(format), format != "pose-csv");
}

// Every dataset robot file loads, with the values of its SOURCE.md.
TEST(ImportTest, DatasetRobotFiles) {
  const RobotDescription mit = DatasetRobot("mit_csail.yaml");
  EXPECT_EQ(mit.drive, DriveType::kDifferential);
  ASSERT_TRUE(mit.lidar2d.has_value());
  const RobotDescription mines = DatasetRobot("mines_rover.yaml");
  EXPECT_DOUBLE_EQ(mines.param("left_radius"), 0.077);
  EXPECT_DOUBLE_EQ(mines.param("track"), 0.330);
  EXPECT_DOUBLE_EQ(mines.lidar2d->x, 0.145);
  const RobotDescription lego = DatasetRobot("lego_robot.yaml");
  EXPECT_NEAR(lego.param("right_radius") * 2 * M_PI / 360, 0.349e-3, 1e-12);  // ticks_to_mm
  EXPECT_DOUBLE_EQ(lego.param("track"), 0.150);
  EXPECT_DOUBLE_EQ(lego.lidar2d->x, 0.030);
  const RobotDescription tricycle = DatasetRobot("optiodom_tricycle.yaml");
  EXPECT_EQ(tricycle.drive, DriveType::kTricycle);
  EXPECT_DOUBLE_EQ(tricycle.param("drive_radius"), 0.0325);
  EXPECT_DOUBLE_EQ(tricycle.param("wheelbase"), 0.15);
  ASSERT_TRUE(tricycle.pose.has_value());
  EXPECT_FALSE(tricycle.lidar2d.has_value());
  const RobotDescription diff = DatasetRobot("optiodom_diff.yaml");
  EXPECT_DOUBLE_EQ(diff.param("left_radius"), 0.042);
  EXPECT_DOUBLE_EQ(diff.param("track"), 0.2);
  ASSERT_TRUE(diff.pose.has_value());
}

}  // namespace
}  // namespace calib
