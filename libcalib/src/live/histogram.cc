#include "calib/live/histogram.h"

#include <algorithm>
#include <cmath>

namespace calib {

Histogram SymmetricHistogram(const std::vector<double>& values, int bins, double range) {
  Histogram h;
  bins = std::max(bins, 1);
  h.counts.assign(bins, 0);
  if (range <= 0) {
    range = 0;
    for (double v : values) range = std::max(range, std::abs(v));
  }
  if (range <= 0) range = 1e-9;  // all zero (or none): one tiny central range
  h.lo = -range;
  h.hi = range;
  const double width = (h.hi - h.lo) / bins;
  for (double e : values) {
    int bin = static_cast<int>(std::floor((e - h.lo) / width));
    if (bin < 0) {
      ++h.below;
      bin = 0;
    } else if (bin >= bins) {
      if (e > h.hi) ++h.above;
      bin = bins - 1;  // the upper edge itself belongs to the last bin
    }
    ++h.counts[bin];
  }
  return h;
}

}  // namespace calib
