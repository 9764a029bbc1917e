#pragma once
// A minimal SVG line/point plot for the human reports: one or more panels
// stacked vertically, each with its own axes, series and shaded spans. No
// dependencies; the text is a complete, self-contained SVG file.

#include <string>
#include <vector>

namespace calib {

class SvgPlot {
 public:
  struct Series {
    std::vector<double> x, y;
    std::string color, label;
    bool points = false;    // markers instead of a line
    std::vector<double> error;  // optional +- bars (points only)
  };
  struct Panel {
    std::string title, x_label, y_label;
    std::vector<Series> series;
    std::vector<std::pair<double, double>> spans;  // shaded x ranges
    bool equal_axes = false;                       // same scale on x and y (a map)
  };

  SvgPlot(std::string title, int width = 900, int panel_height = 260)
      : title_(std::move(title)), width_(width), panel_height_(panel_height) {}
  Panel& AddPanel(const std::string& title, const std::string& x_label, const std::string& y_label);
  std::string Render() const;

 private:
  std::string title_;
  int width_, panel_height_;
  std::vector<Panel> panels_;
};

}  // namespace calib
