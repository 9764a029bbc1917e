#include "calib/calibrate/interval_model.h"

#include <algorithm>

#include <Eigen/Cholesky>
#include <Eigen/LU>


namespace calib {

double RobustScale2(std::vector<double> chi2) {
  double median = 0.0;
  if (!chi2.empty()) {
    std::nth_element(chi2.begin(), chi2.begin() + chi2.size() / 2, chi2.end());
    median = chi2[chi2.size() / 2];
  }
  return std::max(median / kChi2Median3, 1e-12);
}

Eigen::Matrix3d SqrtInformation(const Eigen::Matrix3d& covariance) {
  Eigen::LLT<Eigen::Matrix3d> llt(covariance.inverse());
  if (!covariance.allFinite() || llt.info() != Eigen::Success || !llt.matrixU().toDenseMatrix().allFinite()) {
    return Eigen::Vector3d(1.0 / 0.01, 1.0 / 0.01, 1.0 / 0.005).asDiagonal();  // 1 cm, 0.3 deg
  }
  return llt.matrixU();
}

}  // namespace calib
