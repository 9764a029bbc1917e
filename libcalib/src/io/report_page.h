#pragma once
// The human reports' HTML page (agvcal diagnose, solve, ground, recal --report DIR): a page
// that reads at any width from 1024 px down: wrapped text, tables, figures scaled to the
// column. Every report folder is prepared the same way (calib/io/atomic_file.h, PrepareReportDir).

#include <string>

#include "calib/core/units.h"
#include <vector>

namespace calib {

std::string HtmlEscape(const std::string& text);

class ReportPage {
 public:
  explicit ReportPage(std::string title);
  void Heading(const std::string& text);    // a section
  void Paragraph(const std::string& text);  // wrapped
  void Text(const std::string& lines);      // line breaks kept, long lines wrapped
  void Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);
  void Figure(const std::string& file, const std::string& caption);
  std::string Render() const;

 private:
  std::string title_;
  std::string body_;
};

// "1.2346 ± 0.0012": the value rounded to two significant digits of its sigma (six
// significant digits with a sigma of 0 or not finite). A negative sigma: "1.2346", the value
// rounded to |sigma| without showing it (a change, a difference).
std::string ValueWithSigma(double value, double sigma);

// "12.35" (FixedDecimals(12.345, 2)), "0.0036" (SignificantDigits(0.003556, 2)).
std::string FixedDecimals(double value, int decimals);
std::string SignificantDigits(double value, int digits);

// p-values: core/units.h PValueNumber (table cells), PValueText (sentences).

}  // namespace calib
