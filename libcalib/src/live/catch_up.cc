#include "calib/live/catch_up.h"

#include <algorithm>
#include <utility>

#include "calib/core/stamp_gate.h"

namespace calib {

std::optional<int64_t> LeadingStamp(const uint8_t* data, size_t size) {
  if (size < 16) return std::nullopt;
  uint64_t v = 0;
  for (int i = 8; i < 16; ++i) v = (v << 8) | data[i];  // LCM encodes big-endian
  return static_cast<int64_t>(v);
}

bool StampFilter::Accept(const std::string& channel, int64_t stamp) {
  const StampGateOptions gap;
  Channel& c = channels_[channel];
  auto count = [&c, &gap](int64_t utime) {
    if (c.last) {
      c.intervals.push_back(double(utime - *c.last) * 1e-6);
      if (c.intervals.size() > gap.spacing_window) c.intervals.pop_front();
    }
    c.last = utime;
  };
  if (c.ahead) {
    if (stamp == *c.ahead) {
      ++rejected_;
      return false;
    }
    if (stamp > *c.ahead) count(*c.ahead);  // the gap was real
    c.ahead.reset();
  }
  if (c.last && stamp <= *c.last) {
    ++rejected_;
    return false;
  }
  const double spacing = MedianSpacing(c.intervals);
  if (c.last && spacing > 0.0 &&
      double(stamp - *c.last) * 1e-6 > std::max(gap.gap_spacings * spacing, gap.min_gap_s)) {
    c.ahead = stamp;
  } else {
    count(stamp);
  }
  return true;
}

CatchUpTracker::CatchUpTracker(std::vector<std::string> channels, int64_t quiet_us)
    : channels_(std::move(channels)), quiet_us_(quiet_us) {}

void CatchUpTracker::Live(const std::string& channel, int64_t stamp) {
  first_live_.emplace(channel, stamp);  // keeps the first
}

void CatchUpTracker::Recorded(const std::string& channel, int64_t stamp) {
  auto [it, added] = last_recorded_.emplace(channel, stamp);
  if (!added && stamp > it->second) it->second = stamp;
}

bool CatchUpTracker::ChannelDone(const std::string& channel, int64_t elapsed_us) const {
  const auto live = first_live_.find(channel);
  if (live == first_live_.end()) return elapsed_us >= quiet_us_;
  const auto recorded = last_recorded_.find(channel);
  return recorded != last_recorded_.end() && recorded->second >= live->second;
}

bool CatchUpTracker::Complete(int64_t elapsed_us) const {
  for (const std::string& c : channels_)
    if (!ChannelDone(c, elapsed_us)) return false;
  return true;
}

std::string CatchUpTracker::Pending(int64_t elapsed_us) const {
  std::string out;
  for (const std::string& c : channels_)
    if (!ChannelDone(c, elapsed_us)) out += (out.empty() ? "" : ", ") + c;
  return out;
}

}  // namespace calib
