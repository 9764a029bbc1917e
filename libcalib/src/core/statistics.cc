#include "calib/core/statistics.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <unsupported/Eigen/SpecialFunctions>

namespace calib {

double ChiSquareUpperTail(double x, int dof) {
  return x <= 0 ? 1.0 : Eigen::numext::igammac(0.5 * dof, 0.5 * x);
}

double ChiSquareUpperQuantile(double p, int dof) {
  double lo = 0, hi = 1;
  while (ChiSquareUpperTail(hi, dof) > p && hi < 1e6) hi *= 2;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (ChiSquareUpperTail(mid, dof) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double NoncentralChiSquareUpperTail(double x, int dof, double lambda) {
  if (!(lambda > 0)) return ChiSquareUpperTail(x, dof);
  // A Poisson(lambda / 2) mixture of central chi-squares with dof + 2 j degrees of freedom,
  // summed out from the Poisson's mode until the weights are negligible.
  const double mu = 0.5 * lambda;
  const int mode = static_cast<int>(mu);
  auto weight = [&](int j) { return std::exp(j * std::log(mu) - mu - std::lgamma(j + 1.0)); };
  double sum = 0;
  for (int j = mode; j >= 0; --j) {
    const double w = weight(j);
    sum += w * ChiSquareUpperTail(x, dof + 2 * j);
    if (w < 1e-16 && j < mode) break;
  }
  for (int j = mode + 1;; ++j) {
    const double w = weight(j);
    sum += w * ChiSquareUpperTail(x, dof + 2 * j);
    if (w < 1e-16) break;
  }
  return std::min(1.0, sum);
}

double NoncentralityForPower(double x, int dof, double power) {
  double lo = 0, hi = 1;
  while (NoncentralChiSquareUpperTail(x, dof, hi) < power && hi < 1e8) hi *= 2;
  for (int i = 0; i < 200 && hi - lo > 1e-10 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (NoncentralChiSquareUpperTail(x, dof, mid) < power ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

EstimateDifference CompareEstimates(const Eigen::VectorXd& delta, const Eigen::MatrixXd& sum,
                                    const std::vector<std::string>& names) {
  EstimateDifference d;
  d.dof = static_cast<int>(delta.size());
  d.d2 = delta.dot(sum.ldlt().solve(delta));
  if (!std::isfinite(d.d2) || d.d2 < 0) d.d2 = INFINITY;
  d.p = ChiSquareUpperTail(d.d2, d.dof);
  for (int i = 0; i < d.dof; ++i) {
    const double sigmas = std::abs(delta[i]) / std::sqrt(sum(i, i));
    if (sigmas > d.largest_sigmas || d.largest.empty()) {
      d.largest = names[i];
      d.largest_sigmas = sigmas;
    }
  }
  return d;
}

PairedComparison ComparePaired(const std::vector<double>& first, const std::vector<double>& second) {
  PairedComparison c;
  const std::size_t n = std::min(first.size(), second.size());
  c.windows = static_cast<int>(n);
  std::vector<double> diff;
  for (std::size_t i = 0; i < n; ++i) {
    const double d = second[i] - first[i];
    diff.push_back(d);
    if (std::abs(d) <= 1e-9) ++c.ties;
    else if (d < 0) ++c.second_better;
  }
  if (n == 0) return c;
  double mean = 0, var = 0;
  for (double d : diff) mean += d / n;
  for (double d : diff) var += (d - mean) * (d - mean) / std::max<double>(1, n - 1);
  c.mean_difference = mean;
  c.difference_sem = std::sqrt(var / n);
  // Exact two-sided binomial: twice the smaller tail of Binomial(m, 1/2), in logs (no overflow).
  const int m = c.windows - c.ties, k = std::min(c.second_better, m - c.second_better);
  double tail = 0.0;
  for (int j = 0; j <= k; ++j)
    tail += std::exp(std::lgamma(m + 1.0) - std::lgamma(j + 1.0) - std::lgamma(m - j + 1.0) - m * std::log(2.0));
  c.sign_test_p = m > 0 ? std::min(1.0, 2.0 * tail) : 1.0;
  return c;
}

}  // namespace calib
