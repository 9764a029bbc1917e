#include "calib/core/wheel_track.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "calib/core/units.h"

namespace calib {

bool WheelTrack::Append(const WheelSample& sample) {
  if (!utime_.empty() && sample.utime <= utime_.back()) return false;
  if (utime_.empty()) roles_ = sample.position.size();
  if (sample.position.size() != roles_ || sample.steer.size() != roles_) return false;
  // Steering readings are stored from the first one that is not +0 on (zeros before it).
  const bool steered = std::any_of(sample.steer.begin(), sample.steer.end(),
                                   [](double s) { return s != 0.0 || std::signbit(s); });
  if (steered && !steered_) {
    steer_.assign(utime_.size() * roles_, 0.0);
    steered_ = true;
  }
  utime_.push_back(sample.utime);
  position_.insert(position_.end(), sample.position.begin(), sample.position.end());
  if (steered_) steer_.insert(steer_.end(), sample.steer.begin(), sample.steer.end());
  return true;
}

void WheelTrack::DropBefore(std::size_t first) {
  first = std::min(first, utime_.size());
  utime_.erase(utime_.begin(), utime_.begin() + first);
  position_.erase(position_.begin(), position_.begin() + first * roles_);
  if (steered_) steer_.erase(steer_.begin(), steer_.begin() + first * roles_);
}

WheelSample WheelTrack::sample(std::size_t i) const {
  WheelSample out;
  out.utime = utime_[i];
  out.position.assign(position_.begin() + i * roles_, position_.begin() + (i + 1) * roles_);
  if (!steered_) {
    out.steer.assign(roles_, 0.0);
  } else {
    out.steer.assign(steer_.begin() + i * roles_, steer_.begin() + (i + 1) * roles_);
  }
  return out;
}

std::size_t WheelTrack::bytes() const {
  return utime_.capacity() * sizeof(int64_t) + (position_.capacity() + steer_.capacity()) * sizeof(double);
}

bool WheelTrack::Covers(double t0, double t1) const {
  return !utime_.empty() && t0 >= double(first_utime()) && t1 <= double(last_utime());
}

std::size_t WheelTrack::IndexBefore(double t) const {
  const auto after = std::upper_bound(utime_.begin(), utime_.end(), t, [](double u, int64_t s) { return u < s; });
  return after == utime_.begin() ? 0 : std::size_t(after - utime_.begin()) - 1;
}

namespace {

// The readings of sample i of `track` interpolated towards sample i + 1 at t.
WheelSample Lerp(const WheelTrack& track, std::size_t i, double t) {
  const double s = (t - double(track.utime(i))) / double(track.utime(i + 1) - track.utime(i));
  WheelSample out;
  out.utime = static_cast<int64_t>(std::llround(t));
  for (std::size_t r = 0; r < track.roles(); ++r) {
    out.position.push_back(track.position(i, r) + s * (track.position(i + 1, r) - track.position(i, r)));
    out.steer.push_back(track.steer(i, r) + s * (track.steer(i + 1, r) - track.steer(i, r)));
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
  if (utime <= double(first_utime())) return sample(0);
  if (utime >= double(last_utime())) return sample(size() - 1);
  return Lerp(*this, IndexBefore(utime), utime);
}

std::vector<WheelIncrement> WheelTrack::Increments(double t0, double t1) const {
  std::vector<WheelIncrement> steps;
  if (utime_.empty() || t1 <= t0) return steps;
  WheelSample previous = At(t0);
  for (std::size_t i = IndexBefore(t0) + 1; i < size() && double(utime_[i]) < t1; ++i) {
    if (double(utime_[i]) <= t0) continue;
    WheelSample next = sample(i);
    steps.push_back(Step(previous, next));
    previous = std::move(next);
  }
  steps.push_back(Step(previous, At(t1)));
  return steps;
}

Pose2 WheelTrack::Odometry(const DriveModel& model, double t0, double t1) const {
  Pose2 pose;
  for (const WheelIncrement& inc : Increments(t0, t1)) pose = Compose(pose, model.Integrate(inc));
  return pose;
}

namespace {

// The wheels' own check: a position jump no wheel can make in the time since the last sample.
StampGate<WheelSample>::Check WheelJumpCheck(const RobotDescription& robot, double speed_factor) {
  std::vector<std::string> names;
  std::vector<double> max_rate;  // rad/s per role: limits.max_speed / radius
  for (const std::string& role : WheelRoles(robot.drive)) {
    names.push_back(robot.wheel_name(role));
    max_rate.push_back(robot.limits.max_speed / robot.param(RadiusParamName(role)));
  }
  return [names, max_rate, speed_factor](const WheelSample& last, const WheelSample& next, double dt,
                                         double spacing) -> std::string {
    for (std::size_t i = 0; i < max_rate.size(); ++i) {
      const double jump = next.position[i] - last.position[i];
      const double limit = speed_factor * max_rate[i] * std::max(dt, spacing);
      if (std::abs(jump) > limit) {
        return "wheel '" + names[i] + "' position jumps " + Formatted("%+.6g rad in %.6g s", jump, dt) +
               Formatted(", more than %.6g rad (%g x limits.max_speed / radius): dropped", limit, speed_factor);
      }
    }
    return "";
  };
}

}  // namespace

WheelSampleGate::WheelSampleGate(const RobotDescription& robot, DropHandler on_drop, WheelGateOptions options)
    : StampGate<WheelSample>(std::move(on_drop), WheelJumpCheck(robot, options.speed_factor),
            StampGateOptions{options.stamp_gap_spacings, options.min_stamp_gap_s}) {}

}  // namespace calib
