#include "calib/live/dashboard_model.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "calib/core/units.h"
#include "calib/io/messages.h"
#include "calib/io/process_names.h"

namespace calib {

namespace {

double Seconds(int64_t us) { return us * 1e-6; }

// Text from the bus as the terminal may show it: control characters (escape sequences, line
// breaks, tabs) become '?', so a hostile string cannot move the cursor or break a row.
std::string Printable(std::string text) {
  for (char& c : text)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  return text;
}

// Arrivals per second from a channel's kept arrivals, read at `now_us`. Over a second or more
// of arrivals: their intervals over their span, lowered once the silence since the last grows
// past a typical interval (and past a second), so a source that stops reads slower and slower
// instead of keeping its last rate. Over less than a second (a start, one message, a burst of
// residuals after a solve): their count per second elapsed since the first, at least a second.
double Rate(const std::deque<int64_t>& arrivals, int64_t now_us) {
  if (arrivals.empty()) return 0;
  const std::size_t n = arrivals.size();
  const double span = Seconds(arrivals.back() - arrivals.front());
  if (span < 1.0) return n / std::max(1.0, Seconds(now_us - arrivals.front()));
  const double interval = span / (n - 1);
  const double silence = Seconds(now_us - arrivals.back());
  return (n - 1) / (span + std::max(0.0, silence - std::max(interval, 1.0)));
}

// The rate of a regular source from its stamps: 1 / median interval, so that lost
// messages (a busy receiver) do not lower it. 0 for fewer than two stamps.
double MedianRate(const std::deque<int64_t>& stamps) {
  std::vector<int64_t> steps;
  for (std::size_t i = 1; i < stamps.size(); ++i) steps.push_back(stamps[i] - stamps[i - 1]);
  if (steps.empty()) return 0;
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
  const int64_t median = steps[steps.size() / 2];
  return median > 0 ? 1.0 / Seconds(median) : 0;
}

template <typename T>
void KeepLast(std::deque<T>* values, std::size_t count) {
  while (values->size() > count) values->pop_front();
}

}  // namespace

bool DashboardModel::Stale(int64_t last_arrival, int64_t now_us) const {
  return Seconds(now_us - last_arrival) > options_.stale_after_s;
}

void DashboardModel::OnMessage(const std::string& channel, const std::string& type, bool decoded,
                               std::optional<int64_t> utime, int64_t now_us) {
  Channel& c = channels_[Printable(channel)];
  c.type = type;
  ++c.count;
  if (!decoded) ++c.undecodable;
  c.last_arrival = now_us;
  c.arrivals.push_back(now_us);
  // A missing or non-increasing utime (unknown type, a replay restarting) restarts the data window.
  if (!utime || (!c.utimes.empty() && *utime <= c.utimes.back())) c.utimes.clear();
  if (utime) c.utimes.push_back(*utime);
  const int64_t window = static_cast<int64_t>(options_.rate_window_s * 1e6);
  // The last two arrivals stay whatever their age: a channel that comes once per solve, seconds
  // apart, keeps the interval its rate is read from.
  while (c.arrivals.size() > 2 && now_us - c.arrivals.front() > window) c.arrivals.pop_front();
  KeepLast(&c.utimes, c.arrivals.size());
}

void DashboardModel::OnHeartbeat(const agvcal::heartbeat_t& beat, int64_t now_us) {
  // The group's recording marks come from a short-lived agvcal-recording per waiting process:
  // shown as a process, the group would read as restarted at the start and stale all run long.
  if (beat.process == kGroupMarkProcess) return;
  // A new run (the dashboard left running across two groups): a beat after every known process
  // went stale, or a new pid of a process whose last beat said it had stopped, starts afresh,
  // so the old run's values go and the new pids are not counted as restarts.
  if (!processes_.empty()) {
    bool all_stale = true;
    for (const auto& [name, known] : processes_) all_stale = all_stale && Stale(known.last_arrival, now_us);
    const auto same = processes_.find(Printable(beat.process));
    const bool after_stop = same != processes_.end() && same->second.pid != beat.pid &&
                            same->second.state.rfind("stopped", 0) == 0;
    if (all_stale || after_stop) NewRun();
  }
  const std::string name = Printable(beat.process);
  const bool known = processes_.count(name) > 0;
  Process& p = processes_[name];
  if (known && p.pid != beat.pid) ++p.restarts;
  p.pid = beat.pid;
  p.state = Printable(beat.state);
  p.last_arrival = now_us;
}

void DashboardModel::NewRun() {
  channels_.clear();
  processes_.clear();
  parameter_order_.clear();
  parameters_.clear();
  estimate_.reset();
  estimates_ = 0;
  residuals_.clear();
  commander_.reset();
  ++runs_;
}

void DashboardModel::OnEstimate(const agvcal::calib_estimate_t& raw, int64_t now_us) {
  agvcal::calib_estimate_t estimate = raw;
  estimate.drive = Printable(estimate.drive);
  estimate.status = Printable(estimate.status);
  estimate.message = Printable(estimate.message);
  for (std::string& name : estimate.names) name = Printable(name);
  for (std::string& weak : estimate.weak) weak = Printable(weak);
  // The robot clock going back: another run's solver (a replay started again).
  if (estimate_ && estimate.utime < estimate_->utime) {
    parameter_order_.clear();
    parameters_.clear();
    estimates_ = 0;
    residuals_.clear();
  }
  estimate_ = estimate;
  ++estimates_;
  estimate_arrival_ = now_us;
  for (int i = 0; i < estimate.num_values; ++i) {
    const std::string& name = estimate.names[i];
    if (!parameters_.count(name)) parameter_order_.push_back(name);
    Parameter& p = parameters_[name];
    p.value = estimate.values[i];
    p.std = estimate.stds[i];
    p.nominal = estimate.nominal[i];
    p.values.push_back(p.value);
    p.stds.push_back(p.std);
    KeepLast(&p.values, options_.estimate_history);
    KeepLast(&p.stds, options_.estimate_history);
  }
}

void DashboardModel::OnResidual(const agvcal::calib_residual_t& residual) {
  // An interval at or before the newest: the solver started over (restart, new replay).
  while (!residuals_.empty() && residuals_.back().utime_end >= residual.utime_end)
    residuals_.pop_back();
  ResidualPoint p;
  p.utime_end = residual.utime_end;
  for (int k = 0; k < 3; ++k) p.error[k] = residual.error[k];
  p.chi2 = residual.chi2;
  p.outlier = residual.outlier;
  residuals_.push_back(p);
  KeepLast(&residuals_, options_.residual_history);
}

void DashboardModel::OnCommanderStatus(const agvcal::commander_status_t& status, int64_t now_us) {
  commander_ = status;
  commander_->trajectory = Printable(commander_->trajectory);
  commander_->segment_name = Printable(commander_->segment_name);
  commander_->state = Printable(commander_->state);
  commander_arrival_ = now_us;
}

std::vector<ChannelView> DashboardModel::Channels(int64_t now_us) const {
  std::vector<ChannelView> out;
  const auto solver = processes_.find(kSolverProcess);
  const bool solver_alive = solver != processes_.end() && !Stale(solver->second.last_arrival, now_us);
  for (const auto& [name, c] : channels_) {
    ChannelView v;
    v.name = name;
    v.type = c.type;
    v.count = c.count;
    v.undecodable = c.undecodable;
    v.age_s = Seconds(now_us - c.last_arrival);
    // The solver's channels come once per solve, seconds apart (every N motions): fresh while
    // the solver beats, so that a working solver's estimate does not read stale between solves.
    const bool per_solve = name == kCalibEstimateChannel || name == kCalibResidualsChannel;
    v.stale = Stale(c.last_arrival, now_us) && !(per_solve && solver_alive);
    if (!v.stale) {
      v.rate_hz = Rate(c.arrivals, now_us);
      v.data_rate_hz = MedianRate(c.utimes);
    }
    out.push_back(v);
  }
  return out;
}

std::vector<ProcessView> DashboardModel::Processes(int64_t now_us) const {
  std::vector<ProcessView> out;
  for (const auto& [name, p] : processes_) {
    ProcessView v;
    v.name = name;
    v.pid = p.pid;
    v.state = p.state;
    v.age_s = Seconds(now_us - p.last_arrival);
    v.stale = Stale(p.last_arrival, now_us);
    v.restarts = p.restarts;
    out.push_back(v);
  }
  return out;
}

std::vector<ParameterView> DashboardModel::Parameters() const {
  std::vector<ParameterView> out;
  for (const std::string& name : parameter_order_) {
    const Parameter& p = parameters_.at(name);
    ParameterView v;
    v.name = name;
    v.unit = ParamUnit(name);
    v.value = p.value;
    v.std = p.std;
    v.nominal = p.nominal;
    v.values.assign(p.values.begin(), p.values.end());
    v.stds.assign(p.stds.begin(), p.stds.end());
    const std::size_t n = v.values.size();
    if (n >= 2 && p.std > 0) {
      v.last_change_sigmas = std::abs(v.values[n - 1] - v.values[n - 2]) / p.std;
      const std::size_t needed = static_cast<std::size_t>(options_.converge_count);
      if (n > needed) {
        v.converged = true;
        for (std::size_t i = n - needed; i < n; ++i)
          if (std::abs(v.values[i] - v.values[i - 1]) >= options_.converge_sigmas * p.std)
            v.converged = false;
      }
    }
    out.push_back(v);
  }
  return out;
}

EstimateView DashboardModel::Estimate(int64_t now_us) const {
  EstimateView v;
  if (!estimate_) return v;
  const agvcal::calib_estimate_t& e = *estimate_;
  v.any = true;
  v.drive = e.drive;
  v.status = e.status;
  v.message = e.message;
  v.utime = e.utime;
  v.intervals = e.intervals;
  v.outliers = e.outliers;
  v.condition = e.condition;
  v.weak = e.weak;
  v.estimates = estimates_;
  v.age_s = Seconds(now_us - estimate_arrival_);
  return v;
}

CommanderView DashboardModel::Commander(int64_t now_us) const {
  CommanderView v;
  if (!commander_) return v;
  v.any = true;
  v.trajectory = commander_->trajectory;
  v.segment_name = commander_->segment_name;
  v.state = commander_->state;
  v.segment = commander_->segment;
  v.num_segments = commander_->num_segments;
  v.age_s = Seconds(now_us - commander_arrival_);
  v.stale = Stale(commander_arrival_, now_us);
  return v;
}

std::vector<double> DashboardModel::ResidualSeries(int component, std::size_t count) const {
  std::vector<double> out;
  for (auto it = residuals_.rbegin(); it != residuals_.rend(); ++it) {
    if (count > 0 && out.size() >= count) break;
    if (!it->outlier) out.push_back(it->error[component]);
  }
  std::reverse(out.begin(), out.end());
  return out;
}

ResidualStats DashboardModel::Stats(int component) const {
  ResidualStats s;
  double sum2 = 0;
  for (const ResidualPoint& p : residuals_) {
    ++s.count;
    if (p.outlier) {
      ++s.outliers;
      continue;
    }
    const double e = p.error[component];
    sum2 += e * e;
    s.max_abs = std::max(s.max_abs, std::abs(e));
  }
  const int inliers = s.count - s.outliers;
  if (inliers > 0) s.rms = std::sqrt(sum2 / inliers);
  return s;
}

Histogram DashboardModel::ResidualHistogram(int component, int bins, double range) const {
  return SymmetricHistogram(ResidualSeries(component), bins, range);
}

}  // namespace calib
