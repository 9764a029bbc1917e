// OptiOdom runs (Sousa et al.) -> WHEELS + POSE (importers.h).
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

#include "agvcal/pose2d_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/se2.h"
#include "calib/core/wheel_track.h"
#include "calib/import/importers.h"
#include "calib/io/messages.h"
#include "import/import_common.h"

namespace calib {

namespace {

using namespace import_internal;

struct Metadata {
  std::string path;
  DriveType drive = DriveType::kDifferential;
  double ticks_per_revolution = 0.0;  // encRes * ngear
  double length = 0.0;                // Li: track (diff) or wheelbase (tricycle), m
  std::vector<double> diameters;      // Di, m
  double steer_offset = 0.0;          // Thi, rad, added to the reading (OptiOdom's sign)
};

std::string MetadataPathFor(const std::string& run_path) {
  namespace fs = std::filesystem;
  const fs::path run(run_path);
  const std::string name = run.filename().string();
  const std::size_t at = name.rfind("_run-");
  if (at == std::string::npos)
    throw InputError(run_path, "", "an OptiOdom run file is named <id>_run-NN.csv[.gz]");
  const std::string base = name.substr(0, at) + "_metadata.csv";
  for (const std::string& candidate : {base, base + ".gz"}) {
    const fs::path p = run.parent_path() / candidate;
    if (fs::exists(p)) return p.string();
  }
  throw InputError(run_path, "", "no metadata file beside it (" + base + "[.gz])");
}

Metadata ReadMetadata(const std::string& path) {
  Metadata meta;
  meta.path = path;
  TextReader reader(path);
  std::map<std::string, std::pair<int64_t, std::vector<std::string>>> rows;
  std::string line;
  while (reader.Next(&line)) {
    std::vector<std::string> f = SplitFields(line, ',');
    while (!f.empty() && f.back().empty()) f.pop_back();
    if (f.empty()) continue;
    const std::string key = f[0];
    f.erase(f.begin());
    rows[key] = {reader.line_number(), f};
  }
  const auto get = [&](const std::string& key, const std::string& meaning) {
    const auto it = rows.find(key);
    if (it == rows.end() || it->second.second.empty())
      throw InputError(path, "key " + key, "missing (" + meaning + ")");
    return it->second;
  };
  const auto number = [&](const std::string& key, const std::string& meaning, std::size_t i) {
    const auto [row, values] = get(key, meaning);
    char* end = nullptr;
    const double v = i < values.size() ? std::strtod(values[i].c_str(), &end) : NAN;
    if (i >= values.size() || end != values[i].c_str() + values[i].size() || !std::isfinite(v))
      throw InputError(path, "line " + std::to_string(row) + ", key " + key,
                       "expected a number (" + meaning + ")");
    return v;
  };
  const auto [type_row, type] = get("type", "diff or tricyc");
  if (type[0] == "diff") {
    meta.drive = DriveType::kDifferential;
  } else if (type[0] == "tricyc") {
    meta.drive = DriveType::kTricycle;
  } else {
    throw InputError(path, "line " + std::to_string(type_row) + ", key type",
                     "drive type '" + type[0] + "' is not imported (diff or tricyc)");
  }
  meta.ticks_per_revolution = number("encRes", "encoder ticks per motor revolution", 0) *
                              number("ngear", "gear ratio", 0);
  if (meta.ticks_per_revolution <= 0)
    throw InputError(path, "key encRes", "encRes * ngear must be > 0");
  meta.length = number("Li", "track or wheelbase, m", 0);
  const std::size_t wheels = meta.drive == DriveType::kDifferential ? 2 : 1;
  for (std::size_t i = 0; i < wheels; ++i)
    meta.diameters.push_back(number("Di", "wheel diameters, m, one per wheel", i));
  if (meta.drive == DriveType::kTricycle) meta.steer_offset = number("Thi", "steering offset, rad", 0);
  return meta;
}

// Notes where the robot file's nominal values differ from the metadata's.
void CompareNominal(const Metadata& meta, const RobotDescription& robot, ImportSummary* summary) {
  std::vector<std::pair<std::string, double>> expected;
  if (meta.drive == DriveType::kDifferential) {
    // OptiOdom's run columns are odoR, odoL; Di lists the wheels in that order too.
    expected = {{"right_radius", meta.diameters[0] / 2},
                {"left_radius", meta.diameters[1] / 2},
                {"track", meta.length}};
  } else {
    expected = {{"drive_radius", meta.diameters[0] / 2},
                {"wheelbase", meta.length},
                {"steer_offset", -meta.steer_offset}};
  }
  for (const auto& [key, value] : expected) {
    if (std::abs(robot.param(key) - value) > 1e-9) {
      std::ostringstream note;
      note << robot.source_file << ": " << key << " " << robot.param(key) << " differs from "
           << meta.path << "'s " << value;
      summary->notes.push_back(note.str());
    }
  }
}

}  // namespace

ImportSummary ImportOptiOdom(const std::string& run_path, const RobotDescription& robot,
                             MessageSink* sink) {
  const Metadata meta = ReadMetadata(MetadataPathFor(run_path));
  RequireDrive(robot, meta.drive, "OptiOdom " + std::string(DriveTypeName(meta.drive)));
  ImportSummary summary;
  CompareNominal(meta, robot, &summary);
  const bool tricycle = meta.drive == DriveType::kTricycle;
  const double tick = 2.0 * M_PI / meta.ticks_per_revolution;
  const std::string pose_channel = PoseChannel(robot);
  EventBuffer events;
  StampOrder order("row");
  WheelSample sample;
  sample.position.assign(tricycle ? 1 : 2, 0.0);
  sample.steer.assign(tricycle ? 1 : 2, 0.0);
  bool first = true;

  TextReader reader(run_path);
  std::string line;
  while (reader.Next(&line)) {
    std::vector<std::string> f = SplitFields(line, ',');
    if (f.size() == 1 && f[0].empty()) continue;
    if (f.size() == 7 && f.back().empty()) f.pop_back();  // a trailing comma
    if (f.size() != 6)
      reader.Fail(std::string("expected 6 comma-separated fields (t, x_gt, y_gt, th_gt, ") +
                  (tricycle ? "odoWh, ThWh" : "odoR, odoL") + "), got " + std::to_string(f.size()));
    const int64_t utime = ParseSecondsAsMicros(reader, f[0], FieldName(0, "t"));
    agvcal::pose2d_t pose{};
    pose.utime = utime;
    pose.x = ParseNumber(reader, f[1], FieldName(1, "x_gt"));
    pose.y = ParseNumber(reader, f[2], FieldName(2, "y_gt"));
    pose.theta = WrapAngle(ParseNumber(reader, f[3], FieldName(3, "th_gt")));
    const double a = ParseNumber(reader, f[4], FieldName(4, tricycle ? "odoWh" : "odoR"));
    const double b = ParseNumber(reader, f[5], FieldName(5, tricycle ? "ThWh" : "odoL"));
    if (!order.Accept(reader, utime)) continue;
    if (!first) {  // the first row's ticks were counted before the run began
      if (tricycle) {
        sample.position[0] += a * tick;
      } else {
        sample.position[0] += b * tick;  // left
        sample.position[1] += a * tick;  // right
      }
    }
    first = false;
    if (tricycle) sample.steer[0] = b;
    sample.utime = utime;
    events.Add(kWheelsStream, kWheelsChannel, utime, Encode(WheelStateMessage(sample, robot)));
    events.Add(kPoseStream, pose_channel, utime, Encode(pose));
  }
  summary.lines = reader.line_number();
  summary.duplicates_dropped = order.duplicates;
  std::ostringstream note;
  note << meta.ticks_per_revolution << " ticks per wheel revolution (encRes * ngear, "
       << meta.path << ")";
  summary.notes.push_back(note.str());
  events.Publish(sink, &summary);
  return summary;
}

}  // namespace calib
