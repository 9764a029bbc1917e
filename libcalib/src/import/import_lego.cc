// Brenner's Lego robot (SLAM lectures) -> WHEELS + SCAN; reference positions aside
// (importers.h).
#include <cmath>
#include <filesystem>

#include "calib/core/errors.h"
#include "calib/core/wheel_track.h"
#include "calib/import/importers.h"
#include "calib/io/messages.h"
#include "import/import_common.h"

namespace calib {

namespace {

using namespace import_internal;

// lego_robot.py and the lecture code (slam_02_b, slam_03_b).
constexpr double kTicksPerRevolution = 360.0;  // NXT motor encoder: one tick per degree
constexpr int64_t kBeams = 660;
constexpr double kBeamStep = 0.006135923151543;  // rad (2 pi / 1024)
constexpr double kCentreBeam = 330.0;
constexpr double kRangeMin = 0.02;  // m: the lecture code ignores readings <= 20 mm
constexpr double kRangeMax = 4.0;   // m: not sourced (a URG-class scanner is assumed)

void ExpectTag(const TextReader& reader, const std::vector<std::string>& f, const char* tag,
               std::size_t fields, const char* layout) {
  if (f[0] != tag) reader.Fail("expected a '" + std::string(tag) + "' record, got '" + f[0] + "'");
  if (f.size() != fields)
    reader.Fail("expected " + std::to_string(fields) + " fields (" + layout + "), got " +
                std::to_string(f.size()));
}

}  // namespace

std::string LegoScanPathFor(const std::string& motors_path) {
  namespace fs = std::filesystem;
  const fs::path motors(motors_path);
  if (!fs::exists(motors)) throw InputError(motors_path, "", "cannot open: no such file");
  std::string name = motors.filename().string();
  const std::size_t at = name.rfind("motors");
  if (at == std::string::npos)
    throw InputError(motors_path, "", "a Lego motor file name contains 'motors' (the scan file "
                                      "beside it has 'scan' in its place)");
  name.replace(at, 6, "scan");
  std::vector<std::string> tried{name};
  if (name.size() > 3 && name.compare(name.size() - 3, 3, ".gz") == 0)
    tried.push_back(name.substr(0, name.size() - 3));
  else
    tried.push_back(name + ".gz");
  for (const std::string& candidate : tried) {
    const fs::path p = motors.parent_path() / candidate;
    if (fs::exists(p)) return p.string();
  }
  throw InputError(motors_path, "", "no scan file beside it (tried " + tried[0] + " and " +
                                        tried[1] + ")");
}

ImportSummary ImportLego(const std::string& motors_path, const std::string& scan_path,
                         const RobotDescription& robot, MessageSink* sink) {
  RequireDrive(robot, DriveType::kDifferential, "Lego robot");
  ImportSummary summary;
  EventBuffer events;
  DifferentialTicks ticks(kTicksPerRevolution);
  std::string line;

  TextReader motors(motors_path);
  StampOrder motor_order("motor");
  while (motors.Next(&line)) {
    const std::vector<std::string> f = SplitFields(line);
    if (f.empty()) continue;
    ExpectTag(motors, f, "M", 14, "M t_ms, then pos tacho accel speed of 3 motors");
    const int64_t utime = ParseMillisAsMicros(motors, f[1], FieldName(1, "t_ms"));
    const int64_t left = ParseInteger(motors, f[2], FieldName(2, "left pos"));
    const int64_t right = ParseInteger(motors, f[6], FieldName(6, "right pos"));
    for (std::size_t k = 3; k < f.size(); ++k)
      if (k != 6) ParseInteger(motors, f[k], FieldName(k, "motor value"));
    if (!motor_order.Accept(motors, utime)) continue;
    events.Add(kWheelsStream, kWheelsChannel, utime, ticks.Message(utime, left, right, robot));
  }
  summary.lines += motors.line_number();

  TextReader scan_file(scan_path);
  StampOrder scan_order("scan");
  std::vector<agvcal::laser_scan_t> scans;
  while (scan_file.Next(&line)) {
    const std::vector<std::string> f = SplitFields(line);
    if (f.empty()) continue;
    ExpectTag(scan_file, f, "S", 3 + kBeams, "S t_ms 660 d0..d659");
    const int64_t utime = ParseMillisAsMicros(scan_file, f[1], FieldName(1, "t_ms"));
    if (ParseInteger(scan_file, f[2], FieldName(2, "beam count")) != kBeams)
      scan_file.Fail(FieldName(2, "beam count") + ": expected 660, got " + f[2]);
    std::vector<float> ranges(kBeams);
    for (int64_t i = 0; i < kBeams; ++i) {
      const std::size_t k = 3 + i;
      const int64_t mm = ParseInteger(scan_file, f[k], FieldName(k, "range mm"));
      if (mm < 0) scan_file.Fail(FieldName(k, "range mm") + ": negative range " + f[k]);
      ranges[i] = static_cast<float>(mm * 1e-3);
    }
    if (!scan_order.Accept(scan_file, utime)) continue;
    scans.push_back(MakeScan(utime, -kCentreBeam * kBeamStep, kBeamStep, kRangeMin, kRangeMax,
                             std::move(ranges)));
  }
  summary.lines += scan_file.line_number();
  summary.duplicates_dropped = motor_order.duplicates + scan_order.duplicates;
  SetScanTimes(&scans, 0.0 /* device period unknown: median interval */);
  const std::string channel = ScanChannel(robot);
  for (const auto& scan : scans) events.Add(kScanStream, channel, scan.utime, Encode(scan));
  summary.notes.push_back("360 ticks per wheel revolution (NXT motors); scans in the scanner's "
                          "frame: the -4 deg mounting angle belongs in lidar2d.yaw");
  summary.notes.push_back("the reference file (positions without heading) is not imported");
  events.Publish(sink, &summary);
  return summary;
}

std::vector<ReferencePosition> ReadLegoReference(const std::string& path) {
  std::vector<ReferencePosition> out;
  TextReader reader(path);
  StampOrder order("reference");
  std::string line;
  while (reader.Next(&line)) {
    const std::vector<std::string> f = SplitFields(line);
    if (f.empty()) continue;
    ExpectTag(reader, f, "P", 4, "P t_ms x_mm y_mm");
    ReferencePosition p;
    p.utime = ParseMillisAsMicros(reader, f[1], FieldName(1, "t_ms"));
    p.x = ParseNumber(reader, f[2], FieldName(2, "x_mm")) * 1e-3;
    p.y = ParseNumber(reader, f[3], FieldName(3, "y_mm")) * 1e-3;
    if (order.Accept(reader, p.utime)) out.push_back(p);
  }
  return out;
}

}  // namespace calib
