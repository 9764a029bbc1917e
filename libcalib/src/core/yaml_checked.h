#pragma once
// Checked reading of YAML configuration (robot files, simulation configs):
// every key must be known and given once (a typo fails with a "did you mean"),
// and every error is an InputError naming the file, the 1-based line and the
// key path. Internal to libcalib.

#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace calib {
namespace yaml {

int LineOf(const YAML::Mark& mark);
std::string Join(const std::vector<std::string>& items, const std::string& last = " and ");
size_t EditDistance(const std::string& a, const std::string& b);
// The closest candidate if it is close enough to be a likely typo, else "".
std::string Suggest(const std::string& word, const std::vector<std::string>& candidates);
// "'value'", "a list", "a map" or "nothing", for messages.
std::string Describe(const YAML::Node& node);

// One map entry: its full key path, the line of its key and its value.
struct Field {
  std::string path;
  int line = 0;
  YAML::Node value;
};

// Throws InputError for `origin`.
class Reporter {
 public:
  explicit Reporter(std::string origin) : origin_(std::move(origin)) {}
  [[noreturn]] void Fail(int line, const std::string& path, const std::string& problem) const;
  [[noreturn]] void Fail(const Field& field, const std::string& problem) const {
    Fail(field.line, field.path, problem);
  }
  const std::string& origin() const { return origin_; }

 private:
  std::string origin_;
};

// A YAML map whose keys were checked against the allowed ones on construction:
// scalar, not repeated, known (with a "did you mean" for a likely typo).
class CheckedMap {
 public:
  CheckedMap(const Reporter& reporter, const Field& field, const std::vector<std::string>& allowed,
             const std::string& unknown_hint = "");
  const std::string& path() const { return path_; }
  int line() const { return line_; }
  bool Has(const std::string& key) const { return fields_.count(key) > 0; }
  std::optional<Field> Find(const std::string& key) const;
  // The entry; a missing key is an error (with the hint in the message).
  Field Get(const std::string& key, const std::string& missing_hint = "") const;

 private:
  const Reporter& reporter_;
  std::string path_;
  int line_;
  std::map<std::string, Field> fields_;
};

double ReadNumber(const Reporter& reporter, const Field& field);
std::string ReadString(const Reporter& reporter, const Field& field);
double ReadPositive(const Reporter& reporter, const Field& field);
// |value| <= bound, with `bound_text` naming the bound for the message.
double ReadBounded(const Reporter& reporter, const Field& field, double bound,
                   const std::string& bound_text);
// Optional number: `fallback` when the key is absent.
double NumberOr(const Reporter& reporter, const CheckedMap& map, const std::string& key,
                double fallback);

// Parses text holding exactly one YAML document whose top level is a map;
// `what` names the kind of file in messages ("robot file").
Field ParseSingleDocument(const Reporter& reporter, const std::string& text, const std::string& what);

// A robot file or config is kilobytes: a file larger than this is not one (a data file, a
// device), refused before it is read on.
inline constexpr std::size_t kMaxTextFileBytes = 1 << 20;

// The whole file (core/input_file.h: a FIFO without a writer or a device refused, not waited on
// or read forever); InputError if it cannot be read or is larger than kMaxTextFileBytes.
std::string ReadTextFile(const std::string& path, const std::string& what);

}  // namespace yaml
}  // namespace calib
