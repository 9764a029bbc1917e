#include "calib/calibrate/heldout.h"

#include <algorithm>
#include <cmath>

namespace calib {
namespace {

// Chains one window's steps; Close() adds the window to `out`.
class WindowChain {
 public:
  explicit WindowChain(OdometryError* out) : out_(out) {}
  bool open() const { return open_; }
  double distance() const { return distance_; }
  int64_t start() const { return start_; }
  int64_t end() const { return end_; }
  void Add(const OdometryStep& step) {
    if (!open_) {
      measured_ = predicted_ = Pose2{};
      distance_ = 0.0;
      start_ = step.utime_start;
      open_ = true;
    }
    const Pose2& z = step.measured;
    measured_ = Compose(measured_, z);
    predicted_ = Compose(predicted_, Pose2{z.x - step.error[0], z.y - step.error[1], z.theta - step.error[2]});
    distance_ += std::hypot(z.x, z.y);
    end_ = step.utime_end;
  }
  void Close(bool keep) {
    if (open_ && keep) {
      const Pose2 d = Between(predicted_, measured_);
      out_->per_window.push_back({start_, end_, distance_, std::hypot(d.x, d.y), d.theta});
    }
    open_ = false;
  }

 private:
  OdometryError* out_;
  Pose2 measured_, predicted_;
  int64_t start_ = 0, end_ = 0;
  double distance_ = 0.0;
  bool open_ = false;
};

void Summarize(OdometryError* out) {
  double sum_t2 = 0, sum_h2 = 0, sum_t = 0;
  out->windows = static_cast<int>(out->per_window.size());
  out->distance_m = 0.0;
  for (const WindowError& w : out->per_window) {
    sum_t2 += w.translation_m * w.translation_m;
    sum_t += w.translation_m;
    sum_h2 += w.heading_rad * w.heading_rad;
    out->distance_m += w.distance_m;
  }
  if (out->windows > 0) {
    out->rms_translation_m = std::sqrt(sum_t2 / out->windows);
    out->rms_heading_rad = std::sqrt(sum_h2 / out->windows);
    out->error_per_metre = out->distance_m > 0 ? sum_t / out->distance_m : 0.0;
  }
}


double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5))];
}

}  // namespace

OdometryError OdometryErrorOverWindows(const std::vector<OdometryStep>& steps, double window_s,
                                       bool keep_partial) {
  OdometryError out;
  WindowChain chain(&out);
  for (const OdometryStep& step : steps) {
    if (chain.open() && step.utime_start != chain.end()) chain.Close(keep_partial);  // a gap
    chain.Add(step);
    if ((chain.end() - chain.start()) * 1e-6 >= window_s) chain.Close(true);
  }
  chain.Close(keep_partial);
  Summarize(&out);
  return out;
}

OdometryError OdometryErrorOverPath(const std::vector<OdometryStep>& steps, double window_m) {
  OdometryError out;
  WindowChain chain(&out);
  for (const OdometryStep& step : steps) {
    if (chain.open() && step.utime_start != chain.end()) chain.Close(chain.distance() >= 0.5 * window_m);
    chain.Add(step);
    if (chain.distance() >= window_m) chain.Close(true);
  }
  chain.Close(chain.distance() >= 0.5 * window_m);
  Summarize(&out);
  return out;
}

double PathWindowLength(const std::vector<OdometryStep>& steps, int min_windows) {
  double path = 0.0, longest_step = 0.0;
  for (const OdometryStep& s : steps) {
    const double d = std::hypot(s.measured.x, s.measured.y);
    path += d;
    longest_step = std::max(longest_step, d);
  }
  // Short of the count, the most windows no shorter than the longest step: shorter ones would
  // win only by making a window of a step where the robot barely moved, and every window would
  // then hold far more path than the length says.
  double best = path;
  int best_count = 0;
  const auto most = [&](double length, int count) {
    if (length >= longest_step && count > best_count) best = length, best_count = count;
  };
  for (double length = path; length > 1e-4 * path; length *= 0.95) {
    const int count = OdometryErrorOverPath(steps, length).windows;
    if (count >= min_windows) return length;
    most(length, count);
  }
  most(longest_step, OdometryErrorOverPath(steps, longest_step).windows);
  return best;
}

PairedComparison ComparePaired(const OdometryError& first, const OdometryError& second) {
  std::vector<double> a, b;
  for (const WindowError& w : first.per_window) a.push_back(w.translation_m);
  for (const WindowError& w : second.per_window) b.push_back(w.translation_m);
  return ComparePaired(a, b);
}

// Fit half against held-out half in the regressor that separates the drive parameters: the
// steering angle of a steered drive, the share of turning in the wheels' rotation (0 straight,
// ±1 in place) of a differential drive.
MotionCoverage CompareMotion(DriveType drive, const WheelTrack& wheels,
                             const std::vector<const SensorMotion*>& motions, std::size_t num_fit) {
  MotionCoverage c;
  const bool steered = drive != DriveType::kDifferential;
  c.regressor = steered ? "steer" : "turn_share";
  std::vector<double> fit, heldout;
  std::vector<const SensorMotion*> heldout_motions;
  for (std::size_t k = 0; k < motions.size(); ++k) {
    const SensorMotion& m = *motions[k];
    const bool held_out = k >= num_fit;
    const double t0 = m.utime_start, t1 = m.utime_end;
    double x;
    if (steered) {
      x = wheels.At(0.5 * (t0 + t1)).steer[0];
    } else {
      const WheelSample a = wheels.At(t0), b = wheels.At(t1);
      const double l = b.position[0] - a.position[0], r = b.position[1] - a.position[1];
      if (std::abs(l) + std::abs(r) < 1e-9) continue;  // standing still: no motion to compare
      x = (r - l) / (std::abs(l) + std::abs(r));
    }
    (held_out ? heldout : fit).push_back(x);
    if (held_out) heldout_motions.push_back(&m);
  }
  c.fit_low = Percentile(fit, 0.01);
  c.fit_high = Percentile(fit, 0.99);
  c.heldout_low = Percentile(heldout, 0.01);
  c.heldout_high = Percentile(heldout, 0.99);
  // A margin of 2 % of the range, so that one count of a coarse encoder past it is not news.
  const double margin = 0.02 * (c.fit_high - c.fit_low);
  int outside = 0;
  for (std::size_t k = 0; k < heldout.size(); ++k) {
    if (heldout[k] >= c.fit_low - margin && heldout[k] <= c.fit_high + margin) continue;
    ++outside;
    c.outside_spans.emplace_back(heldout_motions[k]->utime_start, heldout_motions[k]->utime_end);
  }
  c.heldout_outside = heldout.empty() ? 0.0 : double(outside) / heldout.size();
  return c;
}

HeldoutComparison CompareHeldout(const std::vector<OdometryStep>& nominal,
                                 const std::vector<OdometryStep>& calibrated,
                                 const MotionCoverage& coverage, int min_windows) {
  HeldoutComparison h;
  h.window_m = PathWindowLength(nominal, min_windows);
  h.nominal = OdometryErrorOverPath(nominal, h.window_m);
  h.calibrated = OdometryErrorOverPath(calibrated, h.window_m);
  h.paired = ComparePaired(h.nominal, h.calibrated);
  h.coverage = coverage;
  OdometryError inside[2];
  for (std::size_t w = 0; w < h.nominal.per_window.size(); ++w) {
    const WindowError& a = h.nominal.per_window[w];
    const bool extrapolated = std::any_of(
        h.coverage.outside_spans.begin(), h.coverage.outside_spans.end(),
        [&](const auto& span) { return span.first < a.utime_end && span.second > a.utime_start; });
    if (extrapolated) continue;
    inside[0].per_window.push_back(a);
    inside[1].per_window.push_back(h.calibrated.per_window[w]);
  }
  h.paired_within_fit_range = ComparePaired(inside[0], inside[1]);
  return h;
}

}  // namespace calib
