#pragma once
// The median of a few values, as the floor fit and the combination of frames take it.

#include <algorithm>
#include <vector>

namespace calib {

// The median (the mean of the two middle values for an even count); 0 for no values.
inline double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double m = values[mid];
  if (values.size() % 2 == 0) m = 0.5 * (m + *std::max_element(values.begin(), values.begin() + mid));
  return m;
}

}  // namespace calib
