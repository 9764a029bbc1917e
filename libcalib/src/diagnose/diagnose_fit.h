#pragma once
// The fits of the diagnosis (internal to libcalib): the recording cut into intervals of the
// interval model with effect terms (diagnose_model.h), one fit of the calibration with a chosen
// set of effect terms free on the fit blocks, and the statistics every test reads from a fit.
//
// Every chi-square is divided by the baseline's variance factor (Recording::noise_scale2): the
// matcher's covariances give the shape of the noise, the recording its scale, and a test of an
// effect compares chi-squares in that one scale.

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/calibrate/interval_problem.h"
#include "calib/core/robot.h"
#include "calib/diagnose/diagnose.h"
#include "diagnose/diagnose_model.h"

namespace calib::diag {

// An interval whose chi-square at the robust scale exceeds this is set aside: 3 dof, p ~ 1e-10,
// so only failed matches, never an effect's evidence.
inline constexpr double kOutlierChi2 = 50.0;

// One model: the drive parameters (ParamNames order, unused entries 0), the sensor's mount and the
// effect terms (Beta).
struct Model {
  double params[5] = {0, 0, 0, 0, 0};
  double mount[3] = {0, 0, 0};
  double beta[kNumBeta] = {};
};

// One interval of sensor motion with its model and its place in the alternating blocks.
struct Interval : FittedInterval<IntervalModel> {
  int block = 0;  // index of its fit (even) or held-out (odd) block
  Eigen::Vector3d sigma = Eigen::Vector3d::Ones();  // unscaled measurement std per component
};

// The recording as every fit sees it. Built in place: the intervals point into `track`.
struct Recording {
  Recording() = default;
  Recording(const Recording&) = delete;
  Recording& operator=(const Recording&) = delete;

  Track track;
  std::vector<Interval> intervals;  // in time order
  int num_params = 0;               // the drive type's parameters
  std::vector<int> held_params;     // drive parameters held at their start (and the unused slots)
  // The time offset's bound: kMaxOffsetS, or the calibration's wider one when its search found
  // the offset at that bound (calibration.h kWidestTimeOffsetS).
  double max_offset_s = kMaxOffsetS;
  double noise_scale2 = 1.0;    // the baseline fit's variance factor
  int hac_lags = 4;             // Newey-West lags (DiagnoseOptions)
  double drift_window_s = 2.0;  // held-out drift windows (DiagnoseOptions)
  int max_iterations = 50;      // of each fit's solve (DiagnoseOptions)
};

// Cuts the sensor motions the encoders cover into intervals, alternately in fit and held-out
// blocks of `block_s`, into `recording` (its track and intervals replaced). Throws
// UnobservableError when there are too few to tell an effect from noise.
void BuildIntervals(const RobotDescription& robot, const DiagnoseData& data, double block_s,
                    const std::string& origin, Recording* recording);

// A fitted model with its statistics.
struct Fit {
  Model m;
  std::vector<int> free;
  double chi2_fit = 0, chi2_heldout = 0;  // whitened, divided by the variance factor
  std::vector<double> heldout_terms;      // chi2 of each held-out interval, in order
  int n_fit = 0, n_heldout = 0;
  int dof = 1;                 // 3 n_fit less the parameters fitted
  Eigen::MatrixXd cov;         // robust covariance of the free effect parameters
  // Robust std of the calibration: the drive parameters (ParamNames order, NaN where held) and
  // the mount (x, y, yaw), 8 entries.
  std::vector<double> calibration_std;
  Eigen::MatrixXd info_cov;    // the same from the information alone (H^-1: independent residuals)
  double wald = 0, p = 1;      // of the free effect parameters named in `tested`
  std::vector<int> tested;
  std::string not_converged;   // why the solve stopped short of convergence ("" when it converged)
};

// The calibration refitted on the fit blocks from `start` with the effect terms `free` (the others
// at 0), and the Wald test of the terms `tested` (a subset of `free`).
Fit FitModel(const Recording& recording, const Model& start, const std::vector<int>& free,
             const std::vector<int>& tested);

// `with` refitted without the effect terms `effect`; `others` receives the effect terms left free.
Fit FitWithout(const Recording& recording, const Fit& with, const std::vector<int>& effect,
               std::vector<int>* others);

// FitModel from `start` and, when the time offset is free, also from the offset with the lowest
// chi-square on a grid of quarter wheel sample periods over the range searched (the other terms at
// their start) and from one sample period either side of the start: the lowest chi-square. The
// offset's cost has local minima a sample period apart (encoder ticks); fitted with a look-alike
// that took up part of its share, it reaches the joint minimum only from that minimum's basin.
Fit FitAcrossOffsetMinima(const Recording& recording, const Model& start, const std::vector<int>& free,
                          const std::vector<int>& tested);

// The value of effect term `beta` on `grid` with the lowest chi-square on the fit blocks.
double BestOnGrid(const Recording& recording, const Model& m, int beta, const std::vector<double>& grid);

// Sets aside the intervals that are outliers under every model of `models` (each at its own
// robust scale, at most the chosen model's, the last of `models`): a large residual that some
// candidate explains is evidence, not noise.
void Gate(const std::vector<Model>& models, Recording* recording);

// The variance factor of `model` in units of `baseline`'s: the noise scale of a test against
// `model` instead of the baseline.
double RelativeScale(const Fit& model, const Fit& baseline);

// DeltaBic (selection.h) with the chi-squares in the noise scale of `reference`, the model the
// parameters are added to: the baseline has no effect, and a large one would otherwise inflate
// the baseline's scale so much that no second effect could pay for its parameter.
double DeltaBicAt(const Fit& reference, const Fit& f0, double chi2_with, double chi2_without, std::size_t params,
                  double log_n);

// How much lower, as a fraction, the held-out chi-square is after than before.
double HeldoutGain(const Fit& before, const Fit& after);

// Correlation of the estimates `a` and `b` of a covariance.
double Correlation(const Eigen::MatrixXd& cov, int a, int b);

// An interval's error under `m` (measured - predicted, unwhitened).
Eigen::Vector3d ErrorOf(const Interval& it, const Model& m);

// An interval's Jacobians by parameter block.
struct Jacobians {
  Eigen::Matrix<double, 3, 5, Eigen::RowMajor> params;
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> mount;
  Eigen::Matrix<double, 3, kNumBeta, Eigen::RowMajor> beta;
};

// An interval's whitened residual `r` under `m`, and its Jacobians when `jac` is given: over
// the drive parameters, the mount and the effect terms `betas` (the other columns zero).
void Residual(const Interval& it, const Model& m, double r[3], Jacobians* jac = nullptr,
              const std::vector<int>& betas = {});

// An interval's whitened chi-square under `m` (not divided by the variance factor).
double Chi2Of(const Interval& it, const Model& m);

}  // namespace calib::diag
