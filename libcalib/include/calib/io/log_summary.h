#pragma once
// What a recording holds, per channel: message count, time span and rate (from
// the messages' own utime), and whether the messages decode as the types of
// spec/messages.md and arrive in time order.

#include <cstdint>
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "calib/io/recording.h"

namespace calib {

struct ChannelSummary {
  std::string type;              // message type the channel carries, "" if unknown
  int64_t count = 0;
  int64_t first_utime = 0, last_utime = 0;  // message utime (robot clock), us
  double rate_hz = 0.0;          // (count - 1) / span, 0 for fewer than two messages
  int64_t out_of_order = 0;      // messages whose utime is below their predecessor's
  int64_t duplicated = 0;        // messages whose utime equals their predecessor's
};

struct LogSummary {
  std::map<std::string, ChannelSummary> channels;
  int64_t events = 0;
  std::vector<LogSkip> skipped;  // stretches the reader skipped (io/recording.h: torn events)
};

// A message's type and robot-clock utime, for the channels of spec/messages.md and
// the project's channels whose message has a `utime` field.
struct ChannelStamp {
  const char* type = "";
  bool decoded = false;  // false: the bytes are not a valid message of `type`, and
  std::string why;       // what is wrong with them
  int64_t utime = 0;
};
// nullopt for a channel not in that list (its message type is not known).
std::optional<ChannelStamp> StampOf(const std::string& channel, const uint8_t* data, size_t size);

// Reads the whole log. Throws InputError (file, event, problem) for a corrupt
// or truncated log, or a message on a known channel that does not decode.
LogSummary SummarizeLog(const std::string& path);

// The robot-clock utime of the recording's first message: the smallest first_utime over the
// channels with messages (the time origin of the human reports); 0 when there is none.
int64_t RecordingStartUtime(const LogSummary& summary);

}  // namespace calib
