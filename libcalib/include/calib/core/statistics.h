#pragma once
// General statistics of the calibration's results: an estimate with its uncertainty, the
// chi-square tail, two estimates of the same values compared, and a paired comparison of two
// models' errors on the same samples.

#include <string>
#include <vector>

#include <Eigen/Core>

namespace calib {

// An estimated value, its standard deviation and the nominal value it started from.
struct Estimate {
  double value = 0.0;
  double std = 0.0;
  double nominal = 0.0;
};

// P(chi2 > x) with `dof` degrees of freedom.
double ChiSquareUpperTail(double x, int dof);

// The x with P(chi2 > x) = p, `dof` degrees of freedom.
double ChiSquareUpperQuantile(double p, int dof);

// P(chi2 > x) for a noncentral chi-square, `dof` degrees of freedom and noncentrality `lambda`
// (the sum of the squared means of the unit-variance normals).
double NoncentralChiSquareUpperTail(double x, int dof, double lambda);

// The noncentrality at which a test rejecting above `x` (`dof` degrees of freedom) has the
// given power: the squared size, in standard errors, that it detects that often.
double NoncentralityForPower(double x, int dof, double power);

// Two estimates of the same values compared: `delta` their difference (angles wrapped),
// `sum` the sum of their covariances, `names` the values' names. d2 is the squared
// Mahalanobis distance, a chi-square with one degree per value (infinite when `sum` cannot
// weigh the difference); `largest` the value that differs most, in combined sigmas.
struct EstimateDifference {
  double d2 = 0.0;
  int dof = 0;
  double p = 1.0;
  std::string largest;
  double largest_sigmas = 0.0;
};
EstimateDifference CompareEstimates(const Eigen::VectorXd& delta, const Eigen::MatrixXd& sum,
                                    const std::vector<std::string>& names);

// Two models' errors on the same samples (smaller is better), sample by sample: the paired
// comparison that says whether one is better beyond chance. Differences in the errors' unit.
struct PairedComparison {
  int windows = 0;                 // samples compared (the held-out comparison's windows)
  int second_better = 0;           // samples where the second model's error is smaller
  int ties = 0;                    // equal within 1e-9 (left out of the sign test)
  double sign_test_p = 1.0;        // two-sided exact binomial test of "either is as likely better"
  double mean_difference = 0.0;    // mean of (second - first)
  double difference_sem = 0.0;     // its standard error
};
// The first min(first.size(), second.size()) samples of each.
PairedComparison ComparePaired(const std::vector<double>& first, const std::vector<double>& second);

}  // namespace calib
