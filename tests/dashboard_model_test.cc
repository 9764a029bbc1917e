// The dashboard's state model and its character plots, fed with made-up
// messages and times (no bus, no terminal).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "agvcal/wheel_state_t.hpp"
#include "calib/io/log_summary.h"
#include "calib/io/messages.h"
#include "calib/io/process_names.h"
#include "calib/io/text_plot.h"
#include "calib/live/dashboard_model.h"

namespace calib {
namespace {

constexpr int64_t kSecond = 1000000;

agvcal::calib_estimate_t MakeEstimate(double radius, double radius_std, double yaw, double yaw_std) {
  agvcal::calib_estimate_t e{};
  e.utime = 5 * kSecond;
  e.drive = "tricycle";
  e.status = "ok";
  e.num_values = 2;
  e.names = {"drive_radius", "lidar2d.yaw"};
  e.values = {radius, yaw};
  e.stds = {radius_std, yaw_std};
  e.nominal = {0.115, 0.0};
  e.intervals = 400;
  e.condition = 41.5;
  e.num_weak = 1;
  e.weak = {"lidar2d.yaw"};
  return e;
}

agvcal::calib_residual_t MakeResidual(int64_t end, double x, double y, double yaw, bool outlier = false) {
  agvcal::calib_residual_t r{};
  r.utime_start = end - 50000;
  r.utime_end = end;
  r.error[0] = x;
  r.error[1] = y;
  r.error[2] = yaw;
  r.chi2 = 1;
  r.outlier = outlier;
  return r;
}

TEST(DashboardModel, BusRateDataRateAndStaleness) {
  DashboardModel model;  // window 5 s, stale after 3 s
  // WHEELS at 100 Hz of robot time, arriving four times as fast (a replay at -s 4).
  const int64_t t0 = 1000 * kSecond;
  for (int i = 0; i <= 800; ++i)
    model.OnMessage("WHEELS", "wheel_state_t", true, i * 10000, t0 + i * 2500);
  // An unknown channel at 2 Hz with no utime.
  for (int i = 0; i <= 4; ++i) model.OnMessage("MY_CHANNEL", "", true, std::nullopt, t0 + i * 500000);
  const int64_t end = t0 + 800 * 2500;  // 2 s
  std::vector<ChannelView> channels = model.Channels(end + 100000);
  ASSERT_EQ(channels.size(), 2u);
  EXPECT_EQ(channels[0].name, "MY_CHANNEL");  // by name
  EXPECT_NEAR(channels[0].rate_hz, 2.0, 1e-9);
  EXPECT_EQ(channels[0].data_rate_hz, 0.0);
  const ChannelView& wheels = channels[1];
  EXPECT_EQ(wheels.count, 801);
  EXPECT_NEAR(wheels.rate_hz, 400.0, 1e-6);
  EXPECT_NEAR(wheels.data_rate_hz, 100.0, 1e-6);
  EXPECT_NEAR(wheels.age_s, 0.1, 1e-9);
  EXPECT_FALSE(wheels.stale);
  // Silent for just over 3 s: stale, no rate shown.
  channels = model.Channels(end + 3 * kSecond + 1);
  EXPECT_TRUE(channels[1].stale);
  EXPECT_EQ(channels[1].rate_hz, 0.0);
  EXPECT_FALSE(model.Channels(end + 3 * kSecond)[1].stale);
}

TEST(DashboardModel, AChannelOncePerSolveReadsItsIntervalBetweenSolves) {
  DashboardModel model;  // window 5 s
  // The solver's estimate every 12 s: between two solves the window holds no arrival or one.
  // The solver beats every second, so its channel stays fresh between solves.
  agvcal::heartbeat_t beat{};
  beat.process = kSolverProcess;
  beat.pid = 7;
  beat.state = "running";
  for (int s = 0; s <= 100; ++s) model.OnHeartbeat(beat, s * kSecond);
  int64_t t = 10 * kSecond;
  for (int i = 0; i < 3; ++i, t += 12 * kSecond)
    model.OnMessage(kCalibEstimateChannel, "calib_estimate_t", true, t, t);
  const int64_t last = t - 12 * kSecond;
  EXPECT_NEAR(model.Channels(last + 5 * kSecond)[0].rate_hz, 1.0 / 12, 1e-9);
  EXPECT_NEAR(model.Channels(last + 5 * kSecond)[0].data_rate_hz, 1.0 / 12, 1e-9);
  // Solves that stop: the rate falls with the silence instead of keeping its last value.
  EXPECT_NEAR(model.Channels(last + 36 * kSecond)[0].rate_hz, 1.0 / 36, 1e-9);
}

TEST(DashboardModel, RateWindowForgetsOldArrivals) {
  DashboardModel model;
  // 10 s at 10 Hz, then 20 Hz: after 5 s at 20 Hz only the new rate is left in the window.
  int64_t t = 0, u = 0;
  for (int i = 0; i < 100; ++i, t += 100000, u += 100000) model.OnMessage("SCAN", "laser_scan_t", true, u, t);
  for (int i = 0; i <= 120; ++i, t += 50000, u += 50000) model.OnMessage("SCAN", "laser_scan_t", true, u, t);
  const ChannelView scan = model.Channels(t)[0];
  EXPECT_NEAR(scan.rate_hz, 20.0, 1e-6);
  EXPECT_NEAR(scan.data_rate_hz, 20.0, 1e-6);
  // Every fifth message lost: fewer arrivals, the same data rate.
  DashboardModel lossy;
  t = u = 0;
  for (int i = 0; i <= 100; ++i, t += 10000, u += 10000)
    if (i % 5 != 4) lossy.OnMessage("WHEELS", "wheel_state_t", true, u, t);
  const ChannelView wheels = lossy.Channels(t)[0];
  EXPECT_NEAR(wheels.data_rate_hz, 100.0, 1e-6);
  EXPECT_NEAR(wheels.rate_hz, 80.0, 1.0);
  // A burst (the solver's residuals after a solve) is not read as thousands per second.
  DashboardModel burst;
  for (int i = 0; i < 20; ++i) burst.OnMessage("CALIB_RESIDUALS", "", true, std::nullopt, t + i * 10);
  EXPECT_NEAR(burst.Channels(t + 200)[0].rate_hz, 20.0, 1e-9);
  // One arrival, read 2 s later: one in 2 s so far, not "1 Hz".
  DashboardModel single;
  single.OnMessage("COMMANDER_STATUS", "", true, std::nullopt, t);
  EXPECT_NEAR(single.Channels(t + 2 * kSecond)[0].rate_hz, 0.5, 1e-9);
  // Undecodable messages are counted.
  model.OnMessage("SCAN", "laser_scan_t", false, std::nullopt, t);
  EXPECT_EQ(model.Channels(t)[0].undecodable, 1);
}

TEST(DashboardModel, StampOfGivesTypeAndUtime) {
  agvcal::wheel_state_t w{};
  w.utime = 123456789;
  const std::vector<uint8_t> bytes = Encode(w);
  const auto stamp = StampOf(kWheelsChannel, bytes.data(), bytes.size());
  ASSERT_TRUE(stamp.has_value());
  EXPECT_STREQ(stamp->type, "wheel_state_t");
  EXPECT_TRUE(stamp->decoded);
  EXPECT_EQ(stamp->utime, 123456789);
  EXPECT_FALSE(StampOf(kScanChannel, bytes.data(), bytes.size())->decoded);  // not a scan
  EXPECT_FALSE(StampOf("SOMETHING", bytes.data(), bytes.size()).has_value());
}

TEST(DashboardModel, ProcessHealthAndRestarts) {
  DashboardModel model;
  agvcal::heartbeat_t beat{};
  beat.process = "solver";
  beat.pid = 100;
  beat.state = "running";
  model.OnHeartbeat(beat, 0);
  model.OnHeartbeat(beat, kSecond);
  beat.pid = 200;  // restarted by the supervisor
  model.OnHeartbeat(beat, 2 * kSecond);
  beat.process = "scanmatch";
  model.OnHeartbeat(beat, 0);
  const std::vector<ProcessView> p = model.Processes(4 * kSecond);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0].name, "scanmatch");
  EXPECT_TRUE(p[0].stale);   // 4 s without a beat
  EXPECT_EQ(p[1].name, "solver");
  EXPECT_FALSE(p[1].stale);  // 2 s
  EXPECT_EQ(p[1].pid, 200);
  EXPECT_EQ(p[1].restarts, 1);
  EXPECT_NEAR(p[1].age_s, 2.0, 1e-12);
  EXPECT_EQ(p[1].state, "running");
}

// The group's recording marks (agvcal-recording drain, one short-lived pid per waiting process)
// are no process: a replay's dashboard does not list "group" as restarted, then stale all run.
TEST(DashboardModel, GroupMarksAreNoProcess) {
  DashboardModel model;
  agvcal::heartbeat_t mark{};
  mark.process = kGroupMarkProcess;
  mark.state = "draining the logger";
  for (int pid = 10; pid < 13; ++pid) {
    mark.pid = pid;
    model.OnHeartbeat(mark, pid * 100000);
  }
  agvcal::heartbeat_t beat{};
  beat.process = "solver";
  beat.pid = 100;
  beat.state = "running";
  model.OnHeartbeat(beat, 20 * kSecond);
  const std::vector<ProcessView> p = model.Processes(20 * kSecond);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].name, "solver");
  EXPECT_FALSE(p[0].stale);
  EXPECT_EQ(model.runs(), 1);
}

// The solver's channels come once per solve (every 20 motions, about 12 s on the samples): not
// stale between two solves while the solver beats; stale once it is silent too. A sensor's
// channel is stale after 3 s.
TEST(DashboardModel, SolverChannelsFreshWhileTheSolverBeats) {
  DashboardModel model;
  agvcal::heartbeat_t beat{};
  beat.process = kSolverProcess;
  beat.pid = 7;
  beat.state = "running";
  for (int i = 0; i <= 20; ++i) model.OnHeartbeat(beat, i * kSecond);
  model.OnMessage(kCalibEstimateChannel, "calib_estimate_t", true, std::nullopt, 12 * kSecond);
  model.OnMessage(kCalibResidualsChannel, "calib_residual_t", true, std::nullopt, 12 * kSecond);
  model.OnMessage(kWheelsChannel, "wheel_state_t", true, std::nullopt, 12 * kSecond);
  auto stale = [&](const std::string& name, int64_t now) {
    for (const ChannelView& c : model.Channels(now))
      if (c.name == name) return c.stale;
    ADD_FAILURE() << name << " not listed";
    return false;
  };
  EXPECT_FALSE(stale(kCalibEstimateChannel, 20 * kSecond));  // 8 s after the estimate, the solver beat 0 s ago
  EXPECT_FALSE(stale(kCalibResidualsChannel, 20 * kSecond));
  EXPECT_TRUE(stale(kWheelsChannel, 20 * kSecond));
  EXPECT_TRUE(stale(kCalibEstimateChannel, 25 * kSecond));   // the solver silent for 5 s
}

// Left running across two groups (issue 17 item 11): the second run's processes are not the
// first's restarts, and the first run's values are gone; hostile strings lose their control
// characters.
TEST(DashboardModel, NewRunStartsAfresh) {
  DashboardModel model;
  agvcal::heartbeat_t beat{};
  beat.process = "solver";
  beat.pid = 100;
  beat.state = "running";
  model.OnHeartbeat(beat, 0);
  agvcal::calib_estimate_t estimate{};
  estimate.utime = 50 * kSecond;
  estimate.num_values = 1;
  estimate.names = {"drive_radius"};
  estimate.values = {0.1};
  estimate.stds = {0.01};
  estimate.nominal = {0.1};
  estimate.intervals = 400;
  model.OnEstimate(estimate, kSecond);
  beat.state = "stopped";
  model.OnHeartbeat(beat, 2 * kSecond);
  // The next group, 1 s later: a new pid after "stopped".
  beat.pid = 300;
  beat.state = "running";
  model.OnHeartbeat(beat, 3 * kSecond);
  EXPECT_EQ(model.runs(), 2);
  std::vector<ProcessView> p = model.Processes(3 * kSecond);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p[0].restarts, 0);
  EXPECT_FALSE(model.Estimate(3 * kSecond).any);
  EXPECT_TRUE(model.Parameters().empty());
  // Within a run a new pid is a restart; after every process went silent, a new run.
  beat.pid = 301;
  model.OnHeartbeat(beat, 4 * kSecond);
  EXPECT_EQ(model.Processes(4 * kSecond)[0].restarts, 1);
  beat.pid = 400;
  model.OnHeartbeat(beat, 60 * kSecond);
  EXPECT_EQ(model.runs(), 3);
  EXPECT_EQ(model.Processes(60 * kSecond)[0].restarts, 0);
  beat.process = "evil\x1b[2J\nname";
  beat.state = "bad\tstate\r";
  model.OnHeartbeat(beat, 60 * kSecond);
  p = model.Processes(60 * kSecond);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p[0].name, "evil?[2J?name");
  EXPECT_EQ(p[0].state, "bad?state?");
}

TEST(DashboardModel, ParameterHistoryAndConvergence) {
  DashboardModel model;  // converged: last 3 changes each below 0.5 sigma
  const std::vector<double> radius = {0.1150, 0.1160, 0.11630, 0.11631, 0.11632, 0.11631};
  for (std::size_t i = 0; i < radius.size(); ++i) {
    // lidar2d.yaw keeps moving by 1 sigma (0.001) per estimate
    model.OnEstimate(MakeEstimate(radius[i], 0.00004, 0.001 * i, 0.001), i * kSecond);
  }
  const std::vector<ParameterView> params = model.Parameters();
  ASSERT_EQ(params.size(), 2u);
  EXPECT_EQ(params[0].name, "drive_radius");
  EXPECT_EQ(params[0].unit, "m");
  EXPECT_EQ(params[0].values, radius);
  EXPECT_DOUBLE_EQ(params[0].value, 0.11631);
  EXPECT_DOUBLE_EQ(params[0].std, 0.00004);
  EXPECT_DOUBLE_EQ(params[0].nominal, 0.115);
  EXPECT_NEAR(params[0].last_change_sigmas, 0.00001 / 0.00004, 1e-6);
  EXPECT_TRUE(params[0].converged);
  EXPECT_EQ(params[1].name, "lidar2d.yaw");
  EXPECT_EQ(params[1].unit, "rad");
  EXPECT_NEAR(params[1].last_change_sigmas, 1.0, 1e-9);
  EXPECT_FALSE(params[1].converged);
  // One more large step of the radius: no longer converged.
  model.OnEstimate(MakeEstimate(0.1165, 0.00004, 0.006, 0.001), 7 * kSecond);
  EXPECT_FALSE(model.Parameters()[0].converged);

  const EstimateView e = model.Estimate(8 * kSecond);
  EXPECT_TRUE(e.any);
  EXPECT_EQ(e.status, "ok");
  EXPECT_EQ(e.drive, "tricycle");
  EXPECT_EQ(e.estimates, 7);
  EXPECT_DOUBLE_EQ(e.condition, 41.5);
  ASSERT_EQ(e.weak.size(), 1u);
  EXPECT_EQ(e.weak[0], "lidar2d.yaw");
  EXPECT_NEAR(e.age_s, 1.0, 1e-12);
}

TEST(DashboardModel, ResidualHistogramBinsAndStats) {
  DashboardModel model;
  // x: -3, -1.2, 0.3, 1.1, 2.5, 3 mm and an outlier of 50 mm (left out of stats and histogram).
  const std::vector<double> xs = {-0.003, -0.0012, 0.0003, 0.0011, 0.0025, 0.003};
  int64_t t = kSecond;
  for (double x : xs) model.OnResidual(MakeResidual(t += 50000, x, 0.5 * x, 0.0));
  model.OnResidual(MakeResidual(t += 50000, 0.05, 0, 0, true /* outlier */));
  const ResidualStats s = model.Stats(0);
  EXPECT_EQ(s.count, 7);
  EXPECT_EQ(s.outliers, 1);
  EXPECT_NEAR(s.max_abs, 0.003, 1e-15);
  EXPECT_NEAR(s.rms, std::sqrt((9 + 1.44 + 0.09 + 1.21 + 6.25 + 9) * 1e-6 / 6), 1e-12);
  // Automatic range: [-3, 3] mm in 6 bins of 1 mm: -3 | -1.2 | | 0.3 | 1.1 | 2.5 and 3 (upper edge).
  Histogram h = model.ResidualHistogram(0, 6);
  EXPECT_NEAR(h.lo, -0.003, 1e-15);
  EXPECT_NEAR(h.hi, 0.003, 1e-15);
  EXPECT_EQ(h.counts, (std::vector<int>{1, 1, 0, 1, 1, 2}));
  EXPECT_EQ(h.below + h.above, 0);
  // Given range [-2.4, 2.4] mm, 5 bins: -3 below (first bin), 2.5 and 3 above (last bin).
  h = model.ResidualHistogram(0, 5, 0.0024);
  EXPECT_EQ(h.counts, (std::vector<int>{1, 1, 1, 1, 2}));
  EXPECT_EQ(h.below, 1);
  EXPECT_EQ(h.above, 2);
  // Series: inliers only, the last ones.
  EXPECT_EQ(model.ResidualSeries(1, 2), (std::vector<double>{0.00125, 0.0015}));
  // The solver starting over (a restart): history from that interval on is replaced.
  model.OnResidual(MakeResidual(kSecond + 100000, 0.0, 0.0, 0.0));
  EXPECT_EQ(model.residuals().size(), 2u);
}

TEST(DashboardModel, CommanderState) {
  DashboardModel model;
  EXPECT_FALSE(model.Commander(0).any);
  agvcal::commander_status_t s{};
  s.trajectory = "demo";
  s.segment = 2;
  s.num_segments = 7;
  s.segment_name = "arc left";
  s.state = "running";
  model.OnCommanderStatus(s, 10 * kSecond);
  CommanderView c = model.Commander(11 * kSecond);
  EXPECT_TRUE(c.any);
  EXPECT_EQ(c.state, "running");
  EXPECT_EQ(c.segment, 2);
  EXPECT_EQ(c.num_segments, 7);
  EXPECT_FALSE(c.stale);
  EXPECT_TRUE(model.Commander(14 * kSecond).stale);
}

// Cells are counted as code points (every glyph used is one cell wide).
int Cells(const std::string& s) {
  int n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return n;
}

TEST(TextPlot, Sparkline) {
  EXPECT_EQ(Sparkline({0, 1, 2, 3, 4, 5, 6, 7}, 8, Glyphs::kUnicode), "▁▂▃▄▅▆▇█");
  EXPECT_EQ(Sparkline({0, 7}, 4, Glyphs::kAscii), "   #");
  EXPECT_EQ(Sparkline({0, 7, 3.5}, 3, Glyphs::kAscii), " #=");  // 3.5 of 7: level 4 of 0..7
  EXPECT_EQ(Sparkline({1, 100, 2, 3}, 2, Glyphs::kUnicode), "▁█");  // the last two only
  EXPECT_EQ(Cells(Sparkline({5, 5, 5}, 10, Glyphs::kUnicode)), 10);
}

TEST(TextPlot, DotPlotBraille) {
  // Four values rising in a 2-cell wide, 1-cell high plot: dots at rows 3, 2, 1, 0 from the top.
  const std::vector<std::string> rows = DotPlot({0, 1, 2, 3}, 2, 1, 0, 3, Glyphs::kUnicode);
  ASSERT_EQ(rows.size(), 1u);
  // Cell 0: left bottom 0x40 + right third row 0x20; cell 1: left second row 0x02 + right top 0x08.
  EXPECT_EQ(rows[0], "\u2860\u280a");
  // A jump is joined vertically; clamped values stay inside.
  const std::vector<std::string> tall = DotPlot({-10, 10}, 1, 2, -1, 1, Glyphs::kUnicode);
  ASSERT_EQ(tall.size(), 2u);
  EXPECT_EQ(tall[0], "\u28b8");  // right column, all 4 dots of the top cell
  EXPECT_EQ(tall[1], "\u2878");  // bottom cell: left bottom dot 0x40 + right rows 0-2 0x08|0x10|0x20
  for (const auto& r : DotPlot({1, 2}, 30, 3, 0, 3, Glyphs::kUnicode)) EXPECT_EQ(Cells(r), 30);
}

TEST(TextPlot, DotPlotAsciiAndBars) {
  const std::vector<std::string> rows = DotPlot({0, 1, 2}, 4, 3, 0, 2, Glyphs::kAscii);
  EXPECT_EQ(rows, (std::vector<std::string>{"   '", "  - ", " _  "}));  // levels 0, 4, 8 of 0..8
  EXPECT_EQ(BarColumns({0, 1, 4, 2}, 2, Glyphs::kAscii), (std::vector<std::string>{"  # ", " ###"}));
  // Block glyphs: 4 of max 4 fills 16 eighths; 1 -> 4 eighths (half a cell); 2 -> one full cell.
  EXPECT_EQ(BarColumns({1, 4, 2}, 2, Glyphs::kUnicode),
            (std::vector<std::string>{" █ ", "▄██"}));
}

// The solver's message (e.g. an unobservable parameter and the motion that determines it) on
// the dashboard: whole words in lines of the screen's width; a message too long for its rows
// ends at a word with "...", never cut mid-word or dropped without a sign.
TEST(TextPlot, WrapWordsKeepsWholeWords) {
  const std::string message =
      "track: not determined by this recording (its sigma exceeds its value); drive turns in place "
      "in both directions to determine the track, then the robot file's value can be replaced";
  const std::vector<std::string> all = WrapWords(message, 40, 10);
  std::string joined;
  for (const std::string& line : all) {
    EXPECT_LE(Cells(line), 40) << line;
    joined += (joined.empty() ? "" : " ") + line;
  }
  EXPECT_EQ(joined, message);  // every word, in order, none cut
  const std::vector<std::string> two = WrapWords(message, 40, 2);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0], all[0]);
  EXPECT_LE(Cells(two[1]), 40);
  ASSERT_GE(two[1].size(), 3u);
  EXPECT_EQ(two[1].substr(two[1].size() - 3), "...");
  const std::string shown = two[1].substr(0, two[1].size() - 3);
  EXPECT_EQ(message.find(two[0] + " " + shown + " "), 0u) << "the last line ends at a word: " << two[1];
  EXPECT_EQ(WrapWords("", 40, 2), std::vector<std::string>{""});
  EXPECT_EQ(WrapWords("short", 40, 1), std::vector<std::string>{"short"});
  EXPECT_EQ(WrapWords("abcdefghij", 6, 1), std::vector<std::string>{"abcdef"});  // a word longer than a line
}

}  // namespace
}  // namespace calib
