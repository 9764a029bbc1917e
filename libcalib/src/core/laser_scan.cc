#include "calib/core/laser_scan.h"

#include <cmath>

namespace calib {

int64_t LaserScan::end_utime() const {
  if (ranges.empty()) return utime;
  return static_cast<int64_t>(std::ceil(BeamTime(size() - 1)));
}

}  // namespace calib
