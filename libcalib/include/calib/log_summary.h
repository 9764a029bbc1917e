#pragma once
// What a recording holds, per channel: message count, time span and rate (from
// the messages' own utime), and whether the messages decode as the types of
// spec/messages.md and arrive in time order.

#include <cstdint>
#include <map>
#include <string>

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
};

// Reads the whole log. Throws InputError (file, event, problem) for a corrupt
// or truncated log, or a message on a known channel that does not decode.
LogSummary SummarizeLog(const std::string& path);

}  // namespace calib
