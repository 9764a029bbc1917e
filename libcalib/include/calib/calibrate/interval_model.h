#pragma once
// The model of one interval, for Ceres' automatic derivatives: the wheel odometry integrated over
// the interval between two sensor observations, carried through the sensor's mount and compared
// with the sensor's measured motion. The calibration (calibration.cc) fits it with the drive
// kinematics alone; the diagnosis (diagnose/diagnose_model.h) extends it with the effect terms.
// Both build and solve their least-squares problem through interval_problem.h.
//
// Frames. b_k is the robot's body frame (reference point, x forward) at the interval's start
// stamp t0 and end stamp t1 = t0 + D; s_k = b_k ∘ l the sensor's frame, with the mount
// l = (x, y, yaw) of the sensor in the body frame. Poses compose as in SE(2) (a ∘ b, a⁻¹).
//
// Prediction. The encoder samples over the window are cut into steps (the first and last at the
// window's ends by linear interpolation). Each step j has the drive rotation Δφ_j of every wheel
// and its mean steering reading ψ_j; the drive kinematics (kinematics_generic.h) turn them into
// the body displacement d_j = (dx, dy, dθ), travelled along an arc (the exponential map):
//   q = Exp(d_1) ∘ Exp(d_2) ∘ ... ∘ Exp(d_n)        the body motion b_0⁻¹ ∘ b_1
//   z = l⁻¹ ∘ q ∘ l                                 the predicted sensor motion s_0⁻¹ ∘ s_1
//
// Residual. m = (x, y, θ) is the measured sensor motion (scan matching or external poses) with
// covariance Σ; U the upper Cholesky factor of Σ⁻¹ (UᵀU = Σ⁻¹, SqrtInformation):
//   e = m - z,  e_θ wrapped to (-π, π] by a whole number of turns taken at the values (constant
//              for the derivatives, which then stay smooth),
//   r = U e,    so that |r|² = eᵀ Σ⁻¹ e is a chi-square with 3 degrees of freedom.
//
// Time offset δ: a sensor stamp t was taken at wheel time t - δ, so the encoders are integrated
// over [-δ, D - δ] (s from t0). The calibration's window ends are δ itself (automatic
// derivatives through the interpolation at the ends: ∂q/∂δ comes from the encoder steps the
// ends fall in). The diagnosis integrates at δ's value and takes the derivative from smoothed
// wheel speeds instead (diagnose_model.h says why).
//
// Effects (diagnosis only; each term is zero when its parameter is): slip, eccentricity,
// steering lag, backlash and a travel-direction steering offset change Δφ_j and ψ_j; lateral
// slip adds to dy; scan distortion corrects m; de-skewed scans move the window by their lead.
//
// Robust scale and outliers (both users): the median of the intervals' chi-squares over the
// median of a chi-square with 3 degrees of freedom (kChi2Median3) is the squared scale of the
// residuals; an interval whose chi-square in that scale exceeds a threshold is an outlier.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <ceres/jet.h>

#include "calib/core/kinematics_generic.h"
#include "calib/core/robot.h"
#include "calib/core/wheel_track.h"

namespace calib {

// Median of a chi-square variable with 3 degrees of freedom: robust scale of the residuals.
inline constexpr double kChi2Median3 = 2.366;

// The squared robust scale of whitened chi-squares (3 dof): their median over kChi2Median3,
// at least 1e-12.
double RobustScale2(std::vector<double> chi2);

// The outlier gate: `chi2` divided by the squared robust scale beyond `threshold`.
inline bool IsOutlier(double chi2, double scale2, double threshold) { return chi2 / scale2 > threshold; }

// U with UᵀU = covariance⁻¹ (upper Cholesky factor of the information); a fixed 1 cm, 0.3 deg
// when the covariance is not finite or not positive definite.
Eigen::Matrix3d SqrtInformation(const Eigen::Matrix3d& covariance);

// The value of a double or of a Jet (for the decisions that must not be differentiated).
inline double Scalar(double x) { return x; }
template <typename T, int N>
double Scalar(const ceres::Jet<T, N>& x) {
  return x.a;
}

// The encoder samples of a recording in the model's terms: the drive, and the WheelTrack read in
// place (a copy was the largest part of a long live solve's memory, docs/live.md), wheels in
// WheelRoles(drive) order; pos() and steer() of w >= wheels (the second of the two wheels the
// models allow, on a drive with one) are 0. The WheelTrack must outlive the view and stay
// unchanged while it is used.
class EncoderTrack {
 public:
  EncoderTrack() = default;
  EncoderTrack(DriveType drive, const WheelTrack& samples)
      : drive(drive), wheels(static_cast<int>(WheelRoles(drive).size())), samples_(&samples) {}

  DriveType drive = DriveType::kDifferential;
  int wheels = 0;

  std::size_t size() const { return samples_ ? samples_->size() : 0; }
  const std::vector<int64_t>& utimes() const { return samples_->utimes(); }
  int64_t utime(std::size_t i) const { return samples_->utime(i); }
  // Accumulated rotation and steering reading of wheel w at sample i (rad).
  double pos(std::size_t i, int w) const { return w < wheels ? samples_->position(i, w) : 0.0; }
  double steer(std::size_t i, int w) const { return w < wheels ? samples_->steer(i, w) : 0.0; }

 private:
  const WheelTrack* samples_ = nullptr;
};

// The residual of one interval (the functor Ceres differentiates), the comparison written once
// for every model. `Model` derives from it and says how the body motion q is predicted:
//   template <typename T> generic::Pose<T> BodyMotion(const T* params, const T* extra) const;
// and may correct the measured motion by hiding Measured(). `extra` is the model's own parameter
// block (the time offset; the diagnosis's effect parameters).
template <typename Model>
class IntervalCost {
 public:
  // The samples [first, last] of `track` around the interval starting at `utime_start`.
  IntervalCost(const EncoderTrack* track, std::size_t first, std::size_t last, int64_t utime_start,
               double duration, const Eigen::Vector3d& measured, const Eigen::Matrix3d& sqrt_information)
      : track_(track), first_(first), last_(last), t0_(utime_start), duration_(duration),
        measured_(measured), sqrt_information_(sqrt_information) {}

  // r = U e.
  template <typename T>
  bool operator()(const T* params, const T* mount, const T* extra, T* residual) const {
    T e[3];
    Error(params, mount, extra, e);
    for (int i = 0; i < 3; ++i) {
      residual[i] = T(0.0);
      for (int j = 0; j < 3; ++j) residual[i] += sqrt_information_(i, j) * e[j];
    }
    return true;
  }

  // e = m - l⁻¹ ∘ q ∘ l (x, y, theta), unwhitened.
  template <typename T>
  void Error(const T* params, const T* mount, const T* extra, T* e) const {
    using P = generic::Pose<T>;
    const Model& model = static_cast<const Model&>(*this);
    const P q = model.BodyMotion(params, extra);
    const P l{mount[0], mount[1], mount[2]};
    const P z = generic::Compose(generic::Compose(generic::Inverse(l), q), l);
    T measured[3];
    model.Measured(extra, measured);
    e[0] = measured[0] - z.x;
    e[1] = measured[1] - z.y;
    const double turns = std::round((Scalar(measured[2]) - Scalar(z.theta)) / (2.0 * M_PI));
    e[2] = measured[2] - z.theta - T(turns * 2.0 * M_PI);
  }

  // The same at the values of the blocks.
  Eigen::Vector3d ErrorAt(const double* params, const double* mount, const double* extra) const {
    double e[3];
    Error(params, mount, extra, e);
    return {e[0], e[1], e[2]};
  }

  // m as measured; a model that corrects it hides this.
  template <typename T>
  void Measured(const T* /*extra*/, T* measured) const {
    for (int k = 0; k < 3; ++k) measured[k] = T(measured_[k]);
  }

  std::size_t first() const { return first_; }
  std::size_t last() const { return last_; }

 protected:

  // Time of sample i, s from the interval's start stamp.
  double Time(std::size_t i) const { return (track_->utime(i) - t0_) * 1e-6; }

  // Index i of the segment [Time(i), Time(i+1)] that holds t, clamped to the interval's samples.
  std::size_t Segment(double t) const {
    const auto begin = track_->utimes().begin();
    const auto it = std::upper_bound(begin + first_, begin + last_ + 1, t,
                                     [this](double t, int64_t utime) { return t < (utime - t0_) * 1e-6; });
    const std::size_t i = it == begin + first_ ? first_ : std::size_t(it - begin) - 1;
    return std::min(i, last_ - 1);
  }

  // Where t lies in segment i: 0 at its start, 1 at its end.
  template <typename T>
  T Fraction(std::size_t i, const T& t) const {
    return (t - Time(i)) / (Time(i + 1) - Time(i));
  }

  // The value at fraction f of a segment from `start` to `end`.
  template <typename T>
  static T Lerp(double start, double end, const T& f) {
    return start + f * (end - start);
  }

  const EncoderTrack* track_;
  std::size_t first_, last_;  // sample range [first, last] around the interval
  int64_t t0_;                // the interval's start stamp, us
  double duration_;           // D, s
  Eigen::Vector3d measured_;  // m
  Eigen::Matrix3d sqrt_information_;  // U
};

// The calibration's model: the drive kinematics alone, `extra` the time offset δ.
class DriveIntervalCost : public IntervalCost<DriveIntervalCost> {
 public:
  using IntervalCost::IntervalCost;

  template <typename T>
  generic::Pose<T> BodyMotion(const T* params, const T* offset) const {
    generic::Pose<T> q{T(0.0), T(0.0), T(0.0)};
    ForEachStep(-offset[0], T(duration_) - offset[0], [&](const T* rotation, const T* steer) {
      T dx = T(0.0), dy = T(0.0), dtheta = T(0.0);
      generic::BodyDisplacement(track_->drive, params, rotation, steer, &dx, &dy, &dtheta);
      q = generic::Compose(q, generic::Exp(dx, dy, dtheta));
    });
    return q;
  }

 private:
  // Calls step(rotation, mean_steer) for each encoder step over [start, end] (s from the
  // interval's start), the first and last cut by interpolation.
  template <typename T, typename Step>
  void ForEachStep(const T& start, const T& end, Step step) const {
    const int wheels = track_->wheels;
    std::size_t i = Segment(Scalar(start));
    const std::size_t last = Segment(Scalar(end));
    T prev_pos[2], prev_steer[2], pos[2], steer[2];
    Interpolate(i, start, prev_pos, prev_steer);
    for (;;) {
      const bool final_step = i >= last;
      if (final_step) {
        Interpolate(last, end, pos, steer);
      } else {
        ++i;
        for (int w = 0; w < wheels; ++w) {
          pos[w] = T(track_->pos(i, w));
          steer[w] = T(track_->steer(i, w));
        }
      }
      T rotation[2], mean_steer[2];
      for (int w = 0; w < wheels; ++w) {
        rotation[w] = pos[w] - prev_pos[w];
        mean_steer[w] = 0.5 * (steer[w] + prev_steer[w]);
        prev_pos[w] = pos[w];
        prev_steer[w] = steer[w];
      }
      step(rotation, mean_steer);
      if (final_step) break;
    }
  }

  template <typename T>
  void Interpolate(std::size_t i, const T& t, T* pos, T* steer) const {
    const T f = Fraction(i, t);
    for (int w = 0; w < track_->wheels; ++w) {
      pos[w] = Lerp(track_->pos(i, w), track_->pos(i + 1, w), f);
      steer[w] = Lerp(track_->steer(i, w), track_->steer(i + 1, w), f);
    }
  }
};

}  // namespace calib
