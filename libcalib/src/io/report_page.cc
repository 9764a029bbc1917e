#include "io/report_page.h"

#include "calib/io/provenance.h"


namespace calib {
namespace {

// Readable at 1024 px and narrower: a centred column, text and table cells that wrap,
// figures (SVGs drawn 900 px wide) scaled down to the column.
const char* kStyle =
    "body{font-family:sans-serif;max-width:940px;margin:0 auto;padding:0 12px;line-height:1.4;"
    "overflow-wrap:break-word;color:#222}"
    "h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ddd}"
    ".text{white-space:pre-wrap;overflow-wrap:anywhere;font-family:monospace;font-size:13px;background:#f6f6f6;padding:8px;"
    "border:1px solid #e4e4e4}"
    ".tablewrap{overflow-x:auto}"
    "table{border-collapse:collapse;width:100%;font-size:13px}"
    "th,td{border:1px solid #ccc;padding:3px 6px;text-align:left;vertical-align:top}"
    "th{background:#f0f0f0}"
    "figure{margin:14px 0}figure img{max-width:100%;height:auto;display:block;border:1px solid #eee}"
    "figcaption{font-size:13px;color:#444}"
    ".verdict{font-size:1.1em;font-weight:bold;padding:8px;border-left:4px solid #2a6;background:#f3faf5}"
    ".provenance td,.provenance th{font-size:12px;font-family:monospace;overflow-wrap:anywhere}"
    ".provenance th{white-space:nowrap;width:1%}";

}  // namespace

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
         HtmlEscape(title_) + "</title><style>" + kStyle + "</style></head>\n<body>\n<h1>" + HtmlEscape(title_) +
         "</h1>\n" + top + body_ + "</body></html>\n";
}

}  // namespace calib
