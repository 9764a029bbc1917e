#include "calib/core/statistics.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <unsupported/Eigen/SpecialFunctions>

namespace calib {

double ChiSquareUpperTail(double x, int dof) {
  return x <= 0 ? 1.0 : Eigen::numext::igammac(0.5 * dof, 0.5 * x);
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
