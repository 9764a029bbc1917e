// Actuation layer of the diagnosis: DRIVE_CMD setpoints against what the
// encoders report. Baseline: wheels reach the commanded speed and angle at
// once. drive_lag: the speed follows through a first-order lag; steering_rate_limit:
// the angle moves toward the command no faster than a rate. Each is fitted on
// the fit blocks and tested on the held-out blocks: a likelihood ratio with the
// samples' correlation time taken out, so overfitting cannot pass the test.

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <sstream>

#include "calib/core/kinematics.h"
#include "calib/core/statistics.h"
#include "diagnose/diagnose_internal.h"
#include "diagnose/diagnose_model.h"

namespace calib::diag {
namespace {

constexpr double kMinCommands = 20;
constexpr double kMinGain = 0.05;
constexpr int kSubsamples = 8;  // per encoder sample, for the setpoint's mean over it  // practical floor: held-out RMS at least 5 % lower

struct Series {
  std::vector<double> t;                       // s from the first sample
  std::vector<int64_t> utime;
  std::vector<std::array<double, 2>> speed_cmd, steer_cmd;  // setpoint held over [t_i, t_i+1]
  std::vector<bool> heldout;
  std::vector<int> chunk;                      // one-second chunk index
  CommandsBetween between = CommandsBetween::kHold;  // the setpoints' profile (Setpoints)
};

// Minimises f over [lo, hi]: a grid first, then golden section between the grid's best point's
// neighbours. Golden section alone assumes one minimum; a rate limit's cost is flat above every
// commanded rate, and from there the section walks to the top of the range past a limit well
// below the commanded rates. Ties go to the higher value (the null side of
// the rate limit: a limit no command reaches changes nothing).
double GridGoldenMin(const std::function<double(double)>& f, double lo, double hi) {
  constexpr int kGrid = 40;
  int best = 0;
  double best_f = INFINITY;
  for (int i = 0; i <= kGrid; ++i) {
    const double fi = f(lo + (hi - lo) * i / kGrid);
    if (fi <= best_f) best = i, best_f = fi;
  }
  const double step = (hi - lo) / kGrid;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = std::max(lo, lo + (best - 1) * step), b = std::min(hi, lo + (best + 1) * step);
  double c = b - g * (b - a), d = a + g * (b - a);
  double fc = f(c), fd = f(d);
  for (int i = 0; i < 40; ++i) {
    if (fc < fd) b = d, d = c, fd = fc, c = b - g * (b - a), fc = f(c);
    else a = c, c = d, fc = fd, d = a + g * (b - a), fd = f(d);
  }
  return 0.5 * (a + b);
}

// One actuation effect: predicts the measured signal for a parameter value.
struct Layer {
  std::string name, key, component, regressor_words;
  int wheels_used = 0;
  std::function<std::vector<std::array<double, 2>>(double)> predict;  // per sample, per wheel
  std::vector<std::array<double, 2>> measured;
  double null_param = 0;  // parameter of the baseline (no effect)
  double lo = 0, hi = 1;  // search range (in the search variable)
  bool log_search = false;
  double plausible_sigma = 0.5;
  double min_value = 0;         // below it the effect cannot be told from the data's timing
  double max_value = INFINITY;  // above it neither (the rate limit: the commands' own ramp)
  std::string bound_note;       // why, for a candidate outside [min_value, max_value]
  std::vector<double> regressor;  // per sample, for the signature
  std::vector<bool> use;          // wheels used
};

double Sse(const Layer& L, const std::vector<std::array<double, 2>>& pred, const Series& s,
           const std::function<bool(std::size_t)>& keep) {
  double sum = 0;
  for (std::size_t i = 0; i < pred.size(); ++i) {
    if (!keep(i)) continue;
    for (int w = 0; w < 2; ++w)
      if (L.use[w]) sum += std::pow(L.measured[i][w] - pred[i][w], 2);
  }
  return sum;
}

// The command period, s (what a ramping controller ramps over): the mean time between commands
// within half to one and a half times the median (stamps jitter around the period, e.g. by
// the controller's tick, so the median alone can be one jittered value; pauses are left out).
// `jitter`: how finely the stamps tell when the controller took each command, s: the RMS
// deviation of those gaps from the period, and at least half their spread (0.1 to 99.9th
// percentile: a few hiccups in thousands left out). A controller (or simulator) that acts on
// its own tick takes each command at one of its ticks, so the gaps are whole ticks, mostly one
// value and now and then the next: their RMS, small when the longer gap is rare, says little of
// the tick; their spread is the tick. Within a tick when the setpoint changes is not known: a
// ramp toward each command starts from where the previous one stood at the last tick, half a
// tick behind the continuous ramp, and would read as a drive lag of about a quarter tick.
double CommandPeriod(const std::vector<DriveCommand>& commands, double* jitter = nullptr) {
  std::vector<int64_t> gaps;
  for (std::size_t c = 1; c < commands.size(); ++c)
    if (commands[c].utime > commands[c - 1].utime) gaps.push_back(commands[c].utime - commands[c - 1].utime);
  if (jitter) *jitter = 0;
  if (gaps.empty()) return 0.05;
  std::vector<int64_t> sorted = gaps;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = double(sorted[sorted.size() / 2]);
  std::vector<double> regular;
  for (int64_t g : gaps)
    if (g >= 0.5 * median && g <= 1.5 * median) regular.push_back(double(g));
  const double mean = std::accumulate(regular.begin(), regular.end(), 0.0) / regular.size();
  if (jitter) {
    double ss = 0;
    for (double g : regular) ss += (g - mean) * (g - mean);
    std::sort(regular.begin(), regular.end());
    const std::size_t last = regular.size() - 1;  // a few hiccups in thousands left out
    const double spread = regular[last - last / 1000] - regular[last / 1000];
    *jitter = std::max(std::sqrt(ss / regular.size()), 0.5 * spread) * 1e-6;
  }
  return mean * 1e-6;
}

// The setpoint in force at robot time `t` (us) after each command, per wheel: held until the
// next command (kHold); ramped linearly from the setpoint in force when the command came to the
// new one over the command period, then held (kRamp); or interpolated linearly from each command
// to the next (kContinuous: the commands are samples of a continuously changing setpoint; across
// a pause longer than a period and a half the setpoint is held). A command lapses after its
// timeout (speed 0, steering held).
class Setpoints {
 public:
  Setpoints(const RobotDescription& robot, const Track& tr, const std::vector<DriveCommand>& commands,
            CommandsBetween between)
      : commands_(commands), between_(between), period_us_(CommandPeriod(commands) * 1e6), nw_(tr.wheels) {
    first_steer_ = {tr.steer(0, 0), tr.steer(0, 1)};
    const auto model = MakeDriveModel(robot);
    std::array<double, 2> speed{0, 0}, steer{tr.steer(0, 0), tr.steer(0, 1)};
    for (const DriveCommand& cmd : commands) {
      // What was in force when this command came (the previous one's ramp, or a lapse).
      if (!to_.empty()) {
        const Point now = At(cmd.utime, to_.size());
        speed = now.speed, steer = now.steer;
      }
      from_.push_back({speed, steer});
      Point target{{0, 0}, steer};
      if (cmd.mode != DriveMode::kStop) {
        const WheelSetpoint sp = cmd.mode == DriveMode::kTwist ? model->Inverse(cmd.twist) : cmd.wheels;
        for (int w = 0; w < nw_; ++w) {
          target.speed[w] = sp.speed.at(w);
          if (tr.steered[w] && w < int(sp.steer.size())) target.steer[w] = sp.steer[w];
        }
      }
      to_.push_back(target);
    }
  }
  struct Point {
    std::array<double, 2> speed, steer;
  };
  // At time t (us), given the commands up to (not including) index `end`.
  Point At(double t, std::size_t end) const {
    const std::size_t c = std::upper_bound(commands_.begin(), commands_.begin() + end, t,
                                           [](double v, const DriveCommand& k) { return v < double(k.utime); }) -
                          commands_.begin();
    if (c == 0) return {{0, 0}, {first_steer_[0], first_steer_[1]}};
    const DriveCommand& cmd = commands_[c - 1];
    const Point* from = &from_[c - 1];
    const Point* to = &to_[c - 1];
    if (t - cmd.utime > cmd.timeout_s * 1e6) return {{0, 0}, to->steer};
    double f = 1.0;
    if (between_ == CommandsBetween::kRamp) {
      f = std::min(1.0, (t - cmd.utime) / period_us_);
    } else if (between_ == CommandsBetween::kContinuous && c < end) {
      const double gap = double(commands_[c].utime - cmd.utime);
      if (gap <= 1.5 * period_us_) from = to, to = &to_[c], f = (t - cmd.utime) / gap;
    }
    if (f >= 1.0) return *to;
    Point p;
    for (int w = 0; w < 2; ++w) {
      p.speed[w] = from->speed[w] + f * (to->speed[w] - from->speed[w]);
      p.steer[w] = from->steer[w] + f * (to->steer[w] - from->steer[w]);
    }
    return p;
  }
  std::size_t size() const { return to_.size(); }
  // The setpoint command `c` moves toward.
  const Point& Target(std::size_t c) const { return to_[c]; }

 private:
  std::array<double, 2> first_steer_{0, 0};
  const std::vector<DriveCommand>& commands_;
  CommandsBetween between_;
  double period_us_;
  int nw_;
  std::vector<Point> from_, to_;
};

// The setpoints over the wheel samples (each its mean over [t_i, t_i+1]), and the fit /
// held-out blocks.
Series CommandSeries(const RobotDescription& robot, const Track& tr, const std::vector<DriveCommand>& commands,
                     double block_s, CommandsBetween between) {
  const std::size_t n = tr.size();
  const Setpoints setpoints(robot, tr, commands, between);
  Series s;
  s.between = between;
  s.t.resize(n);
  s.utime = tr.utimes();
  s.speed_cmd.assign(n, {0, 0});
  s.steer_cmd.assign(n, {0, 0});
  s.heldout.resize(n);
  s.chunk.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    s.t[i] = (tr.utime(i) - tr.utime(0)) * 1e-6;
    s.heldout[i] = int64_t(s.t[i] / block_s) % 2 == 1;
    s.chunk[i] = int(s.t[i]);
    // The setpoint's mean over [t_i, t_i+1] (a command rarely arrives on an encoder sample: taking
    // the value at t_i moves every step to the next sample, half an encoder period late on average).
    // The steering angle is read, not integrated: its target over the interval is the setpoint
    // just before the interval's end (where the prediction is compared with the next reading; a
    // command stamped at that reading's time acts after it).
    const double t0 = double(tr.utime(i)), t1 = i + 1 < n ? double(tr.utime(i + 1)) : t0;
    s.speed_cmd[i] = {0, 0};
    for (int k = 0; k < kSubsamples; ++k) {
      const Setpoints::Point p = setpoints.At(t0 + (k + 0.5) / kSubsamples * (t1 - t0), setpoints.size());
      for (int w = 0; w < 2; ++w) s.speed_cmd[i][w] += p.speed[w] / kSubsamples;
    }
    s.steer_cmd[i] = setpoints.At(std::max(t0, t1 - 1.0), setpoints.size()).steer;
  }
  return s;
}

// The first wheel's command's rate of change over +-5 samples (the signature's regressor).
std::vector<double> CommandRate(const Series& s, const std::vector<std::array<double, 2>>& command) {
  const std::size_t n = s.t.size();
  std::vector<double> rate(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t lo = i >= 5 ? i - 5 : 0, hi = std::min(n - 1, i + 5);
    rate[i] = (command[hi][0] - command[lo][0]) / std::max(s.t[hi] - s.t[lo], 1e-3);
  }
  return rate;
}

// drive_lag. `s` and `tr` must outlive the layer.
Layer DriveLagLayer(const Series& s, const Track& tr, const std::vector<DriveCommand>& commands) {
  const std::size_t n = tr.size();
  const int nw = tr.wheels;
  Layer L;
  L.name = "drive_lag", L.key = "tau_s", L.component = "speed";
  L.regressor_words = "commanded wheel acceleration (rad/s^2)";
  L.use = {true, nw > 1};
  L.measured = tr.speed;
  L.null_param = 0, L.lo = 0, L.hi = 1.0;
  L.predict = [&s, &tr, n, nw](double tau) {
    // Exact response to the held setpoint; the prediction is smoothed like the measurement.
    std::vector<std::array<double, 2>> pos(n, {0, 0}), out(n, {0, 0});
    std::array<double, 2> y{s.speed_cmd[0][0], s.speed_cmd[0][1]};
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const double dt = s.t[i + 1] - s.t[i];
      const double e = tau > 1e-6 ? std::exp(-dt / tau) : 0.0;
      for (int w = 0; w < nw; ++w) {
        const double u = s.speed_cmd[i][w];
        pos[i + 1][w] = pos[i][w] + u * dt + (y[w] - u) * tau * (1 - e);
        y[w] = u + (y[w] - u) * e;
      }
    }
    const auto seconds = [&s](std::size_t a, std::size_t b) { return s.t[b] - s.t[a]; };
    for (std::size_t i = 0; i < n; ++i)
      for (int w = 0; w < nw; ++w)
        out[i][w] = WindowSlope(n, i, tr.speed_window, seconds, [&](std::size_t j) { return pos[j][w]; });
    return out;
  };
  L.regressor = CommandRate(s, s.speed_cmd);
  // A lag within the jitter of the command stamps (a controller's tick: when within it the
  // robot took the command, CommandPeriod) cannot be told from that timing (JudgeLayer).
  CommandPeriod(commands, &L.min_value);
  std::ostringstream note;
  note.precision(3);
  note << "not beyond the timing resolution of the command stamps (" << L.min_value
       << " s) by more than its uncertainty: not told from when the controller takes each command";
  L.bound_note = note.str();
  return L;
}

// The rate the commands themselves move the steering setpoint at, rad/s. Each run of commands a
// regular period apart (CommandPeriod) over which the steering setpoint keeps moving one way is
// one ramp; its rate is its travel over its time, its first and last steps left out (a ramp
// starts and ends between command times, so they are partial). The stamps are whole ticks of the
// controller while the commander ramps on its own clock, so one step's rate is off by up to a
// tick over the period; over a ramp it averages out. Of the ramps' rates, the one at which half the commanded steering travel goes
// faster (weighted by travel: a few slow corrections do not set it). `share`: the part of one
// step's rate the command stamps' timing resolution leaves uncertain (jitter / period).
double CommandedSteeringRate(const RobotDescription& robot, const Track& tr, const std::vector<DriveCommand>& commands,
                             double* share) {
  double jitter = 0;
  const double period = CommandPeriod(commands, &jitter);
  *share = period > 0 ? jitter / period : 0.0;
  const Setpoints setpoints(robot, tr, commands, CommandsBetween::kHold);
  std::vector<std::pair<double, double>> ramps;  // rate, travel
  std::vector<std::pair<double, double>> run;    // this ramp's steps: change, gap
  auto close_run = [&] {
    const std::size_t skip = run.size() >= 3 ? 1 : 0;
    double travel = 0, time = 0;
    for (std::size_t k = skip; k + skip < run.size(); ++k) travel += run[k].first, time += run[k].second;
    if (time > 0) ramps.push_back({travel / time, travel});
    run.clear();
  };
  int direction = 0;
  for (std::size_t c = 1; c < commands.size(); ++c) {
    const double gap = (commands[c].utime - commands[c - 1].utime) * 1e-6;
    double change = 0;  // the steered wheel that moves most
    for (int w = 0; w < tr.wheels && w < 2; ++w) {
      const double d = setpoints.Target(c).steer[w] - setpoints.Target(c - 1).steer[w];
      if (tr.steered[w] && std::abs(d) > std::abs(change)) change = d;
    }
    const int dir = change > 1e-9 ? 1 : change < -1e-9 ? -1 : 0;
    if (dir == 0 || dir != direction || gap < 0.5 * period || gap > 1.5 * period) close_run();
    direction = dir;
    if (dir != 0 && gap >= 0.5 * period && gap <= 1.5 * period) run.push_back({std::abs(change), gap});
  }
  close_run();
  double total = 0;
  for (const auto& r : ramps) total += r.second;
  std::sort(ramps.begin(), ramps.end());
  double acc = 0;
  for (const auto& [rate, travel] : ramps)
    if ((acc += travel) >= 0.5 * total) return rate;
  return 0.0;
}

// steering_rate_limit, searched in log(rate). `s` and `tr` must outlive the layer.
Layer SteeringRateLimitLayer(const RobotDescription& robot, const Series& s, const Track& tr,
                             const std::vector<DriveCommand>& commands) {
  const std::size_t n = tr.size();
  const int nw = tr.wheels;
  Layer L;
  L.name = "steering_rate_limit", L.key = "rate_rad_s", L.component = "steer";
  L.regressor_words = "commanded steering rate (rad/s)";
  L.use = {tr.steered[0], nw > 1 && tr.steered[1]};
  L.measured.assign(n, {0, 0});
  for (std::size_t i = 0; i < n; ++i) L.measured[i] = {tr.steer(i, 0), tr.steer(i, 1)};
  L.null_param = std::log(1e6), L.lo = std::log(0.02), L.hi = std::log(50.0);
  L.log_search = true;
  L.plausible_sigma = 1.0;  // in log(rate)
  L.predict = [&s, n, nw, &tr](double log_rate) {
    const double rate = std::exp(log_rate);
    std::vector<std::array<double, 2>> out(n, {0, 0});
    std::array<double, 2> r{tr.steer(0, 0), tr.steer(0, 1)};
    out[0] = r;
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const double dt = s.t[i + 1] - s.t[i];
      for (int w = 0; w < nw; ++w) r[w] += std::clamp(s.steer_cmd[i][w] - r[w], -rate * dt, rate * dt);
      out[i + 1] = r;
    }
    return out;
  };
  L.regressor = CommandRate(s, s.steer_cmd);
  // The commands ramp the steering themselves (a commander turns it at its own rate, in steps a
  // command period apart), and each step is taken at the controller's tick: between two takes the
  // steering is seen to move at the commanded rate times the period over the gap, uncertain by
  // the share jitter / period (CommandPeriod). A limit within that share of the commanded rate,
  // or above it, is not told from the command's own ramp delivered in ticks: without a limit the
  // fit puts a "limit" near the commanded rate itself.
  double share = 0;
  const double rate = CommandedSteeringRate(robot, tr, commands, &share);
  L.max_value = rate * (1 - share);
  std::ostringstream note;
  note.precision(3);
  note << "not below " << L.max_value << " rad/s, the rate the commands themselves turn the steering at (" << rate
       << " rad/s) less the " << 100 * share << " % the timing resolution of the command stamps leaves uncertain: "
       << "not told from the command's own ramp";
  L.bound_note = note.str();
  return L;
}

// The layer's parameter (in its search variable) that best predicts the samples `keep` selects.
double FitParameter(const Layer& L, const Series& s, const std::function<bool(std::size_t)>& keep) {
  return GridGoldenMin([&](double x) { return Sse(L, L.predict(x), s, keep); }, L.lo, L.hi);
}

// n log(SSE / n) on the fit blocks at the layer's best parameter there (a Gaussian
// log-likelihood up to constants, comparable between setpoint profiles).
double FitLogSse(const Layer& L, const Series& s) {
  auto keep = [&](std::size_t i) { return !s.heldout[i]; };
  const double best = FitParameter(L, s, keep);
  std::size_t n = 0;
  for (std::size_t i = 0; i < s.t.size(); ++i) n += keep(i) * (int(L.use[0]) + int(L.use[1]));
  return n * std::log(std::max(Sse(L, L.predict(best), s, keep), 1e-300) / std::max<std::size_t>(n, 1));
}

// A layer fitted on the fit blocks and tested on the held-out blocks.
struct LayerTest {
  double est = 0;  // the parameter, in the search variable
  std::vector<std::array<double, 2>> before, after;  // predictions without and with the effect
  double rms_b = 0, rms_a = 0;  // held-out RMS residual without and with
  double t = 0, p = 1, gain = 0;
  double sigma = INFINITY;  // standard error of `est`
  double tau_int = 1;       // correlation time of the held-out residual left, samples
};

// Integrated autocorrelation time, in samples, of a residual of RMS `rms`.
double AutocorrelationTime(const std::vector<double>& r, double rms) {
  double tau_int = 1.0;
  const double var = rms * rms;
  for (std::size_t lag = 1; lag < 400 && lag < r.size() && var > 0; ++lag) {
    double acc = 0;
    for (std::size_t i = lag; i < r.size(); ++i) acc += r[i] * r[i - lag];
    const double rho = acc / (r.size() - lag) / var;
    if (rho < 0.05) break;
    tau_int += 2 * rho;
  }
  return tau_int;
}

LayerTest TestLayer(const Layer& L, const Series& s) {
  const std::size_t n = s.t.size();
  LayerTest out;
  out.est = FitParameter(L, s, [&](std::size_t i) { return !s.heldout[i]; });
  out.before = L.predict(L.null_param), out.after = L.predict(out.est);
  // Test on the held-out blocks: the drop of the squared error in units of the noise left
  // after the effect, with the samples counted as independent only once per correlation time.
  std::vector<double> rb, ra;
  for (std::size_t i = 0; i < n; ++i) {
    if (!s.heldout[i]) continue;
    for (int w = 0; w < 2; ++w) {
      if (!L.use[w]) continue;
      rb.push_back(L.measured[i][w] - out.before[i][w]);
      ra.push_back(L.measured[i][w] - out.after[i][w]);
    }
  }
  const double rms_b = out.rms_b = Rms(rb), rms_a = out.rms_a = Rms(ra);
  const double tau_int = out.tau_int = AutocorrelationTime(ra, rms_a);  // of the remaining residual, samples
  const double sigma2 = std::max(rms_a * rms_a, 1e-300);
  const double lr = ra.empty() ? 0.0 : (rms_b * rms_b - rms_a * rms_a) * ra.size() / sigma2 / tau_int;
  out.t = lr > 0 ? std::sqrt(lr) : 0.0;
  out.p = ChiSquareUpperTail(lr, 1);
  out.gain = rms_b > 0 ? 1 - rms_a / rms_b : 0.0;
  // Standard error from the curvature of the fit blocks' squared error (Gauss-Newton),
  // inflated by the correlation time.
  auto keep = [&](std::size_t i) { return !s.heldout[i]; };
  const double h = L.log_search ? 0.05 : 0.005;
  const double f0 = Sse(L, L.predict(out.est), s, keep);
  const double fp = Sse(L, L.predict(out.est + h), s, keep), fm = Sse(L, L.predict(std::max(out.est - h, L.lo)), s, keep);
  const double curvature = (fp - 2 * f0 + fm) / (h * h);  // = 2 sum J^2
  if (curvature > 0) out.sigma = std::sqrt(2.0 * sigma2 * tau_int / curvature);
  return out;
}

// The candidate's outcome (`o`); whether the effect is found.
bool JudgeLayer(const Layer& L, const LayerTest& test, int m, double alpha, double alpha_share,
                CandidateOutcome* o) {
  const double value = L.log_search ? std::exp(test.est) : test.est;
  const double value_std = L.log_search ? value * test.sigma : test.sigma;
  o->name = L.name, o->layer = "actuation";
  o->estimate = {value, value_std};
  o->p_value = test.p;
  o->p_adjusted = std::min(1.0, test.p * m * alpha / std::max(alpha_share, 1e-300));
  // A drive lag is told only beyond the timing resolution, by more than its own uncertainty at
  // the test's level: a controller that takes each command at its next tick holds the setpoint
  // half a tick late on average, so without any lag the estimate sits at the resolution itself
  // and, with a tight sigma, falls just above or below it by chance.
  // A rate limit is the larger the slower: the fastest limit the recording can tell is its
  // ceiling (the commands' own ramp less the timing share).
  const double z_level = NormalUpper(alpha_share / m);
  o->detectable = L.log_search ? L.max_value : L.min_value + (z_level + NormalUpper(0.2)) * value_std;
  const bool at_null_edge = L.log_search && test.est > L.hi - 0.5;  // no limit inside the searched range
  const bool within_resolution = L.min_value > 0 && value < L.min_value + z_level * value_std;
  const bool unresolved = within_resolution || value >= L.max_value;
  const bool significant = test.p * m < alpha_share && test.gain > kMinGain && !at_null_edge && !unresolved;
  if (significant) {
    o->status = CandidateStatus::kFound;
  } else if (L.log_search && unresolved && !at_null_edge) {
    o->status = CandidateStatus::kNotIdentifiable;  // a limit there cannot be detected: `detectable` is below it
    o->note = L.bound_note;
  } else if (!(test.sigma < L.plausible_sigma) || at_null_edge) {
    o->status = CandidateStatus::kNotIdentifiable;
    if (L.log_search) {
      double max_rate = 0;
      for (double r : L.regressor) max_rate = std::max(max_rate, std::abs(r));
      std::ostringstream note;
      note.precision(3);
      note << "steering was never commanded faster than " << max_rate
           << " rad/s; a limit above that cannot show: command faster steering steps";
      o->note = note.str();
    } else {
      o->note = "the commanded speed hardly changes: command speed steps";
    }
  } else {
    o->status = CandidateStatus::kNotSignificant;
    if (unresolved) o->note = L.bound_note;
  }
  return significant;
}

// The wheel a layer's trace, spans and signature show.
int ShownWheel(const Layer& L) { return L.use[0] ? 0 : 1; }

// Every fifth sample: measured, and predicted without and (when found) with the effect.
DiagnoseReport::Trace LayerTrace(const RobotDescription& robot, const Layer& L, const Series& s,
                                 const LayerTest& test, bool significant) {
  DiagnoseReport::Trace trace;
  const int w0 = ShownWheel(L);
  trace.name = L.component + " " + WheelRoles(robot.drive)[w0];
  for (std::size_t i = 0; i < s.t.size(); i += 5) {
    trace.utime.push_back(s.utime[i]);
    trace.measured.push_back(L.measured[i][w0]);
    trace.before.push_back(test.before[i][w0]);
    trace.after.push_back(significant ? test.after[i][w0] : test.before[i][w0]);
  }
  return trace;
}

// Signature: quantile bins of the regressor `x`, the residuals before and after.
std::vector<SignatureBin> QuantileSignature(const std::vector<double>& x, const std::vector<double>& eb,
                                            const std::vector<double>& ea) {
  std::vector<SignatureBin> bins;
  std::vector<std::size_t> order(x.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return x[a] < x[b]; });
  const int nb = 10;
  for (int b = 0; b < nb; ++b) {
    SignatureBin bin;
    double sx = 0, sb = 0, sa = 0, sa2 = 0;
    for (std::size_t r = order.size() * b / nb; r < order.size() * (b + 1) / nb; ++r) {
      const std::size_t i = order[r];
      ++bin.count, sx += x[i], sb += eb[i], sa += ea[i], sa2 += ea[i] * ea[i];
    }
    if (bin.count < 3) continue;
    bin.x = sx / bin.count, bin.before = sb / bin.count, bin.after = sa / bin.count;
    bin.std_error = std::sqrt(std::max(sa2 / bin.count - bin.after * bin.after, 0.0) / bin.count);
    bins.push_back(bin);
  }
  return bins;
}

// A found actuation effect: where it acts, its held-out figures and its signature.
FoundEffect DescribeLayer(const Layer& L, const Series& s, const LayerTest& test, const CandidateOutcome& o) {
  const std::size_t n = s.t.size();
  FoundEffect fe;
  fe.name = L.name, fe.layer = "actuation", fe.component = L.component;
  fe.params[L.key] = o.estimate;
  fe.wald = test.t * test.t, fe.p_value = test.p, fe.p_adjusted = o.p_adjusted;
  fe.delta_bic = 0;
  fe.regressor = L.regressor_words;
  // Where the effect changes the prediction by more than the noise left after it.
  const double noise = test.rms_a;
  const int w0 = ShownWheel(L);
  std::vector<TimeSpan> spans;
  std::vector<double> in_b, in_a, x, eb, ea;
  for (std::size_t i = 0; i < n; ++i) {
    const double diff = std::abs(test.after[i][w0] - test.before[i][w0]);
    const bool flagged = diff > 2 * noise;
    if (flagged) spans.push_back({s.utime[i], s.utime[std::min(i + 1, n - 1)]});
    if (flagged && s.heldout[i]) {
      in_b.push_back(L.measured[i][w0] - test.before[i][w0]);
      in_a.push_back(L.measured[i][w0] - test.after[i][w0]);
    }
    x.push_back(L.regressor[i]);
    eb.push_back(L.measured[i][w0] - test.before[i][w0]);
    ea.push_back(L.measured[i][w0] - test.after[i][w0]);
  }
  fe.where = MergeSpans(spans, 500000);
  fe.heldout_rms_before = Rms(in_b), fe.heldout_rms_after = Rms(in_a);
  fe.heldout_rms_all_before = test.rms_b, fe.heldout_rms_all_after = test.rms_a;
  fe.signature = QuantileSignature(x, eb, ea);
  fe.regime = L.name == "drive_lag" ? "while the commanded speed changes (starts, stops, speed steps)"
                                    : "during fast steering commands";
  return fe;
}

// "held", "ramped", "interpolated": how the diagnosis models the setpoint between commands.
const char* ProfileWord(CommandsBetween between) {
  switch (between) {
    case CommandsBetween::kRamp: return "ramped";
    case CommandsBetween::kContinuous: return "interpolated";
    case CommandsBetween::kHold: break;
  }
  return "held";
}

const char* ProfileSentence(CommandsBetween between) {
  switch (between) {
    case CommandsBetween::kRamp: return "ramps between DRIVE_CMD messages";
    case CommandsBetween::kContinuous: return "changes continuously, the DRIVE_CMD messages its samples (interpolated)";
    case CommandsBetween::kHold: break;
  }
  return "is held from one DRIVE_CMD to the next";
}

}  // namespace

int ActuationCandidates(const RobotDescription& robot, const DiagnoseData& data) {
  if (data.commands.size() < kMinCommands) return 0;
  return robot.drive == DriveType::kDifferential ? 1 : 2;
}

void DiagnoseActuation(const RobotDescription& robot, const DiagnoseData& data,
                       const DiagnoseOptions& options, double alpha_share, DiagnoseReport* report) {
  const int m = ActuationCandidates(robot, data);
  if (m == 0) {
    report->notes.push_back("no DRIVE_CMD in the recording: actuation layer (drive_lag, steering_rate_limit) not tested");
    return;
  }
  const Track tr = MakeTrack(robot, data.wheels);
  // What the controller does between commands: stated in the robot file, or from the data: the
  // profile under which the drive layer, at its best lag, fits the fit blocks best (Gaussian
  // log-likelihood; every profile has the same parameter). A model that holds each command
  // fitted to ramped setpoints biases the lag low by about half a command period, fitted to
  // samples of a continuous setpoint too; a ramp is a period behind the continuous setpoint.
  std::vector<CommandsBetween> candidates{CommandsBetween::kHold, CommandsBetween::kRamp,
                                          CommandsBetween::kContinuous};
  if (robot.commands_between) candidates = {*robot.commands_between};
  const std::size_t np = candidates.size();
  std::vector<Series> profiles;
  std::vector<std::vector<Layer>> layer_sets(np);
  std::vector<double> score(np, 0.0);
  for (CommandsBetween between : candidates)
    profiles.push_back(CommandSeries(robot, tr, data.commands, options.block_s, between));
  std::ostringstream per_layer;
  per_layer.precision(8);
  for (std::size_t k = 0; k < np; ++k) {
    layer_sets[k].push_back(DriveLagLayer(profiles[k], tr, data.commands));
    if (m > 1) layer_sets[k].push_back(SteeringRateLimitLayer(robot, profiles[k], tr, data.commands));
    for (const Layer& L : layer_sets[k]) {
      const double layer_score = FitLogSse(L, profiles[k]);
      // The speeds decide: they are compared integrated over each sample, so a sub-sample shift
      // of when the controller applies a setpoint (a simulator's or controller's tick) hardly
      // matters; the steering angle is read at instants and such a shift can outweigh the profile.
      if (L.name == "drive_lag") score[k] += layer_score;
      per_layer << " " << ProfileWord(candidates[k]) << " " << L.name << " " << layer_score << ";";
    }
  }
  const std::size_t chosen = std::min_element(score.begin(), score.end()) - score.begin();
  const Series& s = profiles[chosen];
  const std::vector<Layer>& layers = layer_sets[chosen];
  std::vector<LayerTest> tests;
  for (const Layer& L : layers) tests.push_back(TestLayer(L, s));
  // Which other profiles the data do not tell from the chosen one: the gap of the drive layer's
  // log-likelihoods, its samples counted once per correlation time, at the level of the
  // actuation tests. Where the controller's tick is coarse against the command period (a few
  // ticks a command) a held setpoint behind a lag of half a command period fits a ramp about as
  // well, and a drive lag found under the chosen profile alone is that lead.
  std::vector<std::size_t> not_told;
  for (std::size_t k = 0; k < np; ++k) {
    if (k == chosen) continue;
    const double gap = std::abs(score[k] - score[chosen]) / std::max(tests[0].tau_int, 1.0);
    const bool told_apart = gap > ChiSquareUpperQuantile(alpha_share / m, 1);
    if (!told_apart) not_told.push_back(k);
    per_layer << " " << ProfileWord(candidates[k]) << " told apart: " << (told_apart ? "yes" : "no") << ", gap "
              << gap << " per correlation time of " << tests[0].tau_int << " samples;";
  }
  std::ostringstream note;
  note << "actuation: the setpoint " << ProfileSentence(candidates[chosen]);
  if (robot.commands_between)
    note << " (stated in the robot file: commands.between " << CommandsBetweenName(*robot.commands_between) << ";"
         << per_layer.str() << ")";
  else
    note << " (chosen by the fit, log SSE:" << per_layer.str() << ")";
  report->notes.push_back(note.str());
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const Layer& L = layers[l];
    const LayerTest& test = tests[l];
    CandidateOutcome o;
    bool significant = JudgeLayer(L, test, m, options.alpha, alpha_share, &o);
    for (std::size_t k : not_told) {
      if (!significant) break;
      CandidateOutcome other;
      const Layer& L_other = layer_sets[k][l];
      if (!JudgeLayer(L_other, TestLayer(L_other, profiles[k]), m, options.alpha, alpha_share, &other)) {
        significant = false;
        o.status = CandidateStatus::kNotSignificant;
        o.note = std::string("found only with the setpoint ") + ProfileWord(candidates[chosen]) +
                 ", which the data do not tell from " + ProfileWord(candidates[k]) +
                 " setpoints (that profile's fit: " + (other.note.empty() ? "not significant" : other.note) + ")";
      }
    }
    report->candidates.push_back(o);
    report->actuation.push_back(LayerTrace(robot, L, s, test, significant));
    if (significant) report->effects.push_back(DescribeLayer(L, s, test, o));
  }
}

}  // namespace calib::diag
