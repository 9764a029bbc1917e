// The diagnosis's interval cost with derivatives over the free effect terms only
// (diagnose/diagnose_model.h IntervalFunction) against Ceres' automatic derivatives over
// every term: the same residuals and Jacobian columns to the bit, the fixed terms' columns
// zero. A synthetic dual-steer track (every effect term acts on a steered drive) with
// steering changes and a reversal, evaluated at effect terms away from zero.

#include <gtest/gtest.h>

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/core/wheel_track.h"
#include "diagnose/diagnose_model.h"

namespace calib::diag {
namespace {

constexpr int64_t kStart = 1'000'000'000;  // us
constexpr int64_t kPeriod = 20'000;        // 50 Hz encoders
constexpr int kSamples = 400;

// The encoder samples of DualSteerTrack (which reads them in place).
const WheelTrack& DualSteerWheels() {
  static const WheelTrack wheels = [] {
    WheelTrack track;
    double pos0 = 0, pos1 = 0;
    for (int i = 0; i < kSamples; ++i) {
      const double t = i * kPeriod * 1e-6;
      const double speed = i < 300 ? 4.0 + std::sin(t) : -3.0;  // rad/s, reversing near the end
      pos0 += speed * kPeriod * 1e-6;
      pos1 += 0.97 * speed * kPeriod * 1e-6;
      track.Append({kStart + i * kPeriod, {pos0, pos1}, {0.3 * std::sin(1.3 * t), -0.2 * std::sin(0.9 * t + 0.4)}});
    }
    return track;
  }();
  return wheels;
}

Track DualSteerTrack() {
  Track tr(EncoderTrack(DriveType::kDualSteer, DualSteerWheels()));
  tr.steered = {true, true};
  tr.radius_index = {0, 3};
  tr.speed.assign(kSamples, {0, 0});
  tr.steer_sign.assign(kSamples, {0, 0});
  tr.travel_sign.assign(kSamples, 1.0);
  for (int i = 1; i + 1 < kSamples; ++i) {
    for (int w = 0; w < 2; ++w) {
      tr.speed[i][w] = (tr.pos(i + 1, w) - tr.pos(i - 1, w)) / (2 * kPeriod * 1e-6);
      tr.steer_sign[i][w] = tr.steer(i + 1, w) > tr.steer(i - 1, w) ? 1.0 : -1.0;
    }
    tr.travel_sign[i] = tr.speed[i][0] > 0 ? 1.0 : -1.0;
  }
  return tr;
}

// A model over samples [first, last], the interval 0.3 s long from sample `first` + 120.
IntervalModel Interval(const Track& tr, std::size_t first) {
  const Eigen::Matrix3d sqrt_information = Eigen::Vector3d(100, 80, 300).asDiagonal();
  return IntervalModel(&tr, first, first + 150, tr.utime(first + 120), 0.3, Eigen::Vector3d(0.35, 0.02, 0.04),
                       sqrt_information, Eigen::Vector3d(0.1, -0.2, 0.3), 0.01, Pose2{0.003, 0.0, 0.001},
                       Pose2{0.004, 0.001, -0.002});
}

void ExpectSameAsAllTerms(const IntervalModel& model, const std::vector<int>& free) {
  double params[5] = {0.1, 0.01, 0.9, 0.1, 0.45}, mount[3] = {0.3, -0.1, 0.2}, beta[kNumBeta] = {};
  beta[kTimeOffset] = 0.012, beta[kSlip] = 0.02, beta[kLateral] = 0.03, beta[kLag] = 0.08;
  beta[kBacklash] = 0.004, beta[kEcc0C] = 0.002, beta[kEcc0S] = -0.001, beta[kEcc1C] = 0.001;
  beta[kEcc1S] = 0.0015, beta[kTravelOffset] = 0.003, beta[kDistortion] = 0.05;
  const double* blocks[3] = {params, mount, beta};

  ceres::AutoDiffCostFunction<IntervalModel, 3, 5, 3, kNumBeta> all(new IntervalModel(model));
  double r_all[3], jp_all[15], jm_all[9], jb_all[3 * kNumBeta];
  double* jac_all[3] = {jp_all, jm_all, jb_all};
  ASSERT_TRUE(all.Evaluate(blocks, r_all, jac_all));

  const IntervalFunction sized(&model, &free);
  double r[3], jp[15], jm[9], jb[3 * kNumBeta];
  double* jac[3] = {jp, jm, jb};
  ASSERT_TRUE(sized.Evaluate(blocks, r, jac));
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(r[i], r_all[i]) << "residual " << i;
    for (int c = 0; c < 5; ++c) EXPECT_EQ(jp[5 * i + c], jp_all[5 * i + c]) << "drive " << i << "," << c;
    for (int c = 0; c < 3; ++c) EXPECT_EQ(jm[3 * i + c], jm_all[3 * i + c]) << "mount " << i << "," << c;
    for (int c = 0; c < kNumBeta; ++c) {
      const bool is_free = std::find(free.begin(), free.end(), c) != free.end();
      EXPECT_EQ(jb[kNumBeta * i + c], is_free ? jb_all[kNumBeta * i + c] : 0.0) << "effect " << i << "," << c;
    }
  }
  for (int c : free) {  // a comparison of zeros would prove nothing
    EXPECT_TRUE(jb_all[c] != 0.0 || jb_all[kNumBeta + c] != 0.0 || jb_all[2 * kNumBeta + c] != 0.0)
        << "effect " << c << " does not act";
  }
  // Without Jacobians both run the model on doubles.
  double r_plain[3], r_all_plain[3];
  ASSERT_TRUE(sized.Evaluate(blocks, r_plain, nullptr));
  ASSERT_TRUE(all.Evaluate(blocks, r_all_plain, nullptr));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(r_plain[i], r_all_plain[i]);
}

TEST(DiagnoseJets, SameAsDerivativesOverEveryTerm) {
  const Track tr = DualSteerTrack();
  // Forward with steering changes, and across the reversal.
  for (std::size_t first : {20u, 170u}) {
    const IntervalModel model = Interval(tr, first);
    const std::vector<std::vector<int>> free_sets = {
        {},
        {kLag},
        {kTimeOffset},
        {kEcc1C, kEcc1S},
        {kDistortion, kSlip, kLateral},
        {kBacklash, kTravelOffset, kLag, kTimeOffset, kEcc0C},
        {kTimeOffset, kSlip, kLateral, kLag, kBacklash, kEcc0C, kEcc0S, kEcc1C, kEcc1S, kTravelOffset, kDistortion}};
    for (const auto& free : free_sets) {
      SCOPED_TRACE("first " + std::to_string(first) + ", " + std::to_string(free.size()) + " free terms");
      ExpectSameAsAllTerms(model, free);
    }
  }
}

}  // namespace
}  // namespace calib::diag
