#pragma once
// Counting values into equal bins over a range centred on 0, as the dashboard draws its
// residual histograms.

#include <vector>

namespace calib {

// Counts of values in `bins` equal bins over [lo, hi]; values outside land in the first or
// last bin (`below`/`above` count them).
struct Histogram {
  double lo = 0, hi = 0;
  std::vector<int> counts;
  int below = 0, above = 0;
};

// The histogram of `values` over [-range, range] in `bins` bins (at least 1); range 0 takes the
// largest magnitude of the values (a symmetric range, so 0 is central).
Histogram SymmetricHistogram(const std::vector<double>& values, int bins, double range = 0);

}  // namespace calib
