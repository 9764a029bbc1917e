#pragma once
// Pieces the diagnosis files share (internal to libcalib).

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

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

// Where on the floor (diagnose_region.cc): one interval of the current model, linearised.
struct RegionInterval {
  double x = 0, y = 0;  // odometry position at its start, m
  bool heldout = false;
  Eigen::Vector3d r = Eigen::Vector3d::Zero();  // whitened residual
  Eigen::Vector3d g = Eigen::Vector3d::Zero();  // its derivative by the effect's parameter
  Eigen::MatrixXd A;                            // 3 x p: by the calibration's free parameters
};

struct RegionTest {
  int boxes = 0;                           // boxes tried (the Bonferroni factor)
  std::array<double, 4> box{0, 0, 0, 0};   // the chosen one: x0, y0, x1, y1 (odometry frame)
  double beta = 0, std = 0, wald = 0, p = 1, p_adjusted = 1;  // on the fit blocks
  double heldout_beta = 0, heldout_z = 0;  // on the held-out intervals inside the box
  bool heldout_confirmed = false;
  std::vector<bool> inside;                // per interval given
};

// The box of a grid of `cell_m` over the intervals' positions (every box of whole cells) in which
// the effect's term, alone there, is most significant on the fit blocks with the physical sign
// `sign` (+1: positive sizes only, -1 negative, 0 either); intervals in time order.
RegionTest BestRegion(const std::vector<RegionInterval>& intervals, int hac_lags, double cell_m, int sign);

// Actuation layer: DRIVE_CMD against the encoders (drive_lag, steering_rate_limit).
// Appends candidates, found effects and traces to `report`; returns the number
// of candidates tested (for the catalogue-wide correction, applied by the caller
// through `alpha_share`: the level each actuation test is held to).
void DiagnoseActuation(const RobotDescription& robot, const DiagnoseData& data,
                       const DiagnoseOptions& options, double alpha_share, DiagnoseReport* report);

// Number of actuation candidates for a drive type (0 without commands).
int ActuationCandidates(const RobotDescription& robot, const DiagnoseData& data);

}  // namespace calib::diag
