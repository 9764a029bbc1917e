#pragma once
// The least-squares problem over intervals (interval_model.h) that the calibration and the
// diagnosis both solve, built and solved in one place: three parameter blocks (the drive
// parameters, the sensor's mount, and the model's own block: the calibration's time offset, the
// diagnosis's effect terms), one residual block per interval fitted, and one solve that returns
// Ceres' summary. A fit that stopped short of convergence is said so by its caller
// (CalibrationResult::warnings, the diagnosis's notes), never reported as if it had converged.

#include <memory>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "calib/core/sensor_motion.h"

namespace calib {

// One interval of sensor motion with its cost (an IntervalCost model) and whether it is fitted.
template <typename Cost>
struct FittedInterval {
  const SensorMotion* motion = nullptr;
  std::unique_ptr<Cost> cost;
  bool heldout = false, outlier = false;
  bool fitted() const { return !heldout && !outlier; }
};

struct IntervalSolveSettings {
  int max_iterations = 100;
  double tolerance = 1e-12;  // on the cost's and on the parameters' relative change
};

class IntervalProblem {
 public:
  // The blocks `params` (num_params values), `mount` (3) and `extra` (num_extra) must outlive the
  // problem; the solve writes its result into them.
  IntervalProblem(double* params, int num_params, double* mount, double* extra, int num_extra);

  // One interval's residual. `cost` is not owned (it must outlive the problem); `loss` is (null:
  // plain least squares).
  void AddInterval(ceres::CostFunction* cost, ceres::LossFunction* loss = nullptr);
  // Holds the drive parameters `held` (indices into the params block) at their values.
  void HoldParams(const std::vector<int>& held);
  // Holds the extra block's entries `held` at their values (all of them: the block is constant).
  void HoldExtra(const std::vector<int>& held);
  void BoundExtra(int index, double lower, double upper);
  void BoundExtraBelow(int index, double lower);

  // Dense QR on one thread (the sums, and so the results, do not depend on the machine).
  ceres::Solver::Summary Solve(const IntervalSolveSettings& settings);

 private:
  ceres::Problem problem_;
  double* params_;
  double* mount_;
  double* extra_;
  int num_extra_;
};

// "" when the solve converged; otherwise "stopped short of convergence (Ceres' reason)".
std::string NotConverged(const ceres::Solver::Summary& summary);

// The whitened chi-square |r|^2 of one interval's residual at the parameter blocks `blocks`.
double Chi2At(const ceres::CostFunction& cost, const double* const* blocks);

}  // namespace calib
