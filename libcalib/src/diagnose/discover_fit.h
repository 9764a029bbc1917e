#pragma once
// The linear fits of discovery (internal to libcalib): the final model's residual regressed on
// the columns of discover_columns.h (the calibration's, the effects found, and chosen library
// terms or catalogued effects) on the fit blocks, with a Newey-West covariance, and evaluated on
// the held-out blocks.

#include <vector>

#include <Eigen/Core>

#include "diagnose/discover_columns.h"

namespace calib::diag {

// The columns beyond the final model's own (A): library terms (G) and catalogued parameters (C).
struct DesignColumns {
  std::vector<int> terms;      // into DiscoveryRow::G
  std::vector<int> catalogued;  // into DiscoveryRow::C
};

// The design of one row: [A, G(terms), C(catalogued)].
Eigen::MatrixXd Design(const DiscoveryRow& row, const DesignColumns& columns);

struct LinearFit {
  // The change of the final model's parameters (A's columns: r(p + coef) ~ r + A coef), then
  // the terms' coefficients, then the catalogued parameters'.
  Eigen::VectorXd coef;
  Eigen::MatrixXd cov;   // Newey-West sandwich covariance of coef
  double chi2_fit = 0, chi2_heldout = 0;
  int n_fit = 0, n_heldout = 0, params = 0;
  // The coefficient and its std of the column `k` beyond A (0 for the first term).
  double Value(const DiscoveryRow& any, int k) const { return coef[any.A.cols() + k]; }
  double Std(const DiscoveryRow& any, int k) const;
};

// The fit on the rows not held out (least squares of r + X coef); chi-squares on both kinds of rows.
LinearFit FitRows(const std::vector<DiscoveryRow>& rows, const DesignColumns& columns, int hac_lags);

// A row's whitened residual left by `fit`.
Eigen::Vector3d ResidualLeft(const DiscoveryRow& row, const DesignColumns& columns, const LinearFit& fit);

// The held-out score test of the column `added` (a term) against the fit without it: the
// held-out residual's projection on the term's column, with the part the other columns explain
// on the fit blocks removed, over its Newey-West std (signed), that std from the held-out
// residual `fit_with` (the fit blocks' fit with the term) leaves.
double HeldoutScore(const std::vector<DiscoveryRow>& rows, const DesignColumns& without, int added,
                    const LinearFit& fit_without, const LinearFit& fit_with, int hac_lags);

// Chained errors of held-out rows over windows of `window_s` within a held-out block (outliers
// already left out): each window's sum of the errors' component `comp` (2: yaw, the heading
// error; 0, 1: x, y summed in each interval's own frame, to first order the chained distance
// error) and its number of rows.
struct HeadingChains {
  std::vector<double> sums;
  std::vector<int> counts;
  double mean_square = 0;  // of the per-row yaw errors in the windows
  double Rms() const;
};
HeadingChains ChainHeading(const std::vector<DiscoveryRow>& rows, const std::vector<Eigen::Vector3d>& errors,
                           double window_s, int comp = 2);

// Newey-West long-run variance of the per-row vectors `u` (in time order) with `lags`.
Eigen::MatrixXd LongRunVariance(const std::vector<Eigen::VectorXd>& u, int lags);

}  // namespace calib::diag
