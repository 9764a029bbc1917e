#pragma once
// What the terminal dashboard (agvcal-dashboard) shows, kept apart from the
// drawing so it is tested without a terminal or a bus. It consumes decoded
// messages with the time they arrived (`now_us`, microseconds on one clock the
// caller chooses: the wall clock live, anything in tests) and keeps:
//  - per channel: message count, arrival rate on the bus, data rate from the
//    messages' own utime (robot clock, so a replay at -s 4 still reads 20 Hz
//    for a 20 Hz lidar; 1 / the median interval, so messages lost by a busy
//    receiver do not lower it), time since the last message, stale or not;
//  - per process (HEARTBEAT): pid, state, time since the last beat, restarts
//    (a new pid under the same name);
//  - the solver's estimates (CALIB_ESTIMATE): each parameter's value and sigma
//    over time and whether it has converged, the observability state;
//  - the solver's residuals (CALIB_RESIDUALS) per component, for a time plot
//    and a histogram;
//  - the commander's state (COMMANDER_STATUS).
// Text from the bus has its control characters replaced by '?'. A new run (every process
// silent, or one that said "stopped" back with a new pid) clears everything.
// Nothing here reads the clock.

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "agvcal/calib_estimate_t.hpp"
#include "agvcal/calib_residual_t.hpp"
#include "agvcal/commander_status_t.hpp"
#include "agvcal/heartbeat_t.hpp"
#include "calib/live/histogram.h"

namespace calib {

struct DashboardOptions {
  double stale_after_s = 3.0;       // a channel or process silent for longer is stale (the
                                    // solver's channels: only once the solver is too)
  double rate_window_s = 5.0;       // rates are measured over the arrivals of this window
  std::size_t residual_history = 4000;  // residuals kept (per component)
  std::size_t estimate_history = 500;   // estimates kept per parameter
  // A parameter has converged when each of its last `converge_count` changes is
  // below `converge_sigmas` times its current sigma.
  double converge_sigmas = 0.5;
  int converge_count = 3;
};

struct ChannelView {
  std::string name;
  std::string type;        // "" when the channel's message type is not known
  int64_t count = 0;
  double rate_hz = 0;      // arrivals per second over the window, at least the last two
                           // arrivals (over less than 1 s of them: their count per second since
                           // the first); lower once silent for longer than a usual interval;
                           // 0 when stale
  double data_rate_hz = 0; // 1 / median utime step over the same window; 0 if unknown
  double age_s = 0;        // since the last message
  bool stale = false;
  int64_t undecodable = 0; // messages of a known type that did not decode
};

struct ProcessView {
  std::string name;
  int32_t pid = 0;
  std::string state;       // as the process reported it
  double age_s = 0;        // since the last heartbeat
  bool stale = false;
  int restarts = 0;        // times its pid changed
};

struct ParameterView {
  std::string name;
  std::string unit;  // SI, core/units.h ParamUnit: "m", "rad", "s", "rad/s", "" (dimensionless)
  double value = 0, std = -1, nominal = 0;  // std -1: not determined
  std::vector<double> values;  // one per estimate that carried it, oldest first
  std::vector<double> stds;
  double last_change_sigmas = -1;  // |last change| / current sigma; -1 before two estimates
  bool converged = false;
};

struct EstimateView {
  bool any = false;        // an estimate has arrived
  std::string drive, status, message;  // status: waiting, ok, unobservable, final
  int64_t utime = 0;
  int32_t intervals = 0, outliers = 0;
  double condition = 0;
  std::vector<std::string> weak;
  int estimates = 0;       // received so far
  double age_s = 0;
};

struct ResidualPoint {
  int64_t utime_end = 0;
  std::array<double, 3> error{};  // x, y (m), yaw (rad)
  double chi2 = 0;
  bool outlier = false;
};

struct ResidualStats {
  int count = 0, outliers = 0;
  double rms = 0;          // of the inliers
  double max_abs = 0;      // of the inliers
};

struct CommanderView {
  bool any = false;
  std::string trajectory, segment_name, state;
  int32_t segment = 0, num_segments = 0;
  double age_s = 0;
  bool stale = false;
};

class DashboardModel {
 public:
  explicit DashboardModel(DashboardOptions options = {}) : options_(options) {}

  // Every message on the bus: its channel, arrival time and, where the type is
  // known, its robot-clock utime (`decoded` false: known type, bad bytes).
  void OnMessage(const std::string& channel, const std::string& type, bool decoded,
                 std::optional<int64_t> utime, int64_t now_us);
  void OnHeartbeat(const agvcal::heartbeat_t& beat, int64_t now_us);
  void OnEstimate(const agvcal::calib_estimate_t& estimate, int64_t now_us);
  void OnResidual(const agvcal::calib_residual_t& residual);
  void OnCommanderStatus(const agvcal::commander_status_t& status, int64_t now_us);

  std::vector<ChannelView> Channels(int64_t now_us) const;     // by name
  std::vector<ProcessView> Processes(int64_t now_us) const;    // by name
  std::vector<ParameterView> Parameters() const;               // in the solver's order
  EstimateView Estimate(int64_t now_us) const;
  CommanderView Commander(int64_t now_us) const;

  // Residuals, oldest first; `component` 0 x, 1 y, 2 yaw.
  const std::deque<ResidualPoint>& residuals() const { return residuals_; }
  // The last `count` inlier residuals of one component (all when count is 0).
  std::vector<double> ResidualSeries(int component, std::size_t count = 0) const;
  ResidualStats Stats(int component) const;
  // Histogram of the inliers of one component over [-range, range]; range 0
  // takes the largest inlier magnitude (a symmetric range, so 0 is central).
  Histogram ResidualHistogram(int component, int bins, double range = 0) const;

  const DashboardOptions& options() const { return options_; }
  // Runs seen: 1, and one more each time a new run began (OnHeartbeat); all is forgotten then.
  int runs() const { return runs_; }

 private:
  struct Channel {
    std::string type;
    int64_t count = 0, undecodable = 0;
    std::deque<int64_t> arrivals;            // within the rate window, and the last two
    std::deque<int64_t> utimes;              // robot clock, of the same window
    int64_t last_arrival = 0;
  };
  struct Process {
    int32_t pid = 0;
    std::string state;
    int64_t last_arrival = 0;
    int restarts = 0;
  };
  struct Parameter {
    double value = 0, std = -1, nominal = 0;
    std::deque<double> values, stds;
  };

  bool Stale(int64_t last_arrival, int64_t now_us) const;
  void NewRun();

  DashboardOptions options_;
  std::map<std::string, Channel> channels_;
  std::map<std::string, Process> processes_;
  std::vector<std::string> parameter_order_;
  std::map<std::string, Parameter> parameters_;
  std::optional<agvcal::calib_estimate_t> estimate_;
  int estimates_ = 0;
  int64_t estimate_arrival_ = 0;
  std::deque<ResidualPoint> residuals_;
  std::optional<agvcal::commander_status_t> commander_;
  int64_t commander_arrival_ = 0;
  int runs_ = 1;
};

}  // namespace calib
