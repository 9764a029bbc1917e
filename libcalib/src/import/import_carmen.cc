// CARMEN logs -> WHEELS + SCAN (importers.h).
#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "agvcal/laser_scan_t.hpp"
#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/se2.h"
#include "calib/core/wheel_track.h"
#include "calib/import/importers.h"
#include "calib/io/messages.h"
#include "import/import_common.h"

namespace calib {

namespace {

using namespace import_internal;

constexpr double kDeg = M_PI / 180.0;
constexpr double kSickNoReturn = 81.9;  // m: the SICK LMS's 8191 cm code
constexpr int kMaxBeams = 100000;

using OdometryRecord = OdometryPose;

// Geometry of the old-format FLASER/RLASER lines, which do not carry it: CARMEN's
// convention by beam count (a SICK LMS at 1, 0.5 or 0.25 deg).
bool FlaserGeometry(int64_t beams, double* angle_min, double* increment) {
  switch (beams) {
    case 180: *angle_min = -90 * kDeg; *increment = 1.0 * kDeg; return true;
    case 181: *angle_min = -90 * kDeg; *increment = 1.0 * kDeg; return true;
    case 361: *angle_min = -90 * kDeg; *increment = 0.5 * kDeg; return true;
    case 401: *angle_min = -50 * kDeg; *increment = 0.25 * kDeg; return true;
    default: return false;
  }
}

bool IsRecordName(const std::string& tag) {
  if (tag.empty() || !std::isupper(static_cast<unsigned char>(tag[0]))) return false;
  for (char c : tag)
    if (!std::isupper(static_cast<unsigned char>(c)) && !std::isdigit(static_cast<unsigned char>(c)) &&
        c != '_')
      return false;
  return true;
}

int64_t Count(const TextReader& reader, const std::vector<std::string>& f, std::size_t i,
              const std::string& what) {
  if (i >= f.size()) reader.Fail(f[0] + " line ends before " + FieldName(i, what));
  const int64_t n = ParseInteger(reader, f[i], FieldName(i, what));
  if (n < 0 || n > kMaxBeams) reader.Fail(FieldName(i, what) + ": implausible count " + f[i]);
  return n;
}

void ExpectFields(const TextReader& reader, const std::vector<std::string>& f, std::size_t expected,
                  const std::string& layout) {
  if (f.size() != expected) {
    reader.Fail(f[0] + " line has " + std::to_string(f.size()) + " fields, expected " +
                std::to_string(expected) + " (" + layout + ")");
  }
}

std::vector<float> Ranges(const TextReader& reader, const std::vector<std::string>& f,
                          std::size_t first, int64_t n, double no_return) {
  std::vector<float> ranges(static_cast<std::size_t>(n));
  for (int64_t i = 0; i < n; ++i) {
    const std::size_t k = first + static_cast<std::size_t>(i);
    const double r = ParseNumber(reader, f[k], FieldName(k, "range " + std::to_string(i)));
    if (r < 0) reader.Fail(FieldName(k, "range " + std::to_string(i)) + ": negative range " + f[k]);
    ranges[static_cast<std::size_t>(i)] =
        r >= no_return ? std::numeric_limits<float>::infinity() : static_cast<float>(r);
  }
  return ranges;
}

// The ipc_timestamp and the two fields after it (host, logger_timestamp) that end a line.
int64_t Stamp(const TextReader& reader, const std::vector<std::string>& f, std::size_t ipc) {
  ParseNumber(reader, f[ipc + 2], FieldName(ipc + 2, "logger_timestamp"));
  return ParseSecondsAsMicros(reader, f[ipc], FieldName(ipc, "ipc_timestamp"));
}

// A FLASER line: the odometry it carries and its scan (the old format: the geometry from
// the beam count); false when `order` drops its stamp.
bool ReadFlaser(const TextReader& reader, const std::vector<std::string>& f, StampOrder* order,
                OdometryRecord* odom, agvcal::laser_scan_t* scan) {
  const int64_t n = Count(reader, f, 1, "num_readings");
  ExpectFields(reader, f, 2 + n + 9,
               "FLASER n r1..rn x y theta odom_x odom_y odom_theta ipc_timestamp "
               "ipc_hostname logger_timestamp");
  double angle_min = 0, increment = 0;
  if (!FlaserGeometry(n, &angle_min, &increment))
    reader.Fail("FLASER with " + std::to_string(n) +
                " readings: its geometry is not in the line and CARMEN's convention "
                "covers 180, 181, 361 and 401 readings only");
  const std::size_t p = 2 + n;
  OdometryRecord& o = *odom;
  for (std::size_t k = p; k < p + 3; ++k) ParseNumber(reader, f[k], FieldName(k, "laser pose"));
  o.pose = {ParseNumber(reader, f[p + 3], FieldName(p + 3, "odom_x")),
            ParseNumber(reader, f[p + 4], FieldName(p + 4, "odom_y")),
            ParseNumber(reader, f[p + 5], FieldName(p + 5, "odom_theta"))};
  o.utime = Stamp(reader, f, p + 6);
  std::vector<float> ranges = Ranges(reader, f, 2, n, kSickNoReturn);
  if (!order->Accept(reader, o.utime)) return false;
  *scan = MakeScan(o.utime, angle_min, increment, 0.0, kSickNoReturn, std::move(ranges));
  return true;
}

// A RAWLASER1 line: its scan, with the remissions as intensities when there is one per
// beam; false when `order` drops its stamp.
bool ReadRawlaser(const TextReader& reader, const std::vector<std::string>& f, StampOrder* order,
                  agvcal::laser_scan_t* scan) {
  const int64_t n = Count(reader, f, 8, "num_readings");
  const int64_t nrem = Count(reader, f, 9 + n, "num_remissions");
  ExpectFields(reader, f, 9 + n + 1 + nrem + 3,
               "RAWLASER1 laser_type start_angle fov resolution max_range accuracy "
               "remission_mode n r1..rn m e1..em ipc_timestamp ipc_hostname logger_timestamp");
  const double start = ParseNumber(reader, f[2], FieldName(2, "start_angle"));
  const double resolution = ParseNumber(reader, f[4], FieldName(4, "angular_resolution"));
  const double max_range = ParseNumber(reader, f[5], FieldName(5, "maximum_range"));
  if (max_range <= 0) reader.Fail(FieldName(5, "maximum_range") + ": must be > 0, got " + f[5]);
  const int64_t utime = Stamp(reader, f, 9 + n + 1 + nrem);
  *scan = MakeScan(utime, start, resolution, 0.0, max_range, Ranges(reader, f, 9, n, max_range));
  if (nrem == n) {
    for (int64_t i = 0; i < nrem; ++i) {
      const std::size_t k = 10 + n + i;
      scan->intensities.push_back(
          static_cast<float>(ParseNumber(reader, f[k], FieldName(k, "remission"))));
    }
    scan->nintensities = static_cast<int32_t>(nrem);
  }
  return order->Accept(reader, utime);
}

// An ODOM line: pose and velocities; false when `order` drops its stamp.
bool ReadOdom(const TextReader& reader, const std::vector<std::string>& f, StampOrder* order,
              OdometryRecord* odom) {
  ExpectFields(reader, f, 10, "ODOM x y theta tv rv accel ipc_timestamp ipc_hostname "
                              "logger_timestamp");
  OdometryRecord& o = *odom;
  o.pose = {ParseNumber(reader, f[1], FieldName(1, "x")),
            ParseNumber(reader, f[2], FieldName(2, "y")),
            ParseNumber(reader, f[3], FieldName(3, "theta"))};
  o.has_velocity = true;
  o.tv = ParseNumber(reader, f[4], FieldName(4, "tv"));
  o.rv = ParseNumber(reader, f[5], FieldName(5, "rv"));
  ParseNumber(reader, f[6], FieldName(6, "accel"));
  o.utime = Stamp(reader, f, 7);
  return order->Accept(reader, o.utime);
}

}  // namespace

ImportSummary ImportCarmen(const std::string& path, const RobotDescription& robot,
                           MessageSink* sink) {
  RequireDrive(robot, DriveType::kDifferential, "CARMEN");
  ImportSummary summary;
  std::vector<agvcal::laser_scan_t> flaser_scans, rawlaser_scans;
  std::vector<OdometryRecord> odom, flaser_odom;
  StampOrder flaser_order("FLASER"), rawlaser_order("RAWLASER1"), odom_order("ODOM");
  std::map<std::string, int64_t> skipped;

  TextReader reader(path);
  std::string line;
  while (reader.Next(&line)) {
    const std::vector<std::string> f = SplitFields(line);
    if (f.empty()) continue;
    if (f[0][0] == '#') {
      ++skipped["comment"];
      continue;
    }
    const std::string& tag = f[0];
    if (tag == "FLASER") {
      OdometryRecord o;
      agvcal::laser_scan_t scan;
      if (!ReadFlaser(reader, f, &flaser_order, &o, &scan)) continue;
      flaser_odom.push_back(o);
      flaser_scans.push_back(std::move(scan));
    } else if (tag == "RAWLASER1") {
      agvcal::laser_scan_t scan;
      if (!ReadRawlaser(reader, f, &rawlaser_order, &scan)) continue;
      rawlaser_scans.push_back(std::move(scan));
    } else if (tag == "ODOM") {
      OdometryRecord o;
      if (!ReadOdom(reader, f, &odom_order, &o)) continue;
      odom.push_back(o);
    } else if (IsRecordName(tag)) {
      ++skipped[tag];
    } else {
      reader.Fail("not a CARMEN record: '" + tag.substr(0, 40) +
                  "' (expected a message name such as FLASER or ODOM, or a # comment)");
    }
  }
  summary.lines = reader.line_number();
  summary.duplicates_dropped =
      flaser_order.duplicates + rawlaser_order.duplicates + odom_order.duplicates;

  const bool raw = !rawlaser_scans.empty();
  std::vector<agvcal::laser_scan_t>& scans = raw ? rawlaser_scans : flaser_scans;
  const std::vector<OdometryRecord>& poses = odom.empty() ? flaser_odom : odom;
  if (poses.empty())
    throw InputError(path, "", "no odometry: neither ODOM lines nor FLASER lines with odometry");
  if (raw && !flaser_scans.empty())
    summary.notes.push_back("scans from RAWLASER1 (it carries the laser geometry); the " +
                            std::to_string(flaser_scans.size()) + " FLASER lines repeat them");
  summary.notes.push_back(std::string("wheel states from the odometry of the ") +
                          (odom.empty() ? "FLASER" : "ODOM") + " lines, inverted with " +
                          robot.source_file + "'s nominal radii and track");
  SetScanTimes(&scans, 0.0 /* device period unknown: median interval */);

  EventBuffer events;
  const std::string scan_channel = ScanChannel(robot);
  for (const auto& scan : scans) events.Add(kScanStream, scan_channel, scan.utime, Encode(scan));

  AddWheelsFromOdometry(poses, robot, &events, &summary);
  for (const auto& [tag, count] : skipped) {
    summary.skipped += count;
    summary.notes.push_back("skipped " + std::to_string(count) + " " + tag +
                            (tag == "comment" ? " lines" : " records"));
  }
  events.Publish(sink, &summary);
  return summary;
}

}  // namespace calib
