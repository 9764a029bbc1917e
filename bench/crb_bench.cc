// agvcal-bench-crb: the calibration's accuracy against the Cramér–Rao bound (issue 19).
//
//   agvcal-bench-crb [--seeds N] [--sim NAME.yaml]...
//
// For each simulation config (default: config/sims/diff_robot.yaml, forklift.yaml,
// dual_steer_agv.yaml) simulates the default trajectory with seeds 1..N (default 50), and for
// each recording runs what `agvcal solve` runs (ReadCalibrationData: the scan matcher pipeline;
// Calibrate) and compares every estimated value with the simulator's truth.
//
// The bound: the Fisher information of the interval model at the TRUE values with the matcher's
// covariances, F = Σ_i J_iᵀ Σ_i⁻¹ J_i over the valid, non-degenerate intervals (J_i the derivative
// of the predicted sensor motion, PredictSensorMotion with the true drive parameters and mount, by
// central differences), averaged over the seeds; CRB = sqrt(diag(F⁻¹)). The matcher's
// covariances are not exact: the mean of eᵀΣ⁻¹e / 3 at the truth (e: measured minus truly
// predicted motion, the error the calibration sees) says by how much, and CRB·sqrt(that) is the
// bound for errors of the matcher's covariance shape at their actual size.
//
// Prints per parameter: RMSE over the seeds, mean reported sigma, CRB (matcher covariance as
// is), CRB scaled, RMSE/CRB, RMSE/CRB scaled, and reported sigma / RMSE.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>

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

struct Information {
  Eigen::MatrixXd fisher;
  double chi2_sum = 0.0;  // eᵀΣ⁻¹e at the truth
  int intervals = 0;
};

// The Fisher information at the truth with the matcher's covariances, and the residuals there.
Information FisherAtTruth(const calib::RobotDescription& robot, const std::vector<std::string>& names,
                          const std::vector<double>& truth, const calib::WheelTrack& wheels,
                          const std::vector<calib::SensorMotion>& motions) {
  const int p = static_cast<int>(names.size());
  Information info;
  info.fisher = Eigen::MatrixXd::Zero(p, p);
  for (const calib::SensorMotion& m : motions) {
    const double t0 = double(m.utime_start), t1 = double(m.utime_end);
    if (!m.valid || m.degenerate || !wheels.Covers(t0, t1)) continue;
    const Eigen::Matrix3d information = m.covariance.inverse();
    if (!information.allFinite()) continue;
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
    info.fisher += jacobian.transpose() * information * jacobian;
    Eigen::Vector3d e = Eigen::Vector3d(m.delta.x, m.delta.y, m.delta.theta) -
                        Predict(robot, names, truth, wheels, t0, t1);
    e[2] = calib::WrapAngle(e[2]);
    info.chi2_sum += e.dot(information * e);
    ++info.intervals;
  }
  return info;
}

void RunSim(const std::string& name, int seeds) {
  const calib::SimConfig base = calib::LoadSimConfig(std::string(AGVCAL_SOURCE_DIR) + "/config/sims/" + name);
  const std::vector<std::string> names = Names(base.robot);
  const std::vector<double> truth = TrueValues(base, names);
  const int p = static_cast<int>(names.size());
  Eigen::MatrixXd fisher = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd sum_e2 = Eigen::VectorXd::Zero(p), sum_std = Eigen::VectorXd::Zero(p), sum_e = sum_e2;
  double chi2 = 0.0;
  int intervals = 0, solved = 0, failed = 0;
  const std::string log = "/tmp/agvcal_bench_crb.log";
  for (int seed = 1; seed <= seeds; ++seed) {
    calib::SimConfig sim = base;
    sim.seed = seed;
    {
      calib::LogWriter writer(log);
      calib::RunOffline(sim, calib::OfflineRunOptions{}, &writer);
      writer.Close();
    }
    const calib::CalibrationData data =
        calib::ReadCalibrationData(sim.robot, log, calib::MotionSource::kLidar2d, nullptr);
    const Information info = FisherAtTruth(sim.robot, names, truth, data.wheels(), data.motions());
    fisher += info.fisher;
    chi2 += info.chi2_sum;
    intervals += info.intervals;
    try {
      const calib::CalibrationResult r = calib::Calibrate(sim.robot, data.wheels(), data.motions(),
                                                          calib::MotionSource::kLidar2d, {}, log);
      for (int k = 0; k < p; ++k) {
        const calib::Estimate& est = names[k] == "mount_x"   ? r.mount_x
                                     : names[k] == "mount_y" ? r.mount_y
                                     : names[k] == "mount_yaw" ? r.mount_yaw
                                                             : r.params.at(names[k]);
        const double e = est.value - truth[k];
        sum_e[k] += e;
        sum_e2[k] += e * e;
        sum_std[k] += est.std;
      }
      ++solved;
    } catch (const std::exception& ex) {
      ++failed;
      std::fprintf(stderr, "%s seed %d: %s\n", name.c_str(), seed, ex.what());
    }
  }
  std::remove(log.c_str());
  fisher /= seeds;
  const Eigen::VectorXd crb = fisher.inverse().diagonal().cwiseSqrt();
  const double factor = intervals > 0 ? chi2 / (3.0 * intervals) : NAN;
  std::printf("%s: %d seeds solved (%d failed), %.0f intervals per recording, eᵀΣ⁻¹e/3 at the truth %.2f\n",
              name.c_str(), solved, failed, double(intervals) / seeds, factor);
  std::printf("  %-14s %11s %11s %11s %11s %11s %9s %9s %11s\n", "parameter", "truth", "RMSE", "bias", "sigma",
              "CRB", "RMSE/CRB", "RMSE/CRBs", "sigma/RMSE");
  for (int k = 0; k < p; ++k) {
    const double rmse = std::sqrt(sum_e2[k] / solved), bias = sum_e[k] / solved, sigma = sum_std[k] / solved;
    std::printf("  %-14s %11.6g %11.3g %+11.2g %11.3g %11.3g %9.2f %9.2f %11.2f\n", names[k].c_str(), truth[k], rmse,
                bias, sigma, crb[k], rmse / crb[k], rmse / (crb[k] * std::sqrt(factor)), sigma / rmse);
  }
  std::fflush(stdout);
}

int Run(int argc, char** argv) {
  int seeds = 50;
  std::vector<std::string> sims;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << "usage: agvcal-bench-crb [--seeds N] [--sim NAME.yaml]...\n"
                   "RMSE of the calibration over N seeds (default 50) of each drive's default trajectory\n"
                   "against the Cramér–Rao bound from the matcher's covariances.\n";
      return calib::kExitOk;
    }
    if (a == "--seeds" && i + 1 < argc) {
      seeds = std::max(2, std::atoi(argv[++i]));
    } else if (a == "--sim" && i + 1 < argc) {
      sims.push_back(argv[++i]);
    } else {
      throw calib::InputError("command line", a, "unknown option");
    }
  }
  if (sims.empty()) sims = {"diff_robot.yaml", "forklift.yaml", "dual_steer_agv.yaml"};
  for (const std::string& s : sims) RunSim(s, seeds);
  return calib::kExitOk;
}

}  // namespace

int main(int argc, char** argv) { return calib::RunMain("agvcal-bench-crb", Run, argc, argv); }
