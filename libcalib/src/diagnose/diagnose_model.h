#pragma once
// The odometry model of the diagnosis: the interval model of calibrate/interval_model.h (its
// frames, residual and maths are written there) with the terms of the effects of
// spec/effects.md, each zero when its parameter is zero. Internal to libcalib.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <ceres/jet.h>
#include <ceres/sized_cost_function.h>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/interval_model.h"
#include "calib/core/kinematics_generic.h"
#include "calib/core/robot.h"
#include "calib/core/wheel_track.h"

namespace calib::diag {

// Effect parameters, one vector for every model (unused entries stay 0).
enum Beta {
  kTimeOffset = 0,   // time_offset.offset_s
  kSlip,             // longitudinal_slip.slip_per_accel, s^2/m
  kLateral,          // lateral_slip.gain, s
  kLag,              // steering_lag.tau_s
  kBacklash,         // steering_backlash.width_rad
  kEcc0C, kEcc0S,    // wheel_eccentricity of wheel 0: amplitude * (cos, sin) of phase
  kEcc1C, kEcc1S,    // ... of wheel 1
  kTravelOffset,     // not catalogued: steering offset that flips with the travel direction, rad
  kDistortion,       // scan_distortion.scan_period_s (first order, see Track::distortion)
  kNumBeta
};

constexpr double kHistoryS = 2.0;   // steering history kept before an interval (lag <= 0.25 s)
constexpr double kMaxOffsetS = kMaxTimeOffsetS;  // calibration.h

// The encoder track (read in place) with what the effect terms need per sample, in role order.
struct Track : EncoderTrack {
  Track() = default;
  explicit Track(EncoderTrack encoders) : EncoderTrack(std::move(encoders)) {}

  std::array<bool, 2> steered{false, false};
  std::array<int, 2> radius_index{0, 0};  // into ParamNames(drive)
  std::vector<std::array<double, 2>> speed;       // rad/s (smoothed)
  std::vector<std::array<double, 2>> steer_sign;  // last steering motion (+1/-1, 0 unknown)
  std::vector<double> travel_sign;                // last travel direction (+1/-1)
  int smooth_k = 1;  // speed[i] = (pos[i+k] - pos[i-k]) / time between them
};

Track MakeTrack(const RobotDescription& robot, const WheelTrack& wheels);

// One interval (IntervalCost: measured sensor motion minus the prediction, whitened), `extra`
// the effect parameters (Beta).
class IntervalModel : public IntervalCost<IntervalModel> {
 public:
  IntervalModel(const Track* track, std::size_t first, std::size_t last, int64_t utime_start,
                double duration, const Eigen::Vector3d& measured, const Eigen::Matrix3d& sqrt_information,
                const Eigen::Vector3d& distortion, double deskew_lead = 0.0, const Pose2& deskew_head = {},
                const Pose2& deskew_tail = {})
      : IntervalCost(track, first, last, utime_start, duration, measured, sqrt_information), tr_(track),
        distortion_(distortion), lead_(deskew_lead), deskew_head_(deskew_head), deskew_tail_(deskew_tail) {}

  // The measured motion corrected to first order for scan distortion.
  template <typename T>
  void Measured(const T* beta, T* measured) const {
    for (int k = 0; k < 3; ++k) measured[k] = T(measured_[k]) + beta[kDistortion] * distortion_[k];
  }

  // The body motion with the effect terms.
  template <typename T>
  generic::Pose<T> BodyMotion(const T* params, const T* beta) const {
    using P = generic::Pose<T>;
    using std::cos;
    using std::exp;
    using std::sin;
    const Track& tr = *tr_;
    const int nw = tr.wheels;
    const T tau = beta[kLag];
    const double tau_v = std::max(Scalar(tau), 0.0);
    // The scan stamped t was taken at wheel time t - offset: the window [-offset, D - offset],
    // integrated exactly at the offset's current value; its derivative comes from the
    // smoothed wheel speeds at the window's ends (below), not from the encoder samples the
    // prediction itself uses, so encoder noise cannot correlate with its own regressor.
    // De-skewed scans: the window moves by the lead, the de-skew odometry over the lead closes
    // it at both ends (DiagnoseData::deskew_lead_s).
    const double offset_v = Scalar(beta[kTimeOffset]);
    const T a = T(lead_ - offset_v), b = T(duration_ + lead_ - offset_v);
    // The lag filter starts where its memory has faded; its state there is the
    // ramp response u - tau * slope (exact for a steering ramp).
    double lead = std::min(kHistoryS, 8.0 * tau_v);
    std::size_t i = Segment(Scalar(a) - lead);
    T tc = Scalar(a) - lead <= Time(first_) ? T(Time(first_)) : a - T(lead);
    T pos_c[2], u_c[2], lag_c[2], spd_c[2];
    for (int w = 0; w < nw; ++w) {
      Interp(i, tc, w, pos_c + w, u_c + w, spd_c + w);
      lag_c[w] = u_c[w] - tau * Slope(i, w);
    }
    bool integrating = Scalar(tc) >= Scalar(a);
    P q{T(0.0), T(0.0), T(0.0)};
    for (;;) {
      const bool can_advance = i + 1 < last_;
      const double seg_end = can_advance ? Time(i + 1) : 1e300;
      const T& target = integrating ? b : a;
      const bool reach_target = Scalar(target) <= seg_end;
      const T tn = reach_target ? target : T(seg_end);
      T pos_n[2], u_n[2], lag_n[2], spd_n[2];
      const T h = tn - tc;
      const bool step = Scalar(h) > 1e-9;
      for (int w = 0; w < nw; ++w) {
        Interp(i, tn, w, pos_n + w, u_n + w, spd_n + w);
        if (!tr.steered[w]) {
          lag_n[w] = u_n[w];
        } else if (!step) {
          lag_n[w] = lag_c[w];
        } else {
          const T s = T(Slope(i, w));
          const T p = tau_v > 1e-6 ? T(exp(-h / tau)) : T(0.0);
          lag_n[w] = u_n[w] - tau * s + p * (lag_c[w] - u_c[w] + tau * s);
        }
      }
      if (integrating && step) {
        T rotation[2], steer[2];
        for (int w = 0; w < nw; ++w) {
          rotation[w] = pos_n[w] - pos_c[w];
          // longitudinal_slip: distance lost k * integral(a v dt) = k (v_n^2 - v_c^2) / 2.
          const T r = params[tr.radius_index[w]];
          rotation[w] -= beta[kSlip] * r * (spd_n[w] * spd_n[w] - spd_c[w] * spd_c[w]) * 0.5;
          // wheel_eccentricity: integral of A cos(phi - phase) dphi.
          const T c = beta[kEcc0C + 2 * w], s = beta[kEcc0S + 2 * w];
          rotation[w] += c * (sin(pos_n[w]) - sin(pos_c[w])) - s * (cos(pos_n[w]) - cos(pos_c[w]));
          steer[w] = T(0.0);
          if (tr.steered[w]) {
            steer[w] = 0.5 * (lag_n[w] + lag_c[w]) - T(tr.steer_sign[i][w]) * beta[kBacklash] * 0.5 -
                       T(tr.travel_sign[i]) * beta[kTravelOffset] * 0.5;
          }
        }
        T dx, dy, dtheta;
        generic::BodyDisplacement(tr.drive, params, rotation, steer, &dx, &dy, &dtheta);
        dy += -beta[kLateral] * dx * dtheta / h;  // lateral_slip: v_y = -gain v omega
        q = generic::Compose(q, generic::Exp(dx, dy, dtheta));
      }
      for (int w = 0; w < nw; ++w) {
        pos_c[w] = pos_n[w];
        u_c[w] = u_n[w];
        lag_c[w] = lag_n[w];
        spd_c[w] = spd_n[w];
      }
      tc = tn;
      if (reach_target) {
        if (integrating) break;
        integrating = true;
      } else {
        ++i;
      }
    }
    {
      const T d_offset = beta[kTimeOffset] - T(offset_v);  // zero, with the offset's derivative
      T ea[3], eb[3];
      SmoothTwist(params, Scalar(a), ea);
      SmoothTwist(params, Scalar(b), eb);
      const P head = generic::Exp(T(d_offset * ea[0]), T(d_offset * ea[1]), T(d_offset * ea[2]));
      const P tail = generic::Exp(T(d_offset * eb[0]), T(d_offset * eb[1]), T(d_offset * eb[2]));
      q = generic::Compose(generic::Compose(head, q), generic::Inverse(tail));
    }
    if (lead_ > 0) {
      const P head{T(deskew_head_.x), T(deskew_head_.y), T(deskew_head_.theta)};
      const P tail{T(deskew_tail_.x), T(deskew_tail_.y), T(deskew_tail_.theta)};
      q = generic::Compose(generic::Compose(head, q), generic::Inverse(tail));
    }
    return q;
  }

 private:
  double Slope(std::size_t i, int w) const {
    return (tr_->steer(i + 1, w) - tr_->steer(i, w)) / (Time(i + 1) - Time(i));
  }
  // Body twist at time t (s from the interval's start) from the smoothed wheel speeds.
  template <typename T>
  void SmoothTwist(const T* params, double t, T* twist) const {
    const std::size_t i = Segment(t);
    T rates[2] = {T(0.0), T(0.0)}, steer[2] = {T(0.0), T(0.0)};
    for (int w = 0; w < tr_->wheels; ++w) {
      T pos;
      Interp(i, T(t), w, &pos, steer + w, rates + w);
    }
    generic::BodyDisplacement(tr_->drive, params, rates, steer, twist, twist + 1, twist + 2);
  }

  template <typename T>
  void Interp(std::size_t i, const T& t, int w, T* pos, T* steer, T* speed) const {
    const T f = Fraction(i, t);
    *pos = Lerp(tr_->pos(i, w), tr_->pos(i + 1, w), f);
    *steer = Lerp(tr_->steer(i, w), tr_->steer(i + 1, w), f);
    *speed = Lerp(tr_->speed[i][w], tr_->speed[i + 1][w], f);
  }

  const Track* tr_;             // the base's track, with the effect terms' per-sample data
  Eigen::Vector3d distortion_;  // d(measured)/d(scan period), per second of period
  double lead_;                 // s: the de-skewed scans' mean beam time after the stamp
  Pose2 deskew_head_, deskew_tail_;  // de-skew odometry over the lead after each stamp
};

// The Ceres cost of one interval (IntervalModel) with derivatives over the drive parameters,
// the mount and the effect terms `free` only: the other effect terms enter as constants and
// their Jacobian columns are zero. The Jets are sized to the free terms: Jets over all
// 5 + 3 + kNumBeta parameters would spend most of a diagnosis on derivatives no fit uses.
// Each Jet component is computed by the same operations whatever the others are, so residuals
// and the Jacobian's columns equal those of AutoDiffCostFunction over every term to the bit
// (tests/diagnose_jets_test.cc; it would catch a build whose vector and scalar lanes round
// differently, e.g. with fused multiply-adds in one and not the other).
// Without Jacobians the model runs on doubles, as AutoDiffCostFunction does.
class IntervalFunction : public ceres::SizedCostFunction<3, 5, 3, kNumBeta> {
 public:
  // `free` (effect terms, Beta) must outlive the function.
  IntervalFunction(const IntervalModel* model, const std::vector<int>* free) : model_(model), free_(free) {}

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    if (jacobians == nullptr) return (*model_)(parameters[0], parameters[1], parameters[2], residuals);
    // Jets padded to a few sizes (unused components stay 0); 10 rather than 9 for one free term:
    // an even size vectorises whole (about 10 % faster on a dual-steer interval).
    const std::size_t n = free_->size();
    if (n == 0) return WithJets<8>(parameters, residuals, jacobians);
    if (n <= 2) return WithJets<10>(parameters, residuals, jacobians);
    if (n <= 4) return WithJets<12>(parameters, residuals, jacobians);
    if (n <= 8) return WithJets<16>(parameters, residuals, jacobians);
    return WithJets<8 + kNumBeta>(parameters, residuals, jacobians);
  }

 private:
  template <int N>
  bool WithJets(double const* const* parameters, double* residuals, double** jacobians) const {
    using J = ceres::Jet<double, N>;
    const std::vector<int>& free = *free_;
    J params[5], mount[3], beta[kNumBeta], r[3];
    for (int i = 0; i < 5; ++i) params[i] = J(parameters[0][i], i);
    for (int i = 0; i < 3; ++i) mount[i] = J(parameters[1][i], 5 + i);
    for (int j = 0; j < kNumBeta; ++j) beta[j] = J(parameters[2][j]);
    for (std::size_t k = 0; k < free.size(); ++k) beta[free[k]].v[8 + k] = 1.0;
    if (!(*model_)(params, mount, beta, r)) return false;
    for (int i = 0; i < 3; ++i) {
      residuals[i] = r[i].a;
      if (jacobians[0] != nullptr)
        for (int c = 0; c < 5; ++c) jacobians[0][5 * i + c] = r[i].v[c];
      if (jacobians[1] != nullptr)
        for (int c = 0; c < 3; ++c) jacobians[1][3 * i + c] = r[i].v[5 + c];
      if (jacobians[2] != nullptr) {
        for (int c = 0; c < kNumBeta; ++c) jacobians[2][kNumBeta * i + c] = 0.0;
        for (std::size_t k = 0; k < free.size(); ++k) jacobians[2][kNumBeta * i + free[k]] = r[i].v[8 + k];
      }
    }
    return true;
  }

  const IntervalModel* model_;
  const std::vector<int>* free_;
};

}  // namespace calib::diag
