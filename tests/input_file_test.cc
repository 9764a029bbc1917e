// Input files that blocked, ran out of memory or were read for ever (core/input_file.h,
// core/yaml_checked.h), and a recording with a torn event (io/recording.h's LogReader).
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "calib/core/errors.h"
#include "calib/core/robot.h"
#include "calib/io/log_summary.h"
#include "calib/io/recording.h"

namespace calib {
namespace {

std::string Temp(const std::string& name) { return ::testing::TempDir() + "/input_file_" + name; }

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void Write(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

std::string RobotError(const std::string& path) {
  try {
    LoadRobotFile(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

const std::string kForklift = std::string(AGVCAL_SOURCE_DIR) + "/config/robots/forklift.yaml";

TEST(InputFile, ARobotFileLargerThanAnyIsRefusedBeforeParsing) {
  const std::string path = Temp("huge.yaml");
  std::string text = Slurp(kForklift) + "std:\n";
  for (int i = 0; text.size() < (2u << 20); ++i) text += "  k" + std::to_string(i) + ": 0.001\n";
  Write(path, text);
  const auto start = std::chrono::steady_clock::now();
  const std::string error = RobotError(path);
  EXPECT_NE(error.find("larger than 1048576 bytes"), std::string::npos) << error;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2));
}

TEST(InputFile, ADeepNestOrAHugeListIsRefused) {
  Write(Temp("deep.yaml"), "name: " + std::string(100000, '['));
  EXPECT_NE(RobotError(Temp("deep.yaml")).find("nested more than 32 levels"), std::string::npos)
      << RobotError(Temp("deep.yaml"));
  std::string list = "name: [";
  while (list.size() < 900000) list += "1,";
  Write(Temp("list.yaml"), list + "1]\n");
  EXPECT_NE(RobotError(Temp("list.yaml")).find("more than 100000 values"), std::string::npos)
      << RobotError(Temp("list.yaml"));
}

TEST(InputFile, DevicesDirectoriesAndFifosWithoutAWriterAreRefused) {
  EXPECT_NE(RobotError("/dev/zero").find("not a regular file, pipe or FIFO"), std::string::npos)
      << RobotError("/dev/zero");
  EXPECT_NE(RobotError(::testing::TempDir()).find("is a directory"), std::string::npos);
  try {
    LogReader reader(::testing::TempDir());
    FAIL() << "a directory read as a recording";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is a directory"), std::string::npos) << e.what();
  }
  const std::string fifo = Temp("fifo");
  std::remove(fifo.c_str());
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const auto start = std::chrono::steady_clock::now();
  const std::string error = RobotError(fifo);
  EXPECT_NE(error.find("nothing was written to within 10 s"), std::string::npos) << error;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(15));
  std::remove(fifo.c_str());
}

// Events of one recording as bytes, each `channel` with `size` bytes of data.
struct Events {
  std::vector<std::string> bytes;
  std::string All(size_t from = 0, size_t to = size_t(-1)) const {
    std::string out;
    for (size_t i = from; i < bytes.size() && i < to; ++i) out += bytes[i];
    return out;
  }
};

Events MakeEvents(int n) {
  const std::string path = Temp("events.log");
  {
    LogWriter writer(path);
    for (int i = 0; i < n; ++i) writer.Publish("CHAN", 1000000 + i * 10000, std::vector<uint8_t>(100, uint8_t(i)));
    writer.Close();
  }
  const std::string all = Slurp(path);
  Events events;
  const size_t each = all.size() / n;
  for (int i = 0; i < n; ++i) events.bytes.push_back(all.substr(i * each, each));
  return events;
}

std::vector<int> ReadAll(const std::string& path, std::vector<LogSkip>* skips) {
  LogReader reader(path);
  std::vector<int> first_bytes;
  LogEvent event;
  while (reader.Next(&event)) first_bytes.push_back(event.data.at(0));
  *skips = reader.skips();
  return first_bytes;
}

TEST(LogReaderResync, ATornEventThenAnAppendedRecordingIsSkippedAndNamed) {
  // A logger killed inside event 20, restarted with -a: events 40.. appended after the torn one.
  const Events events = MakeEvents(60);
  const std::string path = Temp("torn.log");
  Write(path, events.All(0, 20) + events.bytes[20].substr(0, 70) + events.All(40));
  std::vector<LogSkip> skips;
  const std::vector<int> read = ReadAll(path, &skips);
  ASSERT_EQ(read.size(), 40u);  // was: "bad sync word" at event 21
  EXPECT_EQ(read[19], 19);
  EXPECT_EQ(read[20], 40);
  ASSERT_EQ(skips.size(), 1u);
  const uint64_t torn_at = 20 * events.bytes[0].size();
  EXPECT_EQ(skips[0].begin, torn_at);
  EXPECT_EQ(skips[0].end, torn_at + 70);
  EXPECT_EQ(skips[0].before_utime, 1000000 + 19 * 10000);
  EXPECT_EQ(skips[0].after_utime, 1000000 + 40 * 10000);
  const std::string text = skips[0].Describe();
  EXPECT_NE(text.find("bytes " + std::to_string(torn_at) + "-" + std::to_string(torn_at + 70) + " skipped"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("lacks what was logged between 1.190000 s and 1.400000 s (0.210 s)"), std::string::npos)
      << text;
}

TEST(LogReaderResync, ATornLastEventOfAFinishedFileIsSkippedAndNamed) {
  const Events events = MakeEvents(30);
  const std::string path = Temp("torn_end.log");
  Write(path, events.All(0, 29) + events.bytes[29].substr(0, 50));
  std::vector<LogSkip> skips;
  EXPECT_EQ(ReadAll(path, &skips).size(), 29u);  // was: "truncated event (log cut short)"
  ASSERT_EQ(skips.size(), 1u);
  EXPECT_NE(skips[0].problem.find("cut short"), std::string::npos) << skips[0].problem;
  EXPECT_EQ(skips[0].after_utime, 0);
  EXPECT_NE(skips[0].Describe().find("lacks what was logged after 1.280000 s"), std::string::npos)
      << skips[0].Describe();
  // info says it, and exits 0 on the good events.
  const LogSummary summary = SummarizeLog(path);
  EXPECT_EQ(summary.events, 29);
  EXPECT_EQ(summary.skipped.size(), 1u);
}

TEST(LogReaderResync, AFileThatIsNoRecordingIsStillRefused) {
  const std::string path = Temp("not_a_log.log");
  Write(path, std::string(5000, 'x'));
  std::vector<LogSkip> skips;
  EXPECT_THROW(ReadAll(path, &skips), InputError);
  // A growing log's incomplete tail is still waited for, not skipped.
  const Events events = MakeEvents(10);
  Write(path, events.All(0, 9) + events.bytes[9].substr(0, 50));
  LogReader growing(path);
  LogEvent event;
  int n = 0;
  while (growing.NextComplete(&event)) ++n;
  EXPECT_EQ(n, 9);
  EXPECT_TRUE(growing.skips().empty());
  Write(path, events.All());
  EXPECT_TRUE(growing.NextComplete(&event));
}

TEST(LogReaderResync, APipeIsReadToItsEnd) {
  const Events events = MakeEvents(20);
  const std::string path = Temp("piped.log");
  Write(path, events.All());
  const std::string fifo = Temp("pipe_fifo");
  std::remove(fifo.c_str());
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  // A writer for the FIFO: a child process that copies the recording into it.
  const pid_t child = fork();
  if (child == 0) {
    execlp("sh", "sh", "-c", ("cat '" + path + "' > '" + fifo + "'").c_str(), nullptr);
    _exit(127);
  }
  const LogSummary summary = SummarizeLog(fifo);  // was: "truncated event" (the size of a pipe is 0)
  EXPECT_EQ(summary.events, 20);
  waitpid(child, nullptr, 0);
  std::remove(fifo.c_str());
}

TEST(PrintableChannel, ControlBytesAndTrailingSpacesAreShown) {
  EXPECT_EQ(PrintableChannel("SCAN"), "SCAN");
  EXPECT_EQ(PrintableChannel("SCAN "), "SCAN\\x20");
  EXPECT_EQ(PrintableChannel("\x1b[2J\xff"), "\\x1B[2J\\xFF");
}

}  // namespace
}  // namespace calib
