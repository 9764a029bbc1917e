#include "calib/core/stamp_gate.h"

#include <algorithm>
#include <vector>

namespace calib {

double MedianSpacing(const std::deque<double>& intervals) {
  if (intervals.empty()) return 0.0;
  std::vector<double> sorted(intervals.begin(), intervals.end());
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  return sorted[sorted.size() / 2];
}

}  // namespace calib
