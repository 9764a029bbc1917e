#include "calib/calibrate/interval_model.h"

#include <algorithm>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "calib/core/kinematics.h"

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

EncoderTrack MakeEncoderTrack(DriveType drive, const WheelTrack& wheels) {
  EncoderTrack track;
  track.drive = drive;
  track.wheels = static_cast<int>(WheelRoles(drive).size());
  const std::size_t n = wheels.size();
  track.utime = wheels.utimes();
  track.pos.assign(n, {0, 0});
  track.steer.assign(n, {0, 0});
  for (std::size_t i = 0; i < n; ++i) {
    for (int w = 0; w < track.wheels; ++w) {
      track.pos[i][w] = wheels.position(i, w);
      track.steer[i][w] = wheels.steer(i, w);
    }
  }
  return track;
}

}  // namespace calib
