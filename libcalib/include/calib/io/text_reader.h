#pragma once
// Line-by-line reading of text files recorded elsewhere (datasets, CSV), plain or
// gzip-compressed (told from the content, not the name), with strict field
// parsing. Every error is an InputError naming the file and the 1-based line.

#include <cstdint>
#include <string>
#include <vector>

namespace calib {

class TextReader {
 public:
  // Throws InputError if the file cannot be opened.
  explicit TextReader(const std::string& path);
  ~TextReader();
  TextReader(const TextReader&) = delete;
  TextReader& operator=(const TextReader&) = delete;

  // The next line without its end of line (\n or \r\n) and, on the first line, without a
  // UTF-8 byte-order mark; false at the clean end. Throws InputError for a gzip stream that
  // is cut short (a truncated .gz) or corrupt, at the line being read.
  bool Next(std::string* line);

  const std::string& path() const { return path_; }
  int64_t line_number() const { return line_; }  // of the line last returned; 0 before
  std::string place() const { return "line " + std::to_string(line_); }

  // Throws InputError(path, "line N", problem) for the line last returned.
  [[noreturn]] void Fail(const std::string& problem) const;

 private:
  bool Fill();  // reads more decompressed bytes; false at the end

  std::string path_;
  void* file_ = nullptr;  // gzFile; zlib stays out of this header
  std::string buffer_;
  std::size_t start_ = 0;
  bool end_ = false;
  int64_t line_ = 0;
};

// Fields of a line: separated by runs of whitespace (separator ' '), or by `separator`
// with the whitespace around each field trimmed (e.g. ','; empty fields are kept).
std::vector<std::string> SplitFields(const std::string& line, char separator = ' ');

// Strict field parsers: the whole field must be a finite number (an integer for
// ParseInteger). On failure they throw InputError at the reader's current line, naming
// the field as `what` (e.g. "field 4 (left ticks)") and quoting the text.
double ParseNumber(const TextReader& reader, const std::string& field, const std::string& what);
int64_t ParseInteger(const TextReader& reader, const std::string& field, const std::string& what);

// A whole number of milliseconds as microseconds; a value whose microseconds do not fit
// in int64 is refused like any bad field.
int64_t ParseMillisAsMicros(const TextReader& reader, const std::string& field, const std::string& what);

// A time in seconds ("1134864629.895182", "0.05", "1e3") as microseconds, rounded to the
// nearest; exact for plain decimals, whatever their magnitude.
int64_t ParseSecondsAsMicros(const TextReader& reader, const std::string& field,
                             const std::string& what);

}  // namespace calib
