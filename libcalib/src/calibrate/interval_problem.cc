#include "calib/calibrate/interval_problem.h"


namespace calib {
namespace {

ceres::Problem::Options ProblemOptions() {
  ceres::Problem::Options options;
  options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // the intervals keep theirs
  options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  return options;
}

}  // namespace

IntervalProblem::IntervalProblem(double* params, int num_params, double* mount, double* extra, int num_extra)
    : problem_(ProblemOptions()), params_(params), mount_(mount), extra_(extra), num_extra_(num_extra) {
  problem_.AddParameterBlock(params, num_params);
  problem_.AddParameterBlock(mount, 3);
  problem_.AddParameterBlock(extra, num_extra);
}

void IntervalProblem::AddInterval(ceres::CostFunction* cost, ceres::LossFunction* loss) {
  problem_.AddResidualBlock(cost, loss, params_, mount_, extra_);
}

void IntervalProblem::HoldParams(const std::vector<int>& held) {
  if (held.empty()) return;
  problem_.SetManifold(params_, new ceres::SubsetManifold(problem_.ParameterBlockSize(params_), held));
}

void IntervalProblem::HoldExtra(const std::vector<int>& held) {
  if (held.empty()) return;
  if (static_cast<int>(held.size()) == num_extra_) {
    problem_.SetParameterBlockConstant(extra_);
    return;
  }
  problem_.SetManifold(extra_, new ceres::SubsetManifold(num_extra_, held));
}

void IntervalProblem::BoundExtra(int index, double lower, double upper) {
  problem_.SetParameterLowerBound(extra_, index, lower);
  problem_.SetParameterUpperBound(extra_, index, upper);
}

void IntervalProblem::BoundExtraBelow(int index, double lower) { problem_.SetParameterLowerBound(extra_, index, lower); }

ceres::Solver::Summary IntervalProblem::Solve(const IntervalSolveSettings& settings) {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = settings.max_iterations;
  options.function_tolerance = settings.tolerance;
  options.parameter_tolerance = settings.tolerance;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem_, &summary);
  return summary;
}

std::string NotConverged(const ceres::Solver::Summary& summary) {
  if (summary.termination_type == ceres::CONVERGENCE || summary.termination_type == ceres::USER_SUCCESS) return "";
  return "stopped short of convergence (" + summary.message + ")";
}

double Chi2At(const ceres::CostFunction& cost, const double* const* blocks) {
  double r[3];
  cost.Evaluate(blocks, r, nullptr);
  return r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
}

}  // namespace calib
