#pragma once
// Catching up after a (re)start in a running process group. A process that
// starts late, or is restarted after a crash, has missed what was published
// before it subscribed. It recovers it from the group's recording, which
// lcm-logger is still writing: it subscribes first (live messages are held
// back), reads the recording's complete events, and once the recording
// reaches the first message received live on every channel, delivers the held
// messages. Every message passes a StampFilter, so each is delivered once, in
// stamp order per channel, whether it came from the recording, live, or both.
//
// The stamp of a message is its leading int64 field (utime, or utime_start of
// scan_match_t): every agvcal message begins with its stamp, and a channel's
// stamps increase strictly (LeadingStamp reads it without decoding).

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace calib {

// The first int64 field of an lcm-gen encoded message (after the 8-byte type
// fingerprint); nothing if the message is shorter than 16 bytes.
std::optional<int64_t> LeadingStamp(const uint8_t* data, size_t size);

// Passes a message only if its stamp is newer than the last passed on its channel. A stamp far
// ahead of its channel's usual spacing (StampGateOptions: a flipped bit) is passed but does not
// count as the last until the next message shows the gap real (it comes later still); else
// the messages after it would all be taken for ones already passed. What to do with the lone
// far stamp is the consumer's gate's to decide (core/stamp_gate.h), as over a recording.
class StampFilter {
 public:
  bool Accept(const std::string& channel, int64_t stamp);
  int64_t rejected() const { return rejected_; }

 private:
  struct Channel {
    std::optional<int64_t> last;   // the newest stamp passed that counts
    std::optional<int64_t> ahead;  // a stamp passed far ahead of `last`, not yet confirmed
    std::deque<double> intervals;  // s, between the last few that count
  };
  std::map<std::string, Channel> channels_;
  int64_t rejected_ = 0;
};

// Decides when the recording has caught up with the live messages: for every
// channel, the recording holds a message at least as new as the first one
// received live; a channel silent live counts as caught up once `quiet_us`
// have passed since the start (nothing more of it can be missing).
class CatchUpTracker {
 public:
  CatchUpTracker(std::vector<std::string> channels, int64_t quiet_us);
  void Live(const std::string& channel, int64_t stamp);
  void Recorded(const std::string& channel, int64_t stamp);
  // `elapsed_us`: time since the catch-up started (wall clock).
  bool Complete(int64_t elapsed_us) const;
  // Channels not yet caught up, for messages ("WHEELS, SCAN_MATCH").
  std::string Pending(int64_t elapsed_us) const;

 private:
  bool ChannelDone(const std::string& channel, int64_t elapsed_us) const;
  std::vector<std::string> channels_;
  int64_t quiet_us_;
  std::map<std::string, int64_t> first_live_, last_recorded_;
};

}  // namespace calib
