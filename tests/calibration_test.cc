// The solver against the simulator's truth, with an external pose source as
// the sensor (scan matching is tested on its own and end to end in solve tests).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <regex>
#include <string>

#include <nlohmann/json.hpp>

#include "calib/calibrate/calibration.h"
#include "calib/calibrate/calibration_data.h"
#include "calib/calibrate/heldout.h"
#include "calib/calibrate/result_files.h"
#include "calib/core/errors.h"
#include "calib/core/statistics.h"
#include "calib/io/messages.h"
#include "calib/live/sim_run.h"
#include "calib/sim/simulator.h"

namespace calib {
namespace {

std::string Source(const std::string& relative) {
  return std::string(AGVCAL_SOURCE_DIR) + "/" + relative;
}

// A simulation with a tracked point mounted off the reference point, its nominal mount at 0.
SimConfig PoseSim(const std::string& name, uint64_t seed) {
  SimConfig config = LoadSimConfig(Source("config/sims/" + name + ".yaml"));
  config.seed = seed;
  config.robot.pose = Mount2d{"POSE", 0.0, 0.0, 0.0};
  config.true_pose = Mount2d{"POSE", 0.21, -0.13, 0.035};
  config.pose.rate_hz = 20.0;
  config.pose.noise_xy = 0.0005;
  config.pose.noise_theta = 0.0005;
  config.lidar2d.rate_hz = 0.0;  // not needed here; keeps the run fast
  config.imu.rate_hz = 0.0;
  return config;
}

// The simulator's recording of `trajectory`, as the solver's input (wheels and poses).
CalibrationData Record(const SimConfig& config, const std::string& trajectory) {
  MemorySink sink;
  OfflineRunOptions run;
  run.trajectory = trajectory;
  RunOffline(config, run, &sink);
  CalibrationData data(config.robot);
  for (const LogEvent& e : sink.events) {
    if (e.channel == kWheelsChannel) {
      agvcal::wheel_state_t m;
      EXPECT_TRUE(Decode(e.data.data(), int(e.data.size()), &m));
      data.AddWheels(WheelSampleFromMessage(m, config.robot, "sim"));
    } else if (e.channel == kPoseChannel) {
      agvcal::pose2d_t m;
      EXPECT_TRUE(Decode(e.data.data(), int(e.data.size()), &m));
      data.AddPose(PoseFromMessage(m));
    }
  }
  return data;
}

struct Case {
  std::string sim;
  std::string trajectory;
};

class PoseCalibration : public ::testing::TestWithParam<Case> {};

TEST_P(PoseCalibration, RecoversTruthWithHonestSigmas) {
  const Case c = GetParam();
  const SimConfig config = PoseSim(c.sim, 7);
  const CalibrationData data = Record(config, c.trajectory);
  const CalibrationResult r = Calibrate(config.robot, data.wheels(), data.motions(),
                                        MotionSource::kPose, CalibrationOptions{}, "sim");
  for (const auto& [name, e] : r.params) {
    const double truth = config.true_params.at(name);
    const bool angle = name.find("offset") != std::string::npos;
    // Radii 0.05 %, lengths 0.1 %, steering offsets 0.05 deg (issue 3 targets).
    const double tol = angle ? 0.05 * M_PI / 180 : (name.find("radius") != std::string::npos ? 5e-4 : 1e-3) * std::abs(truth);
    EXPECT_NEAR(e.value, truth, tol) << name << " nominal " << e.nominal << " std " << e.std;
    EXPECT_LT(std::abs(e.value - truth), 4.0 * e.std + 1e-12) << name << " sigma not honest";
  }
  EXPECT_NEAR(r.mount_x.value, 0.21, 0.003);
  EXPECT_NEAR(r.mount_y.value, -0.13, 0.003);
  EXPECT_NEAR(r.mount_yaw.value, 0.035, 0.05 * M_PI / 180);
  EXPECT_LT(r.residual.outliers, r.residual.intervals / 50);
}

INSTANTIATE_TEST_SUITE_P(DriveTypes, PoseCalibration,
                         ::testing::Values(Case{"diff_robot", "default"}, Case{"forklift", "default"}),
                         [](const auto& info) { return info.param.sim; });

// Poses at 20 Hz become motions of 0.2 s that follow each other without a gap, and chained
// they give the motion from the first pose to the last.
TEST(Calibration, PoseIntervalsJoinThePoseStream) {
  PoseIntervals intervals;
  std::vector<SensorMotion> motions;
  StampedPose pose;
  for (int i = 0; i <= 40; ++i) {
    pose.utime = 1'000'000 + 50'000 * i;
    pose.x = 0.01 * i;
    pose.y = 0.002 * i * i;
    pose.theta = 0.03 * i;
    if (auto m = intervals.Add(pose)) motions.push_back(*m);
  }
  ASSERT_EQ(motions.size(), 10u);
  Pose2 chained{0, 0, 0};
  for (std::size_t k = 0; k < motions.size(); ++k) {
    EXPECT_EQ(motions[k].utime_end - motions[k].utime_start, 200'000);
    if (k > 0) {
      EXPECT_EQ(motions[k].utime_start, motions[k - 1].utime_end);
    }
    chained = Compose(chained, motions[k].delta);
  }
  const Pose2 expected = Between({0, 0, 0}, {pose.x, pose.y, pose.theta});
  EXPECT_NEAR(chained.x, expected.x, 1e-12);
  EXPECT_NEAR(chained.y, expected.y, 1e-12);
  EXPECT_NEAR(chained.theta, expected.theta, 1e-12);
}

// Over 20 seeds the pose source's sigmas are honest: |error| / sigma within 3 for 95 % of
// the drive parameters and mount values (issue 3 target). The poses are joined into
// intervals of kMinPoseIntervalS, so this also checks the sandwich on the joined motions.
TEST(Calibration, PoseSourceSigmasAreHonestOverTwentySeeds) {
  for (const char* sim : {"diff_robot", "forklift"}) {
    int values = 0, within3 = 0;
    double worst = 0.0, sum_z2 = 0.0;
    for (int seed = 1; seed <= 20; ++seed) {
      const SimConfig config = PoseSim(sim, seed);
      const CalibrationData data = Record(config, "default");
      const CalibrationResult r = Calibrate(config.robot, data.wheels(), data.motions(), MotionSource::kPose,
                                            CalibrationOptions{}, "sim");
      const auto count = [&](const Estimate& e, double truth) {
        const double z = std::abs(e.value - truth) / e.std;
        ++values;
        within3 += z <= 3.0 ? 1 : 0;
        worst = std::max(worst, z);
        sum_z2 += z * z;
      };
      for (const auto& [name, e] : r.params) count(e, config.true_params.at(name));
      count(r.mount_x, config.true_pose.x);
      count(r.mount_y, config.true_pose.y);
      count(r.mount_yaw, config.true_pose.yaw);
    }
    std::printf("[ info     ] %s: %d of %d within 3 sigma, worst %.2f sigma, rms %.2f\n", sim, within3, values,
                worst, std::sqrt(sum_z2 / values));
    EXPECT_GE(within3, 0.95 * values) << sim;
  }
}

TEST(Calibration, StraightOnlyIsRefusedNamingTheParameters) {
  const SimConfig config = PoseSim("forklift", 3);
  const CalibrationData data = Record(config, "straight");
  try {
    Calibrate(config.robot, data.wheels(), data.motions(), MotionSource::kPose, CalibrationOptions{}, "sim");
    FAIL() << "a straight-only recording must be refused";
  } catch (const UnobservableError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("wheelbase"), std::string::npos) << what;
    // The refusal shows what it refused: the estimate, its sigma and the sigma asked for.
    EXPECT_TRUE(std::regex_search(what, std::regex("wheelbase -?[0-9.]+ ± ([0-9.]+|undetermined) m, determined only below [0-9.]+ m")))
        << what;
    EXPECT_NE(e.remedy().find("steering angles"), std::string::npos) << e.remedy();
  }
}

// A fit that stops at its iteration limit says so. One iteration from drive parameters a tenth off
// cannot reach the optimum: the result carries a warning (RESULT.json `warnings`). With the
// default limit the same fit converges and carries none.
TEST(Calibration, AFitThatDoesNotConvergeIsReportedAsSuch) {
  const SimConfig config = PoseSim("forklift", 5);
  const CalibrationData data = Record(config, "default");
  RobotDescription start = config.robot;
  for (auto& [name, value] : start.params)
    if (name.find("offset") == std::string::npos) value *= 1.1;
  CalibrationOptions limited;
  limited.max_iterations = 1;
  const CalibrationResult r = Calibrate(start, data.wheels(), data.motions(), MotionSource::kPose, limited, "sim");
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("stopped short of convergence"), std::string::npos) << r.warnings[0];
  const nlohmann::json json = nlohmann::json::parse(CalibrationResultJson(r));
  ASSERT_TRUE(json.contains("warnings"));
  EXPECT_EQ(json["warnings"][0].get<std::string>(), r.warnings[0]);

  const CalibrationResult converged =
      Calibrate(start, data.wheels(), data.motions(), MotionSource::kPose, CalibrationOptions{}, "sim");
  EXPECT_TRUE(converged.warnings.empty()) << converged.warnings[0];
  EXPECT_FALSE(nlohmann::json::parse(CalibrationResultJson(converged)).contains("warnings"));
}

// `motions` with every stamp `shift_s` later: a sensor-to-wheel time offset that much larger.
std::vector<SensorMotion> Shifted(const std::vector<SensorMotion>& motions, double shift_s) {
  std::vector<SensorMotion> out = motions;
  for (SensorMotion& m : out) {
    m.utime_start += std::llround(shift_s * 1e6);
    m.utime_end += std::llround(shift_s * 1e6);
  }
  return out;
}

// Issue 16: shifting every sensor stamp must move the offset's estimate by the shift and leave
// the rest as it was. The Lego robot's scans shifted by +-120 ms moved `solve --time-offset` by
// +106 and -101 ms: its intervals (covered at every offset of the range), its closed-form start
// (at offset 0) and its search's scales (at offset 0) moved with where the offset lay in the
// range, and its robust fit stopped elsewhere in a flat basin. Here the poses read 0.42 s late
// as recorded (4 Hz, the Lego robot's rate); at +120 ms the offset lies beyond the first
// search's bound (0.5 s), so the search over the wider range must agree too.
TEST(Calibration, ShiftingEverySensorStampMovesTheOffsetByTheShift) {
  SimConfig config = PoseSim("diff_robot", 16);
  config.pose.rate_hz = 4.0;
  config.wheels.rate_hz = 4.0;
  config.wheels.ticks_per_rev = 360;
  config.pose.noise_xy = 0.005;
  config.pose.noise_theta = 0.01;
  const CalibrationData data = Record(config, "default");
  CalibrationOptions options;
  options.estimate_time_offset = true;
  const std::vector<SensorMotion> recorded = Shifted(data.motions(), 0.42);
  const CalibrationResult base = Calibrate(config.robot, data.wheels(), recorded, MotionSource::kPose, options, "sim");
  ASSERT_TRUE(base.time_offset.has_value());
  EXPECT_NEAR(base.time_offset->value, 0.42, 3 * base.time_offset->std);
  for (const double shift : {0.12, -0.12, 0.037}) {
    const CalibrationResult r =
        Calibrate(config.robot, data.wheels(), Shifted(recorded, shift), MotionSource::kPose, options, "sim");
    ASSERT_TRUE(r.time_offset.has_value());
    // Equal but for rounding: 10 us, a thousandth of the offset's sigma.
    EXPECT_NEAR(r.time_offset->value - base.time_offset->value, shift, 1e-5) << "shift " << shift;
    EXPECT_NEAR(r.params.at("track").value, base.params.at("track").value, 1e-3 * base.params.at("track").std);
    EXPECT_EQ(r.residual.intervals, base.residual.intervals) << "shift " << shift;
  }
}
}  // namespace
}  // namespace calib

namespace calib {
namespace {

// Straight steps of 0.1 m each, every 0.1 s, on which a model 1 % short errs by 1 mm per step.
std::vector<OdometryStep> StraightSteps(int n, int64_t start_us = 0) {
  std::vector<OdometryStep> steps;
  for (int k = 0; k < n; ++k) {
    OdometryStep s;
    s.utime_start = start_us + k * 100000;
    s.utime_end = s.utime_start + 100000;
    s.measured = Pose2{0.1, 0.0, 0.0};
    s.error[0] = 0.001;
    steps.push_back(s);
  }
  return steps;
}

TEST(HeldoutWindows, PathWindowsKeepAPartialWindowOfHalfTheLengthOrMore) {
  // 25 steps (2.5 m), then a gap, then 4 steps (0.4 m): windows of 1 m give 1, 1, 0.5 (kept)
  // and 0.4 (dropped, under half).
  std::vector<OdometryStep> steps = StraightSteps(25);
  for (const OdometryStep& s : StraightSteps(4, 10000000)) steps.push_back(s);
  const OdometryError e = OdometryErrorOverPath(steps, 1.0 - 1e-9);
  ASSERT_EQ(e.windows, 3);
  EXPECT_NEAR(e.per_window[0].distance_m, 1.0, 1e-9);
  EXPECT_NEAR(e.per_window[0].translation_m, 0.010, 1e-9);  // 1 % of 1 m
  EXPECT_NEAR(e.per_window[2].distance_m, 0.5, 1e-9);
  EXPECT_NEAR(e.per_window[2].translation_m, 0.005, 1e-9);
  EXPECT_NEAR(e.distance_m, 2.5, 1e-9);
  EXPECT_NEAR(e.error_per_metre, 0.01, 1e-9);
}

TEST(HeldoutWindows, WindowLengthIsTheLongestThatGivesTheCount) {
  const std::vector<OdometryStep> steps = StraightSteps(100);  // 10 m, unbroken
  const double length = PathWindowLength(steps, 20);
  EXPECT_GE(OdometryErrorOverPath(steps, length).windows, 20);
  EXPECT_LT(OdometryErrorOverPath(steps, length / 0.95).windows, 20);
  EXPECT_GT(length, 0.45);  // about 10 m / 20, on steps of 0.1 m
  // Too little data for 20 windows: the length with the most windows.
  const std::vector<OdometryStep> few = StraightSteps(5);
  EXPECT_EQ(OdometryErrorOverPath(few, PathWindowLength(few, 20)).windows, 5);
}

// Fewer steps than windows asked for, one of them where the robot barely moved: the windows
// are no shorter than the longest step, not as short as that one step, so the length said is
// the path the windows hold.
TEST(HeldoutWindows, FewerStepsThanWindowsGiveWindowsOfTheStepsPath) {
  std::vector<OdometryStep> steps = StraightSteps(15);
  for (std::size_t k = 0; k < steps.size(); ++k) steps[k].measured.x = 0.15 + 0.01 * double(k % 5);
  steps[7].measured.x = 0.002;
  const double length = PathWindowLength(steps, 20);
  EXPECT_GE(length, 0.19) << "the longest step is 0.19 m";
  const OdometryError e = OdometryErrorOverPath(steps, length);
  EXPECT_GE(e.windows, 5);
  for (const WindowError& w : e.per_window) EXPECT_LE(w.distance_m, 2.0 * length + 1e-9);
}

TEST(HeldoutWindows, SignTestIsTheExactBinomial) {
  OdometryError a, b;
  for (int k = 0; k < 20; ++k) {
    a.per_window.push_back({0, 0, 1.0, 0.010, 0.0});
    b.per_window.push_back({0, 0, 1.0, k < 15 ? 0.005 : 0.020, 0.0});
  }
  PairedComparison c = ComparePaired(a, b);
  EXPECT_EQ(c.windows, 20);
  EXPECT_EQ(c.second_better, 15);
  EXPECT_NEAR(c.sign_test_p, 0.041389, 1e-6);  // 2 * P(X <= 5), X ~ Binomial(20, 1/2)
  EXPECT_NEAR(c.mean_difference, (15 * -0.005 + 5 * 0.010) / 20, 1e-12);
  // Ties leave the test: 15 better, 5 equal -> 15 of 15, p = 2 / 2^15.
  for (int k = 15; k < 20; ++k) b.per_window[k].translation_m = 0.010;
  c = ComparePaired(a, b);
  EXPECT_EQ(c.ties, 5);
  EXPECT_NEAR(c.sign_test_p, 2.0 / 32768.0, 1e-12);
}

TEST(Statistics, NoncentralChiSquareTailAndItsPower) {
  // One degree of freedom: (Z + sqrt(lambda))^2, whose tail is two normal tails.
  auto phi_upper = [](double z) { return 0.5 * std::erfc(z / std::sqrt(2.0)); };
  for (double lambda : {0.0, 1.0, 9.0, 25.0, 400.0}) {
    const double c = 10.0;
    const double exact = phi_upper(std::sqrt(c) - std::sqrt(lambda)) + phi_upper(std::sqrt(c) + std::sqrt(lambda));
    EXPECT_NEAR(NoncentralChiSquareUpperTail(c, 1, lambda), exact, 1e-9) << lambda;
  }
  // Two degrees of freedom and no noncentrality: exp(-x / 2).
  EXPECT_NEAR(NoncentralChiSquareUpperTail(5.0, 2, 0.0), std::exp(-2.5), 1e-12);
  EXPECT_NEAR(ChiSquareUpperQuantile(std::exp(-2.5), 2), 5.0, 1e-8);
  EXPECT_NEAR(ChiSquareUpperQuantile(0.05, 1), 3.841459, 1e-5);
  // Power 0.8 at the level 0.01 / 9: one degree needs z(level / 2) + z(0.2) standard errors
  // (the other tail is negligible), two degrees more.
  const double level = 0.01 / 9, c1 = ChiSquareUpperQuantile(level, 1), c2 = ChiSquareUpperQuantile(level, 2);
  const double lambda1 = NoncentralityForPower(c1, 1, 0.8), lambda2 = NoncentralityForPower(c2, 2, 0.8);
  EXPECT_NEAR(NoncentralChiSquareUpperTail(c2, 2, lambda2), 0.8, 1e-8);
  EXPECT_NEAR(std::sqrt(lambda1), std::sqrt(c1) + 0.841621, 1e-4);
  EXPECT_GT(lambda2, 1.15 * lambda1);
}

// On a simulated recording whose nominal values differ from the truth, the calibrated model
// beats the nominal one on the held-out half in nearly every window, beyond chance, and the
// held-out half's larger steering angles are reported.
TEST(HeldoutWindows, CalibratedBeatsNominalOnSimulatedHeldOutHalf) {
  const SimConfig config = PoseSim("forklift", 5);
  const CalibrationData data = Record(config, "default");
  CalibrationOptions options;
  options.fit_fraction = 0.5;
  const CalibrationResult r =
      Calibrate(config.robot, data.wheels(), data.motions(), MotionSource::kPose, options, "sim");
  ASSERT_TRUE(r.heldout.has_value());
  const HeldoutComparison& h = *r.heldout;
  EXPECT_GE(h.paired.windows, 20);
  EXPECT_GE(h.paired.second_better, h.paired.windows - 2);
  EXPECT_LT(h.paired.sign_test_p, 1e-4);
  EXPECT_LT(h.calibrated.error_per_metre, 0.5 * h.nominal.error_per_metre)
      << h.nominal.error_per_metre << " -> " << h.calibrated.error_per_metre;
  EXPECT_EQ(h.coverage.regressor, "steer");
  // The default trajectory steers to ±0.7 rad in its first half and to ±1.0 rad in its second:
  // the comparison says so, and shows that a right model extrapolates well.
  EXPECT_NEAR(h.coverage.fit_high, 0.70, 0.01);
  EXPECT_NEAR(h.coverage.heldout_high, 1.00, 0.01);
  EXPECT_GT(h.coverage.heldout_outside, 0.3);
  // The same robot in both halves: their own fits agree within their sigmas.
  ASSERT_TRUE(h.halves.has_value());
  EXPECT_GT(h.halves->p, 0.01) << "d2 " << h.halves->d2 << ", largest " << h.halves->largest;
  EXPECT_EQ(h.halves->dof, 6);
}

// `second` following `first` 1 s after its end, with no motion across the joint.
CalibrationData Spliced(const RobotDescription& robot, const CalibrationData& first, const CalibrationData& second) {
  const int64_t shift = first.wheels().last_utime() + 1'000'000 - second.wheels().first_utime();
  CalibrationData spliced(robot);
  for (std::size_t i = 0; i < first.wheels().size(); ++i) spliced.AddWheels(first.wheels().sample(i));
  for (std::size_t i = 0; i < second.wheels().size(); ++i) {
    WheelSample w = second.wheels().sample(i);
    w.utime += shift;
    spliced.AddWheels(w);
  }
  for (const SensorMotion& m : first.motions()) spliced.AddMotion(m);
  for (SensorMotion m : second.motions()) {
    m.utime_start += shift;
    m.utime_end += shift;
    spliced.AddMotion(m);
  }
  return spliced;
}

// A recording whose second half comes from the robot with a 3 % longer wheelbase (another
// load, say): the halves' own fits disagree far beyond their sigmas, and say where.
TEST(HeldoutWindows, HalvesOfAChangedRobotDisagree) {
  SimConfig changed = PoseSim("forklift", 6);
  changed.true_params["wheelbase"] *= 1.03;
  const SimConfig original = PoseSim("forklift", 5);
  const CalibrationData first = Record(original, "default"), second = Record(changed, "default");
  const CalibrationData spliced = Spliced(original.robot, first, second);
  CalibrationOptions options;
  options.fit_fraction = 0.5;
  const CalibrationResult r =
      Calibrate(original.robot, spliced.wheels(), spliced.motions(), MotionSource::kPose, options, "sim");
  ASSERT_TRUE(r.heldout.has_value() && r.heldout->halves.has_value());
  const HalvesAgreement& a = *r.heldout->halves;
  EXPECT_LT(a.p, 1e-6) << "d2 " << a.d2;
  EXPECT_EQ(a.largest, "wheelbase");
  EXPECT_NEAR(a.heldout_fit.at("wheelbase").value, changed.true_params.at("wheelbase"),
              0.002 * changed.true_params.at("wheelbase"));
}

// A held-out half that drove straight only cannot determine the track: the halves are not
// compared (a value one half cannot determine differs between the halves by chance alone), and
// the result says why.
TEST(HeldoutWindows, HalvesAreNotComparedOnAValueTheHeldOutHalfCannotDetermine) {
  const SimConfig config = PoseSim("diff_robot", 7);
  const CalibrationData turning = Record(config, "default"), straight = Record(config, "straight");
  const CalibrationData spliced = Spliced(config.robot, turning, straight);
  CalibrationOptions options;
  // The fit half ends where the straight drive begins.
  options.fit_fraction = double(turning.motions().size()) / double(spliced.motions().size());
  const CalibrationResult r =
      Calibrate(config.robot, spliced.wheels(), spliced.motions(), MotionSource::kPose, options, "sim");
  ASSERT_TRUE(r.heldout.has_value());
  EXPECT_FALSE(r.heldout->halves.has_value())
      << "halves compared: p " << r.heldout->halves->p << ", largest " << r.heldout->halves->largest;
  EXPECT_NE(r.heldout->halves_not_compared.find("track"), std::string::npos) << r.heldout->halves_not_compared;
}

}  // namespace
}  // namespace calib
