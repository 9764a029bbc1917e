// agvcal-bench-crb: the calibration's accuracy against the Cramér–Rao bound (issue 19).
//
//   agvcal-bench-crb [--seeds N] [--sim NAME.yaml]... [--nominal-is-truth] [--single-pass]
//                    [--max-rmse-crb R] [--min-sigma-rmse S]
//
// For each simulation config (default: config/sims/diff_robot.yaml, forklift.yaml,
// dual_steer_agv.yaml) simulates the default trajectory with seeds 1..N (default 50), and for
// each recording runs what `agvcal solve` runs (ReadCalibrationData: the scan matcher pipeline;
// Calibrate; SolveAgainDeskewed: the scans matched again with the calibrated values, calibrated
// again) and compares every estimated value with the simulator's truth.
//
// The bound: the Fisher information of the interval model at the TRUE values, J̃ᵀ Ω⁻¹ J̃, with J̃
// the intervals' Jacobians (PredictSensorMotion with the true drive parameters and mount, central
// differences) whitened by the matcher's covariances, over the valid, non-degenerate intervals,
// averaged over the seeds; CRB = sqrt(diag(F⁻¹)). Ω, the covariance of the whitened errors: as the
// matcher reports them and independent (Ω = I: "CRB(Σ)"), and as measured at the truth (the
// errors e = measured − truly predicted motion, pooled over the seeds: C0 per interval and C1
// between neighbours, which share a scan; block tridiagonal: "CRB"). The second is the bound for
// the errors the calibration actually sees.
//
// Prints per parameter: RMSE over the seeds, bias, mean reported sigma, both bounds, RMSE/CRB and
// reported sigma / RMSE.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/recording_input.h"
#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/se2.h"
#include "calib/io/recording.h"
#include "calib/live/sim_run.h"
#include "calib/match/scan_match.h"
#include "calib/sim/simulator.h"

namespace {

// The estimated values, in order: the drive parameters, then the mount.
std::vector<std::string> Names(const calib::RobotDescription& robot) {
  std::vector<std::string> names = calib::ParamNames(robot.drive);
  for (const char* m : {"mount_x", "mount_y", "mount_yaw"}) names.push_back(m);
  return names;
}

std::vector<double> TrueValues(const calib::SimConfig& sim, const std::vector<std::string>& names) {
  std::vector<double> v;
  for (const std::string& n : names) {
    if (n == "mount_x") v.push_back(sim.true_lidar2d.x);
    else if (n == "mount_y") v.push_back(sim.true_lidar2d.y);
    else if (n == "mount_yaw") v.push_back(sim.true_lidar2d.yaw);
    else v.push_back(sim.true_params.at(n));
  }
  return v;
}

// The sensor motion the model predicts over [t0, t1] with the values `v` (Names order).
Eigen::Vector3d Predict(const calib::RobotDescription& nominal, const std::vector<std::string>& names,
                        const std::vector<double>& v, const calib::WheelTrack& wheels, double t0, double t1) {
  calib::RobotDescription robot = nominal;
  calib::Pose2 mount;
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (names[k] == "mount_x") mount.x = v[k];
    else if (names[k] == "mount_y") mount.y = v[k];
    else if (names[k] == "mount_yaw") mount.theta = v[k];
    else robot.params[names[k]] = v[k];
  }
  const std::unique_ptr<calib::DriveModel> model = calib::MakeDriveModel(robot);
  const calib::Pose2 z = calib::PredictSensorMotion(wheels, *model, mount, t0, t1);
  return {z.x, z.y, z.theta};
}

// One recording's intervals at the truth, whitened by the matcher's covariance (U, UᵀU = Σ⁻¹):
// the Jacobians U J and the errors U e (e = measured − truly predicted motion, the error the
// calibration sees), and whether each interval starts where the previous ended (they share a scan).
struct Whitened {
  std::vector<Eigen::MatrixXd> jacobians;
  std::vector<Eigen::Vector3d> errors;
  std::vector<bool> follows_previous;
};

Whitened AtTruth(const calib::RobotDescription& robot, const std::vector<std::string>& names,
                 const std::vector<double>& truth, const calib::WheelTrack& wheels,
                 const std::vector<calib::SensorMotion>& motions) {
  const int p = static_cast<int>(names.size());
  Whitened w;
  int64_t previous_end = -1;
  for (const calib::SensorMotion& m : motions) {
    const double t0 = double(m.utime_start), t1 = double(m.utime_end);
    if (!m.valid || m.degenerate || !wheels.Covers(t0, t1)) continue;
    const Eigen::Matrix3d information = m.covariance.inverse();
    Eigen::LLT<Eigen::Matrix3d> llt(information);
    if (!information.allFinite() || llt.info() != Eigen::Success) continue;
    const Eigen::Matrix3d u = llt.matrixU();
    Eigen::MatrixXd jacobian(3, p);
    for (int k = 0; k < p; ++k) {
      const double h = 1e-6 * std::max(std::abs(truth[k]), 0.01);
      std::vector<double> plus = truth, minus = truth;
      plus[k] += h;
      minus[k] -= h;
      Eigen::Vector3d d = Predict(robot, names, plus, wheels, t0, t1) - Predict(robot, names, minus, wheels, t0, t1);
      d[2] = calib::WrapAngle(d[2]);
      jacobian.col(k) = d / (2.0 * h);
    }
    Eigen::Vector3d e = Eigen::Vector3d(m.delta.x, m.delta.y, m.delta.theta) -
                        Predict(robot, names, truth, wheels, t0, t1);
    e[2] = calib::WrapAngle(e[2]);
    w.jacobians.push_back(u * jacobian);
    w.errors.push_back(u * e);
    w.follows_previous.push_back(m.utime_start == previous_end);
    previous_end = m.utime_end;
  }
  return w;
}

// The noise model of the whitened errors: covariance C0 of one interval and C1 of an interval
// with the one before it (a shared scan), pooled over every recording.
struct NoiseModel {
  Eigen::Matrix3d c0 = Eigen::Matrix3d::Zero(), c1 = Eigen::Matrix3d::Zero();
};

NoiseModel Pool(const std::vector<Whitened>& recordings) {
  NoiseModel model;
  int n = 0, pairs = 0;
  for (const Whitened& w : recordings) {
    for (std::size_t k = 0; k < w.errors.size(); ++k) {
      model.c0 += w.errors[k] * w.errors[k].transpose();
      ++n;
      if (w.follows_previous[k]) {
        model.c1 += w.errors[k] * w.errors[k - 1].transpose();
        ++pairs;
      }
    }
  }
  model.c0 /= std::max(n, 1);
  model.c1 /= std::max(pairs, 1);
  return model;
}

// Fisher information J̃ᵀ Ω⁻¹ J̃ of one recording, Ω block tridiagonal (C0 on the diagonal, C1
// between neighbours that share a scan); C1 shrunk until Ω is positive definite.
Eigen::MatrixXd Fisher(const Whitened& w, const NoiseModel& noise) {
  const int n = static_cast<int>(w.errors.size());
  const int p = n > 0 ? static_cast<int>(w.jacobians[0].cols()) : 0;
  Eigen::MatrixXd stacked(3 * n, p);
  for (int k = 0; k < n; ++k) stacked.block(3 * k, 0, 3, p) = w.jacobians[k];
  for (double shrink = 1.0; shrink >= 0.0; shrink -= 0.05) {
    std::vector<Eigen::Triplet<double>> entries;
    for (int k = 0; k < n; ++k) {
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
          entries.emplace_back(3 * k + i, 3 * k + j, noise.c0(i, j));
          if (k > 0 && w.follows_previous[k]) {
            entries.emplace_back(3 * k + i, 3 * (k - 1) + j, shrink * noise.c1(i, j));
            entries.emplace_back(3 * (k - 1) + j, 3 * k + i, shrink * noise.c1(i, j));
          }
        }
      }
    }
    Eigen::SparseMatrix<double> omega(3 * n, 3 * n);
    omega.setFromTriplets(entries.begin(), entries.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(omega);
    if (ldlt.info() != Eigen::Success || (ldlt.vectorD().array() <= 0.0).any()) continue;
    const Eigen::MatrixXd solved = ldlt.solve(stacked);
    return stacked.transpose() * solved;
  }
  throw std::runtime_error("no positive definite noise model");
}

struct BenchOptions {
  int seeds = 50;
  bool nominal_is_truth = false;
  bool single_pass = false;  // the scans matched once, with the robot file's values
  // Bounds every value must meet (the CI smoke test); by default none.
  double max_rmse_crb = std::numeric_limits<double>::infinity();
  double min_sigma_rmse = 0.0;
};

// Prints the table of one drive; returns the number of seeds that failed to solve and of values
// outside the options' bounds.
int RunSim(const std::string& name, const BenchOptions& options) {
  calib::SimConfig base = calib::LoadSimConfig(std::string(AGVCAL_SOURCE_DIR) + "/config/sims/" + name);
  if (options.nominal_is_truth) {  // the robot file says the truth: de-skewing and priors exact
    base.robot.params = base.true_params;
    base.robot.lidar2d->x = base.true_lidar2d.x;
    base.robot.lidar2d->y = base.true_lidar2d.y;
    base.robot.lidar2d->yaw = base.true_lidar2d.yaw;
  }
  const std::vector<std::string> names = Names(base.robot);
  const std::vector<double> truth = TrueValues(base, names);
  const int p = static_cast<int>(names.size());
  std::vector<Whitened> recordings;
  Eigen::VectorXd sum_e2 = Eigen::VectorXd::Zero(p), sum_std = Eigen::VectorXd::Zero(p), sum_e = sum_e2;
  int solved = 0, failed = 0;
  const std::string log = "/tmp/agvcal_bench_crb_" + std::to_string(getpid()) + ".log";
  for (int seed = 1; seed <= options.seeds; ++seed) {
    calib::SimConfig sim = base;
    sim.seed = seed;
    {
      calib::LogWriter writer(log);
      calib::RunOffline(sim, calib::OfflineRunOptions{}, &writer);
      writer.Close();
    }
    // As SolveLog: the scans matched with the robot file's values, calibrated, matched again with
    // the calibrated values and calibrated again; the bound on the motions of the last pass.
    const calib::CalibrationData data =
        calib::ReadCalibrationData(sim.robot, log, calib::MotionSource::kLidar2d, nullptr);
    calib::SecondPassInput again;
    again.motions = data.motions();
    std::optional<calib::CalibrationResult> r;
    try {
      r = calib::Calibrate(sim.robot, data.wheels(), data.motions(), calib::MotionSource::kLidar2d, {}, log);
      if (!options.single_pass) r = calib::SolveAgainDeskewed(sim.robot, log, *r, {}, log, &again);
    } catch (const std::exception& ex) {
      r.reset();
      ++failed;
      std::fprintf(stderr, "%s seed %d: %s\n", name.c_str(), seed, ex.what());
    }
    recordings.push_back(AtTruth(sim.robot, names, truth, data.wheels(), again.motions));
    if (!r) continue;
    for (int k = 0; k < p; ++k) {
      const calib::Estimate& est = names[k] == "mount_x"     ? r->mount_x
                                   : names[k] == "mount_y"   ? r->mount_y
                                   : names[k] == "mount_yaw" ? r->mount_yaw
                                                             : r->params.at(names[k]);
      const double e = est.value - truth[k];
      sum_e[k] += e;
      sum_e2[k] += e * e;
      sum_std[k] += est.std;
    }
    ++solved;
  }
  std::remove(log.c_str());
  // Two bounds: the matcher's covariances as they are, intervals independent (Ω = I), and the
  // noise model measured at the truth (C0, C1 pooled over the seeds).
  const NoiseModel measured = Pool(recordings);
  const NoiseModel independent{Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Zero()};
  Eigen::MatrixXd fisher_matcher = Eigen::MatrixXd::Zero(p, p), fisher_measured = fisher_matcher;
  std::size_t intervals = 0;
  for (const Whitened& w : recordings) {
    fisher_matcher += Fisher(w, independent) / double(recordings.size());
    fisher_measured += Fisher(w, measured) / double(recordings.size());
    intervals += w.errors.size();
  }
  const Eigen::VectorXd crb_matcher = fisher_matcher.inverse().diagonal().cwiseSqrt();
  const Eigen::VectorXd crb = fisher_measured.inverse().diagonal().cwiseSqrt();
  const Eigen::Matrix3d c1_correlation =
      measured.c0.diagonal().cwiseSqrt().cwiseInverse().asDiagonal() * measured.c1 *
      measured.c0.diagonal().cwiseSqrt().cwiseInverse().asDiagonal();
  std::printf("%s: %d seeds solved (%d failed), %.0f intervals per recording; whitened errors at the truth: "
              "variance %.2f %.2f %.2f (1 if the matcher's covariances were exact), neighbour correlation "
              "%.2f %.2f %.2f\n",
              name.c_str(), solved, failed, double(intervals) / options.seeds, measured.c0(0, 0), measured.c0(1, 1),
              measured.c0(2, 2), c1_correlation(0, 0), c1_correlation(1, 1), c1_correlation(2, 2));
  std::printf("  %-14s %11s %11s %11s %11s %11s %11s %9s %11s\n", "parameter", "truth", "RMSE", "bias", "sigma",
              "CRB(Σ)", "CRB", "RMSE/CRB", "sigma/RMSE");
  int checks_failed = failed;
  for (int k = 0; k < p; ++k) {
    const double rmse = std::sqrt(sum_e2[k] / solved), bias = sum_e[k] / solved, sigma = sum_std[k] / solved;
    std::printf("  %-14s %11.6g %11.3g %+11.2g %11.3g %11.3g %11.3g %9.2f %11.2f\n", names[k].c_str(), truth[k],
                rmse, bias, sigma, crb_matcher[k], crb[k], rmse / crb[k], sigma / rmse);
    if (!(rmse / crb[k] <= options.max_rmse_crb) || !(sigma / rmse >= options.min_sigma_rmse)) {
      std::printf("  FAILED: %s %s: RMSE/CRB %.2f (at most %.2f), sigma/RMSE %.2f (at least %.2f)\n", name.c_str(),
                  names[k].c_str(), rmse / crb[k], options.max_rmse_crb, sigma / rmse, options.min_sigma_rmse);
      ++checks_failed;
    }
  }
  std::fflush(stdout);
  return checks_failed;
}

int Run(int argc, char** argv) {
  BenchOptions options;
  std::vector<std::string> sims;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << "usage: agvcal-bench-crb [--seeds N] [--sim NAME.yaml]... [--nominal-is-truth] [--single-pass]\n"
                   "                        [--max-rmse-crb R] [--min-sigma-rmse S]\n"
                   "RMSE of the calibration over N seeds (default 50) of each drive's default trajectory\n"
                   "against the Cramér–Rao bound from the matcher's covariances. --nominal-is-truth: the\n"
                   "robot file's values set to the truth (de-skewing and odometry priors exact).\n"
                   "--single-pass: the scans matched once, with the robot file's values (no second pass\n"
                   "de-skewed with the calibrated values, as `agvcal solve` had before).\n"
                   "--max-rmse-crb R, --min-sigma-rmse S: exit 1 when a seed fails to solve or a value's\n"
                   "RMSE/CRB exceeds R or its mean reported sigma / RMSE is below S (the CI smoke test).\n";
      return calib::kExitOk;
    }
    if (a == "--seeds" && i + 1 < argc) {
      options.seeds = std::max(2, std::atoi(argv[++i]));
    } else if (a == "--nominal-is-truth") {
      options.nominal_is_truth = true;
    } else if (a == "--single-pass") {
      options.single_pass = true;
    } else if (a == "--max-rmse-crb" && i + 1 < argc) {
      options.max_rmse_crb = std::atof(argv[++i]);
    } else if (a == "--min-sigma-rmse" && i + 1 < argc) {
      options.min_sigma_rmse = std::atof(argv[++i]);
    } else if (a == "--sim" && i + 1 < argc) {
      sims.push_back(argv[++i]);
    } else {
      throw calib::InputError("command line", a, "unknown option");
    }
  }
  if (sims.empty()) sims = {"diff_robot.yaml", "forklift.yaml", "dual_steer_agv.yaml"};
  int failed = 0;
  for (const std::string& s : sims) failed += RunSim(s, options);
  return failed == 0 ? calib::kExitOk : calib::kExitInternal;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-bench-crb", Run, argc, argv); }
