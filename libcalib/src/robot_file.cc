// Reading and validating robot files (spec/robot.md). Every key must be known
// and used exactly once, so a typo never passes silently; every error names the
// file, the 1-based line and the key path.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "calib/errors.h"
#include "calib/robot.h"

namespace calib {
namespace {

constexpr double kHalfPi = 1.57079632679489661923;
constexpr double kPi = 3.14159265358979323846;

int LineOf(const YAML::Mark& mark) { return mark.is_null() ? 0 : mark.line + 1; }

std::string Join(const std::vector<std::string>& items, const std::string& last = " and ") {
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

// The closest candidate if it is close enough to be a likely typo, else "".
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

  [[noreturn]] void Fail(int line, const std::string& path, const std::string& problem) const {
    std::string place;
    if (line > 0) place = "line " + std::to_string(line);
    if (!path.empty()) place += (place.empty() ? "" : ", ") + std::string("key ") + path;
    throw InputError(origin_, place, problem);
  }
  [[noreturn]] void Fail(const Field& field, const std::string& problem) const {
    Fail(field.line, field.path, problem);
  }

 private:
  std::string origin_;
};

// A YAML map whose keys were checked against the allowed ones on construction:
// scalar, not repeated, known (with a "did you mean" for a likely typo).
class CheckedMap {
 public:
  CheckedMap(const Reporter& reporter, const Field& field, const std::vector<std::string>& allowed,
             const std::string& unknown_hint = "")
      : reporter_(reporter), path_(field.path), line_(field.line) {
    if (!field.value.IsMap()) {
      reporter.Fail(field, "expected a map of keys, got " + Describe(field.value));
    }
    for (const auto& entry : field.value) {
      const YAML::Node& key_node = entry.first;
      const int line = LineOf(key_node.Mark()) > 0 ? LineOf(key_node.Mark()) : line_;
      if (!key_node.IsScalar()) {
        reporter.Fail(line, path_, "a key must be a plain name, got " + Describe(key_node));
      }
      const std::string key = key_node.Scalar();
      const std::string path = path_.empty() ? key : path_ + "." + key;
      if (std::find(allowed.begin(), allowed.end(), key) == allowed.end()) {
        std::string problem = "unknown key";
        const std::string suggestion = Suggest(key, allowed);
        if (!suggestion.empty()) {
          problem += " (did you mean " + suggestion + "?)";
        } else if (!unknown_hint.empty()) {
          problem += " (" + unknown_hint + ")";
        } else {
          problem += " (expected " + Join(allowed) + ")";
        }
        reporter.Fail(line, path, problem);
      }
      const auto previous = fields_.find(key);
      if (previous != fields_.end()) {
        reporter.Fail(line, path,
                      "duplicate key (first given on line " +
                          std::to_string(previous->second.line) + ")");
      }
      fields_[key] = Field{path, line, entry.second};
    }
  }

  const std::string& path() const { return path_; }
  int line() const { return line_; }
  bool Has(const std::string& key) const { return fields_.count(key) > 0; }

  std::optional<Field> Find(const std::string& key) const {
    const auto it = fields_.find(key);
    if (it == fields_.end()) return std::nullopt;
    return it->second;
  }

  Field Get(const std::string& key, const std::string& missing_hint = "") const {
    const auto it = fields_.find(key);
    if (it == fields_.end()) {
      reporter_.Fail(line_, path_.empty() ? key : path_ + "." + key,
                     "missing required key" + (missing_hint.empty() ? "" : " (" + missing_hint + ")"));
    }
    return it->second;
  }

 private:
  const Reporter& reporter_;
  std::string path_;
  int line_;
  std::map<std::string, Field> fields_;
};

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
  if (!(value > 0.0)) {
    reporter.Fail(field, "must be > 0, got " + Describe(field.value));
  }
  return value;
}

// |value| <= bound, with `bound_text` naming the bound for the message.
double ReadBounded(const Reporter& reporter, const Field& field, double bound,
                   const std::string& bound_text) {
  const double value = ReadNumber(reporter, field);
  if (std::abs(value) > bound) {
    reporter.Fail(field, "must be within ±" + bound_text + " rad, got " + Describe(field.value));
  }
  return value;
}

// Optional number: `fallback` when the key is absent.
double NumberOr(const Reporter& reporter, const CheckedMap& map, const std::string& key,
                double fallback) {
  const auto field = map.Find(key);
  return field ? ReadNumber(reporter, *field) : fallback;
}

std::string ChannelOr(const Reporter& reporter, const CheckedMap& map, const std::string& fallback) {
  const auto field = map.Find("channel");
  return field ? ReadString(reporter, *field) : fallback;
}

DriveType ReadDrive(const Reporter& reporter, const Field& field) {
  static const std::vector<std::string> kNames{"differential", "tricycle", "dual_steer"};
  static const std::vector<DriveType> kTypes{DriveType::kDifferential, DriveType::kTricycle,
                                             DriveType::kDualSteer};
  const YAML::Node& v = field.value;
  if (!v.IsScalar()) reporter.Fail(field, "expected " + Join(kNames, " or ") + ", got " + Describe(v));
  for (size_t i = 0; i < kNames.size(); ++i) {
    if (v.Scalar() == kNames[i]) return kTypes[i];
  }
  const std::string suggestion = Suggest(v.Scalar(), kNames);
  reporter.Fail(field, "unknown drive type " + Describe(v) +
                           (suggestion.empty() ? "" : " (did you mean " + suggestion + "?)") +
                           "; expected " + Join(kNames, " or "));
}

std::map<std::string, std::string> ReadWheels(const Reporter& reporter, const Field& field,
                                              DriveType drive) {
  const std::vector<std::string>& roles = WheelRoles(drive);
  const std::string roles_text =
      std::string("wheel roles of a ") + DriveTypeName(drive) + " drive are " + Join(roles);
  const CheckedMap map(reporter, field, roles, roles_text);
  std::map<std::string, std::string> wheels;
  std::map<std::string, std::string> role_of_name;
  for (const auto& role : roles) {
    const Field wheel = map.Get(role, roles_text);
    const std::string name = ReadString(reporter, wheel);
    const auto clash = role_of_name.find(name);
    if (clash != role_of_name.end()) {
      reporter.Fail(wheel, "wheel name '" + name + "' is also used by wheels." + clash->second);
    }
    role_of_name[name] = role;
    wheels[role] = name;
  }
  return wheels;
}

std::map<std::string, double> ReadParams(const Reporter& reporter, const Field& field,
                                         DriveType drive) {
  const std::vector<std::string>& names = ParamNames(drive);
  const std::string names_text =
      std::string("parameters of a ") + DriveTypeName(drive) + " drive are " + Join(names);
  const CheckedMap map(reporter, field, names, names_text);
  std::map<std::string, double> params;
  for (const auto& name : names) {
    const Field param = map.Get(name, names_text);
    const bool is_length = name == "track" || name == "wheelbase" ||
                           (name.size() >= 7 && name.compare(name.size() - 7, 7, "_radius") == 0);
    const bool is_offset = name.size() >= 12 &&
                           name.compare(name.size() - 12, 12, "steer_offset") == 0;
    if (is_length) {
      params[name] = ReadPositive(reporter, param);
    } else if (is_offset) {
      params[name] = ReadBounded(reporter, param, kHalfPi, "pi/2");
    } else {
      params[name] = ReadNumber(reporter, param);
    }
  }
  if (drive == DriveType::kDualSteer && params["a"] == 0.0 && params["b"] == 0.0) {
    reporter.Fail(map.Get("a").line, map.path() + ".a",
                  "a and b are both 0, which puts both wheels at the same point");
  }
  return params;
}

Mount2d ReadMount2d(const Reporter& reporter, const Field& field, const std::string& channel) {
  const CheckedMap map(reporter, field, {"channel", "x", "y", "yaw"});
  Mount2d mount;
  mount.channel = ChannelOr(reporter, map, channel);
  mount.x = NumberOr(reporter, map, "x", 0.0);
  mount.y = NumberOr(reporter, map, "y", 0.0);
  mount.yaw = NumberOr(reporter, map, "yaw", 0.0);
  return mount;
}

Mount3d ReadMount3d(const Reporter& reporter, const Field& field) {
  const CheckedMap map(reporter, field, {"channel", "z", "pitch", "roll", "x", "y", "yaw"});
  Mount3d mount;
  mount.channel = ChannelOr(reporter, map, "CLOUD");
  // The height is what the floor observes; a nominal value is needed to start from.
  mount.z = ReadPositive(reporter, map.Get("z", "height of the 3D lidar above the floor, m"));
  if (const auto f = map.Find("pitch")) mount.pitch = ReadBounded(reporter, *f, kHalfPi, "pi/2");
  if (const auto f = map.Find("roll")) mount.roll = ReadBounded(reporter, *f, kHalfPi, "pi/2");
  mount.x = NumberOr(reporter, map, "x", 0.0);
  mount.y = NumberOr(reporter, map, "y", 0.0);
  mount.yaw = NumberOr(reporter, map, "yaw", 0.0);
  return mount;
}

ImuMount ReadImu(const Reporter& reporter, const Field& field) {
  const CheckedMap map(reporter, field, {"channel", "yaw"});
  ImuMount mount;
  mount.channel = ChannelOr(reporter, map, "IMU");
  mount.yaw = NumberOr(reporter, map, "yaw", 0.0);
  return mount;
}

Limits ReadLimits(const Reporter& reporter, const Field& field) {
  const CheckedMap map(reporter, field,
                       {"max_speed", "max_omega", "max_accel", "max_steer", "max_steer_rate"});
  Limits limits;
  if (const auto f = map.Find("max_speed")) limits.max_speed = ReadPositive(reporter, *f);
  if (const auto f = map.Find("max_omega")) limits.max_omega = ReadPositive(reporter, *f);
  if (const auto f = map.Find("max_accel")) limits.max_accel = ReadPositive(reporter, *f);
  if (const auto f = map.Find("max_steer")) {
    limits.max_steer = ReadPositive(reporter, *f);
    if (limits.max_steer > kPi) reporter.Fail(*f, "must be <= pi rad, got " + Describe(f->value));
  }
  if (const auto f = map.Find("max_steer_rate")) limits.max_steer_rate = ReadPositive(reporter, *f);
  return limits;
}

RobotDescription ParseDocument(const Reporter& reporter, const YAML::Node& root,
                               const std::string& origin) {
  static const std::vector<std::string> kTopKeys{"name",  "drive", "wheels", "params",
                                                 "lidar2d", "lidar3d", "imu", "pose",
                                                 "limits", "std",   "source"};
  const int root_line = std::max(1, LineOf(root.Mark()));
  if (!root.IsMap()) {
    reporter.Fail(root_line, "",
                  "the top level must be a map with keys name, drive, wheels, params, ..., got " +
                      Describe(root));
  }
  // A drive parameter at the top level would otherwise get a misleading suggestion.
  for (const auto& entry : root) {
    if (!entry.first.IsScalar()) continue;
    const std::string& key = entry.first.Scalar();
    for (DriveType type : {DriveType::kDifferential, DriveType::kTricycle, DriveType::kDualSteer}) {
      const std::vector<std::string>& names = ParamNames(type);
      if (std::find(names.begin(), names.end(), key) != names.end()) {
        reporter.Fail(LineOf(entry.first.Mark()), key,
                      "unknown key (drive parameters go under params:)");
      }
    }
  }
  const CheckedMap top(reporter, Field{"", root_line, root}, kTopKeys,
                       "expected " + Join(kTopKeys) + "; drive parameters go under params");

  RobotDescription robot;
  robot.source_file = origin;
  robot.name = ReadString(reporter, top.Get("name"));
  robot.drive = ReadDrive(reporter, top.Get("drive", "differential, tricycle or dual_steer"));
  robot.wheels = ReadWheels(reporter, top.Get("wheels", "map of wheel role to wheel name"),
                            robot.drive);
  robot.params = ReadParams(reporter, top.Get("params", "nominal drive parameters"), robot.drive);
  if (const auto f = top.Find("lidar2d")) robot.lidar2d = ReadMount2d(reporter, *f, "SCAN");
  if (const auto f = top.Find("lidar3d")) robot.lidar3d = ReadMount3d(reporter, *f);
  if (const auto f = top.Find("imu")) robot.imu = ReadImu(reporter, *f);
  if (const auto f = top.Find("pose")) robot.pose = ReadMount2d(reporter, *f, "POSE");
  if (const auto f = top.Find("limits")) robot.limits = ReadLimits(reporter, *f);
  // Written by `agvcal solve`; carried for the user, not read back.
  if (const auto f = top.Find("std")) {
    if (!f->value.IsMap()) reporter.Fail(*f, "expected a map of standard deviations, got " +
                                                 Describe(f->value));
  }
  if (const auto f = top.Find("source")) {
    if (!f->value.IsScalar()) reporter.Fail(*f, "expected a log name, got " + Describe(f->value));
  }
  return robot;
}

}  // namespace

RobotDescription ParseRobot(const std::string& yaml_text, const std::string& origin) {
  const Reporter reporter(origin);
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(yaml_text);
  } catch (const YAML::ParserException& e) {
    reporter.Fail(LineOf(e.mark), "", "YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    reporter.Fail(LineOf(e.mark), "", std::string("YAML error: ") + e.what());
  }
  if (documents.empty() || (documents.size() == 1 && documents[0].IsNull())) {
    reporter.Fail(0, "", "empty robot file (expected name, drive, wheels, params, ...)");
  }
  if (documents.size() > 1) {
    reporter.Fail(LineOf(documents[1].Mark()), "",
                  "more than one YAML document; a robot file holds one robot");
  }
  try {
    return ParseDocument(reporter, documents[0], origin);
  } catch (const YAML::Exception& e) {  // Not expected: every access is checked first.
    reporter.Fail(LineOf(e.mark), "", std::string("YAML error: ") + e.what());
  }
}

RobotDescription LoadRobotFile(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw InputError(path, "", "cannot read robot file: is a directory");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", std::string("cannot read robot file: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(path, "", std::string("cannot read robot file: ") + std::strerror(errno));
  return ParseRobot(text.str(), path);
}

}  // namespace calib
