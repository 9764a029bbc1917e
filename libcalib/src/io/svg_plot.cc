#include "io/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "calib/core/units.h"
#include "io/report_page.h"

namespace calib {
namespace {

std::string Num(double v) { return Formatted("%.4g", v); }

}  // namespace

std::vector<SvgTick> SvgTicks(double lo, double hi) {
  const double span = hi - lo;
  if (!(span > 0)) return {{lo, Num(lo)}};
  const double raw = span / 5, mag = std::pow(10, std::floor(std::log10(raw)));
  const double step = raw / mag < 2 ? 2 * mag : raw / mag < 5 ? 5 * mag : 10 * mag;
  std::vector<SvgTick> t;
  for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * span; v += step) {
    const double value = std::abs(v) < 1e-12 * step ? 0 : v;
    int digits = 4;
    if (value != 0)  // down to the step's digit: 116.25 and 116.3, not 116.2 twice
      digits = std::max(digits, static_cast<int>(std::floor(std::log10(std::abs(value))) - std::floor(std::log10(step))) + 1);
    t.push_back({value, Formatted("%.*g", digits, value)});
  }
  return t;
}

SvgPlot::Panel& SvgPlot::AddPanel(const std::string& title, const std::string& x_label, const std::string& y_label) {
  Panel panel;
  panel.title = title, panel.x_label = x_label, panel.y_label = y_label;
  panels_.push_back(panel);
  return panels_.back();
}

std::string SvgPlot::Render() const {
  const int top = 52, left = 80, right = 170, bottom = 45;
  const int height = top + int(panels_.size()) * (panel_height_ + bottom) + 10;
  std::ostringstream s;
  s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width_ << "\" height=\"" << height
    << "\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    << "<text x=\"" << width_ / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\""
    << std::clamp(static_cast<int>((width_ - 20) / (0.56 * std::max<std::size_t>(title_.size(), 1))), 9, 15) << "\">"
    << HtmlEscape(title_) << "</text>\n";
  for (std::size_t p = 0; p < panels_.size(); ++p) {
    const Panel& P = panels_[p];
    const double y0 = top + p * (panel_height_ + bottom), w = width_ - left - right, h = panel_height_ - 20;
    double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
    for (const Series& se : P.series) {
      for (std::size_t i = 0; i < se.x.size(); ++i) {
        if (!std::isfinite(se.x[i]) || !std::isfinite(se.y[i])) continue;
        const double e = i < se.error.size() ? se.error[i] : 0.0;
        xmin = std::min(xmin, se.x[i]), xmax = std::max(xmax, se.x[i]);
        ymin = std::min(ymin, se.y[i] - e), ymax = std::max(ymax, se.y[i] + e);
      }
    }
    if (!std::isfinite(xmin)) xmin = 0, xmax = 1, ymin = 0, ymax = 1;
    if (xmax - xmin < 1e-12) xmin -= 0.5, xmax += 0.5;
    if (ymax - ymin < 1e-15) ymin -= 0.5 * std::max(std::abs(ymin), 1e-9), ymax += 0.5 * std::max(std::abs(ymax), 1e-9);
    const double pad = 0.05 * (ymax - ymin);
    ymin -= pad, ymax += pad;
    if (P.equal_axes) {  // same metres per pixel on both axes
      const double sx = (xmax - xmin) / w, sy = (ymax - ymin) / h, sc = std::max(sx, sy);
      const double cx = 0.5 * (xmin + xmax), cy = 0.5 * (ymin + ymax);
      xmin = cx - sc * w / 2, xmax = cx + sc * w / 2, ymin = cy - sc * h / 2, ymax = cy + sc * h / 2;
    }
    auto X = [&](double x) { return left + (x - xmin) / (xmax - xmin) * w; };
    auto Y = [&](double y) { return y0 + h - (y - ymin) / (ymax - ymin) * h; };
    s << "<text x=\"" << left << "\" y=\"" << y0 - 6 << "\" font-size=\"13\">" << HtmlEscape(P.title) << "</text>\n";
    for (const auto& [a, b] : P.spans) {
      const double xa = X(std::max(a, xmin)), xb = X(std::min(b, xmax));
      if (xb > xa) s << "<rect x=\"" << xa << "\" y=\"" << y0 << "\" width=\"" << std::max(xb - xa, 1.0) << "\" height=\"" << h
                     << "\" fill=\"" << P.span_color << "\" opacity=\"0.6\"/>\n";
    }
    s << "<rect x=\"" << left << "\" y=\"" << y0 << "\" width=\"" << w << "\" height=\"" << h
      << "\" fill=\"none\" stroke=\"#444\"/>\n";
    for (const auto& [t, label] : SvgTicks(xmin, xmax))
      s << "<line x1=\"" << X(t) << "\" x2=\"" << X(t) << "\" y1=\"" << y0 + h << "\" y2=\"" << y0 + h + 4
        << "\" stroke=\"#444\"/><text x=\"" << X(t) << "\" y=\"" << y0 + h + 16 << "\" text-anchor=\"middle\">" << label << "</text>\n";
    for (const auto& [t, label] : SvgTicks(ymin, ymax))
      s << "<line x1=\"" << left - 4 << "\" x2=\"" << left + w << "\" y1=\"" << Y(t) << "\" y2=\"" << Y(t)
        << "\" stroke=\"#ddd\"/><text x=\"" << left - 6 << "\" y=\"" << Y(t) + 4 << "\" text-anchor=\"end\">" << label << "</text>\n";
    s << "<text x=\"" << left + w / 2 << "\" y=\"" << y0 + h + 32 << "\" text-anchor=\"middle\">" << HtmlEscape(P.x_label) << "</text>\n";
    s << "<text transform=\"translate(" << 16 << "," << y0 + h / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
      << HtmlEscape(P.y_label) << "</text>\n";
    int legend = 0;
    for (const Series& se : P.series) {
      if (se.points) {
        for (std::size_t i = 0; i < se.x.size(); ++i) {
          if (!std::isfinite(se.y[i])) continue;
          if (i < se.error.size())
            s << "<line x1=\"" << X(se.x[i]) << "\" x2=\"" << X(se.x[i]) << "\" y1=\"" << Y(se.y[i] - se.error[i])
              << "\" y2=\"" << Y(se.y[i] + se.error[i]) << "\" stroke=\"" << se.color << "\"/>";
          s << "<circle cx=\"" << X(se.x[i]) << "\" cy=\"" << Y(se.y[i]) << "\" r=\"2.5\" fill=\""
            << (i < se.colors.size() ? se.colors[i] : se.color) << "\"/>\n";
        }
      } else if (!se.x.empty()) {
        s << "<polyline fill=\"none\" stroke=\"" << se.color << "\" stroke-width=\"1.2\" points=\"";
        for (std::size_t i = 0; i < se.x.size(); ++i)
          if (std::isfinite(se.y[i])) s << X(se.x[i]) << "," << Y(se.y[i]) << " ";
        s << "\"/>\n";
      }
      if (!se.label.empty()) {
        const double ly = y0 + 14 + 16 * legend++;
        s << "<rect x=\"" << left + w + 10 << "\" y=\"" << ly - 9 << "\" width=\"12\" height=\"10\" fill=\"" << se.color
          << "\"/><text x=\"" << left + w + 26 << "\" y=\"" << ly << "\">" << HtmlEscape(se.label) << "</text>\n";
      }
    }
    if (!P.spans.empty() && !P.span_label.empty()) {
      s << "<rect x=\"" << left + w + 10 << "\" y=\"" << y0 + 5 + 16 * legend << "\" width=\"12\" height=\"10\" fill=\""
        << P.span_color << "\"/><text x=\"" << left + w + 26 << "\" y=\"" << y0 + 14 + 16 * legend << "\">"
        << HtmlEscape(P.span_label) << "</text>\n";
      ++legend;
    }
    if (!P.color_bar_label.empty()) {  // a vertical bar, hi at the top
      const double bx = left + w + 10, by = y0 + 14 + 16 * legend, bh = std::max(40.0, h - 30 - 16 * legend);
      for (int k = 0; k < 20; ++k)
        s << "<rect x=\"" << bx << "\" y=\"" << by + bh * k / 20 << "\" width=\"14\" height=\"" << bh / 20 + 0.5
          << "\" fill=\"" << ColorRamp(P.color_bar_hi - (k + 0.5) / 20 * (P.color_bar_hi - P.color_bar_lo),
                                        P.color_bar_lo, P.color_bar_hi) << "\"/>";
      s << "<text x=\"" << bx << "\" y=\"" << by - 3 << "\">" << HtmlEscape(P.color_bar_label) << "</text>"
        << "<text x=\"" << bx + 18 << "\" y=\"" << by + 10 << "\">" << Num(P.color_bar_hi) << "</text>"
        << "<text x=\"" << bx + 18 << "\" y=\"" << by + bh << "\">" << Num(P.color_bar_lo) << "</text>\n";
    }
  }
  s << "</svg>\n";
  return s.str();
}

std::string ColorRamp(double v, double lo, double hi) {
  const double t = hi > lo ? std::clamp((v - lo) / (hi - lo), 0.0, 1.0) : 0.5;
  // blue (33, 102, 172) -> grey (221, 221, 221) -> red (178, 24, 43)
  const double a[3] = {33, 102, 172}, m[3] = {221, 221, 221}, b[3] = {178, 24, 43};
  int rgb[3];
  for (int k = 0; k < 3; ++k)
    rgb[k] = static_cast<int>(std::lround(t < 0.5 ? a[k] + (m[k] - a[k]) * 2 * t : m[k] + (b[k] - m[k]) * (2 * t - 1)));
  return Formatted("#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
}

SvgPlot::Series HistogramSeries(const std::vector<double>& values, double lo, double hi, int bins,
                                const std::string& color, const std::string& label) {
  SvgPlot::Series s{{}, {}, color, label, false, {}, {}};
  if (!(hi > lo) || bins < 1) return s;
  std::vector<double> count(bins, 0.0);
  int n = 0;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    ++n;
    const int k = static_cast<int>(std::floor((v - lo) / (hi - lo) * bins));
    count[std::clamp(k, 0, bins - 1)] += 1;  // the outermost bins hold the tails
  }
  const double width = (hi - lo) / bins;
  s.x.push_back(lo), s.y.push_back(0);
  for (int k = 0; k < bins; ++k) {
    const double share = n ? count[k] / n : 0.0;
    s.x.push_back(lo + k * width), s.y.push_back(share);
    s.x.push_back(lo + (k + 1) * width), s.y.push_back(share);
  }
  s.x.push_back(hi), s.y.push_back(0);
  return s;
}

}  // namespace calib
