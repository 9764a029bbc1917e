// Mines rover (CoreSLAM / BreezySLAM) logs -> WHEELS + SCAN (importers.h).
#include <cmath>

#include "calib/core/wheel_track.h"
#include "calib/import/importers.h"
#include "calib/io/messages.h"
#include "import/import_common.h"

namespace calib {

namespace {

using namespace import_internal;

// BreezySLAM examples/mines.py and breezyslam/sensors.py (URG04LX).
constexpr std::size_t kFields = 707;
constexpr std::size_t kFirstRange = 24;
constexpr std::size_t kBeams = 682;
constexpr double kTicksPerRevolution = 2000.0;
constexpr double kFieldOfView = 240.0 * M_PI / 180.0;  // first to last beam
constexpr double kRangeMin = 0.02;                      // m, URG-04LX; 0..19 mm are error codes
constexpr double kRangeMax = 4.0;                       // m, URG-04LX rated range
constexpr double kScanPeriod = 0.1;                     // s, 10 Hz

}  // namespace

ImportSummary ImportMines(const std::string& path, const RobotDescription& robot,
                          MessageSink* sink) {
  RequireDrive(robot, DriveType::kDifferential, "Mines rover");
  ImportSummary summary;
  StampOrder order("line");
  EventBuffer events;
  std::vector<agvcal::laser_scan_t> scans;
  DifferentialTicks ticks(kTicksPerRevolution);

  TextReader reader(path);
  std::string line;
  while (reader.Next(&line)) {
    const std::vector<std::string> f = SplitFields(line);
    if (f.empty()) continue;
    if (f.size() != kFields)
      reader.Fail("expected " + std::to_string(kFields) +
                  " fields (t_us, ?, left ticks, right ticks, 20 unused, 682 ranges mm, 1 "
                  "ignored), got " + std::to_string(f.size()));
    const int64_t utime = ParseInteger(reader, f[0], FieldName(0, "t_us"));
    const int64_t left = ParseInteger(reader, f[2], FieldName(2, "left ticks"));
    const int64_t right = ParseInteger(reader, f[3], FieldName(3, "right ticks"));
    std::vector<float> ranges(kBeams);
    for (std::size_t i = 0; i < kBeams; ++i) {
      const std::size_t k = kFirstRange + i;
      const int64_t mm = ParseInteger(reader, f[k], FieldName(k, "range mm"));
      if (mm < 0) reader.Fail(FieldName(k, "range mm") + ": negative range " + f[k]);
      ranges[i] = static_cast<float>(mm * 1e-3);  // 0 and error codes fall below range_min
    }
    if (!order.Accept(reader, utime)) continue;
    events.Add(kWheelsStream, kWheelsChannel, utime, ticks.Message(utime, left, right, robot));
    scans.push_back(MakeScan(utime, -kFieldOfView / 2, kFieldOfView / (kBeams - 1), kRangeMin,
                             kRangeMax, std::move(ranges)));
  }
  summary.lines = reader.line_number();
  summary.duplicates_dropped = order.duplicates;
  SetScanTimes(&scans, kScanPeriod);
  const std::string channel = ScanChannel(robot);
  for (const auto& scan : scans) events.Add(kScanStream, channel, scan.utime, Encode(scan));
  summary.notes.push_back(
      "2000 ticks per wheel revolution (mines.py); scan stamped with the line's time, "
      "whether that is the scan's first beam is not documented");
  events.Publish(sink, &summary);
  return summary;
}

}  // namespace calib
