// Catching up after a restart: the stamp of every agvcal message read without
// decoding, duplicates dropped, the end of the catch-up decided, and a log
// still being written read up to its last complete event.
#include "calib/live/catch_up.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "agvcal/laser_scan_t.hpp"
#include "agvcal/pose2d_t.hpp"
#include "agvcal/scan_match_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/core/errors.h"
#include "calib/io/messages.h"
#include "calib/io/recording.h"

namespace calib {
namespace {

template <typename Message>
std::optional<int64_t> StampOf(const Message& m) {
  const std::vector<uint8_t> bytes = Encode(m);
  return LeadingStamp(bytes.data(), bytes.size());
}

TEST(CatchUpTest, LeadingStampOfEveryInputType) {
  agvcal::wheel_state_t w{};
  w.utime = 1700000000123456;
  EXPECT_EQ(StampOf(w), w.utime);
  agvcal::scan_match_t s{};
  s.utime_start = 1700000000200000;
  s.utime_end = 1700000000250000;
  EXPECT_EQ(StampOf(s), s.utime_start);
  agvcal::pose2d_t p{};
  p.utime = -5;  // signed
  EXPECT_EQ(StampOf(p), -5);
  agvcal::laser_scan_t l{};
  l.utime = 42;
  EXPECT_EQ(StampOf(l), 42);
  const uint8_t short_message[15] = {};
  EXPECT_FALSE(LeadingStamp(short_message, sizeof(short_message)).has_value());
}

TEST(CatchUpTest, StampFilterPassesEachStampOncePerChannel) {
  StampFilter f;
  EXPECT_TRUE(f.Accept("WHEELS", 10));
  EXPECT_TRUE(f.Accept("SCAN_MATCH", 10));  // channels are independent
  EXPECT_FALSE(f.Accept("WHEELS", 10));     // the same message again
  EXPECT_FALSE(f.Accept("WHEELS", 9));      // older
  EXPECT_TRUE(f.Accept("WHEELS", 11));
  EXPECT_EQ(f.rejected(), 2);
}

// A flipped bit in one stamp (+8.4 s on a 100 Hz stream) costs that message alone: the messages
// after it pass (they were all taken for ones already passed), and the far one is passed once for
// the consumer's gate to judge. A real gap (the stream goes on after it) still counts.
TEST(CatchUpTest, StampFilterLetsALoneFarStampNotHideTheMessagesAfterIt) {
  StampFilter f;
  int64_t t = 1000000;
  for (int i = 0; i < 20; ++i, t += 10000) EXPECT_TRUE(f.Accept("WHEELS", t));
  const int64_t far = t + 8388608;
  EXPECT_TRUE(f.Accept("WHEELS", far));
  EXPECT_FALSE(f.Accept("WHEELS", far));  // the same message again (recording and bus)
  for (int i = 0; i < 20; ++i, t += 10000) EXPECT_TRUE(f.Accept("WHEELS", t)) << i;
  EXPECT_FALSE(f.Accept("WHEELS", t - 10000));  // repeats still rejected
  EXPECT_EQ(f.rejected(), 2);

  StampFilter gap;  // a real pause of 3 s: the messages after it pass, older ones do not
  int64_t u = 1000000;
  for (int i = 0; i < 20; ++i, u += 10000) EXPECT_TRUE(gap.Accept("WHEELS", u));
  const int64_t resumed = u + 3000000;
  EXPECT_TRUE(gap.Accept("WHEELS", resumed));
  EXPECT_TRUE(gap.Accept("WHEELS", resumed + 10000));
  EXPECT_FALSE(gap.Accept("WHEELS", resumed));
  EXPECT_FALSE(gap.Accept("WHEELS", u));  // before the pause: already past
}

TEST(CatchUpTest, TrackerWaitsUntilTheRecordingReachesLiveData) {
  CatchUpTracker t({"WHEELS", "SCAN_MATCH"}, 2000000 /* quiet us */);
  EXPECT_FALSE(t.Complete(0));
  t.Live("WHEELS", 1000);
  t.Recorded("WHEELS", 900);
  t.Recorded("SCAN_MATCH", 500);
  EXPECT_FALSE(t.Complete(100000));  // WHEELS 900 < 1000; SCAN_MATCH silent for 0.1 s only
  EXPECT_EQ(t.Pending(100000), "WHEELS, SCAN_MATCH");
  t.Recorded("WHEELS", 1000);
  EXPECT_EQ(t.Pending(100000), "SCAN_MATCH");
  EXPECT_TRUE(t.Complete(2000000));  // SCAN_MATCH silent live for the quiet time
  t.Live("SCAN_MATCH", 700);        // ...unless it speaks: then the recording must reach it
  EXPECT_FALSE(t.Complete(3000000));
  t.Recorded("SCAN_MATCH", 700);
  t.Live("WHEELS", 5000);  // only the first live stamp counts
  EXPECT_TRUE(t.Complete(3000000));
}

TEST(CatchUpTest, ReadsALogBeingWrittenUpToItsLastCompleteEvent) {
  const std::string dir = ::testing::TempDir();
  const std::string full = dir + "/catch_up_full.log", growing = dir + "/catch_up_growing.log";
  {
    LogWriter w(full);
    for (int i = 0; i < 3; ++i) {
      agvcal::wheel_state_t m{};
      m.utime = 1000 + i;
      w.Publish("WHEELS", m.utime, Encode(m));
    }
    w.Close();
  }
  std::ifstream in(full, std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t event = bytes.size() / 3;
  auto write_prefix = [&](size_t n) {
    std::ofstream out(growing, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(n));
  };
  write_prefix(event + 10);  // one event and 10 bytes of the next header
  LogReader reader(growing);
  LogEvent e;
  ASSERT_TRUE(reader.NextComplete(&e));
  EXPECT_EQ(LeadingStamp(e.data.data(), e.data.size()), 1000);
  EXPECT_FALSE(reader.NextComplete(&e));  // incomplete header: not yet
  write_prefix(2 * event + 40);           // the second event and part of the third's body
  ASSERT_TRUE(reader.NextComplete(&e));
  EXPECT_EQ(LeadingStamp(e.data.data(), e.data.size()), 1001);
  EXPECT_FALSE(reader.NextComplete(&e));
  write_prefix(bytes.size());
  ASSERT_TRUE(reader.NextComplete(&e));
  EXPECT_EQ(LeadingStamp(e.data.data(), e.data.size()), 1002);
  EXPECT_FALSE(reader.NextComplete(&e));
  // The reader of a finished log skips a cut last event and names it (docs/bad-input.md).
  write_prefix(event + 10);
  LogReader strict(growing);
  ASSERT_TRUE(strict.Next(&e));
  EXPECT_FALSE(strict.Next(&e));
  ASSERT_EQ(strict.skips().size(), 1u);
  EXPECT_EQ(strict.skips()[0].begin, event);
  EXPECT_NE(strict.skips()[0].problem.find("cut short"), std::string::npos) << strict.skips()[0].problem;
  std::remove(full.c_str());
  std::remove(growing.c_str());
}

}  // namespace
}  // namespace calib
