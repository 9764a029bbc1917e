#include "dashboard/dashboard_view.h"

#include <ncurses.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <string>
#include <vector>

#include "calib/core/units.h"

namespace agvcal_dashboard {

namespace {

using calib::Glyphs;

enum Color { kPlain = 0, kGood = 1, kWarn = 2, kBad = 3, kTitle = 4 };

const char* kComponentNames[3] = {"x", "y", "yaw"};
// Residuals are shown in mm and mrad, as on the console and the reports (docs/units.md).
const double kComponentScale[3] = {1e3, 1e3, 1e3};
const char* kComponentUnits[3] = {"mm", "mm", "mrad"};

bool g_color = false;

// Cells of a UTF-8 string (every glyph we draw is one cell wide).
int Cells(const std::string& s) {
  int n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return n;
}

// The first `cells` cells of a UTF-8 string.
std::string Clip(const std::string& s, int cells) {
  if (cells <= 0) return "";
  int n = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if ((static_cast<unsigned char>(s[i]) & 0xC0) != 0x80 && n++ == cells) return s.substr(0, i);
  }
  return s;
}

// Writes `text` at (y, x), clipped to the screen; the last line stays for the footer.
void Put(int y, int x, const std::string& text, Color color = kPlain, bool bold = false) {
  if (y < 0 || y >= LINES || x >= COLS) return;
  const attr_t attr = (g_color && color != kPlain ? COLOR_PAIR(color) : 0) | (bold ? A_BOLD : 0);
  if (attr) attron(attr);
  mvaddstr(y, x, Clip(text, COLS - x).c_str());
  if (attr) attroff(attr);
}

Color StatusColor(const std::string& status) {
  if (status == "ok" || status == "final") return kGood;
  if (status == "unobservable") return kBad;
  return kWarn;
}

std::string Age(double seconds) {
  return seconds < 100 ? calib::Formatted("%.1f s", seconds) : calib::Formatted("%.0f s", seconds);
}

// Rows a section may use from `y` on, keeping the footer line free.
int RowsLeft(int y) { return std::max(0, LINES - 1 - y); }

void DrawHeader(const ViewState& state) {
  Put(0, 0, std::string(COLS, ' '), kTitle);
  Put(0, 0, "agvcal dashboard", kTitle, true);
  static const char* kNames[] = {"", "1 overview", "2 residuals", "3 parameters", "4 bus"};
  int x = 18;
  for (int v = 1; v <= 4; ++v) {
    const bool current = static_cast<int>(state.view) == v;
    const std::string label = current ? calib::Formatted("[%s]", kNames[v]) : calib::Formatted(" %s ", kNames[v]);
    Put(0, x, label, kTitle, current);
    x += Cells(label) + 1;
  }
  const std::string mode = state.paused ? "PAUSED" : "LIVE";
  Put(0, std::max(x, COLS - 7), mode, state.paused ? kWarn : kTitle, true);
}

void DrawFooter(const calib::DashboardModel& model, int64_t now_us) {
  const calib::EstimateView e = model.Estimate(now_us);
  std::string left = e.any ? calib::Formatted("solver: %s, estimate %d, %s ago", e.status.c_str(), e.estimates,
                                    Age(e.age_s).c_str())
                           : std::string("solver: no CALIB_ESTIMATE yet");
  const std::string keys = "1-4 view  p pause  ? help  q quit";
  Put(LINES - 1, 0, std::string(COLS, ' '));
  Put(LINES - 1, 0, left, e.any ? StatusColor(e.status) : kWarn);
  if (COLS - Cells(keys) > Cells(left) + 1) Put(LINES - 1, COLS - Cells(keys), keys);
}

// Status, intervals, outliers, condition; then the reason when not ok (up to
// `message_lines` lines, ending at a word with "..." when it needs more) or the weak parameters. Returns the next row.
int DrawEstimateStatus(const calib::EstimateView& e, int y, int message_lines) {
  if (!e.any) {
    Put(y, 0, "Calibration: waiting for the solver (CALIB_ESTIMATE)", kWarn);
    return y + 1;
  }
  Put(y, 0, "Calibration:");
  Put(y, 13, e.status, StatusColor(e.status), true);
  Put(y, 14 + Cells(e.status),
      calib::Formatted("%s  intervals %d  outliers %d  condition %.1f", e.drive.c_str(), e.intervals, e.outliers,
             e.condition));
  ++y;
  if (!e.message.empty()) {  // the reason (e.g. the unobservable parameter and the motion to add)
    for (const std::string& line : calib::WrapWords(e.message, std::max(10, COLS - 2), message_lines))
      Put(y++, 2, line, StatusColor(e.status));
  } else {
    std::string weak = "observability: all parameters determined";
    if (!e.weak.empty()) {
      weak = "weak:";
      for (const auto& w : e.weak) weak += " " + w;
    }
    Put(y++, 2, weak, e.weak.empty() ? kGood : kWarn);
  }
  return y;
}

std::string Value(double v) { return calib::Formatted("%.6f", v); }
std::string Sigma(double s) { return s < 0 ? std::string("-") : calib::Formatted("%.6f", s); }

// A unit padded to `cells` cells ("s²/m" is 5 bytes, 4 cells).
std::string UnitCell(const std::string& unit, int cells) {
  return unit + std::string(static_cast<std::size_t>(std::max(0, cells - Cells(unit))), ' ');
}

// Parameter table, one row each with a convergence sparkline; the unit column (SI, the
// robot file's) where the screen is wide enough to keep a sparkline beside it. Returns the
// next row.
int DrawParameterTable(const calib::DashboardModel& model, int y, Glyphs glyphs, int max_rows) {
  const std::vector<calib::ParameterView> params = model.Parameters();
  if (params.empty() || max_rows < 2) return y;
  const bool units = COLS >= 72;
  Put(y++, 0, units ? "parameter           value      sigma    nominal unit  convergence"
                    : "parameter           value      sigma    nominal  convergence", kPlain, true);
  const int spark_x = units ? 54 : 48, spark_w = std::max(0, COLS - spark_x - 11);
  for (std::size_t i = 0; i < params.size() && static_cast<int>(i) + 1 < max_rows; ++i, ++y) {
    const calib::ParameterView& p = params[i];
    Put(y, 0, calib::Formatted("%-14s %10s %10s %10.4f", Clip(p.name, 14).c_str(), Value(p.value).c_str(),
                     Sigma(p.std).c_str(), p.nominal) + (units ? " " + UnitCell(p.unit, 5) : ""));
    Put(y, spark_x, calib::Sparkline(p.values, spark_w, glyphs));
    if (p.converged)
      Put(y, spark_x + spark_w + 1, "converged", kGood);
    else if (p.last_change_sigmas >= 0)
      Put(y, spark_x + spark_w + 1, calib::Formatted("%.1f sig", p.last_change_sigmas), kWarn);
  }
  return y;
}

// One component's residuals as a time plot with a y scale on its left. Returns the range used.
double DrawResidualPlot(const calib::DashboardModel& model, int k, int y, int x, int width, int height,
                        Glyphs glyphs) {
  const int points = glyphs == Glyphs::kUnicode ? 2 * width : width;
  std::vector<double> series = model.ResidualSeries(k, points);
  double range = 0;
  for (double& v : series) range = std::max(range, std::abs(v *= kComponentScale[k]));
  if (range <= 0) range = 1;
  const std::vector<std::string> rows = calib::DotPlot(series, width, height, -range, range, glyphs);
  for (int r = 0; r < height && r < RowsLeft(y) ; ++r) Put(y + r, x, rows[r], kGood);
  return range;
}

void DrawOverview(const calib::DashboardModel& model, int64_t now_us, const ViewState& state) {
  int y = DrawEstimateStatus(model.Estimate(now_us), 1, 4);
  // The parameters first; the residuals, channels, processes and commander below as rows allow.
  y = DrawParameterTable(model, y, state.glyphs, RowsLeft(y) - 2);
  if (RowsLeft(y) >= 7 && !model.residuals().empty()) {
    ++y;
    std::string head = "residual rms";
    for (int k = 0; k < 3; ++k) {
      const calib::ResidualStats s = model.Stats(k);
      head += calib::Formatted("  %s %.3g %s", kComponentNames[k], s.rms * kComponentScale[k], kComponentUnits[k]);
    }
    // Not the header's counts (the last solve's intervals and outliers): each interval's residual
    // is sent once, flagged an outlier or not by the solve that sent it (fits 80 columns).
    head += calib::Formatted("  (%d sent, %d flagged)", model.Stats(0).count, model.Stats(0).outliers);
    Put(y++, 0, head, kPlain, true);
    for (int k = 0; k < 3; ++k, ++y) {
      const double range = DrawResidualPlot(model, k, y, 18, COLS - 18, 1, state.glyphs);
      Put(y, 0, calib::Formatted("%-3s +-%.3g %s", kComponentNames[k], range, kComponentUnits[k]));
    }
  }
  // Channels, three to a row, then processes and the commander on one row each.
  const std::vector<calib::ChannelView> channels = model.Channels(now_us);
  if (RowsLeft(y) >= 5 && !channels.empty()) {
    Put(++y, 0, "channels (Hz of data)", kPlain, true);
    ++y;
    const int per_row = std::max(1, COLS / 26);
    for (std::size_t i = 0; i < channels.size() && RowsLeft(y) > 2; ++i) {
      const calib::ChannelView& c = channels[i];
      const int x = static_cast<int>(i % per_row) * 26;
      const double hz = c.data_rate_hz > 0 ? c.data_rate_hz : c.rate_hz;
      Put(y, x, calib::Formatted("%-16s", Clip(c.name, 16).c_str()));
      Put(y, x + 17, c.stale ? std::string("STALE") : calib::Formatted("%7.1f", hz), c.stale ? kBad : kGood);
      if (i % per_row == static_cast<std::size_t>(per_row - 1) || i + 1 == channels.size()) ++y;
    }
  }
  if (RowsLeft(y) >= 1) {
    int x = 0;
    Put(y, x, "processes", kPlain, true);
    x += 10;
    for (const calib::ProcessView& p : model.Processes(now_us)) {
      const std::string s = p.name + (p.stale ? " STALE" : " ok") + (p.restarts ? calib::Formatted("(%dr)", p.restarts) : "");
      if (x > 10 && x + Cells(s) > COLS && RowsLeft(y + 1) >= 1) x = 10, ++y;  // the next row, not off the edge
      Put(y, x, s, p.stale ? kBad : kGood);
      x += Cells(s) + 2;
    }
    if (model.Processes(now_us).empty()) Put(y, x, "no HEARTBEAT yet", kWarn);
    ++y;
  }
  if (RowsLeft(y) >= 1) {
    const calib::CommanderView c = model.Commander(now_us);
    Put(y, 0, "commander", kPlain, true);
    if (!c.any)
      Put(y, 10, "none (no COMMANDER_STATUS)");
    else
      Put(y, 10,
          calib::Formatted("%s  %s  segment %d/%d %s%s", c.state.c_str(), c.trajectory.c_str(), c.segment + 1,
                 c.num_segments, c.segment_name.c_str(), c.stale ? "  STALE" : ""),
          c.stale || c.state != "running" ? kWarn : kGood);
  }
}

void DrawResiduals(const calib::DashboardModel& model, const ViewState& state) {
  if (model.residuals().empty()) {
    Put(2, 0, "no CALIB_RESIDUALS yet (the solver publishes them as it re-solves)", kWarn);
    return;
  }
  const int block = std::max(2, (LINES - 2) / 3);  // rows per component, its title included
  // About sqrt(n) bins, each as wide as a third of the screen allows.
  const int hist_space = std::clamp(COLS / 3, 8, 60);
  const int bins = std::clamp(static_cast<int>(std::sqrt(model.residuals().size())) + 1, 5, hist_space);
  const int bin_w = hist_space / bins, hist_w = bins * bin_w;
  const int plot_x = 9, plot_w = std::max(4, COLS - plot_x - hist_space - 3);
  const int hist_x = COLS - hist_space;
  for (int k = 0; k < 3; ++k) {
    const int y = 1 + k * block;
    const calib::ResidualStats s = model.Stats(k);
    const double scale = kComponentScale[k];
    Put(y, 0,
        calib::Formatted("%-3s rms %.3g %s  max %.3g %s  n %d  outliers %d", kComponentNames[k], s.rms * scale,
               kComponentUnits[k], s.max_abs * scale, kComponentUnits[k], s.count, s.outliers),
        kPlain, true);
    const int height = std::max(1, block - 1);
    const double range = DrawResidualPlot(model, k, y + 1, plot_x, plot_w, height, state.glyphs);
    Put(y + 1, 0, calib::Formatted("%+.3g", range));
    Put(y + height, 0, calib::Formatted("%+.3g", -range));
    // Histogram of all inliers over the same symmetric range, with its axis on the bottom row.
    const int bar_h = std::max(1, height - 1);
    const calib::Histogram h = model.ResidualHistogram(k, bins, range / scale);
    std::vector<int> columns;
    for (int c : h.counts) columns.insert(columns.end(), bin_w, c);
    const std::vector<std::string> bars = calib::BarColumns(columns, bar_h, state.glyphs);
    for (int r = 0; r < bar_h; ++r) Put(y + 1 + r, hist_x, bars[r], kTitle);
    const std::string lo = calib::Formatted("%.2g", -range), hi = calib::Formatted("%+.2g", range);
    std::string axis(hist_w, ' ');
    axis.replace(0, lo.size(), lo);
    axis.replace(std::max<int>(0, hist_w - static_cast<int>(hi.size())), hi.size(), hi);
    axis[hist_w / 2] = '0';
    if (height > 1) Put(y + height, hist_x, axis);
    Put(y, hist_x, calib::Formatted("histogram %s", kComponentUnits[k]));
  }
}

void DrawParameters(const calib::DashboardModel& model, int64_t now_us, const ViewState& state) {
  int y = DrawEstimateStatus(model.Estimate(now_us), 1, 5) + 1;
  const std::vector<calib::ParameterView> params = model.Parameters();
  if (params.empty()) return;
  const bool two_rows = RowsLeft(y) >= 2 * static_cast<int>(params.size());
  const int spark_w = two_rows ? std::max(0, (COLS - 24) / 2) : 0;
  for (const calib::ParameterView& p : params) {
    if (RowsLeft(y) < 1) break;
    const std::string unit = p.unit.empty() ? "" : " " + p.unit;
    std::string line = calib::Formatted("%-14s %10s +- %s%s  nominal %.4f%s", Clip(p.name, 14).c_str(),
                                        Value(p.value).c_str(), Sigma(p.std).c_str(), unit.c_str(), p.nominal,
                                        unit.c_str());
    Put(y, 0, line, kPlain, true);
    const std::string conv = p.converged ? "converged"
                             : p.last_change_sigmas >= 0 ? calib::Formatted("last step %.1f sig", p.last_change_sigmas)
                                                         : "";
    if (two_rows) {
      Put(y, std::max(Cells(line) + 2, COLS - Cells(conv)), conv, p.converged ? kGood : kWarn);
      ++y;
      Put(y, 2, "value");
      Put(y, 9, calib::Sparkline(p.values, spark_w, state.glyphs), kGood);
      Put(y, 11 + spark_w, "sigma");
      Put(y, 18 + spark_w, calib::Sparkline(p.stds, spark_w, state.glyphs), kTitle);
    } else {
      const int x = std::max(60, Cells(line) + 2);  // after the line, units included
      Put(y, x, calib::Sparkline(p.values, std::max(0, COLS - x - 2), state.glyphs), p.converged ? kGood : kWarn);
    }
    ++y;
  }
}

void DrawBus(const calib::DashboardModel& model, int64_t now_us) {
  int y = 1;
  Put(y++, 0, "channel            type                 count   bus Hz  data Hz     age  state", kPlain, true);
  const std::vector<calib::ChannelView> channels = model.Channels(now_us);
  const std::vector<calib::ProcessView> processes = model.Processes(now_us);
  const int reserve = 3 + static_cast<int>(processes.size());
  for (const calib::ChannelView& c : channels) {
    if (RowsLeft(y) <= std::min(reserve, RowsLeft(y) - 1)) break;
    const std::string data_hz = c.data_rate_hz > 0 ? calib::Formatted("%8.1f", c.data_rate_hz) : "       -";
    Put(y, 0, calib::Formatted("%-18s %-18s %7lld %8.1f %s %7s", Clip(c.name, 18).c_str(),
                     c.type.empty() ? "?" : Clip(c.type, 18).c_str(),
                     static_cast<long long>(c.count), c.rate_hz, data_hz.c_str(), Age(c.age_s).c_str()));
    std::string state = c.stale ? "STALE" : "ok";
    if (c.undecodable) state += calib::Formatted(" %lld bad", static_cast<long long>(c.undecodable));
    Put(y++, 72, state, c.stale || c.undecodable ? kBad : kGood);
  }
  if (RowsLeft(y) >= 2) {
    Put(++y, 0, "process           pid  state                          beat age  restarts  health", kPlain,
        true);
    ++y;
    if (processes.empty()) Put(y++, 0, "no HEARTBEAT yet", kWarn);
  }
  for (const calib::ProcessView& p : processes) {
    if (RowsLeft(y) < 2) break;
    // The state wrapped in its column (a stopped process says what it did), up to 3 rows.
    const std::vector<std::string> state = calib::WrapWords(p.state, 30, 3);
    Put(y, 0, calib::Formatted("%-14s %6d  %-30s %7s %9d", Clip(p.name, 14).c_str(), p.pid,
                               state.empty() ? "" : state[0].c_str(), Age(p.age_s).c_str(), p.restarts));
    Put(y++, 72, p.stale ? "STALE" : "ok", p.stale ? kBad : kGood);
    for (std::size_t i = 1; i < state.size() && RowsLeft(y) >= 2; ++i) Put(y++, 22, state[i]);
  }
  if (RowsLeft(y) >= 1) {
    const calib::CommanderView c = model.Commander(now_us);
    ++y;
    Put(y, 0, "commander", kPlain, true);
    if (!c.any)
      Put(y, 10, "none (no COMMANDER_STATUS)");
    else
      Put(y, 10,
          calib::Formatted("%s, trajectory %s, segment %d/%d %s, %s ago", c.state.c_str(), c.trajectory.c_str(),
                 c.segment + 1, c.num_segments, c.segment_name.c_str(), Age(c.age_s).c_str()),
          c.stale || c.state != "running" ? kWarn : kGood);
  }
}

void DrawHelp() {
  static const char* kLines[] = {
      "agvcal-dashboard keys",
      "",
      "1  overview: estimate, residuals, channels",
      "2  residuals: time plot and histogram",
      "3  parameters: estimates and convergence",
      "4  bus: channels, processes, commander",
      "p  pause / resume the display",
      "?  this help (any key closes it)",
      "q  quit (also Ctrl-C)",
  };
  const int h = sizeof kLines / sizeof kLines[0] + 2, w = 46;
  const int y0 = std::max(1, (LINES - h) / 2), x0 = std::max(0, (COLS - w) / 2);
  for (int r = 0; r < h; ++r) Put(y0 + r, x0, std::string(w, ' '), kTitle);
  for (int r = 0; r < h - 2; ++r) Put(y0 + 1 + r, x0 + 2, kLines[r], kTitle, r == 0);
}

}  // namespace

void InitColors(ViewState* state) {
  state->color = has_colors();
  if (!state->color) return;
  start_color();
  use_default_colors();
  init_pair(kGood, COLOR_GREEN, -1);
  init_pair(kWarn, COLOR_YELLOW, -1);
  init_pair(kBad, COLOR_RED, -1);
  init_pair(kTitle, COLOR_CYAN, -1);
}

void Draw(const calib::DashboardModel& model, int64_t now_us, const ViewState& state) {
  g_color = state.color;
  erase();
  DrawHeader(state);
  switch (state.view) {
    case View::kOverview: DrawOverview(model, now_us, state); break;
    case View::kResiduals: DrawResiduals(model, state); break;
    case View::kParameters: DrawParameters(model, now_us, state); break;
    case View::kBus: DrawBus(model, now_us); break;
  }
  DrawFooter(model, now_us);
  if (state.help) DrawHelp();
  refresh();
}

}  // namespace agvcal_dashboard
