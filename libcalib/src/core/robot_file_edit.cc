// In-place edits of a robot file's YAML text: yaml-cpp finds where each node starts (its
// mark), and the text is changed there, so that everything else (comments, flow or block
// style, alignment) stays as the user wrote it.
#include "calib/core/robot_file_edit.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <optional>
#include <utility>

#include "calib/core/errors.h"
#include "calib/core/units.h"
#include "core/yaml_checked.h"

namespace calib {
namespace {

std::vector<std::string> SplitPath(const std::string& path) {
  std::vector<std::string> keys;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = path.find('.', start);
    keys.push_back(path.substr(start, dot - start));
    if (dot == std::string::npos) return keys;
    start = dot + 1;
  }
}

std::optional<std::pair<YAML::Node, YAML::Node>> FindEntry(const YAML::Node& map, const std::string& key) {
  for (auto it = map.begin(); it != map.end(); ++it)
    if (it->first.IsScalar() && it->first.Scalar() == key) return std::make_pair(it->first, it->second);
  return std::nullopt;
}

// Past the end of the quoted or plain scalar that starts at `pos`.
std::size_t ScalarEnd(const std::string& text, std::size_t pos, bool in_flow) {
  const char quote = text[pos];
  if (quote == '"' || quote == '\'') {
    for (std::size_t i = pos + 1; i < text.size(); ++i) {
      if (quote == '"' && text[i] == '\\') ++i;
      else if (text[i] == quote && quote == '\'' && i + 1 < text.size() && text[i + 1] == '\'') ++i;
      else if (text[i] == quote) return i + 1;
    }
    return text.size();
  }
  std::size_t end = pos;
  while (end < text.size() && text[end] != '\n' && text[end] != '\r' &&
         !(in_flow && (text[end] == ',' || text[end] == '}' || text[end] == ']')) &&
         !(text[end] == '#' && end > pos && (text[end - 1] == ' ' || text[end - 1] == '\t')))
    ++end;
  while (end > pos && (text[end - 1] == ' ' || text[end - 1] == '\t')) --end;
  return end;
}

// Replaces [pos, end) by `value`; a comment after it on the line keeps its column if the
// spaces before it allow.
std::string Replace(const std::string& text, std::size_t pos, std::size_t end, const std::string& value) {
  std::size_t spaces_end = end;
  while (spaces_end < text.size() && text[spaces_end] == ' ') ++spaces_end;
  std::size_t erase_end = end;
  std::string insert = value;
  if (spaces_end < text.size() && text[spaces_end] == '#' && spaces_end > end) {
    const long spaces = static_cast<long>(spaces_end - end);
    const long wanted = std::max(1L, spaces - (static_cast<long>(value.size()) - static_cast<long>(end - pos)));
    erase_end = spaces_end;
    insert += std::string(static_cast<std::size_t>(wanted), ' ');
  }
  return text.substr(0, pos) + insert + text.substr(erase_end);
}

// The position of the '}' that closes the flow map opened at `open`.
std::size_t FlowMapClose(const std::string& text, std::size_t open) {
  int depth = 0;
  for (std::size_t i = open; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '"' || c == '\'') {
      i = ScalarEnd(text, i, true) - 1;
    } else if (c == '#' && i > 0 && (text[i - 1] == ' ' || text[i - 1] == '\t')) {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (c == '{' || c == '[') {
      ++depth;
    } else if (c == '}' || c == ']') {
      if (--depth == 0) return i;
    }
  }
  return std::string::npos;
}

// Where a new entry of the block map whose last key starts at `last_key` goes: the start of
// the first line after that entry (its value may continue on more indented lines).
std::size_t AfterBlockEntry(const std::string& text, std::size_t last_key, std::size_t indent) {
  std::size_t line = text.find('\n', last_key);
  while (line != std::string::npos) {
    const std::size_t start = line + 1;
    if (start >= text.size()) return text.size();
    const std::size_t first = text.find_first_not_of(" \t", start);
    if (first != std::string::npos && text[first] != '\n' && text[first] != '\r' && first - start <= indent)
      return start;
    line = text.find('\n', start);
  }
  return text.size();
}

std::string FlowSnippet(const std::vector<std::string>& keys, std::size_t from, const std::string& value) {
  if (from + 1 == keys.size()) return keys[from] + ": " + value;
  return keys[from] + ": {" + FlowSnippet(keys, from + 1, value) + "}";
}

// Adds keys[depth..] (a nested entry) to `map`, which lacks keys[depth].
std::string Insert(const std::string& text, const YAML::Node& map, bool is_root, const std::vector<std::string>& keys,
                   std::size_t depth, const std::string& value) {
  const std::string snippet = FlowSnippet(keys, depth, value);
  if (map.Style() == YAML::EmitterStyle::Flow && !is_root) {
    const std::size_t close = FlowMapClose(text, static_cast<std::size_t>(map.Mark().pos));
    std::size_t at = close;
    while (at > 0 && (text[at - 1] == ' ' || text[at - 1] == '\n' || text[at - 1] == '\t')) --at;
    const bool empty = text[at - 1] == '{';
    return text.substr(0, at) + (empty ? "" : ", ") + snippet + text.substr(at);
  }
  std::size_t last_key = 0, indent = 0;
  for (auto it = map.begin(); it != map.end(); ++it) {
    if (static_cast<std::size_t>(it->first.Mark().pos) >= last_key) {
      last_key = static_cast<std::size_t>(it->first.Mark().pos);
      indent = static_cast<std::size_t>(it->first.Mark().column);
    }
  }
  std::string line = std::string(indent, ' ');
  // A new top-level map is a block with one flow entry per line, as robot files are written.
  if (is_root && depth + 1 < keys.size())
    line += keys[depth] + ":\n  " + FlowSnippet(keys, depth + 1, value);
  else
    line += snippet;
  std::string out = text;
  if (!out.empty() && out.back() != '\n') out += '\n';
  const std::size_t at = AfterBlockEntry(out, last_key, indent);
  return out.substr(0, at) + line + "\n" + out.substr(at);
}

}  // namespace

std::string SetYamlScalar(const std::string& text, const std::string& origin, const std::string& path,
                          const std::string& value_text) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(origin, "line " + std::to_string(e.mark.line + 1), std::string("YAML error: ") + e.what());
  }
  const std::vector<std::string> keys = SplitPath(path);
  YAML::Node map = root;
  for (std::size_t depth = 0; depth < keys.size(); ++depth) {
    if (!map.IsMap()) throw InputError(origin, "key " + path, "expected a map to write " + path + " into");
    const auto entry = FindEntry(map, keys[depth]);
    if (!entry) return Insert(text, map, depth == 0, keys, depth, value_text);
    if (depth + 1 == keys.size()) {
      const YAML::Node& value = entry->second;
      if (!value.IsScalar() || value.Mark().pos < 0)
        throw InputError(origin, "line " + std::to_string(entry->first.Mark().line + 1) + ", key " + path,
                         "expected a number to replace");
      const auto pos = static_cast<std::size_t>(value.Mark().pos);
      return Replace(text, pos, ScalarEnd(text, pos, map.Style() == YAML::EmitterStyle::Flow), value_text);
    }
    map = entry->second;
  }
  return text;
}

std::string WriteCalibratedValues(const std::string& text, const std::string& origin,
                                  const std::vector<RobotFileValue>& values, const std::string& command,
                                  const std::string& source, const std::string& details) {
  std::string out = text;
  // The robot file's note that its values are nominal is no longer true of calibrated ones.
  const std::string nominal_note = "# nominal values; calibration starts here";
  if (const std::size_t at = out.find(nominal_note); at != std::string::npos) {
    std::size_t start = at;
    while (start > 0 && (out[start - 1] == ' ' || out[start - 1] == '\t')) --start;
    out.erase(start, at + nominal_note.size() - start);
  }
  for (const RobotFileValue& v : values)
    out = SetYamlScalar(out, origin, v.path, RoundedToSigma(v.value, v.std, v.significant));
  for (const RobotFileValue& v : values) {
    if (DecimalsForSigma(v.std) >= 0) out = SetYamlScalar(out, origin, "std." + v.path, RoundedToSigma(v.std, v.std));
  }
  YAML::Emitter quoted;
  quoted << source;
  out = SetYamlScalar(out, origin, "source", quoted.c_str());
  std::string header = "# Calibrated by agvcal " + command + " from " + source + "\n";
  for (std::size_t line = 0; line < details.size();) {
    const std::size_t end = std::min(details.find('\n', line), details.size());
    header += "#   " + details.substr(line, end - line) + "\n";
    line = end + 1;
  }
  // An earlier header (its first line and its indented lines) is replaced.
  if (out.rfind("# Calibrated by agvcal ", 0) == 0) {
    out.erase(0, out.find('\n') + 1);
    while (out.rfind("#   ", 0) == 0) out.erase(0, out.find('\n') == std::string::npos ? out.size() : out.find('\n') + 1);
  }
  return header + out;
}

std::string WriteCalibratedRobotFile(const std::string& path, const std::vector<RobotFileValue>& values,
                                     const std::string& command, const std::string& source,
                                     const std::string& details) {
  return WriteCalibratedValues(yaml::ReadTextFile(path, "robot file"), path, values, command, source, details);
}

}  // namespace calib
