// The interval model (calibrate/interval_model.h) on a small synthetic interval of each drive
// type: zero residual at the truth, and its automatic Jacobians against central differences.

#include "calib/calibrate/interval_model.h"

#include <gtest/gtest.h>

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/core/kinematics.h"
#include "calib/core/se2.h"
#include "calib/core/wheel_track.h"

namespace calib {
namespace {

constexpr int64_t kTrackStart = 1'000'000'000;  // us
constexpr int64_t kSamplePeriod = 20'000;       // 50 Hz encoders
constexpr double kOffsetS = 0.013;              // the sensor's stamps late by 13 ms
const Pose2 kMount{0.3, -0.1, 0.2};
// The automatic against the central-difference Jacobian, entry by entry: relative to the entry
// (absolute below 1), with steps of 1e-5 of each value (at least 1e-5). The window ends stay
// clear of the encoder samples, where the model has kinks in the time offset.
constexpr double kRelativeStep = 1e-5;
constexpr double kJacobianPrecision = 1e-6;

struct Drive {
  DriveType type;
  std::map<std::string, double> params;
};

// Two seconds of encoder samples with accelerating wheels and a steering that keeps changing.
WheelTrack SyntheticWheels(DriveType type) {
  WheelTrack wheels;
  for (int k = 0; k <= 100; ++k) {
    const double t = k * kSamplePeriod * 1e-6;
    WheelSample s;
    s.utime = kTrackStart + k * kSamplePeriod;
    switch (type) {
      case DriveType::kDifferential:
        s.position = {8.0 * t + 0.5 * t * t, 9.0 * t + 1.5 * t * t};
        s.steer = {0.0, 0.0};
        break;
      case DriveType::kTricycle:
        s.position = {6.0 * t + t * t};
        s.steer = {0.1 + 0.3 * std::sin(1.3 * t)};
        break;
      case DriveType::kDualSteer:
        s.position = {5.0 * t + 0.4 * t * t, 4.8 * t + 0.5 * t * t};
        s.steer = {0.2 * std::sin(t), 0.05 * std::cos(2.0 * t)};
        break;
    }
    EXPECT_TRUE(wheels.Append(s));
  }
  return wheels;
}

// One interval of a sensor whose stamps lag the encoders by kOffsetS, measured exactly: the
// odometry over [t0 - offset, t1 - offset] (WheelTrack::Odometry, the kinematics' own
// integration) seen from the mount.
class IntervalModelTest : public ::testing::TestWithParam<Drive> {
 protected:
  void SetUp() override {
    const Drive& drive = GetParam();
    wheels_ = SyntheticWheels(drive.type);
    track_ = EncoderTrack(drive.type, wheels_);
    const std::unique_ptr<DriveModel> model = MakeDriveModel(drive.type, drive.params);
    const int64_t t0 = kTrackStart + 700'003, t1 = kTrackStart + 1'107'011;  // off the samples
    const double shift = kOffsetS * 1e6;
    const Pose2 q = wheels_.Odometry(*model, t0 - shift, t1 - shift);
    const Pose2 z = Compose(Compose(Inverse(kMount), q), kMount);
    // Samples around the interval with room for the offset, as the calibration takes them.
    const std::size_t first = (t0 - kTrackStart) / kSamplePeriod - 3;
    const std::size_t last = (t1 - kTrackStart) / kSamplePeriod + 4;
    const Eigen::Matrix3d covariance = Eigen::Vector3d(4e-6, 1e-6, 2.5e-7).asDiagonal();
    cost_ = std::make_unique<DriveIntervalCost>(&track_, first, last, t0, (t1 - t0) * 1e-6,
                                                Eigen::Vector3d(z.x, z.y, z.theta), SqrtInformation(covariance));
    for (const std::string& name : ParamNames(drive.type)) params_.push_back(drive.params.at(name));
  }

  // The automatic Jacobians of the cost at (params, mount, offset) against central differences:
  // every entry within kJacobianPrecision of the larger of its magnitude and 1.
  template <int N>
  void CheckJacobians(const std::vector<double>& params, const Pose2& mount, double offset) {
    ceres::AutoDiffCostFunction<DriveIntervalCost, 3, N, 3, 1> function(cost_.get(), ceres::DO_NOT_TAKE_OWNERSHIP);
    std::vector<double> values[3] = {params, {mount.x, mount.y, mount.theta}, {offset}};
    const double* blocks[3] = {values[0].data(), values[1].data(), values[2].data()};
    Eigen::Matrix<double, 3, N, Eigen::RowMajor> jp;
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> jm;
    Eigen::Vector3d jo, r;
    double* jacobians[3] = {jp.data(), jm.data(), jo.data()};
    ASSERT_TRUE(function.Evaluate(blocks, r.data(), jacobians));
    const Eigen::MatrixXd automatic[3] = {jp, jm, jo};
    double worst = 0.0;
    for (int b = 0; b < 3; ++b) {
      EXPECT_GT(automatic[b].norm(), 0.0) << "block " << b << " does not move the residual";
      for (std::size_t c = 0; c < values[b].size(); ++c) {
        const double x = values[b][c], h = kRelativeStep * std::max(std::abs(x), 1.0);
        Eigen::Vector3d plus, minus;
        values[b][c] = x + h;
        function.Evaluate(blocks, plus.data(), nullptr);
        values[b][c] = x - h;
        function.Evaluate(blocks, minus.data(), nullptr);
        values[b][c] = x;
        const Eigen::Vector3d numeric = (plus - minus) / (2.0 * h);
        for (int row = 0; row < 3; ++row) {
          const double a = automatic[b](row, c), error = std::abs(a - numeric[row]) / std::max(std::abs(a), 1.0);
          EXPECT_LT(error, kJacobianPrecision) << "block " << b << " column " << c << " row " << row << ": automatic "
                                               << a << ", numeric " << numeric[row];
          worst = std::max(worst, error);
        }
      }
    }
    std::ostringstream worst_text;
    worst_text << worst;
    RecordProperty("worst_relative_error", worst_text.str());
  }

  void CheckJacobians(const std::vector<double>& params, const Pose2& mount, double offset) {
    if (params.size() == 3) {
      CheckJacobians<3>(params, mount, offset);
    } else {
      CheckJacobians<5>(params, mount, offset);
    }
  }

  WheelTrack wheels_;
  EncoderTrack track_;
  std::unique_ptr<DriveIntervalCost> cost_;
  std::vector<double> params_;
};

TEST_P(IntervalModelTest, ZeroResidualAtTheTruth) {
  const double mount[3] = {kMount.x, kMount.y, kMount.theta};
  const double offset = kOffsetS;
  double e[3], r[3];
  cost_->Error(params_.data(), mount, &offset, e);
  (*cost_)(params_.data(), mount, &offset, r);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(e[k], 0.0, 1e-12) << k;
    EXPECT_NEAR(r[k], 0.0, 1e-9) << k;
  }
  // Without the offset the same interval does not fit: the offset term is live.
  const double no_offset = 0.0;
  cost_->Error(params_.data(), mount, &no_offset, e);
  EXPECT_GT(std::hypot(e[0], e[1], e[2]), 1e-4);
}

TEST_P(IntervalModelTest, AutomaticJacobianMatchesNumericAtTheTruth) {
  CheckJacobians(params_, kMount, kOffsetS);
}

TEST_P(IntervalModelTest, AutomaticJacobianMatchesNumericAwayFromTheTruth) {
  std::vector<double> params = params_;
  for (std::size_t i = 0; i < params.size(); ++i) params[i] *= 1.0 + 0.03 * (i % 2 ? -1.0 : 1.0);
  CheckJacobians(params, Pose2{0.25, -0.02, 0.15}, 0.004);
}

INSTANTIATE_TEST_SUITE_P(
    DriveTypes, IntervalModelTest,
    ::testing::Values(
        Drive{DriveType::kDifferential, {{"left_radius", 0.1}, {"right_radius", 0.102}, {"track", 0.5}}},
        Drive{DriveType::kTricycle, {{"drive_radius", 0.15}, {"wheelbase", 1.2}, {"steer_offset", 0.02}}},
        Drive{DriveType::kDualSteer,
              {{"a1_radius", 0.12}, {"a1_steer_offset", 0.01}, {"b", 1.0}, {"a2_radius", 0.125}, {"a", 0.3}}}),
    [](const auto& info) { return std::string(DriveTypeName(info.param.type)); });

// UᵀU is the information, and an unusable covariance falls back to 1 cm, 0.3 deg.
TEST(SqrtInformation, IsTheUpperCholeskyFactorOfTheInformation) {
  Eigen::Matrix3d covariance;
  covariance << 4e-6, 1e-6, 0.0, 1e-6, 2e-6, 1e-7, 0.0, 1e-7, 1e-6;
  const Eigen::Matrix3d u = SqrtInformation(covariance);
  EXPECT_TRUE(u.isUpperTriangular());
  EXPECT_TRUE((u.transpose() * u * covariance).isApprox(Eigen::Matrix3d::Identity(), 1e-9));
  const Eigen::Matrix3d fallback = SqrtInformation(Eigen::Matrix3d::Zero());
  EXPECT_TRUE(fallback.isApprox(Eigen::Vector3d(100.0, 100.0, 200.0).asDiagonal().toDenseMatrix()));
}

// The robust scale is the median chi-square over kChi2Median3, and the gate uses it.
TEST(RobustScale2, IsTheMedianOverTheChiSquareMedian) {
  EXPECT_DOUBLE_EQ(RobustScale2({9.0, 1.0, 4.0, 100.0, 2.0}), 4.0 / kChi2Median3);
  EXPECT_DOUBLE_EQ(RobustScale2({}), 1e-12);
  const double scale2 = RobustScale2({2.0, 2.0, 2.0});
  EXPECT_FALSE(IsOutlier(16.0 * scale2, scale2, 16.27));
  EXPECT_TRUE(IsOutlier(17.0 * scale2, scale2, 16.27));
}

}  // namespace
}  // namespace calib
