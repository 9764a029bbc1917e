#include "calib/match/laser_scan.h"

#include <algorithm>
#include <cmath>

#include "calib/core/errors.h"

namespace calib {

int64_t LaserScan::end_utime() const {
  if (ranges.empty()) return utime;
  return static_cast<int64_t>(std::ceil(BeamTime(size() - 1)));
}

LaserScan LaserScanFromMessage(const agvcal::laser_scan_t& message, const std::string& origin) {
  const std::string place = "laser_scan_t utime " + std::to_string(message.utime);
  auto fail = [&](const std::string& problem) { throw InputError(origin, place, problem); };
  if (message.nranges < 0 || static_cast<size_t>(message.nranges) != message.ranges.size())
    fail("nranges " + std::to_string(message.nranges) + " but " +
         std::to_string(message.ranges.size()) + " ranges");
  if (message.nintensities != 0 && message.nintensities != message.nranges)
    fail("nintensities " + std::to_string(message.nintensities) + ", expected 0 or nranges " +
         std::to_string(message.nranges));
  if (message.intensities.size() != static_cast<size_t>(std::max(message.nintensities, 0)))
    fail("nintensities " + std::to_string(message.nintensities) + " but " +
         std::to_string(message.intensities.size()) + " intensities");
  const std::pair<const char*, float> fields[] = {{"angle_min", message.angle_min},
                                                  {"angle_increment", message.angle_increment},
                                                  {"time_increment", message.time_increment},
                                                  {"scan_time", message.scan_time}};
  for (const auto& [name, value] : fields)
    if (!std::isfinite(value)) fail(std::string(name) + " is not finite");
  if (message.angle_increment == 0.0f && message.nranges > 1) fail("angle_increment is 0");
  if (message.time_increment < 0.0f) fail("time_increment is negative");
  if (message.scan_time < 0.0f) fail("scan_time is negative");
  if (double(message.time_increment) * std::max(message.nranges - 1, 0) > kMaxScanDuration)
    fail("beams span " + std::to_string(double(message.time_increment) * (message.nranges - 1)) +
         " s (time_increment " + std::to_string(message.time_increment) + " s per beam)");
  if (!(message.range_min >= 0.0f) || !(message.range_max > message.range_min))
    fail("range interval [" + std::to_string(message.range_min) + ", " +
         std::to_string(message.range_max) + "] is empty or not a number");

  LaserScan scan;
  scan.utime = message.utime;
  scan.angle_min = message.angle_min;
  scan.angle_increment = message.angle_increment;
  scan.time_increment = message.time_increment;
  scan.scan_time = message.scan_time;
  scan.range_min = message.range_min;
  scan.range_max = message.range_max;
  scan.ranges = message.ranges;
  return scan;
}

}  // namespace calib
