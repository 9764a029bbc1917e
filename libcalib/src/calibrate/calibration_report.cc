// agvcal solve / recal --report DIR: the calibration as a person looks at it.

#include "calib/calibrate/calibration_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <tuple>

#include "calib/core/se2.h"
#include "calib/io/atomic_file.h"
#include "calib/io/provenance.h"
#include "calib/core/units.h"
#include "io/report_page.h"
#include "io/svg_plot.h"

namespace calib {
namespace {

const char* kNominal = "#999999";
const char* kCalibrated = "#1f5fbf";
const char* kOutlier = "#d62728";


// The value in the unit a person reads it in: mm beside m, deg beside rad, ms beside s (a
// negative sigma: rounded to |sigma| without showing it, ValueWithSigma).
std::string Readable(double value, double sigma, const std::string& unit) {
  if (unit == "m") return ValueWithSigma(value * 1e3, sigma * 1e3) + " mm";
  if (unit == "rad") return ValueWithSigma(value * 180 / M_PI, sigma * 180 / M_PI) + " deg";
  if (unit == "s") return ValueWithSigma(value * 1e3, sigma * 1e3) + " ms";
  if (unit == "rad/s") return ValueWithSigma(value * 180 / M_PI, sigma * 180 / M_PI) + " deg/s";
  return ValueWithSigma(value, sigma);
}

// name, estimate: the values a calibration result holds, in the order it prints them.
std::vector<std::pair<std::string, Estimate>> Estimates(const CalibrationResult& r) {
  std::vector<std::pair<std::string, Estimate>> out;
  for (const std::string& name : r.param_names) out.push_back({name, r.params.at(name)});
  if (r.imu) {
    out.push_back({"imu.gyro_bias", r.imu->gyro_bias});
    out.push_back({"imu.gyro_scale", r.imu->gyro_scale});
    out.push_back({"imu.yaw", r.imu->yaw});
    out.push_back({"imu.time_offset", r.imu->time_offset});
  } else {
    const std::string mount = MotionSourceName(r.source);
    out.push_back({mount + ".x", r.mount_x});
    out.push_back({mount + ".y", r.mount_y});
    out.push_back({mount + ".yaw", r.mount_yaw});
  }
  if (r.time_offset) out.push_back({"time_offset", *r.time_offset});
  return out;
}

std::vector<std::vector<std::string>> ParameterRows(const CalibrationResult& r) {  // kParameterHeader
  std::vector<std::vector<std::string>> rows;
  for (const auto& [name, e] : Estimates(r)) {
    const std::string unit = ParamUnit(name);
    const double change = e.value - e.nominal;
    const std::string suffix = unit.empty() ? "" : " " + unit;
    rows.push_back({name, ValueWithSigma(e.value, e.std) + suffix, Readable(e.value, e.std, unit),
                    ValueWithSigma(e.nominal, 0) + suffix, Readable(change, -e.std, unit),
                    e.std > 0 ? FixedDecimals(change / e.std, 1) : "held"});
  }
  return rows;
}

std::vector<std::string> ParameterHeader(const std::string& before) {
  return {"parameter", "calibrated ± 1σ", "the same in", before, "change", "change / σ"};
}

std::string ObservabilityText(const CalibrationResult& r) {
  std::ostringstream s;
  s << "Condition number of the correlation-normalised Fisher information: " << FixedDecimals(r.condition, 1)
    << " (1: every value determined independently; large: values trade off against each other). "
    << "Weakly determined: ";
  if (r.weak.empty()) s << "none.";
  for (std::size_t i = 0; i < r.weak.size(); ++i) s << (i ? ", " : "") << r.weak[i] << (i + 1 == r.weak.size() ? "." : "");
  return s.str();
}

// Contiguous runs of held-out intervals, in seconds since the origin.
std::vector<std::pair<double, double>> HeldoutSpans(const std::vector<IntervalResidual>& iv, int64_t t0) {
  std::vector<std::pair<double, double>> spans;
  for (std::size_t i = 0; i < iv.size(); ++i) {
    if (!iv[i].heldout) continue;
    const double a = (iv[i].utime_start - t0) * 1e-6, b = (iv[i].utime_end - t0) * 1e-6;
    if (i > 0 && iv[i - 1].heldout && !spans.empty()) spans.back().second = b;
    else spans.push_back({a, b});
  }
  return spans;
}

// Every k-th interval so that at most `limit` are drawn (a plot of tens of thousands of dots
// says no more and weighs megabytes).
std::size_t Stride(std::size_t n, std::size_t limit) { return std::max<std::size_t>(1, (n + limit - 1) / limit); }

std::string ResidualTimePlot(const std::vector<IntervalResidual>& iv, int64_t t0, const std::string& before) {
  const std::size_t stride = Stride(iv.size(), 1500);
  SvgPlot plot("Residual per interval: " + before + " (grey), calibrated (blue), outliers (red)" +
               std::string(stride > 1 ? ", every " + std::to_string(stride) + "th interval" : ""));
  const char* names[3] = {"x residual (mm)", "y residual (mm)", "yaw residual (mrad)"};
  const std::vector<std::pair<double, double>> spans = HeldoutSpans(iv, t0);
  for (int c = 0; c < 3; ++c) {
    SvgPlot::Panel& p = plot.AddPanel(names[c], SvgPlot::kTimeAxis, c == 2 ? "mrad" : "mm");
    SvgPlot::Series b{{}, {}, kNominal, before, true, {}, {}}, a{{}, {}, kCalibrated, "calibrated", true, {}, {}},
        o{{}, {}, kOutlier, "outlier", true, {}, {}};
    for (std::size_t i = 0; i < iv.size(); i += stride) {
      const double t = ((iv[i].utime_start + iv[i].utime_end) / 2 - t0) * 1e-6;
      b.x.push_back(t), b.y.push_back(iv[i].nominal_error[c] * 1e3);
      SvgPlot::Series& s = iv[i].outlier ? o : a;
      s.x.push_back(t), s.y.push_back(iv[i].error[c] * 1e3);
    }
    p.series = {b, a, o};
    p.spans = spans;
    p.span_label = "held out (not fitted)";
    p.span_color = SvgPlot::kHeldoutSpanColor;
  }
  return plot.Render();
}

std::string ResidualHistogramPlot(const std::vector<IntervalResidual>& iv, const std::string& before) {
  SvgPlot plot("Residual distribution of the fitted intervals (outliers left out): " + before + " (grey), calibrated (blue)");
  const char* names[3] = {"x residual", "y residual", "yaw residual"};
  for (int c = 0; c < 3; ++c) {
    std::vector<double> nominal, after;
    for (const IntervalResidual& r : iv)
      if (!r.heldout && !r.outlier) nominal.push_back(r.nominal_error[c] * 1e3), after.push_back(r.error[c] * 1e3);
    // The range: the calibrated residuals' 99th percentile of |e|, three times over.
    std::vector<double> mag;
    for (double v : after) mag.push_back(std::abs(v));
    std::sort(mag.begin(), mag.end());
    double range = mag.empty() ? 1.0 : 3 * mag[std::min(mag.size() - 1, mag.size() * 99 / 100)];
    if (!(range > 0)) range = 1.0;
    const std::string unit = c == 2 ? "mrad" : "mm";
    SvgPlot::Panel& p = plot.AddPanel(std::string(names[c]) + " (" + unit + "; the outermost bins hold the tails)",
                                      unit, "share of intervals");
    p.series = {HistogramSeries(nominal, -range, range, 41, kNominal, before),
                HistogramSeries(after, -range, range, 41, kCalibrated, "calibrated")};
  }
  return plot.Render();
}

std::string HeldoutWindowsPlot(const HeldoutComparison& h, int64_t t0) {
  SvgPlot plot("Held-out windows of " + SignificantText(h.window_m, 2) +
               " m path: odometry error at each window's end, nominal (grey) and calibrated (blue)");
  SvgPlot::Panel& p = plot.AddPanel("position error at the window's end (mm)", SvgPlot::kTimeAxis, "mm");
  SvgPlot::Series b{{}, {}, kNominal, "nominal", true, {}, {}}, a{{}, {}, kCalibrated, "calibrated", true, {}, {}};
  SvgPlot::Series hb = b, ha = a;
  for (const auto& [err, series, heading] : {std::tuple{&h.nominal, &b, &hb}, std::tuple{&h.calibrated, &a, &ha}}) {
    for (const WindowError& w : err->per_window) {
      const double t = ((w.utime_start + w.utime_end) / 2 - t0) * 1e-6;
      series->x.push_back(t), series->y.push_back(w.translation_m * 1e3);
      heading->x.push_back(t), heading->y.push_back(std::abs(w.heading_rad) * 1e3);
    }
  }
  p.series = {b, a};
  SvgPlot::Panel& ph = plot.AddPanel("heading error at the window's end, magnitude (mrad)", SvgPlot::kTimeAxis, "mrad");
  ph.series = {hb, ha};
  return plot.Render();
}

std::string RoutePlot(const std::vector<IntervalResidual>& iv, const std::string& source) {
  SvgPlot plot("Route: the " + source + "'s measured motions chained (fitted grey, held out blue, outliers red)", 900, 600);
  SvgPlot::Panel& p = plot.AddPanel("route (drifts: chained measurements, not a map)", "x (m)", "y (m)");
  p.equal_axes = true;
  SvgPlot::Series fit{{}, {}, "#bbbbbb", "fitted", false, {}, {}}, held{{}, {}, kCalibrated, "held out", true, {}, {}},
      out{{}, {}, kOutlier, "outliers", true, {}, {}};
  Pose2 pose;
  fit.x.push_back(0), fit.y.push_back(0);
  const std::size_t stride = Stride(iv.size(), 1500);
  for (std::size_t i = 0; i < iv.size(); ++i) {
    pose = Compose(pose, Pose2{iv[i].measured[0], iv[i].measured[1], iv[i].measured[2]});
    if (i % stride) continue;
    fit.x.push_back(pose.x), fit.y.push_back(pose.y);
    if (iv[i].heldout) held.x.push_back(pose.x), held.y.push_back(pose.y);
    if (iv[i].outlier) out.x.push_back(pose.x), out.y.push_back(pose.y);
  }
  p.series = {fit, held, out};
  return plot.Render();
}

std::vector<std::vector<std::string>> HeldoutRows(const HeldoutComparison& h) {
  auto row = [](const std::string& name, const OdometryError& e) {
    return std::vector<std::string>{name, std::to_string(e.windows), FixedDecimals(e.error_per_metre * 1e3, 2) + " mm/m",
                                    FixedDecimals(e.rms_translation_m * 1e3, 2) + " mm",
                                    FixedDecimals(e.rms_heading_rad * 1e3, 2) + " mrad"};
  };
  return {row("nominal (robot file)", h.nominal), row("calibrated", h.calibrated)};
}

// The figures and tables of one calibration, written to `dir` and added to `page`.
// `before`: what the calibration started from ("robot file", "in use").
void AddCalibration(const CalibrationResult& r, int64_t t0, const std::string& before, const std::string& dir,
                    ReportPage* page) {
  page->Heading("Parameters");
  page->Table(ParameterHeader(before), ParameterRows(r));
  page->Heading("Observability");
  page->Paragraph(ObservabilityText(r));
  if (r.intervals.empty()) {
    page->Paragraph("This calibration keeps no per-interval residuals (IMU-referenced): no residual plots.");
    return;
  }
  page->Heading("Residuals");
  WriteFileAtomically(dir + "/residual_time.svg", ResidualTimePlot(r.intervals, t0, before));
  page->Figure("residual_time.svg", "Measured minus predicted sensor motion per interval over time, with the values " +
                                        before + " and with the calibration; shaded: held out of the fit");
  WriteFileAtomically(dir + "/residual_histogram.svg", ResidualHistogramPlot(r.intervals, before));
  page->Figure("residual_histogram.svg", "Distribution of the fitted intervals' residuals, " + before + " and calibrated");
  if (r.heldout) {
    page->Heading("Held-out windows");
    const HeldoutComparison& h = *r.heldout;
    page->Paragraph("Odometry chained over windows of " + SignificantText(h.window_m, 2) + " m of path on the " +
                    std::to_string(h.intervals) + " held-out intervals, which the fit did not see. Calibrated better in " +
                    std::to_string(h.paired.second_better) + " of " + std::to_string(h.paired.windows - h.paired.ties) +
                    " windows (sign test " + PValueText(h.paired.sign_test_p) + ").");
    page->Table({"model", "windows", "error per metre", "RMS position error", "RMS heading error"}, HeldoutRows(h));
    WriteFileAtomically(dir + "/heldout_windows.svg", HeldoutWindowsPlot(h, t0));
    page->Figure("heldout_windows.svg", "Held-out windows: error at each window's end, nominal and calibrated");
  }
  page->Heading("Route");
  WriteFileAtomically(dir + "/route.svg", RoutePlot(r.intervals, MotionSourceName(r.source)));
  page->Figure("route.svg", "The route as the motion sensor measured it");
}

std::string OriginText(int64_t t0) {
  return "Times are seconds since the recording's first message (utime " + std::to_string(t0) + ").";
}

std::string RecalHeldoutPlot(const RecalRun& run, int64_t t0) {
  SvgPlot plot("Held-out segments of every decision: odometry error per metre with the calibration in use (grey) "
               "and the candidate (blue)");
  SvgPlot::Panel& p = plot.AddPanel("error per metre of path on each held-out segment (mm/m)", SvgPlot::kTimeAxis, "mm/m");
  SvgPlot::Series b{{}, {}, kNominal, "in use", true, {}, {}}, a{{}, {}, kCalibrated, "candidate", true, {}, {}};
  for (const RecalDecision& d : run.decisions) {
    if (!d.improvement || d.heldout.empty()) continue;
    for (std::size_t k = 0; k < d.heldout.size(); ++k) {
      const double t = ((d.heldout[k].utime_start + d.heldout[k].utime_end) / 2 - t0) * 1e-6;
      if (k < d.improvement->current.size()) b.x.push_back(t), b.y.push_back(d.improvement->current[k] * 1e3);
      if (k < d.improvement->candidate.size()) a.x.push_back(t), a.y.push_back(d.improvement->candidate[k] * 1e3);
    }
    for (const Segment& seg : d.heldout) p.spans.push_back({(seg.utime_start - t0) * 1e-6, (seg.utime_end - t0) * 1e-6});
  }
  p.series = {b, a};
  p.span_label = "held-out segment";
  p.span_color = SvgPlot::kHeldoutSpanColor;
  return plot.Render();
}

std::vector<std::vector<std::string>> DecisionRows(const RecalRun& run, int64_t t0) {
  std::vector<std::vector<std::string>> rows;
  for (const RecalDecision& d : run.decisions) {
    std::vector<std::string> row{std::to_string(d.number), FixedDecimals((d.utime - t0) * 1e-6, 1) + " s",
                                 VerdictName(d.verdict), std::to_string(d.fit.size()) + " / " + std::to_string(d.heldout.size())};
    if (d.improvement)
      row.push_back(FixedDecimals(d.improvement->mean_current * 1e3, 2) + " → " + FixedDecimals(d.improvement->mean_candidate * 1e3, 2) +
                    " mm/m (" + PValueText(d.improvement->p) + ")");
    else
      row.push_back("-");
    row.push_back(d.consistency ? PValueText(d.consistency->p) + (d.consistency->consistent ? "" : ", moved: " +
                                  d.consistency->largest + " " + FixedDecimals(d.consistency->largest_sigmas, 1) + " σ")
                                : "-");
    row.push_back(d.reason);
    rows.push_back(row);
  }
  return rows;
}

std::vector<std::vector<std::string>> InUseRows(const CalibrationInUse& start, const CalibrationInUse& end) {
  std::vector<std::vector<std::string>> rows;
  auto at = [](const CalibrationInUse& c, const std::string& name) -> std::string {
    for (std::size_t i = 0; i < c.names.size(); ++i)
      if (c.names[i] == name && i < static_cast<std::size_t>(c.value.size()))
        return ValueWithSigma(c.value[i], i < static_cast<std::size_t>(c.covariance.rows())
                                              ? std::sqrt(std::max(0.0, c.covariance(i, i))) : 0.0);
    return "-";
  };
  for (const std::string& name : end.names)
    rows.push_back({name, at(start, name), at(end, name), ParamUnit(name)});
  return rows;
}

}  // namespace

std::string SolveVerdict(const CalibrationResult& r) {
  if (r.heldout && r.heldout->halves && r.heldout->halves->p < 0.01) {
    const HalvesAgreement& a = *r.heldout->halves;
    return "Check before writing the calibration: the fitted and the held-out part of the recording call for "
           "different values (most apart: " + a.largest + ", " + PValueText(a.p) +
           "), so the robot changed during the recording or the model leaves physics out: run agvcal diagnose.";
  }
  if (!r.weak.empty()) {
    std::string names;
    for (std::size_t i = 0; i < r.weak.size(); ++i) names += (i ? ", " : "") + r.weak[i];
    return "Calibrated, but the recording determines " + names + " only weakly: to pin " +
           (r.weak.size() > 1 ? "them" : "it") + " down, " + MotionThatDetermines(r.drive, r.weak.front()) +
           ", and calibrate again before writing the calibration.";
  }
  if (!r.heldout)
    return "Write the calibration (--write-robot): the recording determines every value; to check it on data the "
           "fit does not see, run again with --fit-fraction 0.7.";
  const HeldoutComparison& h = *r.heldout;
  const std::string errors = FixedDecimals(h.nominal.error_per_metre * 1e3, 1) + " to " +
                             FixedDecimals(h.calibrated.error_per_metre * 1e3, 1) + " mm per metre of path";
  const int counted = h.paired.windows - h.paired.ties;
  const bool significant = h.paired.sign_test_p < 0.05 && counted > 0;
  if (significant && 2 * h.paired.second_better > counted)
    return "Write the calibration (--write-robot): on the held-out part of the recording it cuts the odometry error "
           "from " + errors + " (better in " + std::to_string(h.paired.second_better) + " of " +
           std::to_string(counted) + " windows, sign test " + PValueText(h.paired.sign_test_p) + ").";
  if (significant)
    return "Keep the robot file's values: on the held-out part of the recording the calibration errs more (" +
           errors + ", sign test " + PValueText(h.paired.sign_test_p) + "); run agvcal diagnose.";
  return "The calibration is not measurably better than the robot file's values on the held-out part of the "
         "recording (" + errors + ", sign test " + PValueText(h.paired.sign_test_p) +
         "): record a longer run to tell, or write it if its changes matter to you.";
}

std::string MilliradiansText(double radians, int significant) {
  return SignificantText(radians * 1e3, significant) + " mrad (" + SignificantText(radians * 180 / M_PI, significant) +
         " deg)";
}

std::string CalibrationConsoleText(const CalibrationResult& r) {
  std::ostringstream s;
  s << DriveTypeName(r.drive) << " drive, " << r.residual.intervals << " intervals (" << r.residual.outliers
    << " outliers), residual rms x " << MillimetresText(r.residual.rms_x) << ", y " << MillimetresText(r.residual.rms_y)
    << ", yaw " << MilliradiansText(r.residual.rms_yaw) << "\n";
  s << Formatted("  %-20s %-48s %s\n", "parameter", "estimate ± 1 sigma", "(nominal: the robot file)");
  for (const auto& [name, e] : Estimates(r)) {
    const std::string unit = ParamUnit(name);
    std::string estimate = EstimateText(e.value, e.std, unit);
    // Pad to 48 columns counting characters, not bytes ("±" is two bytes in UTF-8).
    std::size_t width = 0;
    for (const char c : estimate) width += (static_cast<unsigned char>(c) & 0xC0) != 0x80;
    estimate += std::string(width < 48 ? 48 - width : 1, ' ');
    const bool held = name == "imu.gyro_scale" && !r.imu->gyro_scale_estimated;
    s << Formatted("  %-20s %s(nominal %.6g%s)\n", (name + (held ? "(held)" : "")).c_str(), estimate.c_str(),
                   e.nominal, unit.empty() ? "" : (" " + unit).c_str());
  }
  if (r.imu)
    s << Formatted("  gyro noise %.3g rad/s/sqrt(Hz), wheel heading noise %.3g rad/sqrt(m), distance %.4f m\n",
                   r.imu->gyro_noise, r.imu->wheel_noise, r.imu->distance_m);
  if (!r.weak.empty()) {
    s << "  weakly determined:";
    for (const std::string& w : r.weak) s << " " << w;
    s << "\n";
  }
  return s.str();
}

std::string SolveReportSummary(const CalibrationResult& r, const std::string& log_path) {
  std::ostringstream s;
  s << SolveVerdict(r) << "\n\n"
    << DriveTypeName(r.drive) << " drive, motion measured by " << MotionSourceName(r.source) << ": "
    << r.residual.intervals << " intervals fitted, " << r.residual.outliers << " outliers set aside";
  if (r.heldout) s << ", " << r.heldout->intervals << " held out";
  s << ".\nResidual RMS of the fitted inliers: x " << FixedDecimals(r.residual.rms_x * 1e3, 2) << " mm, y "
    << FixedDecimals(r.residual.rms_y * 1e3, 2) << " mm, yaw " << MilliradiansText(r.residual.rms_yaw) << ".\n";
  for (const auto& row : ParameterRows(r)) s << "  " << row[0] << " = " << row[1] << " (" << row[2] << ")\n";
  s << ObservabilityText(r) << "\n";
  if (r.heldout)
    s << "Held-out odometry error per metre: nominal " << FixedDecimals(r.heldout->nominal.error_per_metre * 1e3, 2)
      << " mm/m, calibrated " << FixedDecimals(r.heldout->calibrated.error_per_metre * 1e3, 2) << " mm/m (sign test "
      << PValueText(r.heldout->paired.sign_test_p) << ").\n";
  return s.str();
}

void WriteSolveReportDir(const RobotDescription& robot, const CalibrationResult& r, const std::string& log_path,
                         int64_t t0, const std::string& dir) {
  MakeReportDir(dir);
  const std::string summary = SolveReportSummary(r, log_path);
  WriteFileAtomically(dir + "/summary.txt", WithProvenance(summary));
  ReportPage page("agvcal solve: the calibration of " + (robot.name.empty() ? "the robot" : robot.name) + " (" +
                  DriveTypeName(robot.drive) + " drive)");
  page.Verdict(SolveVerdict(r));
  page.Text(summary.substr(summary.find("\n\n") + 2));
  page.Paragraph(OriginText(t0));
  AddCalibration(r, t0, "robot file", dir, &page);
  WriteFileAtomically(dir + "/index.html", page.Render());
}

}  // namespace calib

namespace calib {

void WriteRecalReportDir(const CalibrationInUse& start, const RecalRun& run, const std::string& log_path,
                         int64_t t0, const std::string& dir) {
  MakeReportDir(dir);
  std::ostringstream s;
  s << "agvcal recal " << log_path << "\n" << run.segments << " segments (" << run.dropped << " dropped as too short, "
    << run.waiting << " waiting for a decision), " << run.decisions.size() << " decisions.\n";
  for (const auto& row : DecisionRows(run, t0)) s << "decision " << row[0] << " at " << row[1] << ": " << row[2] << ": " << row.back() << "\n";
  s << "Calibration in use at the start: " << start.origin << "; at the end: " << run.in_use.origin << ".\n";
  // What to act on: the calibration in use at the end, which the robot should run with.
  const std::string verdict = run.in_use.origin == start.origin
                                  ? "Keep the calibration in use: over " + std::to_string(run.decisions.size()) +
                                        " decisions no candidate beat it on held-out data."
                                  : "Use the calibration the run ended with (" + run.in_use.origin + "): it beat the "
                                        "one in use at the start on held-out data.";
  WriteFileAtomically(dir + "/summary.txt", WithProvenance(verdict + "\n\n" + s.str()));
  ReportPage page("agvcal recal: recalibration decisions");
  page.Verdict(verdict);
  page.Text(s.str());
  page.Paragraph(OriginText(t0));
  page.Heading("Decisions");
  page.Table({"decision", "at", "verdict", "segments fit / held out", "held-out error per metre, in use → candidate",
              "consistency with the calibration in use", "reason"},
             DecisionRows(run, t0));
  page.Heading("Calibration in use");
  page.Table({"parameter", "at the start ± 1σ", "at the end ± 1σ", "unit"}, InUseRows(start, run.in_use));
  if (!run.decisions.empty()) {
    WriteFileAtomically(dir + "/heldout_segments.svg", RecalHeldoutPlot(run, t0));
    page.Figure("heldout_segments.svg", "Each decision's held-out segments: the calibration in use against the candidate");
  }
  const RecalDecision* last = nullptr;
  for (const RecalDecision& d : run.decisions)
    if (d.fit_result) last = &d;
  if (last) {
    page.Heading("The fit of decision " + std::to_string(last->number));
    AddCalibration(*last->fit_result, t0, "in use", dir, &page);
  }
  WriteFileAtomically(dir + "/index.html", page.Render());
}

}  // namespace calib
