// Robot files (spec/robot.md): the examples in config/robots load with their
// values, and every kind of bad input is an InputError naming file, line and key.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>

#include "calib/core/errors.h"
#include "calib/core/robot.h"

namespace calib {
namespace {

const char kOrigin[] = "test/robot.yaml";

// A valid tricycle file; line numbers below refer to it.
const char kTricycle[] =
    "name: forklift-07\n"                                         // 1
    "drive: tricycle\n"                                           // 2
    "wheels: {drive: drive}\n"                                    // 3
    "params:\n"                                                   // 4
    "  drive_radius: 0.115\n"                                     // 5
    "  wheelbase: 1.42\n"                                         // 6
    "  steer_offset: 0.0\n"                                       // 7
    "lidar2d: {channel: SCAN, x: 1.60, y: 0.0, yaw: 0.0}\n"       // 8
    "limits: {max_speed: 0.6, max_omega: 0.6, max_accel: 0.5}\n"; // 9

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test setup: '" << from << "' not in text";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// Parses `text` and expects an InputError whose message names the origin, the
// line (0: no line expected) and the key, and contains `problem`.
void ExpectError(const std::string& text, int line, const std::string& key,
                 const std::string& problem) {
  try {
    ParseRobot(text, kOrigin);
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.file(), kOrigin);
    EXPECT_NE(what.find(kOrigin), std::string::npos) << what;
    if (line > 0) {
      const std::string at = "line " + std::to_string(line);
      EXPECT_TRUE(what.find(at + ",") != std::string::npos || what.find(at + ":") != std::string::npos)
          << what;
    }
    if (!key.empty()) {
      EXPECT_NE(what.find("key " + key + ":"), std::string::npos) << what;
    }
    EXPECT_NE(what.find(problem), std::string::npos) << what;
  }
}

TEST(RobotFileTest, ParsesSpecExample) {
  const RobotDescription robot = ParseRobot(kTricycle, kOrigin);
  EXPECT_EQ(robot.name, "forklift-07");
  EXPECT_EQ(robot.drive, DriveType::kTricycle);
  EXPECT_EQ(robot.wheel_name("drive"), "drive");
  EXPECT_DOUBLE_EQ(robot.param("drive_radius"), 0.115);
  EXPECT_DOUBLE_EQ(robot.param("wheelbase"), 1.42);
  EXPECT_DOUBLE_EQ(robot.param("steer_offset"), 0.0);
  ASSERT_TRUE(robot.lidar2d.has_value());
  EXPECT_EQ(robot.lidar2d->channel, "SCAN");
  EXPECT_DOUBLE_EQ(robot.lidar2d->x, 1.60);
  EXPECT_FALSE(robot.lidar3d.has_value());
  EXPECT_FALSE(robot.imu.has_value());
  EXPECT_FALSE(robot.pose.has_value());
  EXPECT_DOUBLE_EQ(robot.limits.max_speed, 0.6);
  EXPECT_DOUBLE_EQ(robot.limits.max_steer, Limits().max_steer);  // omitted: default
  EXPECT_EQ(robot.source_file, kOrigin);
}

TEST(RobotFileTest, DefaultsChannelsAndMountFields) {
  const RobotDescription robot = ParseRobot(
      Replace(kTricycle, "lidar2d: {channel: SCAN, x: 1.60, y: 0.0, yaw: 0.0}",
              "lidar2d: {x: 1.6}\nlidar3d: {z: 1.9}\nimu: {}\npose: {yaw: 0.1}"),
      kOrigin);
  ASSERT_TRUE(robot.lidar2d && robot.lidar3d && robot.imu && robot.pose);
  EXPECT_EQ(robot.lidar2d->channel, "SCAN");
  EXPECT_DOUBLE_EQ(robot.lidar2d->y, 0.0);
  EXPECT_EQ(robot.lidar3d->channel, "CLOUD");
  EXPECT_DOUBLE_EQ(robot.lidar3d->z, 1.9);
  EXPECT_DOUBLE_EQ(robot.lidar3d->pitch, 0.0);
  EXPECT_EQ(robot.imu->channel, "IMU");
  EXPECT_EQ(robot.pose->channel, "POSE");
  EXPECT_DOUBLE_EQ(robot.pose->yaw, 0.1);
}

TEST(RobotFileTest, AcceptsCalibratedOutputKeys) {
  const RobotDescription robot = ParseRobot(
      std::string(kTricycle) +
          "std:\n  params: {drive_radius: 0.0002, wheelbase: 0.003}\n"
          "source: logs/forklift-07-run3.lcmlog\n",
      kOrigin);
  EXPECT_DOUBLE_EQ(robot.param("wheelbase"), 1.42);
  ExpectError(std::string(kTricycle) + "std: 0.1\n", 10, "std", "expected a map");
}

// What the controller does between DRIVE_CMD messages: absent, the diagnosis decides from the
// data; stated, it is taken; any other word is refused at its line.
TEST(RobotFileTest, CommandsBetween) {
  EXPECT_FALSE(ParseRobot(kTricycle, kOrigin).commands_between.has_value());
  for (const auto& [word, value] : {std::pair{"hold", CommandsBetween::kHold}, std::pair{"ramp", CommandsBetween::kRamp},
                                    std::pair{"continuous", CommandsBetween::kContinuous}}) {
    const RobotDescription robot = ParseRobot(std::string(kTricycle) + "commands: {between: " + word + "}\n", kOrigin);
    ASSERT_TRUE(robot.commands_between.has_value()) << word;
    EXPECT_EQ(*robot.commands_between, value) << word;
    EXPECT_STREQ(CommandsBetweenName(value), word);
  }
  ExpectError(std::string(kTricycle) + "commands: {between: smooth}\n", 10, "commands.between",
              "expected hold, ramp or continuous, got 'smooth'");
  ExpectError(std::string(kTricycle) + "commands: {rate: 20}\n", 10, "commands.rate", "unknown key");
}

TEST(RobotFileTest, LoadsExampleFiles) {
  const std::string dir = std::string(AGVCAL_SOURCE_DIR) + "/config/robots/";

  const RobotDescription diff = LoadRobotFile(dir + "diff_robot.yaml");
  EXPECT_EQ(diff.drive, DriveType::kDifferential);
  EXPECT_DOUBLE_EQ(diff.param("left_radius"), 0.075);
  EXPECT_DOUBLE_EQ(diff.param("right_radius"), 0.075);
  EXPECT_DOUBLE_EQ(diff.param("track"), 0.45);
  EXPECT_EQ(diff.params.size(), 3u);
  EXPECT_EQ(diff.wheels.size(), 2u);
  EXPECT_NE(diff.wheel_name("left"), diff.wheel_name("right"));
  ASSERT_TRUE(diff.lidar2d.has_value());
  EXPECT_DOUBLE_EQ(diff.lidar2d->x, 0.20);
  EXPECT_TRUE(diff.imu.has_value());
  EXPECT_EQ(diff.source_file, dir + "diff_robot.yaml");

  const RobotDescription fork = LoadRobotFile(dir + "forklift.yaml");
  EXPECT_EQ(fork.drive, DriveType::kTricycle);
  EXPECT_EQ(fork.name, "forklift-07");
  EXPECT_EQ(fork.wheel_name("drive"), "drive");
  EXPECT_DOUBLE_EQ(fork.param("drive_radius"), 0.115);
  EXPECT_DOUBLE_EQ(fork.param("wheelbase"), 1.42);
  EXPECT_DOUBLE_EQ(fork.param("steer_offset"), 0.0);
  ASSERT_TRUE(fork.lidar2d.has_value());
  EXPECT_DOUBLE_EQ(fork.lidar2d->x, 1.60);
  ASSERT_TRUE(fork.lidar3d.has_value());
  EXPECT_DOUBLE_EQ(fork.lidar3d->z, 1.90);
  EXPECT_EQ(fork.lidar3d->channel, "CLOUD");

  const RobotDescription dual = LoadRobotFile(dir + "dual_steer_agv.yaml");
  EXPECT_EQ(dual.drive, DriveType::kDualSteer);
  EXPECT_DOUBLE_EQ(dual.param("a1_radius"), 0.10);
  EXPECT_DOUBLE_EQ(dual.param("a1_steer_offset"), 0.0);
  EXPECT_DOUBLE_EQ(dual.param("b"), 1.20);
  EXPECT_DOUBLE_EQ(dual.param("a2_radius"), 0.10);
  EXPECT_DOUBLE_EQ(dual.param("a"), 0.60);
  EXPECT_TRUE(dual.lidar2d.has_value());
  EXPECT_FALSE(dual.lidar3d.has_value());

  for (const RobotDescription* robot : {&diff, &fork, &dual}) {
    const Limits& l = robot->limits;
    EXPECT_GT(l.max_speed, 0.0);
    EXPECT_LE(l.max_speed, 1.0);
    EXPECT_GT(l.max_omega, 0.0);
    EXPECT_DOUBLE_EQ(l.max_accel, 0.5);
    EXPECT_DOUBLE_EQ(l.max_steer, 1.3);
    EXPECT_DOUBLE_EQ(l.max_steer_rate, 1.0);
  }
}

TEST(RobotFileTest, TypoInKeyIsUnknownWithSuggestion) {
  ExpectError(Replace(kTricycle, "  wheelbase:", "  wheelbas:"), 6, "params.wheelbas",
              "unknown key (did you mean wheelbase?)");
  ExpectError(Replace(kTricycle, "drive: tricycle", "driv: tricycle"), 2, "driv",
              "did you mean drive?");
  ExpectError(Replace(kTricycle, "channel: SCAN", "chanel: SCAN"), 8, "lidar2d.chanel",
              "did you mean channel?");
  ExpectError(Replace(kTricycle, "max_accel", "max_acel"), 9, "limits.max_acel",
              "did you mean max_accel?");
  ExpectError(std::string(kTricycle) + "colour: red\n", 10, "colour", "unknown key");
  ExpectError(std::string(kTricycle) + "wheelbase: 1.5\n", 10, "wheelbase",
              "unknown key (drive parameters go under params:)");
}

TEST(RobotFileTest, ParameterOfAnotherDriveIsUnknown) {
  ExpectError(Replace(kTricycle, "  wheelbase: 1.42", "  track: 1.42"), 6, "params.track",
              "parameters of a tricycle drive are drive_radius, wheelbase and steer_offset");
}

TEST(RobotFileTest, DuplicateKeyIsAnError) {
  ExpectError(Replace(kTricycle, "  steer_offset: 0.0\n", "  steer_offset: 0.0\n  wheelbase: 1.5\n"),
              8, "params.wheelbase", "duplicate key (first given on line 6)");
}

TEST(RobotFileTest, MissingKey) {
  ExpectError(Replace(kTricycle, "  wheelbase: 1.42\n", ""), 4, "params.wheelbase",
              "missing required key");
  ExpectError(Replace(kTricycle, "name: forklift-07\n", ""), 1, "name", "missing required key");
  ExpectError(Replace(kTricycle, "lidar2d: {channel: SCAN, x: 1.60, y: 0.0, yaw: 0.0}",
                      "lidar3d: {pitch: 0.01}"),
              8, "lidar3d.z", "missing required key");
}

TEST(RobotFileTest, WrongDriveType) {
  ExpectError(Replace(kTricycle, "drive: tricycle", "drive: tricycel"), 2, "drive",
              "unknown drive type 'tricycel' (did you mean tricycle?)");
  ExpectError(Replace(kTricycle, "drive: tricycle", "drive: hovercraft"), 2, "drive",
              "expected differential, tricycle or dual_steer");
}

TEST(RobotFileTest, MissingWheelRole) {
  std::string text = Replace(kTricycle, "drive: tricycle", "drive: differential");
  text = Replace(text, "wheels: {drive: drive}", "wheels: {left: wl}");
  ExpectError(text, 3, "wheels.right", "missing required key");
}

TEST(RobotFileTest, ExtraWheelRole) {
  ExpectError(Replace(kTricycle, "wheels: {drive: drive}", "wheels: {drive: drive, caster: c}"),
              3, "wheels.caster", "wheel roles of a tricycle drive are drive");
}

TEST(RobotFileTest, WheelNamesNonEmptyAndDistinct) {
  std::string text = Replace(kTricycle, "drive: tricycle", "drive: differential");
  text = Replace(text, "wheels: {drive: drive}", "wheels: {left: w, right: w}");
  text = Replace(text, "  drive_radius: 0.115\n  wheelbase: 1.42\n  steer_offset: 0.0\n",
                 "  left_radius: 0.1\n  right_radius: 0.1\n  track: 0.5\n");
  ExpectError(text, 3, "wheels.right", "also used by wheels.left");
  ExpectError(Replace(kTricycle, "wheels: {drive: drive}", "wheels: {drive: ''}"), 3,
              "wheels.drive", "must not be empty");
}

TEST(RobotFileTest, NonNumericParam) {
  ExpectError(Replace(kTricycle, "wheelbase: 1.42", "wheelbase: long"), 6, "params.wheelbase",
              "expected a number, got 'long'");
  ExpectError(Replace(kTricycle, "wheelbase: 1.42", "wheelbase: \"1.42\""), 6, "params.wheelbase",
              "quoted string");
  ExpectError(Replace(kTricycle, "wheelbase: 1.42", "wheelbase: [1, 2]"), 6, "params.wheelbase",
              "expected a number, got a list");
  ExpectError(Replace(kTricycle, "wheelbase: 1.42", "wheelbase: .nan"), 6, "params.wheelbase",
              "finite");
  ExpectError(Replace(kTricycle, "x: 1.60", "x: 1.6m"), 8, "lidar2d.x", "expected a number");
}

TEST(RobotFileTest, ImplausibleValues) {
  ExpectError(Replace(kTricycle, "drive_radius: 0.115", "drive_radius: -0.115"), 5,
              "params.drive_radius", "must be from 0.001 to 100 m");
  ExpectError(Replace(kTricycle, "wheelbase: 1.42", "wheelbase: 0"), 6, "params.wheelbase",
              "must be from 0.001 to 100 m");
  ExpectError(Replace(kTricycle, "steer_offset: 0.0", "steer_offset: 1.7"), 7,
              "params.steer_offset", "within ±pi/2");
  ExpectError(Replace(kTricycle, "max_speed: 0.6", "max_speed: 0"), 9, "limits.max_speed",
              "must be from 0.001 to 100 m/s");
  // Values the reader took but no robot has: blamed on the robot file, not on the recording.
  ExpectError(Replace(kTricycle, "drive_radius: 0.115", "drive_radius: 1e-300"), 5, "params.drive_radius",
              "must be from 0.001 to 100 m, got '1e-300'");
  ExpectError(Replace(kTricycle, "x: 1.60", "x: 1e300"), 8, "lidar2d.x", "must be from -100 to 100 m");
  ExpectError(Replace(kTricycle, "max_speed: 0.6", "max_speed: 1e-300"), 9, "limits.max_speed",
              "must be from 0.001 to 100 m/s");
  ExpectError(Replace(kTricycle, "max_omega: 0.6", "max_omega: 1e9"), 9, "limits.max_omega",
              "must be from 0.001 to 100 rad/s");
  const std::string dual =
      "name: agv\n"
      "drive: dual_steer\n"
      "wheels: {a1: fl, a2: rr}\n"
      "params: {a1_radius: 0.1, a1_steer_offset: 0, b: 0, a2_radius: 0.1, a: 0}\n";
  ExpectError(dual, 4, "params.a", "both 0");
}

TEST(RobotFileTest, WrongStructure) {
  ExpectError(Replace(kTricycle, "wheels: {drive: drive}", "wheels: [drive]"), 3, "wheels",
              "expected a map of keys, got a list");
  ExpectError(Replace(kTricycle, "lidar2d: {channel: SCAN, x: 1.60, y: 0.0, yaw: 0.0}",
                      "imu:"),
              8, "imu", "expected a map of keys, got nothing");
  ExpectError("- name: x\n- drive: tricycle\n", 1, "", "top level must be a map");
}

TEST(RobotFileTest, YamlSyntaxError) {
  ExpectError(Replace(kTricycle, "wheels: {drive: drive}", "wheels: {drive: drive"), 0, "",
              "YAML syntax error");
  try {
    ParseRobot("name: x\ndrive: tricycle\n  wheels: y\n", kOrigin);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("YAML syntax error"), std::string::npos) << e.what();
  }
}

TEST(RobotFileTest, EmptyAndUnreadableFiles) {
  ExpectError("", 0, "", "empty robot file");
  ExpectError("# nothing here\n", 0, "", "empty robot file");
  ExpectError("name: a\n---\nname: b\n", 0, "", "more than one YAML document");
  // yaml-cpp 0.7's LoadAll never returns on these (found by bench/fuzz): each is one line, at once.
  ExpectError(",", 1, "", "YAML syntax error: a ',' outside");
  ExpectError("  ,x\n", 1, "", "YAML syntax error: a ',' outside");

  const std::string missing = "/nonexistent/robot.yaml";
  try {
    LoadRobotFile(missing);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), missing);
    EXPECT_NE(std::string(e.what()).find("cannot read"), std::string::npos) << e.what();
  }

  const std::string path = ::testing::TempDir() + "robot_file_test_bad.yaml";
  {
    std::ofstream out(path);
    out << Replace(kTricycle, "wheelbase:", "wheelbas:");
  }
  try {
    LoadRobotFile(path);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              path + ": line 6, key params.wheelbas: unknown key (did you mean wheelbase?)");
  }
  std::remove(path.c_str());
}

// The ros: block (docs/ros.md): topics, joints per wheel role, stamps; the bundled example.
TEST(RobotFileTest, RosBlock) {
  const std::string ros =
      "ros:\n"                                                                       // 10
      "  stamps: record\n"                                                           // 11
      "  joint_states: {wheels: {drive: traction}, steering: {drive: steering}}\n"   // 12
      "  scan: /front/scan\n";                                                       // 13
  const RobotDescription robot = ParseRobot(kTricycle + ros, kOrigin);
  ASSERT_TRUE(robot.ros.has_value());
  EXPECT_FALSE(robot.ros->header_stamps);
  EXPECT_EQ(robot.ros->joint_states, "/joint_states");
  EXPECT_EQ(robot.ros->wheel_joints.at("drive"), "traction");
  EXPECT_EQ(robot.ros->steering_joints.at("drive"), "steering");
  EXPECT_EQ(robot.ros->scan, "/front/scan");
  EXPECT_EQ(robot.ros->imu, "");
  EXPECT_EQ(robot.ros->tf_static, "/tf_static");
  EXPECT_FALSE(ParseRobot(kTricycle, kOrigin).ros.has_value());

  ExpectError(kTricycle + Replace(ros, "scan:", "scna:"), 13, "ros.scna", "did you mean scan?");
  ExpectError(kTricycle + Replace(ros, "stamps: record", "stamps: bag"), 11, "ros.stamps",
              "expected header");
  ExpectError(kTricycle + Replace(ros, "{drive: traction}", "{left: traction}"), 12,
              "ros.joint_states.wheels.left", "wheel roles of a tricycle drive are drive");
  ExpectError(kTricycle + Replace(ros, "{drive: steering}", "{drive: traction}"), 12,
              "ros.joint_states.steering.drive", "joint 'traction' is named twice");

  const RobotDescription example =
      LoadRobotFile(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/ros/diff_robot.yaml");
  ASSERT_TRUE(example.ros.has_value());
  EXPECT_EQ(example.ros->wheel_joints.at("right"), "right_wheel_joint");
  EXPECT_EQ(example.ros->cmd_vel, "/cmd_vel");
}

// ros.odom as the drive's own odometry (docs/ros.md): a differential drive's only.
TEST(RobotFileTest, RosOdomAsWheels) {
  std::ifstream in(std::string(AGVCAL_SOURCE_DIR) + "/config/robots/ros/diff_robot.yaml");
  std::string diff((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  diff = diff.substr(0, diff.find("ros:\n"));
  const RobotDescription robot = ParseRobot(diff + "ros:\n  odom: {topic: /wheel_odom, as: wheels}\n", kOrigin);
  EXPECT_EQ(robot.ros->odom, "/wheel_odom");
  EXPECT_TRUE(robot.ros->odom_as_wheels);
  const RobotDescription pose = ParseRobot(diff + "ros:\n  odom: {as: pose}\n", kOrigin);
  EXPECT_EQ(pose.ros->odom, "/odom");
  EXPECT_FALSE(pose.ros->odom_as_wheels);
  EXPECT_FALSE(ParseRobot(diff + "ros:\n  odom: /odom\n", kOrigin).ros->odom_as_wheels);
  ExpectError(kTricycle + std::string("ros:\n  odom: {as: wheels}\n"), 11, "ros.odom",
              "only a differential drive's wheels follow from its poses, this is a tricycle drive");
  ExpectError(kTricycle + std::string("ros:\n  odom: {as: wheel}\n"), 11, "ros.odom.as", "expected pose");
}

}  // namespace
}  // namespace calib
