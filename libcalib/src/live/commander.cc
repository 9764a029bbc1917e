#include "calib/live/commander.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/units.h"

namespace calib {
namespace {

// Commands stay this far (relative) inside the limits, so rounding never crosses them.
constexpr double kLimitMargin = 1e-9;
// Below this, a speed (m/s per unit progress rate) counts as zero.
constexpr double kTiny = 1e-9;

// Trapezoidal (or triangular) profile of a progress rate: accelerate at `accel` to `peak`,
// cruise, decelerate to rest, covering `length`.
struct Profile {
  double length = 0.0, peak = 0.0, accel = 1.0;
  double t_ramp = 0.0, t_cruise = 0.0;

  static Profile Make(double length, double peak, double accel) {
    Profile p;
    p.length = std::max(length, 0.0);
    p.accel = accel;
    p.peak = peak;
    if (p.length <= 0.0) {
      p.peak = 0.0;
      return p;
    }
    if (p.length < peak * peak / accel) p.peak = std::sqrt(p.length * accel);
    p.t_ramp = p.peak / accel;
    p.t_cruise = std::max(0.0, (p.length - p.peak * p.peak / accel) / p.peak);
    return p;
  }
  double duration() const { return 2.0 * t_ramp + t_cruise; }
  double Rate(double t) const {
    if (t <= 0.0 || t >= duration()) return 0.0;
    if (t < t_ramp) return std::min(peak, accel * t);
    if (t < t_ramp + t_cruise) return peak;
    return std::min(peak, accel * (duration() - t));
  }
  double Progress(double t) const {
    if (t <= 0.0) return 0.0;
    if (t >= duration()) return length;
    if (t < t_ramp) return 0.5 * accel * t * t;
    if (t < t_ramp + t_cruise) return 0.5 * peak * t_ramp + peak * (t - t_ramp);
    const double left = duration() - t;
    return std::max(0.0, length - 0.5 * accel * left * left);
  }
};

// The motion of one segment per unit progress rate (1 m/s of the progress point, or 1 rad/s
// of turning for an angle segment), and its limits in progress units.
struct Motion {
  Twist2 xi;                        // body twist at the reference point
  std::vector<double> wheel_speed;  // rad/s (steered drives)
  std::vector<double> steer;        // true steering angle per role (steered drives)
  double length = 0.0;              // m or rad
  double peak = 0.0;                // progress units per s
  double accel = 0.0;               // progress units per s^2
};

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
  DriveType drive = DriveType::kDifferential;
  std::vector<double> offsets;              // raw = true + offset, per role
  std::vector<std::pair<double, double>> contacts;  // wheel contact points (x, y)
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

  bool steered() const { return drive != DriveType::kDifferential; }
  bool finished() const { return index >= phases.size(); }

  // Construction (the constructor's steps, defined next to it).
  Twist2 SteeredDirection(const TrajectorySegment& seg, const Limits& lim, const std::string& origin,
                          const std::string& place) const;
  Motion SegmentMotion(const TrajectorySegment& seg, const DriveModel& model, const Limits& lim,
                       const std::pair<double, double>& progress_point, const std::string& origin,
                       const std::string& place) const;
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
    const size_t n = offsets.size();
    cmd.wheels.speed.assign(n, 0.0);
    cmd.wheels.steer.assign(n, 0.0);
    for (size_t i = 0; i < n; ++i) {
      if (m) cmd.wheels.speed[i] = rate * m->wheel_speed[i];
      cmd.wheels.steer[i] = steer[i] + offsets[i];
    }
    return cmd;
  }
};

namespace {

std::string TrajectoryOrigin(const Trajectory& t) { return "trajectory '" + t.name + "'"; }
std::string SegmentPlace(size_t i, const TrajectorySegment& s) {
  return "segment " + std::to_string(i + 1) + " (" + s.description + ")";
}

// Row of the rolling constraint of a wheel at (x, y) with true steering angle `steer`: the
// contact-point velocity (vx - w y, vy + w x) has no component across the wheel.
struct Row {
  double a, b, c;
};
Row RollingConstraint(double x, double y, double steer) {
  const double s = std::sin(steer), c = std::cos(steer);
  return {-s, c, s * y + c * x};
}

double PointSpeed(const Twist2& t, double x, double y) {
  return std::hypot(t.vx - t.omega * y, t.vy + t.omega * x);
}

}  // namespace

// ---------------------------------------------------------------------------------------------

// The direction of a steered drive's motion for the segment's steering angles (any scale,
// signed by the segment's speed): the twist both wheels' rolling constraints allow.
Twist2 Commander::Impl::SteeredDirection(const TrajectorySegment& seg, const Limits& lim,
                                         const std::string& origin, const std::string& place) const {
  const size_t n = WheelRoles(drive).size();
  if (seg.steer.size() != n) {
    throw InputError(origin, place, "needs one steering angle per wheel role");
  }
  for (double a : seg.steer) {
    if (!(std::abs(a) <= lim.max_steer)) {
      throw InputError(origin, place,
                       Formatted("steering angle %.3f rad beyond max_steer %.3f rad", a,
                           lim.max_steer));
    }
  }
  if (seg.speed == 0.0) throw InputError(origin, place, "needs a non-zero speed");
  Row r[2];
  if (drive == DriveType::kTricycle) {
    r[0] = {0.0, 1.0, 0.0};  // the rear axle does not slide sideways
    r[1] = RollingConstraint(contacts[0].first, contacts[0].second, seg.steer[0]);
  } else {
    r[0] = RollingConstraint(contacts[0].first, contacts[0].second, seg.steer[0]);
    r[1] = RollingConstraint(contacts[1].first, contacts[1].second, seg.steer[1]);
  }
  // The twist both constraints allow: their cross product.
  Twist2 dir = {r[0].b * r[1].c - r[0].c * r[1].b, r[0].c * r[1].a - r[0].a * r[1].c,
                r[0].a * r[1].b - r[0].b * r[1].a};
  const double norm = std::hypot(dir.vx, dir.vy, dir.omega);
  const double scale = std::hypot(r[0].a, r[0].b, r[0].c) * std::hypot(r[1].a, r[1].b, r[1].c);
  if (norm < 1e-3 * scale) {
    throw InputError(origin, place,
                     "the steering angles do not determine the motion (degenerate geometry)");
  }
  // Orient it so that the first steered wheel rolls forwards, then apply the sign of travel.
  const double wx = contacts[0].first, wy = contacts[0].second;
  double along = (dir.vx - dir.omega * wy) * std::cos(seg.steer[0]) +
                 (dir.vy + dir.omega * wx) * std::sin(seg.steer[0]);
  if (std::abs(along) < 1e-9 * norm && drive == DriveType::kDualSteer) {
    const double x2 = contacts[1].first, y2 = contacts[1].second;
    along = (dir.vx - dir.omega * y2) * std::cos(seg.steer[1]) +
            (dir.vy + dir.omega * x2) * std::sin(seg.steer[1]);
  }
  const double sign = (along < 0 ? -1.0 : 1.0) * (seg.speed < 0 ? -1.0 : 1.0);
  return {sign * dir.vx, sign * dir.vy, sign * dir.omega};
}

// The motion of one segment per unit progress rate, within the robot's limits.
Motion Commander::Impl::SegmentMotion(const TrajectorySegment& seg, const DriveModel& model,
                                      const Limits& lim, const std::pair<double, double>& progress_point,
                                      const std::string& origin, const std::string& place) const {
  const size_t n = WheelRoles(drive).size();
  const bool by_angle = seg.angle > 0.0;
  if (!(seg.distance >= 0.0 && seg.angle >= 0.0 && seg.pause_s >= 0.0) ||
      (!by_angle && seg.distance <= 0.0)) {
    throw InputError(origin, place, "needs a positive distance or angle and a pause >= 0");
  }
  Motion m;
  m.length = by_angle ? seg.angle : seg.distance;
  // Direction of the motion (any scale) and the requested peak of its progress rate.
  Twist2 dir;
  double request = std::abs(seg.speed);
  if (drive == DriveType::kDifferential) {
    dir = {seg.speed, 0.0, seg.omega};
    if (by_angle) request = std::abs(seg.omega);
  } else {
    dir = SteeredDirection(seg, lim, origin, place);
  }
  // Normalise to one unit of progress per second.
  const double unit = by_angle ? std::abs(dir.omega)
                               : PointSpeed(dir, progress_point.first, progress_point.second);
  if (!(unit > kTiny * std::max(1.0, std::hypot(dir.vx, dir.vy, dir.omega)))) {
    throw InputError(origin, place,
                     by_angle ? "an angle segment must turn" : "a distance segment must move");
  }
  m.xi = {dir.vx / unit, dir.vy / unit, dir.omega / unit};
  if (drive != DriveType::kDifferential && by_angle) {
    // The requested speed is of the progress point; express it as a turn rate.
    request *= std::abs(m.xi.omega) /
               std::max(kTiny, PointSpeed(m.xi, progress_point.first, progress_point.second));
  }
  // The fastest point (reference point or a wheel) bounds speed and acceleration.
  double fastest = PointSpeed(m.xi, 0.0, 0.0);
  for (const auto& c : contacts) fastest = std::max(fastest, PointSpeed(m.xi, c.first, c.second));
  double peak = request;
  if (fastest > kTiny) peak = std::min(peak, lim.max_speed / fastest);
  if (std::abs(m.xi.omega) > kTiny) peak = std::min(peak, lim.max_omega / std::abs(m.xi.omega));
  m.peak = peak * (1.0 - kLimitMargin);
  m.accel = lim.max_accel / std::max(fastest, kTiny) * (1.0 - kLimitMargin);
  if (!(m.peak > 0.0)) throw InputError(origin, place, "has no speed");
  if (drive != DriveType::kDifferential) {
    m.steer = seg.steer;
    const WheelSetpoint ws = model.Inverse(m.xi);
    m.wheel_speed = ws.speed;
    for (size_t i = 0; i < n; ++i) {
      // Inverse() may point a wheel the other way round and reverse its drive instead.
      const double diff = ws.steer[i] - offsets[i] - seg.steer[i];
      if (std::cos(diff) < 0.0) m.wheel_speed[i] = -m.wheel_speed[i];
      const double contact = PointSpeed(m.xi, contacts[i].first, contacts[i].second);
      if (contact > 1e-6 && std::abs(std::sin(diff)) > 1e-6) {
        throw std::logic_error(origin + ": " + place +
                               ": kinematic model disagrees with the steering geometry");
      }
    }
  }
  return m;
}

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
    turn_to(last, std::vector<double>(WheelRoles(drive).size(), 0.0), 0.0 /* no settle before the stop */);
  }
  for (const Phase& p : phases) nominal_duration += p.duration;
}

Commander::Commander(const RobotDescription& robot, Trajectory trajectory, CommanderOptions options)
    : robot_(robot), trajectory_(std::move(trajectory)), options_(std::move(options)),
      impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  const Limits& lim = robot_.limits;
  const std::string origin = TrajectoryOrigin(trajectory_);
  s.drive = robot_.drive;
  const size_t n = WheelRoles(s.drive).size();
  const auto model = MakeDriveModel(robot_);
  if (!(lim.max_speed > 0 && lim.max_omega > 0 && lim.max_accel > 0 && lim.max_steer > 0 &&
        lim.max_steer_rate > 0)) {
    throw InputError(robot_.source_file, "limits", "every limit must be positive");
  }
  s.steer_rate = lim.max_steer_rate * (1.0 - kLimitMargin);
  s.settle_s = std::max(0.0, options_.steer_settle_s);

  // Reference point and wheel contact points (robot frame).
  std::pair<double, double> progress_point{0.0, 0.0};
  switch (s.drive) {
    case DriveType::kDifferential: {
      const double half = 0.5 * robot_.param("track");
      s.contacts = {{0.0, half}, {0.0, -half}};
      s.offsets = {0.0, 0.0};
      break;
    }
    case DriveType::kTricycle:
      s.contacts = {{robot_.param("wheelbase"), 0.0}};
      s.offsets = {robot_.param("steer_offset")};
      break;
    case DriveType::kDualSteer:
      s.contacts = {{robot_.param("b"), 0.0}, {0.0, -robot_.param("a")}};
      s.offsets = {robot_.param("a1_steer_offset"), 0.0};
      progress_point = s.contacts[0];
      break;
  }

  for (size_t k = 0; k < trajectory_.segments.size(); ++k) {
    const TrajectorySegment& seg = trajectory_.segments[k];
    s.motions.push_back(s.SegmentMotion(seg, *model, lim, progress_point, origin, SegmentPlace(k, seg)));
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

// --- trajectories -----------------------------------------------------------------------------

namespace {

TrajectorySegment Seg(std::string description, double speed, double omega,
                      std::vector<double> steer, double distance, double angle,
                      double pause_s = 0.5) {
  TrajectorySegment s;
  s.description = std::move(description);
  s.speed = speed;
  s.omega = omega;
  s.steer = std::move(steer);
  s.distance = distance;
  s.angle = angle;
  s.pause_s = pause_s;
  return s;
}

const char* Dir(double sign) { return sign > 0 ? "forward" : "reverse"; }

// --- differential

void AddStraightDiff(std::vector<TrajectorySegment>* out, double speed, double distance) {
  out->push_back(Seg(Formatted("straight, forward %.1f m at %.2f m/s", distance, speed), speed, 0.0, {},
                     distance, 0.0));
  out->push_back(Seg(Formatted("straight, reverse %.1f m at %.2f m/s", distance, speed), -speed, 0.0, {},
                     distance, 0.0));
}

void AddUmbmark(const Limits& lim, std::vector<TrajectorySegment>* out) {
  const double side = 2.5;
  const double turn_rate = 0.6 * lim.max_omega;
  for (double sense : {1.0, -1.0}) {
    const char* name = sense > 0 ? "CCW" : "CW";
    for (int k = 1; k <= 4; ++k) {
      out->push_back(Seg(std::string("umbmark ") + name + Formatted(" side %d/4: forward %.1f m", k, side),
                         lim.max_speed, 0.0, {}, side, 0.0));
      out->push_back(Seg(std::string("umbmark ") + name + Formatted(" corner %d/4: turn %+.0f deg", k,
                                                               sense * 90.0),
                         0.0, sense * turn_rate, {}, 0.0, M_PI / 2));
    }
  }
}

void AddTurns(const Limits& lim, std::vector<TrajectorySegment>* out) {
  for (double fraction : {1.0, 0.4}) {
    const double turns = fraction >= 1.0 ? 2.0 : 1.0;
    for (double sense : {1.0, -1.0}) {
      const double rate = sense * fraction * lim.max_omega;
      out->push_back(Seg(Formatted("turn in place %+.0f turn(s) at %+.2f rad/s", sense * turns, rate), 0.0,
                         rate, {}, 0.0, turns * 2.0 * M_PI));
    }
  }
}

void AddFigure8(const Limits& lim, std::vector<TrajectorySegment>* out, double radius) {
  const double speed = std::min(lim.max_speed, lim.max_omega * radius);
  for (double first : {1.0, -1.0}) {
    for (double sense : {first, -first}) {
      out->push_back(Seg(std::string("figure-eight loop ") + (sense > 0 ? "left" : "right") +
                             Formatted(", radius %.1f m", radius),
                         speed, sense * speed / radius, {}, 0.0, 2.0 * M_PI));
    }
  }
}

// The IMU calibration (docs/imu.md): a straight run of the distance the user will measure,
// turns in place of several whole turns both ways, back along the straight; long pauses
// at rest show the gyro's bias.
void AddImuCalibration(const RobotDescription& robot, std::vector<TrajectorySegment>* out) {
  const Limits& lim = robot.limits;
  const double distance = robot.imu && robot.imu->distance ? *robot.imu->distance : 3.0;
  const double still = 10.0;
  out->push_back(Seg(Formatted("straight, forward %.2f m (measure it)", distance), lim.max_speed, 0.0, {},
                     distance, 0.0, still));
  out->push_back(Seg("turn in place +2 turns", 0.0, lim.max_omega, {}, 0.0, 4 * M_PI, still));
  out->push_back(Seg(Formatted("straight, reverse %.2f m", distance), -lim.max_speed, 0.0, {}, distance,
                     0.0, still));
  out->push_back(Seg("turn in place -2 turns", 0.0, -lim.max_omega, {}, 0.0, 4 * M_PI, still));
}

Trajectory MakeDifferential(const RobotDescription& robot, const std::string& name) {
  const Limits& lim = robot.limits;
  Trajectory t;
  t.name = name;
  auto& s = t.segments;
  if (name == "default") {
    AddUmbmark(lim, &s);
    AddTurns(lim, &s);
    AddFigure8(lim, &s, 1.2);
    AddStraightDiff(&s, 0.5 * lim.max_speed, 3.0);
  } else if (name == "umbmark") {
    AddUmbmark(lim, &s);
  } else if (name == "turns") {
    AddTurns(lim, &s);
  } else if (name == "figure8") {
    AddFigure8(lim, &s, 1.2);
  } else if (name == "demo") {
    AddStraightDiff(&s, lim.max_speed, 1.5);
    s.push_back(Seg("turn in place +90 deg", 0.0, 0.6 * lim.max_omega, {}, 0.0, M_PI / 2));
    s.push_back(Seg("turn in place -90 deg", 0.0, -0.6 * lim.max_omega, {}, 0.0, M_PI / 2));
    const double v = std::min(lim.max_speed, lim.max_omega);  // radius 1 m
    s.push_back(Seg("arc left, forward 90 deg, radius 1 m", v, v, {}, 0.0, M_PI / 2));
    s.push_back(Seg("arc left, reverse 90 deg, radius 1 m", -v, -v, {}, 0.0, M_PI / 2));
  } else if (name == "straight") {
    AddStraightDiff(&s, lim.max_speed, 3.0);
    AddStraightDiff(&s, 0.5 * lim.max_speed, 3.0);
  } else if (name == "imu") {
    AddImuCalibration(robot, &s);
  }
  return t;
}

// --- tricycle

// Steering angles of the arcs, scaled down to fit max_steer.
std::vector<double> ArcAngles(const Limits& lim, std::vector<double> angles) {
  const double largest = *std::max_element(angles.begin(), angles.end());
  const double scale = std::min(1.0, 0.95 * lim.max_steer / largest);
  for (double& a : angles) a *= scale;
  return angles;
}

void AddArcThereAndBack(std::vector<TrajectorySegment>* out, const Limits& lim, double steer,
                        double distance) {
  for (double sign : {1.0, -1.0}) {
    out->push_back(Seg(Formatted("arc, steer %+.2f rad, ", steer) + Dir(sign) + Formatted(" %.1f m", distance),
                       sign * lim.max_speed, 0.0, {steer}, distance, 0.0));
  }
}

void AddStraightSteered(std::vector<TrajectorySegment>* out, size_t roles, double speed,
                        double distance) {
  for (double sign : {1.0, -1.0}) {
    out->push_back(Seg(std::string("straight, ") + Dir(sign) +
                           Formatted(" %.1f m at %.2f m/s", distance, speed),
                       sign * speed, 0.0, std::vector<double>(roles, 0.0), distance, 0.0));
  }
}

// Normal work rather than excitation (recalibration during operation, docs/recalibration.md):
// pallet runs from a dock at the start to four racks, north-east, south-east (driving out
// forward), north-west and south-west (driving out in reverse): straight 2 m, a 90-degree
// corner, 2.5 m down the rack aisle, a stop to pick up, then the same way back, which retraces
// the way out, so `laps` rounds keep the robot on its route without any feedback.
void AddRoute(std::vector<TrajectorySegment>* out, const Limits& lim, int laps) {
  const double a = ArcAngles(lim, {0.7})[0];
  const double v = lim.max_speed;
  for (int lap = 1; lap <= laps; ++lap) {
    for (const char* rack : {"north-east", "south-east", "north-west", "south-west"}) {
      const double way = rack[6] == 'e' ? 1.0 : -1.0;              // forward out to the east
      const double side = rack[0] == 'n' ? 1.0 : -1.0;  // steering that reaches the rack, either way
      const std::string run = Formatted("lap %d, ", lap) + "rack " + rack + ": ";
      for (double dir : {way, -way}) {
        const std::string how = dir > 0 ? "forward " : "reverse ";
        std::vector<TrajectorySegment> legs{
            Seg(run + how + "2.0 m", dir * v, 0.0, {0.0}, 2.0, 0.0),
            Seg(run + how + "corner 90 deg", dir * v, 0.0, {side * a}, 0.0, M_PI / 2),
            Seg(run + how + "aisle 2.5 m", dir * v, 0.0, {0.0}, 2.5, 0.0, 2.0 /* pick-up */)};
        if (dir != way) std::reverse(legs.begin(), legs.end());
        out->insert(out->end(), legs.begin(), legs.end());
      }
    }
  }
}

Trajectory MakeTricycle(const Limits& lim, const std::string& name) {
  Trajectory t;
  t.name = name;
  auto& s = t.segments;
  if (name == "default") {
    for (double a : ArcAngles(lim, {0.2, 0.4, 0.7, 1.0})) {
      AddArcThereAndBack(&s, lim, a, 3.0);
      AddArcThereAndBack(&s, lim, -a, 3.0);
    }
    AddStraightSteered(&s, 1, lim.max_speed, 4.0);
    AddStraightSteered(&s, 1, 0.5 * lim.max_speed, 4.0);
  } else if (name == "demo") {
    const double a = ArcAngles(lim, {0.4})[0];
    AddArcThereAndBack(&s, lim, a, 1.2);
    AddArcThereAndBack(&s, lim, -a, 1.2);
    AddStraightSteered(&s, 1, lim.max_speed, 1.5);
  } else if (name == "straight") {
    AddStraightSteered(&s, 1, lim.max_speed, 3.0);
    AddStraightSteered(&s, 1, 0.5 * lim.max_speed, 3.0);
  } else if (name == "route") {
    AddRoute(&s, lim, 3);
  }
  return t;
}

// --- dual steer

// The three-segment run: a1 at +steer, straight, a1 at -steer (a2 at zero), each `leg` m of
// a1 travel, then the same back in reverse so the robot returns to its start.
void AddThreeSegment(std::vector<TrajectorySegment>* out, const Limits& lim, double steer,
                     double leg) {
  const std::vector<std::vector<double>> forward{{steer, 0.0}, {0.0, 0.0}, {-steer, 0.0}};
  const char* names[3] = {"first turn", "straight", "second turn"};
  for (int k = 0; k < 3; ++k) {
    out->push_back(Seg(Formatted("three-segment run %+.2f rad: ", steer) + names[k] +
                           Formatted(", a1 %+.2f, a2 0, forward %.1f m", forward[k][0], leg),
                       lim.max_speed, 0.0, forward[k], leg, 0.0));
  }
  for (int k = 2; k >= 0; --k) {
    out->push_back(Seg(Formatted("three-segment run %+.2f rad back: ", steer) + names[k] +
                           Formatted(", a1 %+.2f, a2 0, reverse %.1f m", forward[k][0], leg),
                       -lim.max_speed, 0.0, forward[k], leg, 0.0));
  }
}

void AddBothSteered(std::vector<TrajectorySegment>* out, const Limits& lim, const char* what,
                    double a1, double a2, double distance) {
  for (double sign : {1.0, -1.0}) {
    out->push_back(Seg(std::string(what) + Formatted(", a1 %+.2f, a2 %+.2f, ", a1, a2) + Dir(sign) +
                           Formatted(" %.1f m", distance),
                       sign * lim.max_speed, 0.0, {a1, a2}, distance, 0.0));
  }
}

Trajectory MakeDualSteer(const RobotDescription& robot, const std::string& name) {
  const Limits& lim = robot.limits;
  Trajectory t;
  t.name = name;
  auto& s = t.segments;
  const std::vector<double> angles = ArcAngles(lim, {0.5, 1.0});
  if (name == "default") {
    for (double a : angles) {
      AddThreeSegment(&s, lim, a, 1.8);
      AddThreeSegment(&s, lim, -a, 1.8);
    }
    const double c = ArcAngles(lim, {0.4})[0];
    // Crab runs: both wheels alike (a pure translation unless the wheels line up with it).
    AddBothSteered(&s, lim, "crab", c, c, 2.0);
    AddBothSteered(&s, lim, "crab", -c, -c, 2.0);
    AddBothSteered(&s, lim, "counter-steer", c, -c, 2.0);
    AddBothSteered(&s, lim, "counter-steer", -c, c, 2.0);
    AddStraightSteered(&s, 2, lim.max_speed, 4.0);
  } else if (name == "three_segment") {
    AddThreeSegment(&s, lim, angles[0], 1.8);
    AddThreeSegment(&s, lim, -angles[0], 1.8);
  } else if (name == "demo") {
    AddThreeSegment(&s, lim, angles[0], 1.0);
  } else if (name == "straight") {
    AddStraightSteered(&s, 2, lim.max_speed, 3.0);
    AddStraightSteered(&s, 2, 0.5 * lim.max_speed, 3.0);
  }
  // Drop motions the geometry cannot realise (e.g. a crab angle along the line of the wheels).
  std::vector<TrajectorySegment> kept;
  for (const auto& seg : s) {
    const double x1 = robot.param("b"), y2 = -robot.param("a");
    const Row r1 = RollingConstraint(x1, 0.0, seg.steer[0]);
    const Row r2 = RollingConstraint(0.0, y2, seg.steer[1]);
    const double cx = r1.b * r2.c - r1.c * r2.b, cy = r1.c * r2.a - r1.a * r2.c,
                 cw = r1.a * r2.b - r1.b * r2.a;
    const double scale = std::hypot(r1.a, r1.b, r1.c) * std::hypot(r2.a, r2.b, r2.c);
    if (std::hypot(cx, cy, cw) >= 0.05 * scale) kept.push_back(seg);
  }
  s = kept;
  return t;
}

}  // namespace

std::vector<std::string> TrajectoryNames(DriveType type) {
  switch (type) {
    case DriveType::kDifferential:
      return {"default", "umbmark", "turns", "figure8", "demo", "straight", "imu"};
    case DriveType::kTricycle:
      return {"default", "demo", "straight", "route"};
    case DriveType::kDualSteer:
      return {"default", "three_segment", "demo", "straight"};
  }
  return {};
}

Trajectory MakeTrajectory(const RobotDescription& robot, const std::string& name) {
  const auto names = TrajectoryNames(robot.drive);
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string known;
    for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
    throw InputError("trajectory '" + name + "'", "",
                     std::string("unknown for a ") + DriveTypeName(robot.drive) +
                         " drive; known: " + known);
  }
  switch (robot.drive) {
    case DriveType::kDifferential: return MakeDifferential(robot, name);
    case DriveType::kTricycle: return MakeTricycle(robot.limits, name);
    case DriveType::kDualSteer: return MakeDualSteer(robot, name);
  }
  throw std::logic_error("unknown drive type");
}

}  // namespace calib
