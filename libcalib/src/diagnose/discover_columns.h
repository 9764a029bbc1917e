#pragma once
// The linearised problem of discovery (internal to libcalib): each interval's whitened residual
// under the final model, its derivative by every parameter the final model fits (the
// calibration and the effects found), and by the coefficient of every term of the library
// (core/physics_terms.h), each entering through its channel while the wheel odometry is
// integrated over the interval. Discovery (discover.h) fits the terms jointly with the
// calibration on these columns.

#include <vector>

#include <Eigen/Core>

#include "calib/core/physics_terms.h"
#include "diagnose/diagnose_fit.h"

namespace calib::diag {

struct DiscoveryRow {
  bool heldout = false;
  int block = 0;
  int64_t utime_start = 0, utime_end = 0;
  Eigen::Vector3d r = Eigen::Vector3d::Zero();  // whitened residual of the final model
  Eigen::MatrixXd A;                            // 3 x p: by the final model's free parameters
  Eigen::MatrixXd G;                            // 3 x terms: by each library term's coefficient
  Eigen::MatrixXd C;                            // 3 x kNumBeta: by each catalogued effect's parameter
  Eigen::Matrix3d unwhiten = Eigen::Matrix3d::Identity();  // U^-1: whitened back to m, m, rad
  Eigen::Vector3d sigma = Eigen::Vector3d::Ones();         // measurement std (unscaled)
};

// The rows of every interval not set aside, in time order, for the library `terms`; `free_betas`
// are the effect parameters the final model `m` fits (their columns join A). With
// `coefficients` (one per term), the residual and the columns are those of `m` with the terms
// at these values (the timing terms to first order).
std::vector<DiscoveryRow> DiscoveryRows(const Recording& recording, const Model& m,
                                        const std::vector<LibraryTerm>& terms, const std::vector<int>& free_betas,
                                        const std::vector<double>& coefficients = {});

// The drive parameters the final model fits (not held), in A's order.
std::vector<int> FreeParams(const Recording& recording);

// `m` with A's columns changed by `change` (free parameters, mount, then `free_betas`).
Model Updated(const Recording& recording, const Model& m, const std::vector<int>& free_betas, const double* change);

}  // namespace calib::diag
