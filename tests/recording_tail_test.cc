#include "calib/io/recording_tail.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "calib/core/errors.h"
#include "calib/io/recording.h"

namespace calib {
namespace {

std::vector<char> Bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void Append(const std::string& path, const std::vector<char>& bytes, size_t count) {
  std::ofstream out(path, std::ios::binary | std::ios::app);
  out.write(bytes.data(), static_cast<std::streamsize>(count));
}

// Three events on two channels, as the logger writes them.
std::string ThreeEvents(const std::string& name) {
  const std::string path = testing::TempDir() + name;
  LogWriter writer(path);
  writer.Publish("WHEELS", 100, std::vector<uint8_t>(40, 1));
  writer.Publish("SCAN", 150, std::vector<uint8_t>(300, 2));
  writer.Publish("WHEELS", 200, std::vector<uint8_t>(40, 3));
  writer.Close();
  return path;
}

std::vector<std::string> Channels(const std::string& path) {
  std::vector<std::string> channels;
  LogReader reader(path);
  LogEvent event;
  while (reader.Next(&event)) channels.push_back(event.channel);  // throws on anything torn
  return channels;
}

TEST(RecordingTailTest, AWholeRecordingIsLeftAsItIs) {
  const std::string path = ThreeEvents("whole.log");
  const auto size = std::filesystem::file_size(path);
  const RecordingTail tail = CutToLastWholeEvent(path);
  EXPECT_EQ(tail.whole_events, 3);
  EXPECT_EQ(tail.whole_end, size);
  EXPECT_EQ(std::filesystem::file_size(path), size);
}

// A logger killed while writing leaves part of an event (here every length of a cut, in the
// header and in the body); the next logger appends whole events. Without the cut, the
// recording is unreadable from the torn event on.
TEST(RecordingTailTest, ATornLastEventIsCutSoThatWhatIsAppendedReads) {
  const std::vector<char> source = Bytes(ThreeEvents("source.log"));
  for (size_t torn : {1u, 27u, 28u, 40u, 73u}) {  // the first event is 74 bytes
    const std::string path = ThreeEvents("torn.log");
    const auto whole = std::filesystem::file_size(path);
    Append(path, source, torn);  // the first event's first bytes again: a write cut short
    const RecordingTail tail = CutToLastWholeEvent(path);
    EXPECT_EQ(tail.whole_events, 3) << torn;
    EXPECT_EQ(tail.whole_end, whole) << torn;
    EXPECT_EQ(tail.file_size, whole + torn) << torn;
    EXPECT_EQ(std::filesystem::file_size(path), whole) << torn;
    Append(path, source, source.size());  // the restarted logger's events
    EXPECT_EQ(Channels(path).size(), 6u) << torn;
  }
}

// Without the cut the appended events still read, but only because the reader skips the torn
// event to them and says so: the cut leaves nothing to skip.
TEST(RecordingTailTest, WithoutTheCutTheReaderHasToSkipTheTornEvent) {
  const std::vector<char> source = Bytes(ThreeEvents("source.log"));
  const std::string path = ThreeEvents("uncut.log");
  Append(path, source, 40);
  Append(path, source, source.size());
  {
    LogReader reader(path);
    LogEvent event;
    while (reader.Next(&event)) {
    }
    EXPECT_EQ(reader.skips().size(), 1u);
  }
  const std::string cut = ThreeEvents("cut.log");
  Append(cut, source, 40);
  CutToLastWholeEvent(cut);
  Append(cut, source, source.size());
  LogReader reader(cut);
  LogEvent event;
  int events = 0;
  while (reader.Next(&event)) ++events;
  EXPECT_EQ(events, 6);
  EXPECT_TRUE(reader.skips().empty());
}

// Damage before the end is not a torn tail: the reader skips it where it reads, and the cut
// takes nothing but a torn tail, so no whole event after the damage is lost.
TEST(RecordingTailTest, DamageBeforeTheEndIsNotCut) {
  const std::string path = ThreeEvents("corrupt.log");
  std::vector<char> bytes = Bytes(path);
  bytes[0] = 0;  // the first event's sync word
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  const RecordingTail tail = CutToLastWholeEvent(path);
  EXPECT_EQ(tail.whole_end, bytes.size());
  EXPECT_EQ(std::filesystem::file_size(path), bytes.size());
}

TEST(RecordingTailTest, AMissingFileIsAnInputError) {
  EXPECT_THROW(FindLastWholeEvent(testing::TempDir() + "missing.log"), InputError);
}

}  // namespace
}  // namespace calib
