#include "io/report_page.h"

#include "calib/io/provenance.h"
#include "report_style.h"  // kReportStyle, generated from libcalib/src/io/report_style.css

namespace calib {

std::string HtmlEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else if (c == '"') out += "&quot;";
    else out += c;
  }
  return out;
}

ReportPage::ReportPage(std::string title) : title_(std::move(title)) {}

void ReportPage::Verdict(const std::string& sentence) { verdict_ = sentence; }

void ReportPage::Heading(const std::string& text) { body_ += "<h2>" + HtmlEscape(text) + "</h2>\n"; }

void ReportPage::Paragraph(const std::string& text) { body_ += "<p>" + HtmlEscape(text) + "</p>\n"; }

void ReportPage::Text(const std::string& lines) { body_ += "<div class=\"text\">" + HtmlEscape(lines) + "</div>\n"; }

void ReportPage::Table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  body_ += "<div class=\"tablewrap\"><table>\n<tr>";
  for (const std::string& h : header) body_ += "<th>" + HtmlEscape(h) + "</th>";
  body_ += "</tr>\n";
  for (const std::vector<std::string>& row : rows) {
    body_ += "<tr>";
    for (const std::string& cell : row) body_ += "<td>" + HtmlEscape(cell) + "</td>";
    body_ += "</tr>\n";
  }
  body_ += "</table></div>\n";
}

void ReportPage::Figure(const std::string& file, const std::string& caption) {
  body_ += "<figure><img src=\"" + HtmlEscape(file) + "\" alt=\"" + HtmlEscape(caption) + "\"><figcaption>" +
           HtmlEscape(caption) + " (" + HtmlEscape(file) + ")</figcaption></figure>\n";
}

std::string ReportPage::Render() const {
  std::string top;
  if (!verdict_.empty()) top += "<p class=\"verdict\">" + HtmlEscape(verdict_) + "</p>\n";
  if (const Provenance* p = RunProvenance()) {
    top += "<div class=\"tablewrap provenance\"><table>\n";
    for (const auto& [key, value] : ProvenanceFields(*p))
      top += "<tr><th>" + HtmlEscape(key) + "</th><td>" + HtmlEscape(value) + "</td></tr>\n";
    top += "</table></div>\n";
  }
  return "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
         "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>" +
         HtmlEscape(title_) + "</title><style>" + kReportStyle + "</style></head>\n<body>\n<h1>" + HtmlEscape(title_) +
         "</h1>\n" + top + body_ + "</body></html>\n";
}

}  // namespace calib
