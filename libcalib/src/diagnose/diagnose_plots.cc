// The human report of the diagnosis: summary.txt, SVG plots and an index.html
// that shows them together.

#include <filesystem>
#include <sstream>

#include "calib/diagnose/diagnose.h"
#include "calib/io/atomic_file.h"
#include "io/svg_plot.h"

namespace calib {
namespace {

const char* kBefore = "#999999";
const char* kAfter = "#1f5fbf";

std::string HtmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return out;
}

}  // namespace

void WriteDiagnoseReportDir(const DiagnoseReport& r, const std::string& dir) {
  PrepareReportDir(dir);  // created, checked, the last report's figures removed
  std::vector<std::string> files;
  const int64_t t0 = r.intervals.empty() ? 0 : r.intervals.front().utime_start;
  auto sec = [&](int64_t u) { return (u - t0) * 1e-6; };
  std::vector<std::pair<double, double>> spans;
  for (const FoundEffect& e : r.effects)
    if (e.layer != "actuation")
      for (const TimeSpan& t : e.where) spans.push_back({sec(t.utime_start), sec(t.utime_end)});

  {  // Residual over time, held-out intervals, before and after.
    SvgPlot plot("Held-out residual over time: calibrated model (grey) and with the effects found (blue)");
    const char* names[3] = {"x residual (mm)", "y residual (mm)", "yaw residual (mrad)"};
    for (int c = 0; c < 3; ++c) {
      SvgPlot::Panel& p = plot.AddPanel(names[c], "time (s)", c == 2 ? "mrad" : "mm");
      SvgPlot::Series b{{}, {}, kBefore, "before", true, {}}, a{{}, {}, kAfter, "after", true, {}};
      for (const DiagnosedInterval& d : r.intervals) {
        if (!d.heldout || d.outlier) continue;
        const double t = sec((d.utime_start + d.utime_end) / 2);
        b.x.push_back(t), b.y.push_back(d.before[c] * 1e3);
        a.x.push_back(t), a.y.push_back(d.after[c] * 1e3);
      }
      p.series = {b, a};
      p.spans = spans;
    }
    WriteFileAtomically(dir + "/residual_time.svg", plot.Render());
    files.push_back("residual_time.svg");
  }
  int n = 0;
  for (const FoundEffect& e : r.effects) {
    const std::string name = "signature_" + std::to_string(++n) + "_" + e.name + ".svg";
    SvgPlot plot("Signature of " + e.name + (e.wheel.empty() ? "" : " (" + e.wheel + ")") +
                 ": mean residual per bin, without (grey) and with (blue) the effect");
    const std::string comp = e.signature_component.empty() ? e.component : e.signature_component;
    SvgPlot::Panel& p = plot.AddPanel(comp + " residual against " + e.regressor, e.regressor, comp + " residual");
    SvgPlot::Series b{{}, {}, kBefore, "without", true, {}}, a{{}, {}, kAfter, "with", true, {}};
    for (const SignatureBin& bin : e.signature) {
      b.x.push_back(bin.x), b.y.push_back(bin.before);
      a.x.push_back(bin.x), a.y.push_back(bin.after), a.error.push_back(2 * bin.std_error);
    }
    SvgPlot::Series zero{{b.x.empty() ? 0.0 : b.x.front(), b.x.empty() ? 1.0 : b.x.back()}, {0, 0}, "#000000", "", false, {}};
    p.series = {zero, b, a};
    WriteFileAtomically(dir + "/" + name, plot.Render());
    files.push_back(name);
  }
  n = 0;
  for (const FoundEffect& e : r.effects) {  // The held-out proof over stretches.
    ++n;
    if (e.stretches.empty()) continue;
    const std::string name = "heldout_" + std::to_string(n) + "_" + e.name + ".svg";
    const bool yaw = e.component == "yaw";
    SvgPlot plot("Held-out proof of " + e.name + ": chained error per stretch, without (grey) and with (blue)");
    SvgPlot::Panel& p = plot.AddPanel(e.component + " error over the stretch of each held-out block where it acts most",
                                      "time (s)", yaw ? "mrad" : "mm");
    SvgPlot::Series b{{}, {}, kBefore, "without", true, {}}, a{{}, {}, kAfter, "with", true, {}};
    for (const HeldoutStretch& h : e.stretches) {
      const double t = sec((h.utime_start + h.utime_end) / 2);
      b.x.push_back(t), b.y.push_back(h.before * 1e3);
      a.x.push_back(t), a.y.push_back(h.after * 1e3);
    }
    SvgPlot::Series zero{{b.x.front(), b.x.back()}, {0, 0}, "#000000", "", false, {}};
    p.series = {zero, b, a};
    for (const HeldoutStretch& h : e.stretches) p.spans.push_back({sec(h.utime_start), sec(h.utime_end)});
    WriteFileAtomically(dir + "/" + name, plot.Render());
    files.push_back(name);
  }
  {  // The route with the mismatch spans.
    SvgPlot plot("Route (wheel odometry): where the effects found (red) and unexplained structure (orange) stand out",
                 900, 600);
    SvgPlot::Panel& p = plot.AddPanel("route", "x (m)", "y (m)");
    p.equal_axes = true;
    SvgPlot::Series path{{}, {}, "#bbbbbb", "route", false, {}}, hit{{}, {}, "#d62728", "effects", true, {}},
        other{{}, {}, "#ff9900", "unexplained", true, {}};
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
    WriteFileAtomically(dir + "/route.svg", plot.Render());
    files.push_back("route.svg");
  }
  for (const DiagnoseReport::Trace& tr : r.actuation) {
    const std::string name = "actuation_" + tr.name.substr(0, tr.name.find(' ')) + ".svg";
    SvgPlot plot("Actuation: " + tr.name + " measured (black), commanded model (grey), with the effects found (blue)");
    SvgPlot::Panel& p = plot.AddPanel(tr.name, "time (s)", tr.name.rfind("speed", 0) == 0 ? "rad/s" : "rad");
    SvgPlot::Series m{{}, {}, "#000000", "measured", false, {}}, b{{}, {}, kBefore, "before", false, {}},
        a{{}, {}, kAfter, "after", false, {}};
    for (std::size_t i = 0; i < tr.utime.size(); ++i) {
      const double t = sec(tr.utime[i]);
      m.x.push_back(t), m.y.push_back(tr.measured[i]);
      b.x.push_back(t), b.y.push_back(tr.before[i]);
      a.x.push_back(t), a.y.push_back(tr.after[i]);
    }
    p.series = {b, a, m};
    WriteFileAtomically(dir + "/" + name, plot.Render());
    files.push_back(name);
  }
  const std::string summary = DiagnoseSummaryText(r);
  WriteFileAtomically(dir + "/summary.txt", summary);
  std::ostringstream html;
  html << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>agvcal diagnose</title></head><body>\n"
       << "<h1>agvcal diagnose: " << r.verdict << "</h1>\n<pre>" << HtmlEscape(summary) << "</pre>\n";
  for (const std::string& f : files) html << "<p><img src=\"" << f << "\" alt=\"" << f << "\"></p>\n";
  html << "</body></html>\n";
  WriteFileAtomically(dir + "/index.html", html.str());
}

}  // namespace calib
