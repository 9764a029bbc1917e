#pragma once
// Small plots made of characters for a terminal (the dashboard): a sparkline,
// a dot plot over time and vertical histogram bars. UTF-8 block and braille
// characters, or plain ASCII where the terminal's locale is not UTF-8. Every
// row returned is exactly `width` cells wide.

#include <string>
#include <vector>

namespace calib {

enum class Glyphs { kUnicode, kAscii };

// One cell per value, the last `width` values, scaled between their minimum
// (lowest glyph) and maximum (highest); all equal: the middle glyph. Padded
// with spaces on the left when there are fewer values than cells.
std::string Sparkline(const std::vector<double>& values, int width, Glyphs glyphs);

// The last values as dots in `width` x `height` cells, the oldest on the left,
// `lo` at the bottom and `hi` at the top (values outside are clamped to the edge
// rows). Braille cells hold 2 x 4 dots, so the last 2 * width values are drawn,
// consecutive dots joined vertically; ASCII draws `width` values, one of _ - '
// each (three heights per cell).
// Rows top first.
std::vector<std::string> DotPlot(const std::vector<double>& values, int width, int height,
                                 double lo, double hi, Glyphs glyphs);

// One column per count, bars rising from the bottom row, the largest count
// filling `height` rows (eighths of a cell with block glyphs, whole cells with
// `#` in ASCII); a non-zero count shows at least its lowest mark. Rows top first.
std::vector<std::string> BarColumns(const std::vector<int>& counts, int height, Glyphs glyphs);

// The words of `text` in lines of at most `width` cells (UTF-8), at most `max_lines` of them:
// a text that needs more ends its last line at a word with "..." rather than mid-sentence or
// silently short. A word longer than a line is cut. At least one line (empty for no text).
std::vector<std::string> WrapWords(const std::string& text, int width, int max_lines);

}  // namespace calib
