#include "calib/io/text_plot.h"

#include <algorithm>
#include <cmath>

namespace calib {

namespace {

std::string Utf8(char32_t c) {
  std::string s;
  if (c < 0x80) {
    s += static_cast<char>(c);
  } else if (c < 0x800) {
    s += static_cast<char>(0xC0 | (c >> 6));
    s += static_cast<char>(0x80 | (c & 0x3F));
  } else {
    s += static_cast<char>(0xE0 | (c >> 12));
    s += static_cast<char>(0x80 | ((c >> 6) & 0x3F));
    s += static_cast<char>(0x80 | (c & 0x3F));
  }
  return s;
}

// Lower eighth blocks: index 1..8 is U+2581..U+2588; 0 is a space.
std::string Eighths(int n) { return n <= 0 ? " " : Utf8(0x2580 + std::min(n, 8)); }

// Position of v in [lo, hi] on `levels` steps 0..levels-1, clamped.
int Level(double v, double lo, double hi, int levels) {
  if (!(hi > lo)) return levels / 2;
  const double t = (v - lo) / (hi - lo);
  return std::clamp(static_cast<int>(std::lround(t * (levels - 1))), 0, levels - 1);
}

}  // namespace

std::string Sparkline(const std::vector<double>& values, int width, Glyphs glyphs) {
  static const char kAscii[] = " .:-=+*#";
  const int n = std::min<int>(width, static_cast<int>(values.size()));
  if (width <= 0) return "";
  const auto first = values.end() - n;
  double lo = 0, hi = 0;
  if (n > 0) {
    const auto [mn, mx] = std::minmax_element(first, values.end());
    lo = *mn;
    hi = *mx;
  }
  std::string out(width - n, ' ');
  for (auto it = first; it != values.end(); ++it) {
    const int level = Level(*it, lo, hi, 8);  // 0..7
    out += glyphs == Glyphs::kUnicode ? Eighths(level + 1) : std::string(1, kAscii[level]);
  }
  return out;
}

std::vector<std::string> DotPlot(const std::vector<double>& values, int width, int height,
                                 double lo, double hi, Glyphs glyphs) {
  if (width <= 0 || height <= 0) return {};
  if (glyphs == Glyphs::kAscii) {  // three heights per cell: _ - '
    static const char kMarks[] = "_-'";
    std::vector<std::string> rows(height, std::string(width, ' '));
    const int n = std::min<int>(width, static_cast<int>(values.size()));
    for (int i = 0; i < n; ++i) {
      const int level = Level(values[values.size() - n + i], lo, hi, 3 * height);
      rows[height - 1 - level / 3][width - n + i] = kMarks[level % 3];
    }
    return rows;
  }
  // Braille: dot (column dx, row dy from the top) of a cell is this bit of U+2800.
  static const int kBit[2][4] = {{0x01, 0x02, 0x04, 0x40}, {0x08, 0x10, 0x20, 0x80}};
  std::vector<std::vector<int>> cells(height, std::vector<int>(width, 0));
  const int dots_x = 2 * width, dots_y = 4 * height;
  const int n = std::min<int>(dots_x, static_cast<int>(values.size()));
  int previous = -1;
  for (int i = 0; i < n; ++i) {
    const int x = dots_x - n + i;
    const int y = Level(values[values.size() - n + i], lo, hi, dots_y);  // from the bottom
    const int from = previous < 0 ? y : std::min(y, previous + (previous < y ? 1 : 0));
    const int to = previous < 0 ? y : std::max(y, previous - (previous > y ? 1 : 0));
    for (int yy = from; yy <= to; ++yy) {
      const int top = dots_y - 1 - yy;
      cells[top / 4][x / 2] |= kBit[x % 2][top % 4];
    }
    previous = y;
  }
  std::vector<std::string> rows;
  for (const auto& row : cells) {
    std::string s;
    for (int bits : row) s += bits ? Utf8(0x2800 + bits) : " ";
    rows.push_back(s);
  }
  return rows;
}

std::vector<std::string> BarColumns(const std::vector<int>& counts, int height, Glyphs glyphs) {
  if (height <= 0) return {};
  const int top = counts.empty() ? 0 : *std::max_element(counts.begin(), counts.end());
  const int steps = glyphs == Glyphs::kUnicode ? 8 : 1;  // marks per cell
  std::vector<std::string> rows(height);
  for (int count : counts) {
    int marks = top > 0 ? static_cast<int>(std::lround(double(count) / top * height * steps)) : 0;
    if (count > 0) marks = std::max(marks, 1);
    for (int r = 0; r < height; ++r) {  // r counts from the bottom
      const int in_cell = std::clamp(marks - r * steps, 0, steps);
      std::string& row = rows[height - 1 - r];
      row += glyphs == Glyphs::kUnicode ? Eighths(in_cell) : std::string(1, in_cell ? '#' : ' ');
    }
  }
  return rows;
}

namespace {

int Cells(const std::string& s) {
  int n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return n;
}

// The first `cells` cells of a UTF-8 string.
std::string FirstCells(const std::string& s, int cells) {
  int n = 0;
  for (std::size_t i = 0; i < s.size(); ++i)
    if ((static_cast<unsigned char>(s[i]) & 0xC0) != 0x80 && n++ == cells) return s.substr(0, i);
  return s;
}

}  // namespace

std::vector<std::string> WrapWords(const std::string& text, int width, int max_lines) {
  width = std::max(width, 4);
  max_lines = std::max(max_lines, 1);
  std::vector<std::string> words;
  for (std::size_t start = 0; start < text.size();) {
    std::size_t end = text.find(' ', start);
    if (end == std::string::npos) end = text.size();
    if (end > start) words.push_back(FirstCells(text.substr(start, end - start), width));
    start = end + 1;
  }
  std::vector<std::string> lines(1);
  std::size_t i = 0;
  for (; i < words.size(); ++i) {
    const bool fits = lines.back().empty() || Cells(lines.back()) + 1 + Cells(words[i]) <= width;
    if (!fits) {
      if (static_cast<int>(lines.size()) == max_lines) break;
      lines.emplace_back();
    }
    lines.back() += (lines.back().empty() ? "" : " ") + words[i];
  }
  if (i < words.size()) {  // more words than lines: the last line ends at a word, with "..."
    std::string& last = lines.back();
    while (Cells(last) + 3 > width && last.find(' ') != std::string::npos) last.resize(last.rfind(' '));
    if (Cells(last) + 3 > width) last = FirstCells(last, width - 3);
    last += "...";
  }
  return lines;
}

}  // namespace calib
