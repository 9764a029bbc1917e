#include "calib/devices/device_clock.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace calib {

int64_t DeviceClock::Add(int64_t device_us, int64_t host_arrival_us) {
  if (!points_.empty()) {
    const int64_t last = points_.back().device;
    if (device_us < last || double(device_us - last) > options_.max_gap_s * 1e6) {
      points_.clear();
      ++restarts_;
    }
  }
  if (points_.empty()) {
    origin_device_ = device_us;
    origin_host_ = host_arrival_us;
  }
  points_.push_back({device_us, host_arrival_us});
  while (double(points_.back().device - points_.front().device) > options_.window_s * 1e6)
    points_.pop_front();
  Fit();
  return ToHost(device_us);
}

int64_t DeviceClock::ToHost(int64_t device_us) const {
  return origin_host_ + std::llround(offset_ + rate_ * double(device_us - origin_device_));
}

void DeviceClock::Fit() {
  struct P {
    double x, y;
  };
  // Lower convex hull (monotone chain; device times never decrease in the window).
  std::vector<P> hull;
  double sum_x = 0.0;
  for (const Point& p : points_) {
    const P q{double(p.device - origin_device_), double(p.host - origin_host_)};
    sum_x += q.x;
    if (!hull.empty() && hull.back().x == q.x) {
      if (q.y >= hull.back().y) continue;
      hull.pop_back();
    }
    while (hull.size() >= 2) {
      const P& a = hull[hull.size() - 2];
      const P& b = hull.back();
      // Drop b unless a -> b -> q turns left (b strictly below the chord a-q).
      if ((b.x - a.x) * (q.y - a.y) - (b.y - a.y) * (q.x - a.x) > 0.0) break;
      hull.pop_back();
    }
    hull.push_back(q);
  }
  const double mean_x = sum_x / double(points_.size());
  const double span_us = double(points_.back().device - points_.front().device);
  const double max_drift = options_.max_drift_ppm * 1e-6;
  double rate = 1.0;
  bool fitted = false;
  if (hull.size() >= 2 && span_us >= options_.min_span_s * 1e6) {
    std::size_t j = 0;
    while (j + 2 < hull.size() && hull[j + 1].x < mean_x) ++j;
    const double slope = (hull[j + 1].y - hull[j].y) / (hull[j + 1].x - hull[j].x);
    if (std::abs(slope - 1.0) <= max_drift) {
      rate = slope;
      offset_ = hull[j].y - slope * hull[j].x;
      fitted = true;
    } else {
      rate = std::clamp(slope, 1.0 - max_drift, 1.0 + max_drift);
    }
  }
  if (!fitted) {
    // The highest line of this rate below every arrival.
    double offset = INFINITY;
    for (const P& p : hull) offset = std::min(offset, p.y - rate * p.x);
    offset_ = offset;
  }
  rate_ = rate;
}

int64_t CounterUnwrapper::Unwrap(uint64_t raw) {
  const int64_t value = static_cast<int64_t>(raw);
  if (!any_) {
    any_ = true;
    last_ = value;
    return last_;
  }
  if (bits_ >= 64) return last_ = value;
  const uint64_t modulus = uint64_t(1) << bits_;
  const uint64_t half = modulus >> 1;
  uint64_t delta = (static_cast<uint64_t>(value) - static_cast<uint64_t>(last_)) & (modulus - 1);
  const int64_t step = delta >= half ? static_cast<int64_t>(delta) - static_cast<int64_t>(modulus)
                                     : static_cast<int64_t>(delta);
  last_ += step;
  return last_;
}

}  // namespace calib
