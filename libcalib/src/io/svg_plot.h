#pragma once
// A minimal SVG line/point plot for the human reports: one or more panels
// stacked vertically, each with its own axes, series and shaded spans. No
// dependencies; the text is a complete, self-contained SVG file.

#include <string>
#include <vector>

namespace calib {

class SvgPlot {
 public:
  // Span colours: where a diagnosed effect stands out, and data held out of a fit.
  static constexpr const char* kEffectSpanColor = "#f6c3c3";
  static constexpr const char* kHeldoutSpanColor = "#cfe0f3";
  struct Series {
    std::vector<double> x, y;
    std::string color, label;
    bool points = false;    // markers instead of a line
    std::vector<double> error;  // optional +- bars (points only)
    std::vector<std::string> colors;  // optional colour per point (points only), e.g. ColorRamp
  };
  struct Panel {
    std::string title, x_label, y_label;
    std::vector<Series> series;
    std::vector<std::pair<double, double>> spans;  // shaded x ranges
    std::string span_label;                        // legend of the spans (none when empty)
    std::string span_color = kEffectSpanColor;
    bool equal_axes = false;                       // same scale on x and y (a map)
    // A colour bar in the legend for points coloured by ColorRamp(v, lo, hi); none when empty.
    std::string color_bar_label;
    double color_bar_lo = 0.0, color_bar_hi = 1.0;
  };

  // The time axis of every report plot: one origin, the recording's first message.
  static constexpr const char* kTimeAxis = "time since the recording's first message (s)";

  SvgPlot(std::string title, int width = 900, int panel_height = 260)
      : title_(std::move(title)), width_(width), panel_height_(panel_height) {}
  Panel& AddPanel(const std::string& title, const std::string& x_label, const std::string& y_label);
  std::string Render() const;

 private:
  std::string title_;
  int width_, panel_height_;
  std::vector<Panel> panels_;
};

// The tick rule of every report plot, the fleet report's too (scripts/agvcal_fleet/svg.py
// follows it; fleet_unit compares the two through tests/tools/svg_ticks): about five round
// values over [lo, hi], the step 2, 5 or 10 times a power of ten, from the first multiple of
// the step at or above lo; labels with 4 significant digits, more where the step needs them.
struct SvgTick {
  double value;
  std::string label;
};
std::vector<SvgTick> SvgTicks(double lo, double hi);

// A diverging colour for v in [lo, hi]: blue at lo, light grey in the middle, red at hi.
std::string ColorRamp(double v, double lo, double hi);

// A histogram of `values` over [lo, hi] in `bins` bins as a stepped line (share of the values
// per bin, so that histograms of different counts compare).
SvgPlot::Series HistogramSeries(const std::vector<double>& values, double lo, double hi, int bins,
                                const std::string& color, const std::string& label);

}  // namespace calib
