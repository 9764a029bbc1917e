#include "diagnose/discover_fit.h"

#include <cmath>

#include <Eigen/Cholesky>

namespace calib::diag {

Eigen::MatrixXd Design(const DiscoveryRow& row, const DesignColumns& columns) {
  Eigen::MatrixXd X(3, row.A.cols() + columns.terms.size() + columns.catalogued.size());
  X.leftCols(row.A.cols()) = row.A;
  int c = int(row.A.cols());
  for (int k : columns.terms) X.col(c++) = row.G.col(k);
  for (int j : columns.catalogued) X.col(c++) = row.C.col(j);
  return X;
}

double LinearFit::Std(const DiscoveryRow& any, int k) const {
  const int i = int(any.A.cols()) + k;
  return std::sqrt(std::max(cov(i, i), 0.0));
}

Eigen::MatrixXd LongRunVariance(const std::vector<Eigen::VectorXd>& u, int lags) {
  if (u.empty()) return Eigen::MatrixXd();
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(u[0].size(), u[0].size());
  for (std::size_t k = 0; k < u.size(); ++k) {
    S += u[k] * u[k].transpose();
    for (int l = 1; l <= lags && l <= int(k); ++l) {
      const double w = 1.0 - double(l) / (lags + 1);
      S += w * (u[k] * u[k - l].transpose() + u[k - l] * u[k].transpose());
    }
  }
  return S;
}

namespace {

// The inverse of the normal matrix N, with the columns scaled to unit norm first (the
// calibration's and the terms' columns differ by orders of magnitude) and a column the rows do
// not excite (norm 0: a parameter of another drive) left at 0.
Eigen::MatrixXd InverseNormal(const Eigen::MatrixXd& N) {
  const int p = int(N.rows());
  Eigen::VectorXd scale(p);
  for (int i = 0; i < p; ++i) scale[i] = N(i, i) > 1e-300 ? 1.0 / std::sqrt(N(i, i)) : 0.0;
  Eigen::MatrixXd Ns = scale.asDiagonal() * N * scale.asDiagonal();
  for (int i = 0; i < p; ++i)
    if (scale[i] == 0.0) Ns(i, i) = 1.0;
  Ns += 1e-12 * Eigen::MatrixXd::Identity(p, p);
  const Eigen::MatrixXd inv = Ns.ldlt().solve(Eigen::MatrixXd::Identity(p, p));
  return scale.asDiagonal() * inv * scale.asDiagonal();
}

}  // namespace

LinearFit FitRows(const std::vector<DiscoveryRow>& rows, const DesignColumns& columns, int hac_lags) {
  LinearFit fit;
  if (rows.empty()) return fit;
  const int p = int(rows[0].A.cols() + columns.terms.size() + columns.catalogued.size());
  fit.params = p;
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(p);
  for (const DiscoveryRow& row : rows) {
    if (row.heldout) continue;
    const Eigen::MatrixXd X = Design(row, columns);
    N += X.transpose() * X;
    b += X.transpose() * row.r;
  }
  const Eigen::MatrixXd Ninv = InverseNormal(N);
  fit.coef = -(Ninv * b);
  std::vector<Eigen::VectorXd> scores;
  for (const DiscoveryRow& row : rows) {
    const Eigen::MatrixXd X = Design(row, columns);
    const Eigen::Vector3d e = row.r + X * fit.coef;
    if (row.heldout) {
      fit.chi2_heldout += e.squaredNorm();
      ++fit.n_heldout;
    } else {
      fit.chi2_fit += e.squaredNorm();
      ++fit.n_fit;
      scores.push_back(X.transpose() * e);
    }
  }
  fit.cov = Ninv * LongRunVariance(scores, hac_lags) * Ninv;
  return fit;
}

Eigen::Vector3d ResidualLeft(const DiscoveryRow& row, const DesignColumns& columns, const LinearFit& fit) {
  if (fit.coef.size() == 0) return row.r;
  return row.r + Design(row, columns) * fit.coef;
}

double HeldoutScore(const std::vector<DiscoveryRow>& rows, const DesignColumns& without, int added,
                    const LinearFit& fit_without, const LinearFit& fit_with, int hac_lags) {
  if (rows.empty()) return 0;
  // The term's column with what the other columns explain of it on the fit blocks removed.
  const int p = int(rows[0].A.cols() + without.terms.size() + without.catalogued.size());
  Eigen::MatrixXd N = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(p);
  for (const DiscoveryRow& row : rows) {
    if (row.heldout) continue;
    const Eigen::MatrixXd X = Design(row, without);
    N += X.transpose() * X;
    b += X.transpose() * row.G.col(added);
  }
  const Eigen::VectorXd projection = InverseNormal(N) * b;
  // The score sums the held-out residual left without the term; its variance is the noise's.
  // The residual without the term carries the term's own signal, and where the term's column is
  // large on a few intervals (a clock drift where the motion changes fast, late in the
  // recording) that signal swamped the variance: the score of a term the fit blocks show many
  // sigma strong stayed near 2. The noise's variance: the larger of the empirical one from the
  // residual the fit with the term leaves (which the fit's own error lowers where the held-out
  // blocks agree with it) and the fit blocks' noise level over the column's own long-run size.
  DesignColumns with = without;
  with.terms.push_back(added);
  std::vector<Eigen::VectorXd> u, columns;
  double sum = 0;
  for (const DiscoveryRow& row : rows) {
    if (!row.heldout) continue;
    const Eigen::Vector3d g = row.G.col(added) - Design(row, without) * projection;
    sum -= g.dot(ResidualLeft(row, without, fit_without));  // the sign of the term's coefficient
    u.push_back(Eigen::VectorXd::Constant(1, g.dot(ResidualLeft(row, with, fit_with))));
    columns.push_back(g);
  }
  if (u.empty()) return 0;
  const double noise_level = fit_with.chi2_fit / std::max(1, 3 * fit_with.n_fit - fit_with.params);
  const double v = std::max(LongRunVariance(u, hac_lags)(0, 0), noise_level * LongRunVariance(columns, hac_lags).trace());
  return v > 0 ? sum / std::sqrt(v) : 0.0;
}

double HeadingChains::Rms() const {
  double s = 0;
  for (double x : sums) s += x * x;
  return sums.empty() ? 0.0 : std::sqrt(s / sums.size());
}

HeadingChains ChainHeading(const std::vector<DiscoveryRow>& rows, const std::vector<Eigen::Vector3d>& errors,
                           double window_s, int comp) {
  HeadingChains chains;
  double sum = 0, squares = 0;
  int count = 0, total = 0, block = -1;
  int64_t window_start = 0;
  auto close = [&]() {
    if (count >= 2) {
      chains.sums.push_back(sum);
      chains.counts.push_back(count);
    }
    sum = 0, count = 0;
  };
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const DiscoveryRow& row = rows[k];
    if (!row.heldout) continue;
    if (row.block != block || (row.utime_end - window_start) * 1e-6 > window_s) {
      close();
      block = row.block;
      window_start = row.utime_start;
    }
    const double yaw = errors[k][comp];
    sum += yaw;
    ++count;
    squares += yaw * yaw;
    ++total;
  }
  close();
  chains.mean_square = total ? squares / total : 0.0;
  return chains;
}

}  // namespace calib::diag
