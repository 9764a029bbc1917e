// The command line every process and agvcal sub-command reads (processes/common/command_line.h):
// what it accepts, what it refuses with exit status 2, and the --source option on top of it.
#include "common/command_line.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "calib/core/errors.h"
#include "common/process_util.h"

namespace agvcal_process {
namespace {

using calib::MotionSource;

// A command "test LOG [--out FILE] [--source NAME] [--quiet]" given `words`; `status` is what
// Parse returned.
struct Parsed {
  std::unique_ptr<CommandLine> args = std::make_unique<CommandLine>("test");
  std::optional<int> status;
};

Parsed Parse(std::vector<std::string> words) {
  Parsed parsed;
  parsed.args->Positional("LOG", "a recording")
      .Option("--out", "FILE", "where to write")
      .Option("--source", "NAME", "the sensor")
      .Flag("--quiet", "no progress");
  words.insert(words.begin(), "test");
  std::vector<char*> argv;
  for (std::string& word : words) argv.push_back(word.data());
  parsed.status = parsed.args->Parse(static_cast<int>(argv.size()), argv.data(), 1);
  return parsed;
}

TEST(CommandLineTest, OptionsAndArgumentsInAnyOrder) {
  const Parsed p = Parse({"--quiet", "run.log", "--out", "r.json"});
  ASSERT_FALSE(p.status);
  EXPECT_EQ(p.args->positional, std::vector<std::string>{"run.log"});
  EXPECT_TRUE(p.args->Has("--quiet"));
  EXPECT_EQ(p.args->Get("--out", ""), "r.json");
  EXPECT_FALSE(p.args->Has("--source"));
  EXPECT_EQ(p.args->Get("--source", "fallback"), "fallback");
}

TEST(CommandLineTest, AValueMayLookLikeAnOptionAndTheLastOneCounts) {
  const Parsed p = Parse({"run.log", "--out", "--quiet", "--out", "second.json"});
  ASSERT_FALSE(p.status);
  EXPECT_EQ(p.args->Get("--out", ""), "second.json");
  EXPECT_FALSE(p.args->Has("--quiet"));
  EXPECT_EQ(Parse({"run.log", "--out=r.json"}).args->Get("--out", ""), "r.json");
}

TEST(CommandLineTest, ABadCommandLineIsExitStatusTwo) {
  EXPECT_EQ(Parse({"run.log", "--bogus"}).status, calib::kExitBadInput);
  EXPECT_EQ(Parse({"run.log", "--out"}).status, calib::kExitBadInput);
  EXPECT_EQ(Parse({}).status, calib::kExitBadInput);
  EXPECT_EQ(Parse({"run.log", "another.log"}).status, calib::kExitBadInput);
  EXPECT_EQ(Parse({"run.log", "--help"}).status, calib::kExitOk);
  EXPECT_EQ(Parse({"--version"}).status, calib::kExitOk);
}

TEST(CommandLineTest, NumbersAreCheckedWhenRead) {
  const Parsed p = Parse({"run.log", "--out", "2.5"});
  EXPECT_EQ(p.args->GetDouble("--out", 0.0), 2.5);
  EXPECT_EQ(p.args->GetDouble("--source", 7.0), 7.0);
  try {
    Parse({"run.log", "--out", "2.5x"}).args->GetDouble("--out", 0.0);
    FAIL() << "2.5x read as a number";
  } catch (const calib::InputError& e) {
    EXPECT_STREQ(e.what(), "command line: --out: expected a number, got '2.5x'");
  }
}

TEST(SourceOptionTest, OneParserForEveryCommand) {
  const std::vector<MotionSource> live = {MotionSource::kLidar2d, MotionSource::kPose};
  const std::vector<MotionSource> all = {MotionSource::kLidar2d, MotionSource::kPose, MotionSource::kImu};
  EXPECT_EQ(MotionSourceOption(*Parse({"a.log"}).args, live, MotionSource::kLidar2d), MotionSource::kLidar2d);
  EXPECT_EQ(MotionSourceOption(*Parse({"a.log", "--source", "pose"}).args, live, MotionSource::kLidar2d),
            MotionSource::kPose);
  EXPECT_FALSE(MotionSourceOption(*Parse({"a.log"}).args, all, std::nullopt));
  try {
    MotionSourceOption(*Parse({"a.log", "--source", "imu"}).args, live, MotionSource::kLidar2d);
    FAIL() << "imu accepted";
  } catch (const calib::InputError& e) {
    EXPECT_STREQ(e.what(), "command line: --source: expected lidar2d or pose, got 'imu'");
  }
  try {
    MotionSourceOption(*Parse({"a.log", "--source", "lidar"}).args, all, std::nullopt);
    FAIL() << "lidar accepted";
  } catch (const calib::InputError& e) {
    EXPECT_STREQ(e.what(), "command line: --source: expected lidar2d, pose or imu, got 'lidar'");
  }
}

}  // namespace
}  // namespace agvcal_process
