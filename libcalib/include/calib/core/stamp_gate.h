#pragma once
// Keeps a message stream's impossible stamps out of its consumers, one gate per stream (WHEELS,
// SCAN, POSE, IMU, DRIVE_CMD, CLOUD: io's Subscribe* functions apply it, live and offline):
//   - a stamp at or before the last passed one is dropped (out of order, repeated);
//   - a stamp more than `gap_spacings` usual spacings (and `min_gap_s`) after the last passed
//     one is held until the next message shows whether the gap is real (the next one comes
//     later still) or the stamp alone is wrong (the next one falls before it: the held one is
//     dropped, not every message after it);
//   - an optional check of the stream's own (a wheel that turns faster than it can) drops a
//     message that cannot be physically true.
// Clean data pass unchanged and in order; only a message after a long gap waits for its
// successor (Finish passes one still held at the end).

#include <algorithm>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "calib/core/units.h"

namespace calib {

struct StampGateOptions {
  double gap_spacings = 50.0;
  double min_gap_s = 0.5;
  std::size_t spacing_window = 15;  // intervals in the median of the usual spacing
};

// Median of the recent intervals between passed messages, s (0 while there are none).
double MedianSpacing(const std::deque<double>& intervals);

// T: any message with a `utime` (us).
template <typename T>
class StampGate {
 public:
  // `origin` names the message in a drop's message ("run.log: event 12 (SCAN)").
  using DropHandler = std::function<void(const std::string& origin, const std::string& problem)>;
  // Whether `next`, `dt_s` after the last passed message `last`, can be true, given the usual
  // spacing `spacing_s` (0 while unknown): "" if so, else the problem (the message is dropped).
  using Check = std::function<std::string(const T& last, const T& next, double dt_s, double spacing_s)>;

  explicit StampGate(DropHandler on_drop, Check check = nullptr, StampGateOptions options = {})
      : on_drop_(std::move(on_drop)), check_(std::move(check)), options_(options) {}

  // The next message in arrival order (its stamp: `item.utime`); returns those to pass on now, in order.
  std::vector<T> Add(T item, const std::string& origin) {
    const int64_t utime = item.utime;
    std::vector<T> out;
    if (held_) {
      if (utime > held_->utime) {
        Pass(std::move(held_->item), held_->utime, &out);  // the gap was real
      } else if (utime > *last_utime_) {
        Drop(held_->origin, Formatted("stamp %.6f s after the previous message's, %.6f s after the next one's: "
                                      "dropped alone",
                                      double(held_->utime - *last_utime_) * 1e-6, double(held_->utime - utime) * 1e-6));
      } else {
        Drop(origin, "stamp not after the previous message's (out of order or repeated)");
        return out;
      }
      held_.reset();
    }
    Take(std::move(item), utime, origin, &out);
    return out;
  }

  // End of data: the message still held, if any.
  std::vector<T> Finish() {
    std::vector<T> out;
    if (held_) Pass(std::move(held_->item), held_->utime, &out);
    held_.reset();
    return out;
  }

  int64_t dropped() const { return dropped_; }

 private:
  struct Held {
    T item;
    int64_t utime;
    std::string origin;
  };
  void Take(T item, int64_t utime, const std::string& origin, std::vector<T>* out) {
    if (!last_utime_) {
      Pass(std::move(item), utime, out);
      return;
    }
    const double dt = double(utime - *last_utime_) * 1e-6;
    if (dt <= 0.0) {
      Drop(origin, "stamp not after the previous message's (out of order or repeated)");
      return;
    }
    const double spacing = MedianSpacing(intervals_);
    if (check_) {
      const std::string problem = check_(*last_, item, dt, spacing);
      if (!problem.empty()) {
        Drop(origin, problem);
        return;
      }
    }
    if (spacing > 0.0 && dt > std::max(options_.gap_spacings * spacing, options_.min_gap_s)) {
      held_ = Held{std::move(item), utime, origin};
      return;
    }
    Pass(std::move(item), utime, out);
  }

  void Pass(T item, int64_t utime, std::vector<T>* out) {
    if (last_utime_) {
      intervals_.push_back(double(utime - *last_utime_) * 1e-6);
      if (intervals_.size() > options_.spacing_window) intervals_.pop_front();
    }
    last_utime_ = utime;
    if (check_) last_ = item;  // kept only for the check (a scan or a cloud is not copied otherwise)
    out->push_back(std::move(item));
  }

  void Drop(const std::string& origin, const std::string& problem) {
    ++dropped_;
    if (on_drop_) on_drop_(origin, problem);
  }

  DropHandler on_drop_;
  Check check_;
  StampGateOptions options_;
  std::optional<int64_t> last_utime_;
  std::optional<T> last_;
  std::optional<Held> held_;
  std::deque<double> intervals_;  // s, the last few between passed messages
  int64_t dropped_ = 0;
};

}  // namespace calib
