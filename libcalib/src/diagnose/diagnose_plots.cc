// The human report of the diagnosis: summary.txt, SVG plots and an index.html
// that shows them together with the candidates and the calibration as tables.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "calib/calibrate/calibration_report.h"
#include "calib/diagnose/diagnose.h"
#include "calib/io/atomic_file.h"
#include "calib/core/units.h"
#include "io/report_page.h"
#include "io/svg_plot.h"
#include "calib/io/provenance.h"

namespace calib {
namespace {

const char* kBefore = "#999999";
const char* kAfter = "#1f5fbf";

// The time origin of every plot and span: the recording's first message.
struct Clock {
  int64_t t0;
  double operator()(int64_t utime) const { return (utime - t0) * 1e-6; }
};

std::string ResidualTimePlot(const DiagnoseReport& r, const Clock& sec) {
  std::vector<std::pair<double, double>> spans;
  for (const FoundEffect& e : r.effects)
    if (e.layer != "actuation")
      for (const TimeSpan& t : e.where) spans.push_back({sec(t.utime_start), sec(t.utime_end)});
  SvgPlot plot("Held-out residual over time: calibrated model (grey) and with the effects found (blue)");
  const char* names[3] = {"x residual (mm)", "y residual (mm)", "yaw residual (mrad)"};
  for (int c = 0; c < 3; ++c) {
    SvgPlot::Panel& p = plot.AddPanel(names[c], SvgPlot::kTimeAxis, c == 2 ? "mrad" : "mm");
    SvgPlot::Series b{{}, {}, kBefore, "before", true, {}, {}}, a{{}, {}, kAfter, "after", true, {}, {}};
    for (const DiagnosedInterval& d : r.intervals) {
      if (!d.heldout || d.outlier) continue;
      const double t = sec((d.utime_start + d.utime_end) / 2);
      b.x.push_back(t), b.y.push_back(d.before[c] * 1e3);
      a.x.push_back(t), a.y.push_back(d.after[c] * 1e3);
    }
    p.series = {b, a};
    p.spans = spans;
    p.span_label = "an effect stands out";
  }
  return plot.Render();
}

// Signature residuals are in the component's unit (m or rad): drawn in mm or mrad.
std::string SignaturePlot(const FoundEffect& e) {
  SvgPlot plot("Signature of " + e.name + (e.wheel.empty() ? "" : " (" + e.wheel + ")") +
               ": mean residual per bin, without (grey) and with (blue) the effect");
  const std::string comp = e.signature_component.empty() ? e.component : e.signature_component;
  const bool odometry = comp == "x" || comp == "y" || comp == "yaw";
  const double scale = odometry ? 1e3 : 1.0;
  const std::string unit = comp == "yaw" ? "mrad" : odometry ? "mm" : comp == "speed" ? "rad/s" : "rad";
  SvgPlot::Panel& p = plot.AddPanel(comp + " residual (" + unit + ") against " + e.regressor, e.regressor,
                                    comp + " residual (" + unit + ")");
  SvgPlot::Series b{{}, {}, kBefore, "without", true, {}, {}}, a{{}, {}, kAfter, "with (±2 s.e.)", true, {}, {}};
  for (const SignatureBin& bin : e.signature) {
    b.x.push_back(bin.x), b.y.push_back(bin.before * scale);
    a.x.push_back(bin.x), a.y.push_back(bin.after * scale), a.error.push_back(2 * bin.std_error * scale);
  }
  SvgPlot::Series zero{{b.x.empty() ? 0.0 : b.x.front(), b.x.empty() ? 1.0 : b.x.back()}, {0, 0}, "#000000", "", false, {}, {}};
  p.series = {zero, b, a};
  return plot.Render();
}

std::string HeldoutPlot(const FoundEffect& e, const Clock& sec) {
  const bool yaw = e.component == "yaw";
  SvgPlot plot("Held-out proof of " + e.name + ": chained error per stretch, without (grey) and with (blue)");
  SvgPlot::Panel& p = plot.AddPanel(e.component + " error over the stretch of each held-out block where it acts most",
                                    SvgPlot::kTimeAxis, yaw ? "mrad" : "mm");
  SvgPlot::Series b{{}, {}, kBefore, "without", true, {}, {}}, a{{}, {}, kAfter, "with", true, {}, {}};
  for (const HeldoutStretch& h : e.stretches) {
    const double t = sec((h.utime_start + h.utime_end) / 2);
    b.x.push_back(t), b.y.push_back(h.before * 1e3);
    a.x.push_back(t), a.y.push_back(h.after * 1e3);
  }
  SvgPlot::Series zero{{b.x.front(), b.x.back()}, {0, 0}, "#000000", "", false, {}, {}};
  p.series = {zero, b, a};
  for (const HeldoutStretch& h : e.stretches) p.spans.push_back({sec(h.utime_start), sec(h.utime_end)});
  p.span_label = "held-out stretch";
  p.span_color = SvgPlot::kHeldoutSpanColor;
  return plot.Render();
}

std::string RoutePlot(const DiagnoseReport& r) {
  SvgPlot plot("Route (wheel odometry): where the effects found (red) and unexplained structure (orange) stand out",
               900, 600);
  SvgPlot::Panel& p = plot.AddPanel("route", "x (m)", "y (m)");
  p.equal_axes = true;
  SvgPlot::Series path{{}, {}, "#bbbbbb", "route", false, {}, {}}, hit{{}, {}, "#d62728", "effects", true, {}, {}},
      other{{}, {}, "#ff9900", "unexplained", true, {}, {}};
  auto inside = [](const std::vector<TimeSpan>& where, const DiagnosedInterval& d) {
    for (const TimeSpan& t : where)
      if (d.utime_start < t.utime_end && d.utime_end > t.utime_start) return true;
    return false;
  };
  for (const DiagnosedInterval& d : r.intervals) {
    path.x.push_back(d.motion.x), path.y.push_back(d.motion.y);
    for (const FoundEffect& e : r.effects)
      if (e.layer != "actuation" && inside(e.where, d)) {
        hit.x.push_back(d.motion.x), hit.y.push_back(d.motion.y);
        break;
      }
    for (const Unexplained& u : r.unexplained)
      if (inside(u.where, d)) {
        other.x.push_back(d.motion.x), other.y.push_back(d.motion.y);
        break;
      }
  }
  p.series = {path, hit, other};
  return plot.Render();
}

std::string TraceUnit(const DiagnoseReport::Trace& tr) { return ComponentUnit(tr.name); }

std::string ActuationPlot(const DiagnoseReport::Trace& tr, const Clock& sec) {
  SvgPlot plot("Actuation: " + tr.name + " measured (black), commanded model (grey), with the effects found (blue)");
  SvgPlot::Panel& p = plot.AddPanel(tr.name + " (" + TraceUnit(tr) + ")", SvgPlot::kTimeAxis, TraceUnit(tr));
  SvgPlot::Series m{{}, {}, "#000000", "measured", false, {}, {}}, b{{}, {}, kBefore, "commanded", false, {}, {}},
      a{{}, {}, kAfter, "with effects", false, {}, {}};
  for (std::size_t i = 0; i < tr.utime.size(); ++i) {
    const double t = sec(tr.utime[i]);
    m.x.push_back(t), m.y.push_back(tr.measured[i]);
    b.x.push_back(t), b.y.push_back(tr.before[i]);
    a.x.push_back(t), a.y.push_back(tr.after[i]);
  }
  p.series = {b, a, m};
  return plot.Render();
}

// The largest steps of the commanded model, at least 4 s apart (at most `count`).
std::vector<std::size_t> CommandSteps(const DiagnoseReport::Trace& tr, std::size_t count) {
  std::vector<std::size_t> order;
  for (std::size_t i = 1; i < tr.before.size(); ++i) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return std::abs(tr.before[a] - tr.before[a - 1]) > std::abs(tr.before[b] - tr.before[b - 1]);
  });
  std::vector<std::size_t> steps;
  for (std::size_t i : order) {
    if (steps.size() == count || !(std::abs(tr.before[i] - tr.before[i - 1]) > 0)) break;
    bool apart = true;
    for (std::size_t s : steps) apart = apart && std::abs((tr.utime[i] - tr.utime[s]) * 1e-6) > 4.0;
    if (apart) steps.push_back(i);
  }
  std::sort(steps.begin(), steps.end());
  return steps;
}

// Around the largest command steps, 1 s before to 2 s after: a lag of a tenth of a second
// shows as the measured curve trailing the commanded step.
std::string ActuationZoomPlot(const DiagnoseReport::Trace& tr, const std::vector<std::size_t>& steps, const Clock& sec) {
  SvgPlot plot("Close up of " + tr.name + " at the largest command changes: commanded (grey), measured "
               "(black), with the effects found (blue)", 900, 200);
  for (std::size_t s : steps) {
    const double ts = sec(tr.utime[s]);
    SvgPlot::Panel& p = plot.AddPanel("command change at " + FixedDecimals(ts, 2) + " s (" + TraceUnit(tr) + ")", SvgPlot::kTimeAxis,
                                      TraceUnit(tr));
    SvgPlot::Series m{{}, {}, "#000000", "measured", false, {}, {}}, b{{}, {}, kBefore, "commanded", false, {}, {}},
        a{{}, {}, kAfter, "with effects", false, {}, {}};
    for (std::size_t i = 0; i < tr.utime.size(); ++i) {
      const double t = sec(tr.utime[i]);
      if (t < ts - 1.0 || t > ts + 2.0) continue;
      m.x.push_back(t), m.y.push_back(tr.measured[i]);
      b.x.push_back(t), b.y.push_back(tr.before[i]);
      a.x.push_back(t), a.y.push_back(tr.after[i]);
    }
    p.series = {b, a, m};
  }
  return plot.Render();
}


std::vector<std::vector<std::string>> CandidateRows(const DiagnoseReport& r) {
  std::vector<std::vector<std::string>> rows;
  for (const CandidateOutcome& c : r.candidates) {
    const std::string unit = ParamUnit(EffectSizeKey(c.name));
    std::string reason = CandidateNoteInWords(c.note);
    if (reason.empty() && c.status == CandidateStatus::kFound) reason = "significant and proven on held-out data";
    if (reason.empty() && c.status == CandidateStatus::kNotSignificant) reason = "not beyond the false-alarm level";
    rows.push_back({c.name + (c.wheel.empty() ? "" : " (" + c.wheel + ")"), c.layer, CandidateStatusName(c.status),
                    EstimateText(c.estimate.value, c.estimate.std, unit),
                    std::isfinite(c.detectable) && c.detectable > 0 ? QuantityText(c.detectable, unit, 3) : "-",
                    PValueNumber(c.p_adjusted), reason});
  }
  return rows;
}

// In `agvcal solve`'s order (docs/units.md): the drive's parameters as the robot file lists them,
// then the sensor's mount x, y, yaw, then anything else by name.
std::vector<std::vector<std::string>> CalibrationRows(const DiagnoseReport& r) {
  std::vector<std::string> names = r.param_names;
  for (const char* axis : {".x", ".y", ".yaw"}) names.push_back(MotionSourceName(r.source) + std::string(axis));
  for (const auto& [name, base] : r.calibration)
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  std::vector<std::vector<std::string>> rows;
  for (const std::string& name : names) {
    const auto base = r.calibration.find(name);
    if (base == r.calibration.end()) continue;
    const auto it = r.refitted.find(name);
    const std::string unit = ParamUnit(name);
    rows.push_back({name, EstimateText(base->second.value, base->second.std, unit),
                    it == r.refitted.end() ? "-" : EstimateText(it->second.value, it->second.std, unit)});
  }
  return rows;
}

std::vector<std::vector<std::string>> EffectRows(const DiagnoseReport& r, const Clock& sec) {
  std::vector<std::vector<std::string>> rows;
  for (const FoundEffect& e : r.effects) {
    std::string size, where;
    for (const auto& [k, v] : e.params) size += (size.empty() ? "" : ", ") + k + " = " + EstimateText(v.value, v.std, ParamUnit(k));
    where = SpanTimes(e.where, sec.t0);
    if (e.region)
      where += "; on the floor x " + FixedDecimals((*e.region)[0], 2) + "–" + FixedDecimals((*e.region)[2], 2) + " m, y " +
               FixedDecimals((*e.region)[1], 2) + "–" + FixedDecimals((*e.region)[3], 2) + " m";
    rows.push_back({e.name + (e.wheel.empty() ? "" : " (" + e.wheel + ")"), size, PValueNumber(e.p_adjusted),
                    where.empty() ? "-" : where, e.regime});
  }
  return rows;
}

void AddTables(const DiagnoseReport& r, const Clock& sec, ReportPage* page) {
  if (!r.effects.empty()) {
    page->Heading("Effects found");
    page->Table({"effect", "size ± 1σ", "p (catalogue-wide)", "where it stands out", "under what motion"},
                EffectRows(r, sec));
  }
  if (!r.discovered.empty()) {
    page->Heading("Physics discovered outside the catalogue");
    std::vector<std::vector<std::string>> rows;
    for (const Discovered& d : r.discovered)
      rows.push_back({d.channel, d.equation, d.interpretation, PValueNumber(d.p_adjusted),
                      d.where.empty() ? "-" : SpanTimes(d.where, sec.t0)});
    page->Table({"channel", "equation (coefficient units as written)", "reading", "p (library-wide)", "where it stands out"},
                rows);
  }
  page->Heading("Every candidate of the catalogue");
  page->Paragraph("Status found: in the model now; rejected: significant alone but explained by the effects found "
                  "(a look-alike); indistinguishable: the recording cannot tell it from its look-alike; "
                  "not_identifiable: this recording could not have detected it; not_significant: tested, not there. "
                  "Detectable size: the smallest size this recording would have found (false-alarm rate α, power 0.8).");
  page->Table({"candidate", "layer", "status", "estimate ± 1σ", "detectable size", "p (catalogue-wide)", "reason"},
              CandidateRows(r));
  page->Heading("Calibration");
  page->Paragraph("Baseline: the calibrated model fitted on the fit blocks without any effect; refitted: jointly "
                  "with the effects found.");
  page->Table({"parameter", "baseline ± 1σ", "refitted with the effects ± 1σ"}, CalibrationRows(r));
}

}  // namespace

void WriteDiagnoseReportDir(const DiagnoseReport& r, const std::string& dir) {
  MakeReportDir(dir);
  const Clock sec{ReportTimeOrigin(r)};
  ReportPage page(std::string("agvcal diagnose: ") +
                  (!r.effects.empty()       ? "missing physics found"
                   : r.unexplained.empty() ? "no missing physics found"
                                           : "residual structure no catalogued effect explains"));
  const std::string summary = DiagnoseSummaryText(r);
  WriteFileAtomically(dir + "/summary.txt", WithProvenance(summary));
  page.Verdict(DiagnoseVerdict(r));
  page.Text(summary.substr(summary.find("\n\n") + 2));
  page.Paragraph("Times are seconds since the recording's first message (utime " + std::to_string(sec.t0) + ").");
  AddTables(r, sec, &page);
  page.Heading("Plots");
  auto figure = [&](const std::string& name, const std::string& svg, const std::string& caption) {
    WriteFileAtomically(dir + "/" + name, svg);
    page.Figure(name, caption);
  };
  figure("residual_time.svg", ResidualTimePlot(r, sec),
         "Held-out residual over time before and after modelling the effects; shaded: where an effect stands out");
  int n = 0;
  for (const FoundEffect& e : r.effects) {
    const std::string tag = std::to_string(++n) + "_" + e.name;
    figure("signature_" + tag + ".svg", SignaturePlot(e), "The signature of " + e.name + ": residual against " + e.regressor);
    if (!e.stretches.empty())
      figure("heldout_" + tag + ".svg", HeldoutPlot(e, sec),
             "Held-out proof of " + e.name + "; shaded: the held-out stretches judged");
  }
  figure("route.svg", RoutePlot(r), "The route with the spans where the effects stand out");
  for (const DiagnoseReport::Trace& tr : r.actuation) {
    std::string tag = tr.name;
    std::replace(tag.begin(), tag.end(), ' ', '_');
    figure("actuation_" + tag + ".svg", ActuationPlot(tr, sec), "Actuation over the whole recording: " + tr.name);
    const std::vector<std::size_t> steps = CommandSteps(tr, 3);
    if (!steps.empty())
      figure("actuation_zoom_" + tag + ".svg", ActuationZoomPlot(tr, steps, sec),
             "Close up of the largest command steps: a lag shows as the measured curve trailing the command");
  }
  WriteFileAtomically(dir + "/index.html", page.Render());
}

}  // namespace calib
