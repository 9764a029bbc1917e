#include "calib/io/text_reader.h"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "calib/core/errors.h"

namespace calib {

namespace {
constexpr unsigned kChunk = 1 << 16;
gzFile Gz(void* file) { return static_cast<gzFile>(file); }
}  // namespace

TextReader::TextReader(const std::string& path) : path_(path) {
  // fopen first: zlib reports a missing file without errno on some versions.
  std::FILE* probe = std::fopen(path.c_str(), "rb");
  if (!probe) throw InputError(path, "", std::string("cannot open: ") + std::strerror(errno));
  std::fclose(probe);
  file_ = gzopen(path.c_str(), "rb");
  if (!file_) throw InputError(path, "", "cannot open");
  gzbuffer(Gz(file_), 1 << 17);
}

TextReader::~TextReader() {
  if (file_) gzclose(Gz(file_));
}

void TextReader::Fail(const std::string& problem) const { throw InputError(path_, place(), problem); }

bool TextReader::Fill() {
  if (end_) return false;
  if (start_ > 0) {
    buffer_.erase(0, start_);
    start_ = 0;
  }
  const std::size_t old = buffer_.size();
  buffer_.resize(old + kChunk);
  const int got = gzread(Gz(file_), &buffer_[old], kChunk);
  int err = Z_OK;
  const char* message = gzerror(Gz(file_), &err);
  if (got < 0 || (err != Z_OK && err != Z_BUF_ERROR)) {
    buffer_.resize(old);
    throw InputError(path_, "line " + std::to_string(line_ + 1),
                     std::string("corrupt compressed data (") + message + ")");
  }
  buffer_.resize(old + static_cast<std::size_t>(got));
  if (got == 0) {
    // zlib signals a stream that ends inside the compressed data with Z_BUF_ERROR.
    if (err == Z_BUF_ERROR)
      throw InputError(path_, "line " + std::to_string(line_ + 1),
                       "the gzip data end early (truncated .gz file): the rest of the input is "
                       "missing");
    end_ = true;
    return false;
  }
  return true;
}

bool TextReader::Next(std::string* line) {
  std::size_t newline;
  while ((newline = buffer_.find('\n', start_)) == std::string::npos) {
    if (!Fill()) {
      if (start_ >= buffer_.size()) return false;
      newline = buffer_.size();  // last line without an end of line
      break;
    }
  }
  std::size_t end = newline;
  if (end > start_ && buffer_[end - 1] == '\r') --end;
  line->assign(buffer_, start_, end - start_);
  start_ = std::min(newline + 1, buffer_.size());
  ++line_;
  if (line_ == 1 && line->compare(0, 3, "\xEF\xBB\xBF") == 0) line->erase(0, 3);
  return true;
}

std::vector<std::string> SplitFields(const std::string& line, char separator) {
  std::vector<std::string> fields;
  const auto space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  if (separator == ' ') {
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && space(line[i])) ++i;
      const std::size_t begin = i;
      while (i < line.size() && !space(line[i])) ++i;
      if (i > begin) fields.emplace_back(line, begin, i - begin);
    }
    return fields;
  }
  std::size_t begin = 0;
  while (true) {
    const std::size_t end = std::min(line.find(separator, begin), line.size());
    std::size_t a = begin, b = end;
    while (a < b && space(line[a])) ++a;
    while (b > a && space(line[b - 1])) --b;
    fields.emplace_back(line, a, b - a);
    if (end == line.size()) break;
    begin = end + 1;
  }
  return fields;
}

double ParseNumber(const TextReader& reader, const std::string& field, const std::string& what) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(field.c_str(), &end);
  if (field.empty() || end != field.c_str() + field.size() || errno == ERANGE ||
      !std::isfinite(value))
    reader.Fail(what + ": expected a finite number, got '" + field + "'");
  return value;
}

int64_t ParseInteger(const TextReader& reader, const std::string& field, const std::string& what) {
  errno = 0;
  char* end = nullptr;
  const long long value = std::strtoll(field.c_str(), &end, 10);
  if (field.empty() || end != field.c_str() + field.size() || errno == ERANGE)
    reader.Fail(what + ": expected an integer, got '" + field + "'");
  return value;
}

int64_t ParseMillisAsMicros(const TextReader& reader, const std::string& field, const std::string& what) {
  const int64_t millis = ParseInteger(reader, field, what);
  if (millis > INT64_MAX / 1000 || millis < INT64_MIN / 1000)
    reader.Fail(what + ": time out of range, got '" + field + "'");
  return millis * 1000;
}

int64_t ParseSecondsAsMicros(const TextReader& reader, const std::string& field,
                             const std::string& what) {
  const double seconds = ParseNumber(reader, field, what);
  if (std::abs(seconds) > 9.0e12) reader.Fail(what + ": time out of range, got '" + field + "'");
  // Plain decimals are converted digit by digit: a double cannot hold an epoch time to the
  // microsecond and still round every stamp the same way.
  std::size_t i = 0;
  const bool negative = field[0] == '-';
  if (field[0] == '-' || field[0] == '+') ++i;
  int64_t whole = 0;
  std::size_t digits = 0;
  while (i < field.size() && std::isdigit(static_cast<unsigned char>(field[i]))) {
    whole = whole * 10 + (field[i++] - '0');
    ++digits;
  }
  int64_t micros = 0;
  int fraction_digits = 0;
  bool round_up = false;
  if (i < field.size() && field[i] == '.') {
    ++i;
    while (i < field.size() && std::isdigit(static_cast<unsigned char>(field[i]))) {
      if (fraction_digits < 6) {
        micros = micros * 10 + (field[i] - '0');
        ++fraction_digits;
      } else if (fraction_digits == 6) {
        round_up = field[i] >= '5';
        ++fraction_digits;
      }
      ++i;
    }
  }
  if (i != field.size() || digits == 0) return std::llround(seconds * 1e6);  // exponent form
  for (int k = std::min(fraction_digits, 6); k < 6; ++k) micros *= 10;
  const int64_t total = whole * 1000000 + micros + (round_up ? 1 : 0);
  return negative ? -total : total;
}

}  // namespace calib
