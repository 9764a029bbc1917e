#pragma once
// The human reports' HTML page (agvcal diagnose, solve, ground, recal --report DIR): a page
// that reads at any width from 1024 px down: wrapped text, tables, figures scaled to the
// column. Every report folder is prepared the same way (calib/io/atomic_file.h, PrepareReportDir).

#include <string>
#include <vector>

namespace calib {

std::string HtmlEscape(const std::string& text);

class ReportPage {
 public:
  explicit ReportPage(std::string title);
  // The one sentence a person acts on (what was found, how sure, what to do next): first on the
  // page, above the run's provenance (calib/io/provenance.h) and the body.
  void Verdict(const std::string& sentence);
  void Heading(const std::string& text);    // a section
  void Paragraph(const std::string& text);  // wrapped
  void Text(const std::string& lines);      // line breaks kept, long lines wrapped
  void Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);
  void Figure(const std::string& file, const std::string& caption);
  std::string Render() const;

 private:
  std::string title_;
  std::string verdict_;
  std::string body_;
};

// Numbers in the pages: calib/core/units.h (ValueWithSigma, FixedDecimals, SignificantText).

}  // namespace calib
