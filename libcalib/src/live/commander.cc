#include "calib/live/commander.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/units.h"
#include "live/segment_motion.h"

namespace calib {
namespace {

enum class PhaseKind { kHold, kSteer, kDrive };

struct Phase {
  PhaseKind kind = PhaseKind::kHold;
  int segment = 0;
  double duration = 0.0;                // s
  std::vector<double> steer_from;       // true angles; a hold keeps steer_from
  std::vector<double> steer_to;
  int motion = -1;                      // kDrive: index into motions
  Profile profile;                      // kDrive
};

}  // namespace

struct Commander::Impl {
  CommandedWheels wheels;
  std::vector<Motion> motions;              // one per segment
  std::vector<Phase> phases;
  double nominal_duration = 0.0;
  double steer_rate = 1.0;                  // rad/s used for steering ramps
  double settle_s = 0.5;

  // Execution state.
  bool started = false;
  int64_t t0 = 0;
  int64_t last_utime = 0;
  size_t index = 0;                         // current phase
  double phase_start = 0.0;                 // s since t0
  bool interrupted = false;
  double interrupt_time = 0.0;

  bool steered() const { return wheels.drive != DriveType::kDifferential; }
  bool finished() const { return index >= phases.size(); }

  // Construction (the constructor's last step, defined next to it).
  void PlanPhases(std::vector<double> steer, double start_delay_s,
                  const std::vector<TrajectorySegment>& segments);

  double SteerDuration(const std::vector<double>& from, const std::vector<double>& to) const {
    double largest = 0.0;
    for (size_t i = 0; i < from.size(); ++i) largest = std::max(largest, std::abs(to[i] - from[i]));
    return largest / steer_rate;
  }

  std::vector<double> SteerAt(const Phase& p, double tau) const {
    if (p.kind != PhaseKind::kSteer) return p.steer_from;
    if (p.duration <= 0.0) return p.steer_to;
    const double s = std::clamp(tau / p.duration, 0.0, 1.0);
    std::vector<double> out(p.steer_from.size());
    for (size_t i = 0; i < out.size(); ++i)
      out[i] = p.steer_from[i] + s * (p.steer_to[i] - p.steer_from[i]);
    return out;
  }

  void AdvanceTo(double now) {
    while (index < phases.size() && now >= phase_start + phases[index].duration) {
      phase_start += phases[index].duration;
      ++index;
    }
  }

  // Continues after an interruption at interrupt_time, from rest, at `now`.
  void Resume(double now) {
    interrupted = false;
    AdvanceTo(interrupt_time);
    if (finished()) return;
    Phase& p = phases[index];
    const double tau = interrupt_time - phase_start;
    switch (p.kind) {
      case PhaseKind::kHold:
        phase_start += now - interrupt_time;  // the remaining standstill is kept
        break;
      case PhaseKind::kSteer: {
        p.steer_from = SteerAt(p, tau);
        p.duration = SteerDuration(p.steer_from, p.steer_to);
        phase_start = now;
        break;
      }
      case PhaseKind::kDrive: {
        const Motion& m = motions[p.motion];
        const double remaining = p.profile.length - p.profile.Progress(tau);
        Phase settle;
        settle.kind = PhaseKind::kHold;
        settle.segment = p.segment;
        settle.duration = settle_s;
        settle.steer_from = m.steer;
        if (remaining > 1e-4) {
          p.profile = Profile::Make(remaining, m.peak, m.accel);
          p.duration = p.profile.duration();
          phases.insert(phases.begin() + index, settle);
        } else {
          p = settle;
        }
        phase_start = now;
        break;
      }
    }
  }

  DriveCommand CommandAt(double now) const {
    DriveCommand cmd;
    if (finished()) {
      cmd.mode = DriveMode::kStop;
      return cmd;
    }
    const Phase& p = phases[index];
    const double tau = now - phase_start;
    double rate = 0.0;
    std::vector<double> steer;
    const Motion* m = nullptr;
    if (p.kind == PhaseKind::kDrive) {
      m = &motions[p.motion];
      rate = p.profile.Rate(tau);
      steer = m->steer;
    } else {
      steer = SteerAt(p, tau);
    }
    if (!steered()) {
      cmd.mode = DriveMode::kTwist;
      if (m) cmd.twist = {rate * m->xi.vx, rate * m->xi.vy, rate * m->xi.omega};
      return cmd;
    }
    cmd.mode = DriveMode::kWheels;
    const size_t n = wheels.offsets.size();
    cmd.wheels.speed.assign(n, 0.0);
    cmd.wheels.steer.assign(n, 0.0);
    for (size_t i = 0; i < n; ++i) {
      if (m) cmd.wheels.speed[i] = rate * m->wheel_speed[i];
      cmd.wheels.steer[i] = steer[i] + wheels.offsets[i];
    }
    return cmd;
  }
};

namespace {

std::string TrajectoryOrigin(const Trajectory& t) { return "trajectory '" + t.name + "'"; }
std::string SegmentPlace(size_t i, const TrajectorySegment& s) {
  return "segment " + std::to_string(i + 1) + " (" + s.description + ")";
}

}  // namespace

// ---------------------------------------------------------------------------------------------

// The phase plan: start delay, then per segment steering ramp and settle (when the
// steering changes), drive, pause; finally the steering back to zero. `steer`: the
// steering at the start.
void Commander::Impl::PlanPhases(std::vector<double> steer, double start_delay_s,
                                 const std::vector<TrajectorySegment>& segments) {
  auto hold = [&](int segment, double duration) {
    Phase p;
    p.kind = PhaseKind::kHold;
    p.segment = segment;
    p.duration = duration;
    p.steer_from = steer;
    phases.push_back(p);
  };
  // Turns the wheels to `target` at the steering-rate limit, then lets them settle.
  auto turn_to = [&](int segment, const std::vector<double>& target, double settle) {
    if (SteerDuration(steer, target) <= 0.0) return;
    Phase p;
    p.kind = PhaseKind::kSteer;
    p.segment = segment;
    p.steer_from = steer;
    p.steer_to = target;
    p.duration = SteerDuration(steer, target);
    phases.push_back(p);
    steer = target;
    if (settle > 0.0) hold(segment, settle);
  };
  hold(0, std::max(0.0, start_delay_s));
  for (size_t k = 0; k < motions.size(); ++k) {
    const Motion& m = motions[k];
    const int seg = static_cast<int>(k);
    if (steered()) turn_to(seg, m.steer, settle_s);
    Phase p;
    p.kind = PhaseKind::kDrive;
    p.segment = seg;
    p.motion = seg;
    p.steer_from = steer;
    p.profile = Profile::Make(m.length, m.peak, m.accel);
    p.duration = p.profile.duration();
    phases.push_back(p);
    hold(seg, segments[k].pause_s);
  }
  if (steered()) {
    const int last = std::max(0, static_cast<int>(motions.size()) - 1);
    turn_to(last, std::vector<double>(WheelRoles(wheels.drive).size(), 0.0), 0.0 /* no settle before the stop */);
  }
  for (const Phase& p : phases) nominal_duration += p.duration;
}

Commander::Commander(const RobotDescription& robot, Trajectory trajectory, CommanderOptions options)
    : robot_(robot), trajectory_(std::move(trajectory)), options_(std::move(options)),
      impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  const Limits& lim = robot_.limits;
  const std::string origin = TrajectoryOrigin(trajectory_);
  const size_t n = WheelRoles(robot_.drive).size();
  const auto model = MakeDriveModel(robot_);
  if (!(lim.max_speed > 0 && lim.max_omega > 0 && lim.max_accel > 0 && lim.max_steer > 0 &&
        lim.max_steer_rate > 0)) {
    throw InputError(robot_.source_file, "limits", "every limit must be positive");
  }
  s.steer_rate = lim.max_steer_rate * (1.0 - kLimitMargin);
  s.settle_s = std::max(0.0, options_.steer_settle_s);

  // Reference point and wheel contact points (robot frame).
  s.wheels = CommandedWheelsOf(robot_);

  for (size_t k = 0; k < trajectory_.segments.size(); ++k) {
    const TrajectorySegment& seg = trajectory_.segments[k];
    s.motions.push_back(SegmentMotion(seg, s.wheels, *model, lim, origin, SegmentPlace(k, seg)));
  }

  // The steering the wheels start from, then the phase plan.
  std::vector<double> steer(n, 0.0);
  if (s.steered() && !options_.initial_steer.empty()) {
    if (options_.initial_steer.size() != n) {
      throw InputError(origin, "initial steering", "needs one angle per wheel role");
    }
    for (size_t i = 0; i < n; ++i) steer[i] = options_.initial_steer[i];
  }
  s.PlanPhases(steer, options_.start_delay_s, trajectory_.segments);
}

Commander::~Commander() = default;
Commander::Commander(const Commander& other)
    : robot_(other.robot_), trajectory_(other.trajectory_), options_(other.options_),
      impl_(std::make_unique<Impl>(*other.impl_)) {}
Commander& Commander::operator=(const Commander& other) {
  if (this != &other) {
    robot_ = other.robot_;
    trajectory_ = other.trajectory_;
    options_ = other.options_;
    impl_ = std::make_unique<Impl>(*other.impl_);
  }
  return *this;
}
Commander::Commander(Commander&&) noexcept = default;
Commander& Commander::operator=(Commander&&) noexcept = default;

DriveCommand Commander::Step(int64_t utime) {
  Impl& s = *impl_;
  if (!s.started) {
    s.started = true;
    s.t0 = utime;
    s.last_utime = utime;
  }
  utime = std::max(utime, s.last_utime);
  s.last_utime = utime;
  const double now = static_cast<double>(utime - s.t0) * 1e-6;
  if (s.interrupted) s.Resume(now);
  s.AdvanceTo(now);
  DriveCommand cmd = s.CommandAt(now);
  cmd.utime = utime;
  cmd.timeout_s = options_.command_timeout_s;
  return cmd;
}

void Commander::Interrupt(int64_t utime) {
  Impl& s = *impl_;
  if (!s.started || s.interrupted || s.finished()) return;
  utime = std::max(utime, s.last_utime);
  s.interrupted = true;
  s.interrupt_time = static_cast<double>(utime - s.t0) * 1e-6;
}

CommanderStatus Commander::status() const {
  const Impl& s = *impl_;
  CommanderStatus st;
  st.num_segments = static_cast<int>(trajectory_.segments.size());
  if (s.finished()) {
    st.state = CommanderState::kFinished;
    st.segment = std::max(0, st.num_segments - 1);
    st.segment_description = "finished";
    return st;
  }
  st.state = CommanderState::kRunning;
  st.segment = s.phases[s.index].segment;
  if (!s.started || (s.index == 0 && s.phases[0].kind == PhaseKind::kHold)) {
    st.segment_description = "start: standstill";
  } else if (st.segment < st.num_segments) {
    st.segment_description = trajectory_.segments[st.segment].description;
  }
  return st;
}

double Commander::nominal_duration_s() const { return impl_->nominal_duration; }

}  // namespace calib
