#include "core/yaml_checked.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <yaml-cpp/eventhandler.h>

#include "calib/core/errors.h"
#include "calib/core/input_file.h"

namespace calib {
namespace yaml {

int LineOf(const YAML::Mark& mark) { return mark.is_null() ? 0 : mark.line + 1; }

std::string Join(const std::vector<std::string>& items, const std::string& last) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) {
    if (i > 0) out += (i + 1 == items.size()) ? last : ", ";
    out += items[i];
  }
  return out;
}

size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      const size_t substitute = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
      row[j] = std::min({above + 1, row[j - 1] + 1, substitute});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string Suggest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  size_t best_distance = std::string::npos;
  for (const auto& candidate : candidates) {
    const size_t d = EditDistance(word, candidate);
    if (d < best_distance) best_distance = d, best = candidate;
  }
  const size_t limit = std::max<size_t>(2, std::max(word.size(), best.size()) / 3);
  return best_distance <= limit ? best : std::string();
}

std::string Describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null: return "nothing";
    case YAML::NodeType::Scalar: return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Map: return "a map";
    case YAML::NodeType::Undefined: break;
  }
  return "nothing";
}

void Reporter::Fail(int line, const std::string& path, const std::string& problem) const {
  std::string place;
  if (line > 0) place = "line " + std::to_string(line);
  if (!path.empty()) place += (place.empty() ? "" : ", ") + std::string("key ") + path;
  throw InputError(origin_, place, problem);
}

CheckedMap::CheckedMap(const Reporter& reporter, const Field& field,
                       const std::vector<std::string>& allowed, const std::string& unknown_hint)
    : reporter_(reporter), path_(field.path), line_(field.line) {
  if (!field.value.IsMap()) reporter.Fail(field, "expected a map of keys, got " + Describe(field.value));
  for (const auto& entry : field.value) {
    const YAML::Node& key_node = entry.first;
    const int line = LineOf(key_node.Mark()) > 0 ? LineOf(key_node.Mark()) : line_;
    if (!key_node.IsScalar())
      reporter.Fail(line, path_, "a key must be a plain name, got " + Describe(key_node));
    const std::string key = key_node.Scalar();
    const std::string path = path_.empty() ? key : path_ + "." + key;
    if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
      std::string problem = "unknown key";
      const std::string suggestion = Suggest(key, allowed);
      if (!suggestion.empty())
        problem += " (did you mean " + suggestion + "?)";
      else if (!unknown_hint.empty())
        problem += " (" + unknown_hint + ")";
      else
        problem += " (expected " + Join(allowed) + ")";
      reporter.Fail(line, path, problem);
    }
    const auto previous = fields_.find(key);
    if (previous != fields_.end())
      reporter.Fail(line, path,
                    "duplicate key (first given on line " + std::to_string(previous->second.line) + ")");
    fields_[key] = Field{path, line, entry.second};
  }
}

std::optional<Field> CheckedMap::Find(const std::string& key) const {
  const auto it = fields_.find(key);
  if (it == fields_.end()) return std::nullopt;
  return it->second;
}

Field CheckedMap::Get(const std::string& key, const std::string& missing_hint) const {
  const auto it = fields_.find(key);
  if (it == fields_.end())
    reporter_.Fail(line_, path_.empty() ? key : path_ + "." + key,
                   "missing required key" + (missing_hint.empty() ? "" : " (" + missing_hint + ")"));
  return it->second;
}

double ReadNumber(const Reporter& reporter, const Field& field) {
  const YAML::Node& v = field.value;
  if (!v.IsScalar()) reporter.Fail(field, "expected a number, got " + Describe(v));
  if (v.Tag() == "!") reporter.Fail(field, "expected a number, got the quoted string " + Describe(v));
  double value = 0.0;
  try {
    value = v.as<double>();
  } catch (const YAML::Exception&) {
    reporter.Fail(field, "expected a number, got " + Describe(v));
  }
  if (!std::isfinite(value)) reporter.Fail(field, "expected a finite number, got " + Describe(v));
  return value;
}

std::string ReadString(const Reporter& reporter, const Field& field) {
  const YAML::Node& v = field.value;
  if (!v.IsScalar()) reporter.Fail(field, "expected a name, got " + Describe(v));
  if (v.Scalar().empty()) reporter.Fail(field, "must not be empty");
  return v.Scalar();
}

double ReadPositive(const Reporter& reporter, const Field& field) {
  const double value = ReadNumber(reporter, field);
  if (!(value > 0.0)) reporter.Fail(field, "must be > 0, got " + Describe(field.value));
  return value;
}

double ReadBounded(const Reporter& reporter, const Field& field, double bound,
                   const std::string& bound_text) {
  const double value = ReadNumber(reporter, field);
  if (std::abs(value) > bound)
    reporter.Fail(field, "must be within ±" + bound_text + " rad, got " + Describe(field.value));
  return value;
}

double NumberOr(const Reporter& reporter, const CheckedMap& map, const std::string& key,
                double fallback) {
  const auto field = map.Find(key);
  return field ? ReadNumber(reporter, *field) : fallback;
}

namespace {
// Where the documents of a text start, without building them; and how deep and how large the
// text is, so that a nest or a list no config has is refused before yaml-cpp builds it (its
// nodes take hundreds of bytes each; a deep nest recurses).
constexpr int kMaxYamlDepth = 32;
constexpr long kMaxYamlNodes = 100000;

class DocumentStarts : public YAML::EventHandler {
 public:
  explicit DocumentStarts(const Reporter& reporter) : reporter_(reporter) {}
  std::vector<YAML::Mark> marks;
  void OnDocumentStart(const YAML::Mark& mark) override { marks.push_back(mark); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { Count(mark); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { Count(mark); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t, const std::string&) override {
    Count(mark);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    Open(mark);
  }
  void OnSequenceEnd() override { --depth_; }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    Open(mark);
  }
  void OnMapEnd() override { --depth_; }

 private:
  void Count(const YAML::Mark& mark) {
    if (++nodes_ > kMaxYamlNodes)
      reporter_.Fail(LineOf(mark), "", "more than " + std::to_string(kMaxYamlNodes) + " values: no config is this large");
  }
  void Open(const YAML::Mark& mark) {
    Count(mark);
    if (++depth_ > kMaxYamlDepth)
      reporter_.Fail(LineOf(mark), "", "nested more than " + std::to_string(kMaxYamlDepth) + " levels deep: no config is");
  }
  const Reporter& reporter_;
  int depth_ = 0;
  long nodes_ = 0;
};
}  // namespace

Field ParseSingleDocument(const Reporter& reporter, const std::string& text, const std::string& what) {
  // Not YAML::LoadAll: yaml-cpp 0.7 (Debian 12) never consumes a ',' at block level and
  // LoadAll then makes empty documents until memory runs out (found by bench/fuzz). At most
  // two documents are parsed here, and a second that starts where the first did is that case.
  YAML::Node root;
  try {
    std::istringstream stream(text);
    YAML::Parser parser(stream);
    DocumentStarts starts(reporter);
    while (starts.marks.size() < 2 && parser.HandleNextDocument(starts)) {
    }
    if (starts.marks.size() > 1) {
      const YAML::Mark& second = starts.marks[1];
      if (second.pos == starts.marks[0].pos)
        reporter.Fail(LineOf(second), "", "YAML syntax error: a ',' outside a [ ] or { } collection");
      reporter.Fail(LineOf(second), "", "more than one YAML document in a " + what);
    }
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    reporter.Fail(LineOf(e.mark), "", "YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    reporter.Fail(LineOf(e.mark), "", std::string("YAML error: ") + e.what());
  }
  if (root.IsNull()) reporter.Fail(0, "", "empty " + what);
  const int root_line = std::max(1, LineOf(root.Mark()));
  if (!root.IsMap()) reporter.Fail(root_line, "", "the top level must be a map of keys (" + what + "), got " + Describe(root));
  return Field{"", root_line, root};
}

std::string ReadTextFile(const std::string& path, const std::string& what) {
  return ReadWholeFile(path, what, kMaxTextFileBytes);
}

}  // namespace yaml
}  // namespace calib
