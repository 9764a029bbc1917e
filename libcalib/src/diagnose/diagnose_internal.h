#pragma once
// Pieces the diagnosis files share (internal to libcalib).

#include <cmath>
#include <string>
#include <vector>

#include "calib/diagnose/diagnose.h"

namespace calib::diag {

// Upper normal quantile z with P(Z > z) = p.
inline double NormalUpper(double p) {
  double lo = -10, hi = 40;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Holm's step-down adjustment of p-values (same order as given).
std::vector<double> HolmAdjust(const std::vector<double>& p);

// Root mean square (0 for none).
double Rms(const std::vector<double>& v);

// Merges the times of flagged intervals into spans (gaps up to `gap_us` bridged).
std::vector<TimeSpan> MergeSpans(std::vector<TimeSpan> flagged, int64_t gap_us);

// Actuation layer: DRIVE_CMD against the encoders (drive_lag, steering_rate_limit).
// Appends candidates, found effects and traces to `report`; returns the number
// of candidates tested (for the catalogue-wide correction, applied by the caller
// through `alpha_share`: the level each actuation test is held to).
void DiagnoseActuation(const RobotDescription& robot, const DiagnoseData& data,
                       const DiagnoseOptions& options, double alpha_share, DiagnoseReport* report);

// Number of actuation candidates for a drive type (0 without commands).
int ActuationCandidates(const RobotDescription& robot, const DiagnoseData& data);

}  // namespace calib::diag
