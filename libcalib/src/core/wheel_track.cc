#include "calib/core/wheel_track.h"

#include <algorithm>
#include <cmath>

namespace calib {

bool WheelTrack::Append(const WheelSample& sample) {
  if (!samples_.empty() && sample.utime <= samples_.back().utime) return false;
  samples_.push_back(sample);
  return true;
}

bool WheelTrack::Covers(double t0, double t1) const {
  return !samples_.empty() && t0 >= double(first_utime()) && t1 <= double(last_utime());
}

namespace {

// Index of the last sample at or before t (0 if t precedes the track).
std::size_t SampleBefore(const std::vector<WheelSample>& samples, double t) {
  const auto after = std::upper_bound(samples.begin(), samples.end(), t,
                                      [](double u, const WheelSample& s) { return u < s.utime; });
  return after == samples.begin() ? 0 : std::size_t(after - samples.begin()) - 1;
}

WheelSample Lerp(const WheelSample& a, const WheelSample& b, double t) {
  const double s = (t - double(a.utime)) / double(b.utime - a.utime);
  WheelSample out;
  out.utime = static_cast<int64_t>(std::llround(t));
  for (std::size_t i = 0; i < a.position.size(); ++i) {
    out.position.push_back(a.position[i] + s * (b.position[i] - a.position[i]));
    out.steer.push_back(a.steer[i] + s * (b.steer[i] - a.steer[i]));
  }
  return out;
}

WheelIncrement Step(const WheelSample& a, const WheelSample& b) {
  WheelIncrement inc;
  for (std::size_t i = 0; i < a.position.size(); ++i) {
    inc.rotation.push_back(b.position[i] - a.position[i]);
    inc.steer_start.push_back(a.steer[i]);
    inc.steer_end.push_back(b.steer[i]);
  }
  return inc;
}

}  // namespace

WheelSample WheelTrack::At(double utime) const {
  if (utime <= double(first_utime())) return samples_.front();
  if (utime >= double(last_utime())) return samples_.back();
  const std::size_t i = SampleBefore(samples_, utime);
  return Lerp(samples_[i], samples_[i + 1], utime);
}

std::vector<WheelIncrement> WheelTrack::Increments(double t0, double t1) const {
  std::vector<WheelIncrement> steps;
  if (samples_.empty() || t1 <= t0) return steps;
  WheelSample previous = At(t0);
  for (std::size_t i = SampleBefore(samples_, t0) + 1;
       i < samples_.size() && double(samples_[i].utime) < t1; ++i) {
    if (double(samples_[i].utime) <= t0) continue;
    steps.push_back(Step(previous, samples_[i]));
    previous = samples_[i];
  }
  steps.push_back(Step(previous, At(t1)));
  return steps;
}

Pose2 WheelTrack::Odometry(const DriveModel& model, double t0, double t1) const {
  Pose2 pose;
  for (const WheelIncrement& inc : Increments(t0, t1)) pose = Compose(pose, model.Integrate(inc));
  return pose;
}

}  // namespace calib
