// Robot files written back with calibrated values (core/robot_file_edit.h): the input's
// comments and layout survive, each value is rounded to its sigma and reads back as exactly
// the number written; and the units helper every command prints with (core/units.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "calib/core/robot.h"
#include "calib/core/robot_file_edit.h"
#include "calib/core/units.h"

namespace calib {
namespace {

std::string ReadSource(const std::string& relative) {
  std::ifstream in(std::string(AGVCAL_SOURCE_DIR) + "/" + relative);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> CommentsOf(const std::string& text) {
  std::vector<std::string> comments;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.find('#') != std::string::npos) comments.push_back(line.substr(line.find('#')));
  return comments;
}

// The number written for `key` on the line of `text` that holds it (first match).
std::string WrittenNumber(const std::string& text, const std::string& key, std::size_t from = 0) {
  const std::size_t at = text.find(key + ": ", from);
  EXPECT_NE(at, std::string::npos) << key << " not in\n" << text;
  if (at == std::string::npos) return "";
  const std::size_t start = at + key.size() + 2;
  return text.substr(start, text.find_first_of(",} \n", start) - start);
}

const std::vector<RobotFileValue> kForklift = {
    {"params.drive_radius", 0.11629812345678, 0.0000171234},
    {"params.wheelbase", 1.4334561234567, 0.000212},
    {"params.steer_offset", 0.0130971234, 0.0000221},
    {"lidar2d.x", 1.615188123456, 0.000227},
    {"lidar2d.y", 0.012738123, 0.000307},
    {"lidar2d.yaw", -0.0142061234, 0.0000974},
    {"lidar3d.z", 1.7312345678, 0.0021},
    {"lidar3d.pitch", 0.00871234567, 0.000134},
};

TEST(RobotFileWriteTest, RoundTripKeepsCommentsAndRoundsToSigma) {
  const std::string input = ReadSource("config/robots/forklift.yaml");
  const std::string out = WriteCalibratedValues(input, "forklift.yaml", kForklift, "solve", "run 1.log");
  // Every comment of the input is still there, and the layout: same number of lines plus
  // the header and the std: and source: entries.
  const std::vector<std::string> before = CommentsOf(input), after = CommentsOf(out);
  for (const std::string& c : before) {
    if (c.find("nominal values") != std::string::npos) continue;  // dropped: the values are calibrated now
    EXPECT_NE(std::find(after.begin(), after.end(), c), after.end()) << "comment lost: " << c << "\n" << out;
  }
  EXPECT_EQ(out.rfind("# Calibrated by agvcal solve from run 1.log\n", 0), 0u) << out;
  EXPECT_NE(out.find("  wheelbase: 1.43346          # m, drive wheel"), std::string::npos)
      << "value in place, comment at its column:\n" << out;
  EXPECT_NE(out.find("lidar2d: {channel: SCAN, x: 1.61519, y: 0.01274, yaw: -0.014206}"), std::string::npos) << out;

  const RobotDescription robot = ParseRobot(out, "written.yaml");
  auto check = [&](const std::string& key, double read, const RobotFileValue& v) {
    const std::string text = WrittenNumber(out, key);
    EXPECT_EQ(read, std::strtod(text.c_str(), nullptr)) << key << ": reads back exactly what is written";
    const int decimals = DecimalsForSigma(v.std);
    EXPECT_LE(std::abs(read - v.value), 0.5 * std::pow(10.0, -decimals) * (1 + 1e-9)) << key;
    EXPECT_LT(text.size(), 10u) << key << " = " << text << ": rounded to its sigma, not 17 digits";
  };
  check("drive_radius", robot.params.at("drive_radius"), kForklift[0]);
  check("wheelbase", robot.params.at("wheelbase"), kForklift[1]);
  check("steer_offset", robot.params.at("steer_offset"), kForklift[2]);
  check("yaw", robot.lidar2d->yaw, kForklift[5]);
  check("z", robot.lidar3d->z, kForklift[6]);
  check("pitch", robot.lidar3d->pitch, kForklift[7]);
  EXPECT_EQ(WrittenNumber(out, "drive_radius", out.find("std:")), "0.000017");
  EXPECT_EQ(WrittenNumber(out, "yaw", out.find("std:")), "0.000097");
  EXPECT_NE(out.find("\nsource: run 1.log\n"), std::string::npos) << out;
  EXPECT_EQ(robot.lidar3d->body.has_value(), true) << "the rest of lidar3d is kept";
}

// Calibrated values are no longer "nominal values; calibration starts here": that comment goes,
// and the header says what produced the values and how much of the recording they stand on.
TEST(RobotFileWriteTest, CalibratedValuesLoseTheNominalCommentAndCarryTheirProvenance) {
  const std::string input = ReadSource("config/robots/forklift.yaml");
  ASSERT_NE(input.find("nominal values; calibration starts here"), std::string::npos);
  const std::string details = "recording_sha256: 0123abcd\nfitted on the first 33 of 48 usable intervals (69 %)";
  const std::string out = WriteCalibratedValues(input, "forklift.yaml", kForklift, "solve", "run.log", details);
  EXPECT_EQ(out.find("nominal values"), std::string::npos) << out;
  EXPECT_NE(out.find("\nparams:\n"), std::string::npos) << "the params line without its comment:\n" << out;
  EXPECT_EQ(out.rfind("# Calibrated by agvcal solve from run.log\n#   recording_sha256: 0123abcd\n"
                      "#   fitted on the first 33 of 48 usable intervals (69 %)\n", 0), 0u) << out;
  // Written again: one header, the new one.
  const std::string again = WriteCalibratedValues(out, "forklift.yaml", kForklift, "solve", "b.log", "date: x");
  EXPECT_EQ(again.rfind("# Calibrated by agvcal solve from b.log\n#   date: x\n# Tricycle", 0), 0u) << again;
  EXPECT_NO_THROW(ParseRobot(again, "again.yaml"));
}

TEST(RobotFileWriteTest, RewritingMergesStdAndKeepsOneHeader) {
  const std::string input = ReadSource("config/robots/forklift.yaml");
  const std::string once = WriteCalibratedValues(input, "f.yaml", {kForklift[0], kForklift[1]}, "solve", "a.log");
  const std::string twice = WriteCalibratedValues(once, "f.yaml", {kForklift[6]}, "ground", "b.log");
  EXPECT_EQ(twice.find("# Calibrated by agvcal solve"), std::string::npos) << twice;
  EXPECT_EQ(twice.rfind("# Calibrated by agvcal ground from b.log\n", 0), 0u) << twice;
  EXPECT_NE(twice.find("params: {drive_radius: 0.000017, wheelbase: 0.00021}"), std::string::npos) << twice;
  EXPECT_NE(twice.find("  lidar3d: {z: 0.0021}"), std::string::npos) << twice;
  EXPECT_NE(twice.find("\nsource: b.log\n"), std::string::npos) << twice;
  EXPECT_EQ(twice.find("a.log"), std::string::npos) << twice;
  EXPECT_NO_THROW(ParseRobot(twice, "twice.yaml"));
}

TEST(RobotFileWriteTest, AddsMissingKeysInTheFilesStyle) {
  const std::string input =
      "name: r\ndrive: differential\nwheels: {left: l, right: r}\n"
      "params:\n  left_radius: 0.1   # m\n  right_radius: 0.1\n  track: 0.5\n"
      "imu: {channel: IMU}\n";
  const std::string out = WriteCalibratedValues(
      input, "d.yaml",
      {{"params.left_radius", 0.1012345, 0.00012}, {"imu.yaw", 0.0123456, 0.0011},
       {"imu.gyro_noise", 0.000123456, 0.0, 3}, {"lidar2d.x", 0.2512, 0.0031}},
      "solve", "x.log");
  EXPECT_NE(out.find("  left_radius: 0.10123 # m"), std::string::npos) << out;
  EXPECT_NE(out.find("imu: {channel: IMU, yaw: 0.0123, gyro_noise: 0.000123}"), std::string::npos) << out;
  EXPECT_NE(out.find("lidar2d:\n  x: 0.2512\n"), std::string::npos) << out;
  const RobotDescription robot = ParseRobot(out, "d.yaml");
  EXPECT_EQ(robot.imu->gyro_noise, 0.000123);
  EXPECT_EQ(robot.lidar2d->x, 0.2512);
}

// Every robot file of the project takes every calibrated value back in place and reads back.
TEST(RobotFileWriteTest, EveryBundledRobotFileRoundTrips) {
  int files = 0;
  for (const std::string dir : {"config/robots", "config/robots/datasets"}) {
    for (const auto& entry : std::filesystem::directory_iterator(std::string(AGVCAL_SOURCE_DIR) + "/" + dir)) {
      if (entry.path().extension() != ".yaml") continue;
      ++files;
      const std::string path = entry.path().string();
      const RobotDescription robot = LoadRobotFile(path);
      std::vector<RobotFileValue> values;
      for (const auto& [name, v] : robot.params) values.push_back({"params." + name, v * 1.01 + 0.001234567, 0.00031});
      if (robot.lidar2d) values.push_back({"lidar2d.yaw", robot.lidar2d->yaw + 0.0123456, 0.00021});
      if (robot.pose) values.push_back({"pose.x", robot.pose->x + 0.0123456, 0.0021});
      if (robot.lidar3d) values.push_back({"lidar3d.pitch", robot.lidar3d->pitch + 0.0123456, 0.000012});
      const std::string out = WriteCalibratedRobotFile(path, values, "solve", "x.log");
      const RobotDescription back = ParseRobot(out, path + " (written)");
      for (const auto& [name, v] : robot.params)
        EXPECT_NEAR(back.params.at(name), v * 1.01 + 0.001234567, 0.000005) << path << " " << name << "\n" << out;
      if (robot.lidar2d) {
        EXPECT_NEAR(back.lidar2d->yaw, robot.lidar2d->yaw + 0.0123456, 0.000005) << path;
      }
      if (robot.pose) {
        EXPECT_NEAR(back.pose->x, robot.pose->x + 0.0123456, 0.00005) << path;
      }
      if (robot.lidar3d) {
        EXPECT_NEAR(back.lidar3d->pitch, robot.lidar3d->pitch + 0.0123456, 0.0000005) << path;
      }
      for (const std::string& c : CommentsOf(ReadSource(dir + "/" + entry.path().filename().string()))) {
        if (c.find("nominal values") != std::string::npos) continue;  // dropped: the values are calibrated now
        const std::vector<std::string> after = CommentsOf(out);
        EXPECT_NE(std::find(after.begin(), after.end(), c), after.end()) << path << ": comment lost: " << c;
      }
    }
  }
  EXPECT_GE(files, 8);
}

TEST(UnitsTest, PValuesNeverZero) {
  EXPECT_EQ(PValueText(0.0), "p < 1e-12");
  EXPECT_EQ(PValueText(8.718e-99), "p < 1e-12");
  EXPECT_EQ(PValueText(0.031234), "p = 0.031");
  EXPECT_EQ(PValueText(3.14e-5), "p = 3.1e-05");
  EXPECT_EQ(PValueText(1.0), "p = 1");
}

TEST(UnitsTest, RoundsToTwoDigitsOfTheSigma) {
  EXPECT_EQ(DecimalsForSigma(0.00004), 6);
  EXPECT_EQ(DecimalsForSigma(0.0000996), 5);  // rounds to 0.00010
  EXPECT_EQ(DecimalsForSigma(0.0), -1);
  EXPECT_EQ(RoundedToSigma(0.11521349, 0.00004), "0.115213");
  EXPECT_EQ(RoundedToSigma(-0.0000001, 0.001), "0.0000");
  EXPECT_EQ(RoundedToSigma(1e-7, 0.0), "1.00000e-07") << "a YAML 1.1 float keeps its point";
  EXPECT_EQ(EstimateText(0.012, 0.00012, "rad"), "0.01200 ± 0.00012 rad (0.6875 ± 0.0069 deg)");
  EXPECT_EQ(EstimateText(0.115213, 0.00004, "m"), "0.115213 ± 0.000040 m");
  EXPECT_EQ(QuantityText(0.009809, "s²/m", 3), "0.00981 s²/m");
  EXPECT_EQ(ParamUnit("lidar2d.yaw"), "rad");
  EXPECT_EQ(ParamUnit("a1_steer_offset"), "rad");
  EXPECT_EQ(ParamUnit("slip_per_accel"), "s²/m");
  EXPECT_EQ(ParamUnit("amplitude"), "(relative)");
  EXPECT_EQ(MillimetresText(0.001056), "1.06 mm");
}

// The one value-and-sigma rendering of the reports, the terminal and the pages.
TEST(UnitsTest, ValueWithSigma) {
  EXPECT_EQ(ValueWithSigma(1.234567, 0.0012), "1.2346 ± 0.0012");
  EXPECT_EQ(ValueWithSigma(1.234567, 0.0996), "1.23 ± 0.10") << "two digits of the sigma after rounding";
  EXPECT_EQ(ValueWithSigma(0.5, 0.0), "0.5") << "held: the value alone";
  EXPECT_EQ(ValueWithSigma(0.5, std::numeric_limits<double>::infinity()), "0.5 ± undetermined");
  EXPECT_EQ(ValueWithSigma(-0.0004, -0.01), "0.000") << "a change rounded to its sigma, no \"-0\"";
  EXPECT_EQ(ValueWithSigma(std::nan(""), 0.1), "n/a");
  EXPECT_EQ(EstimateText(0.5, 0.0, "m"), "0.5 m");
  EXPECT_EQ(EstimateText(0.01, 0.001, "(relative)"), "0.0100 ± 0.0010 (relative)");
  EXPECT_EQ(FixedDecimals(12.345, 1), "12.3");
  EXPECT_EQ(Formatted("%5.1f|%s", 2.5, "x"), "  2.5|x");
}

}  // namespace
}  // namespace calib
