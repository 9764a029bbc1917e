// Closed-form checks of the drive models of calib/core/kinematics.h: straight lines, turns in place,
// arcs against the analytic circle, reversing, Inverse/Forward round trips and arc exactness.
#include "calib/core/kinematics.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace calib {
namespace {

constexpr double kTol = 1e-9;  // m, rad: everything here is closed form

void ExpectPoseNear(const Pose2& actual, const Pose2& expected, double tol = kTol) {
  EXPECT_NEAR(actual.x, expected.x, tol);
  EXPECT_NEAR(actual.y, expected.y, tol);
  EXPECT_NEAR(WrapAngle(actual.theta - expected.theta), 0.0, tol);
}

void ExpectTwistNear(const Twist2& actual, const Twist2& expected, double tol = kTol) {
  EXPECT_NEAR(actual.vx, expected.vx, tol);
  EXPECT_NEAR(actual.vy, expected.vy, tol);
  EXPECT_NEAR(actual.omega, expected.omega, tol);
}

// End of an arc of signed radius `radius` (centre at (0, radius)) swept through `dtheta`,
// starting at the origin heading along x.
Pose2 CircleEnd(double radius, double dtheta) {
  return {radius * std::sin(dtheta), radius * (1.0 - std::cos(dtheta)), dtheta};
}

// Signed radius of the circle through the origin, tangent to x there, and through (x, y).
double RadiusThrough(const Pose2& p) { return (p.x * p.x + p.y * p.y) / (2.0 * p.y); }

// Integrate one increment as n equal slices composed, to compare with one big step.
Pose2 IntegrateInSlices(const DriveModel& model, const WheelIncrement& inc, int n) {
  WheelIncrement slice = inc;
  for (double& r : slice.rotation) r /= n;
  Pose2 pose;
  for (int i = 0; i < n; ++i) pose = Compose(pose, model.Integrate(slice));
  return pose;
}

WheelIncrement Negated(WheelIncrement inc) {
  for (double& r : inc.rotation) r = -r;
  return inc;
}

// ---------------------------------------------------------------------------------------------
// Differential: left_radius 0.1, right_radius 0.1, track 0.5.

class DifferentialTest : public ::testing::Test {
 protected:
  static constexpr double kRadius = 0.1, kTrack = 0.5;
  std::unique_ptr<DriveModel> dut_ = MakeDriveModel(
      DriveType::kDifferential, {{"left_radius", kRadius}, {"right_radius", kRadius},
                                 {"track", kTrack}});

  // Increment from contact-point travel (m) of each wheel.
  static WheelIncrement Travel(double left, double right) {
    return {{left / kRadius, right / kRadius}, {0, 0}, {0, 0}};
  }
};

TEST_F(DifferentialTest, StraightLine) {
  ExpectPoseNear(dut_->Integrate(Travel(1.0, 1.0)), {1.0, 0.0, 0.0});
}

TEST_F(DifferentialTest, TurnInPlace) {
  // Each wheel travels a quarter of the circle of diameter track about the axle middle.
  const double d = kTrack / 2.0 * M_PI_2;
  ExpectPoseNear(dut_->Integrate(Travel(-d, d)), {0.0, 0.0, M_PI_2});
  ExpectPoseNear(dut_->Integrate(Travel(d, -d)), {0.0, 0.0, -M_PI_2});
}

TEST_F(DifferentialTest, ConstantArcLiesOnAnalyticCircle) {
  const double radius = 2.0, dtheta = 1.0;  // left turn, centre on the +y side
  const WheelIncrement inc =
      Travel((radius - kTrack / 2) * dtheta, (radius + kTrack / 2) * dtheta);
  const Pose2 end = dut_->Integrate(inc);
  ExpectPoseNear(end, CircleEnd(radius, dtheta));
  EXPECT_NEAR(std::hypot(end.x, end.y), 2.0 * radius * std::sin(dtheta / 2), kTol);  // chord
  EXPECT_NEAR(RadiusThrough(end), radius, 1e-9);
}

TEST_F(DifferentialTest, ReversingRetracesTheArc) {
  ExpectPoseNear(dut_->Integrate(Travel(-1.0, -1.0)), {-1.0, 0.0, 0.0});
  const WheelIncrement arc = Travel(0.7, 0.9);
  ExpectPoseNear(dut_->Integrate(Negated(arc)), Inverse(dut_->Integrate(arc)));
}

TEST_F(DifferentialTest, UnequalRadiiCurveAtTheExpectedRadius) {
  const double left_radius = 0.1, right_radius = 0.102;
  auto model = MakeDriveModel(DriveType::kDifferential, {{"left_radius", left_radius},
                                                         {"right_radius", right_radius},
                                                         {"track", kTrack}});
  // Equal wheel rotation: the larger right wheel travels further, so the robot turns left with
  // curvature (d_r - d_l) / (track * (d_l + d_r) / 2).
  const double phi = 20.0;
  const Pose2 end = model->Integrate({{phi, phi}, {0, 0}, {0, 0}});
  const double expected_radius =
      kTrack * (left_radius + right_radius) / (2.0 * (right_radius - left_radius));  // 25.25 m
  EXPECT_NEAR(RadiusThrough(end), expected_radius, 1e-6);
  EXPECT_NEAR(end.theta, (right_radius - left_radius) * phi / kTrack, kTol);
  // Inverse divides by each wheel's own radius.
  const Twist2 t{0.5, 0.0, 0.0};
  const WheelSetpoint w = model->Inverse(t);
  EXPECT_NEAR(w.speed[0], 0.5 / left_radius, kTol);
  EXPECT_NEAR(w.speed[1], 0.5 / right_radius, kTol);
  ExpectTwistNear(model->Forward(w), t);
}

TEST_F(DifferentialTest, InverseClosedFormAndRoundTrip) {
  const WheelSetpoint w = dut_->Inverse({0.5, 0.0, 0.4});
  ASSERT_EQ(w.speed.size(), 2u);
  EXPECT_NEAR(w.speed[0], (0.5 - 0.4 * kTrack / 2) / kRadius, kTol);  // 4 rad/s
  EXPECT_NEAR(w.speed[1], (0.5 + 0.4 * kTrack / 2) / kRadius, kTol);  // 6 rad/s
  for (const Twist2& t : {Twist2{0.5, 0, 0.4}, Twist2{-0.3, 0, 0.2}, Twist2{0, 0, -1.0}}) {
    ExpectTwistNear(dut_->Forward(dut_->Inverse(t)), t);
  }
  // vy cannot be realised and is dropped.
  ExpectTwistNear(dut_->Forward(dut_->Inverse({0.5, 0.3, 0.4})), {0.5, 0.0, 0.4});
}

TEST_F(DifferentialTest, IntegrateMatchesForwardOverDt) {
  const WheelSetpoint w{{3.0, 5.0}, {0, 0}};
  const double dt = 0.8;
  ExpectPoseNear(dut_->Integrate({{3.0 * dt, 5.0 * dt}, {0, 0}, {0, 0}}),
                 ExpTwist(dut_->Forward(w), dt));
}

TEST_F(DifferentialTest, ManySmallStepsEqualOneBigStep) {
  const WheelIncrement inc = Travel(1.3, 2.9);  // a large turn: Euler steps would drift
  ExpectPoseNear(IntegrateInSlices(*dut_, inc, 100), dut_->Integrate(inc));
}

TEST_F(DifferentialTest, WrongNumberOfWheelsThrows) {
  EXPECT_THROW(dut_->Integrate({{1.0}, {}, {}}), std::invalid_argument);
  EXPECT_THROW(dut_->Forward({{1.0, 2.0, 3.0}, {}}), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Tricycle: drive_radius 0.1, wheelbase 1.2, steer_offset 0.05.

class TricycleTest : public ::testing::Test {
 protected:
  static constexpr double kRadius = 0.1, kWheelbase = 1.2, kOffset = 0.05;
  std::unique_ptr<DriveModel> dut_ = MakeDriveModel(
      DriveType::kTricycle, {{"drive_radius", kRadius}, {"wheelbase", kWheelbase},
                             {"steer_offset", kOffset}});

  // Increment from the drive wheel's travel (m) at a constant true steering angle.
  static WheelIncrement Travel(double d, double alpha) {
    return {{d / kRadius}, {alpha + kOffset}, {alpha + kOffset}};
  }
};

TEST_F(TricycleTest, StraightLineAtTheOffset) {
  ExpectPoseNear(dut_->Integrate(Travel(1.0, 0.0)), {1.0, 0.0, 0.0});
}

TEST_F(TricycleTest, RawZeroIsNotStraightWhenOffset) {
  // Raw 0 is a true angle of -offset: a slight right turn.
  const Pose2 end = dut_->Integrate({{1.0 / kRadius}, {0.0}, {0.0}});
  EXPECT_NEAR(end.theta, std::sin(-kOffset) / kWheelbase, kTol);
  EXPECT_LT(end.y, 0.0);
}

TEST_F(TricycleTest, SteeredAcrossTurnsAboutTheRearAxle) {
  const double d = kWheelbase * M_PI_2;  // quarter circle of the drive wheel
  ExpectPoseNear(dut_->Integrate(Travel(d, M_PI_2)), {0.0, 0.0, M_PI_2});
}

TEST_F(TricycleTest, ConstantArcLiesOnAnalyticCircle) {
  const double alpha = 0.3, d = 2.0;
  const double radius = kWheelbase / std::tan(alpha);  // of the rear axle middle
  const double dtheta = d * std::sin(alpha) / kWheelbase;
  const Pose2 end = dut_->Integrate(Travel(d, alpha));
  ExpectPoseNear(end, CircleEnd(radius, dtheta));
  EXPECT_NEAR(std::hypot(end.x, end.y), 2.0 * radius * std::sin(dtheta / 2), kTol);  // chord
  EXPECT_NEAR(RadiusThrough(end), radius, 1e-9);
}

TEST_F(TricycleTest, SteeringIsTheMeanOfStartAndEnd) {
  const double alpha = 0.3;
  const WheelIncrement sweep{{2.0 / kRadius}, {alpha - 0.1 + kOffset}, {alpha + 0.1 + kOffset}};
  ExpectPoseNear(dut_->Integrate(sweep), dut_->Integrate(Travel(2.0, alpha)));
}

TEST_F(TricycleTest, ReversingRetracesTheArc) {
  ExpectPoseNear(dut_->Integrate(Travel(-1.0, 0.0)), {-1.0, 0.0, 0.0});
  const WheelIncrement arc = Travel(1.5, -0.4);
  ExpectPoseNear(dut_->Integrate(Negated(arc)), Inverse(dut_->Integrate(arc)));
}

TEST_F(TricycleTest, InverseSteersWithinAQuarterTurnAndAddsTheOffset) {
  // Pure rotation: wheel across, speed omega * wheelbase.
  WheelSetpoint w = dut_->Inverse({0.0, 0.0, 0.5});
  EXPECT_NEAR(w.steer[0], M_PI_2 + kOffset, kTol);
  EXPECT_NEAR(w.speed[0], 0.5 * kWheelbase / kRadius, kTol);
  w = dut_->Inverse({0.0, 0.0, -0.5});
  EXPECT_NEAR(w.steer[0], -M_PI_2 + kOffset, kTol);
  EXPECT_NEAR(w.speed[0], 0.5 * kWheelbase / kRadius, kTol);
  // Reversing while turning left: wheel points forward-right and drives backwards.
  w = dut_->Inverse({-0.5, 0.0, 0.2});
  EXPECT_NEAR(w.steer[0], std::atan(0.2 * kWheelbase / -0.5) + kOffset, kTol);
  EXPECT_NEAR(w.speed[0], -std::hypot(0.5, 0.2 * kWheelbase) / kRadius, kTol);
  // Straight reverse: no swing round, negative speed.
  w = dut_->Inverse({-0.5, 0.0, 0.0});
  EXPECT_NEAR(w.steer[0], kOffset, kTol);
  EXPECT_NEAR(w.speed[0], -0.5 / kRadius, kTol);
  // Standing still keeps the wheel straight.
  w = dut_->Inverse({});
  EXPECT_NEAR(w.steer[0], kOffset, kTol);
  EXPECT_EQ(w.speed[0], 0.0);
}

TEST_F(TricycleTest, InverseForwardRoundTrip) {
  for (const Twist2& t : {Twist2{0.5, 0, 0.2}, Twist2{-0.5, 0, 0.2}, Twist2{-0.3, 0, -0.4},
                          Twist2{0, 0, 0.7}, Twist2{0.2, 0, 0}}) {
    ExpectTwistNear(dut_->Forward(dut_->Inverse(t)), t);
  }
  ExpectTwistNear(dut_->Forward(dut_->Inverse({0.5, 0.3, 0.2})), {0.5, 0.0, 0.2});
}

TEST_F(TricycleTest, IntegrateMatchesForwardOverDt) {
  const double speed = 4.0, steer = 0.6, dt = 0.5;
  ExpectPoseNear(dut_->Integrate({{speed * dt}, {steer}, {steer}}),
                 ExpTwist(dut_->Forward({{speed}, {steer}}), dt));
}

TEST_F(TricycleTest, ManySmallStepsEqualOneBigStep) {
  const WheelIncrement inc = Travel(3.0, 0.7);
  ExpectPoseNear(IntegrateInSlices(*dut_, inc, 100), dut_->Integrate(inc));
}

// ---------------------------------------------------------------------------------------------
// Dual steer: a1_radius 0.1, a1_steer_offset 0.1, b 1.5, a2_radius 0.12, a 0.6.

class DualSteerTest : public ::testing::Test {
 protected:
  static constexpr double kR1 = 0.1, kOffset1 = 0.1, kB = 1.5, kR2 = 0.12, kA = 0.6;
  std::unique_ptr<DriveModel> dut_ = MakeDriveModel(
      DriveType::kDualSteer,
      {{"a1_radius", kR1}, {"a1_steer_offset", kOffset1}, {"b", kB}, {"a2_radius", kR2},
       {"a", kA}});

  // Increment from each wheel's travel (m) at constant true steering angles.
  static WheelIncrement Travel(double d1, double alpha1, double d2, double alpha2) {
    return {{d1 / kR1, d2 / kR2}, {alpha1 + kOffset1, alpha2}, {alpha1 + kOffset1, alpha2}};
  }
};

TEST_F(DualSteerTest, StraightLine) {
  ExpectPoseNear(dut_->Integrate(Travel(1.0, 0.0, 1.0, 0.0)), {1.0, 0.0, 0.0});
}

TEST_F(DualSteerTest, Sideways) {
  ExpectPoseNear(dut_->Integrate(Travel(1.0, M_PI_2, 1.0, M_PI_2)), {0.0, 1.0, 0.0});
  ExpectPoseNear(dut_->Integrate(Travel(1.0, -M_PI_2, 1.0, -M_PI_2)), {0.0, -1.0, 0.0});
}

TEST_F(DualSteerTest, TurnInPlaceAboutW) {
  // a1 at (b, 0) moves along +y, a2 at (0, -a) along +x, each a quarter of its circle about W.
  ExpectPoseNear(dut_->Integrate(Travel(kB * M_PI_2, M_PI_2, kA * M_PI_2, 0.0)),
                 {0.0, 0.0, M_PI_2});
}

TEST_F(DualSteerTest, InverseOfARotationMatchesTheSeedGeometry) {
  // a1 at (b, 0): across, speed omega * b; a2 at (0, -a): straight ahead, speed omega * a.
  const WheelSetpoint w = dut_->Inverse({0.0, 0.0, 0.4});
  ASSERT_EQ(w.speed.size(), 2u);
  EXPECT_NEAR(w.steer[0], M_PI_2 + kOffset1, kTol);
  EXPECT_NEAR(w.speed[0], 0.4 * kB / kR1, kTol);
  EXPECT_NEAR(w.steer[1], 0.0, kTol);
  EXPECT_NEAR(w.speed[1], 0.4 * kA / kR2, kTol);
}

TEST_F(DualSteerTest, A2HeldStraightIsATricycleAboutW) {
  const double alpha1 = 0.4, d1 = 1.8;
  const double omega = d1 * std::sin(alpha1) / kB, vx = d1 * std::cos(alpha1);
  const double d2 = vx + omega * kA;  // what a2 at (0, -a) travels on that arc
  const Pose2 end = dut_->Integrate(Travel(d1, alpha1, d2, 0.0));
  const double radius = kB / std::tan(alpha1);
  ExpectPoseNear(end, CircleEnd(radius, omega));
  EXPECT_NEAR(std::hypot(end.x, end.y), 2.0 * radius * std::sin(omega / 2), kTol);  // chord
  // Same as a tricycle whose drive wheel is a1 and whose rear axle passes through W.
  auto tricycle = MakeDriveModel(DriveType::kTricycle, {{"drive_radius", kR1},
                                                        {"wheelbase", kB},
                                                        {"steer_offset", kOffset1}});
  ExpectPoseNear(end, tricycle->Integrate({{d1 / kR1}, {alpha1 + kOffset1}, {alpha1 + kOffset1}}));
  // Continuous time: omega = s1 sin(alpha1) / b.
  const double s1 = 0.7;
  const Twist2 twist = dut_->Forward(
      {{s1 / kR1, (s1 * std::cos(alpha1) + s1 * std::sin(alpha1) / kB * kA) / kR2},
       {alpha1 + kOffset1, 0.0}});
  ExpectTwistNear(twist, {s1 * std::cos(alpha1), 0.0, s1 * std::sin(alpha1) / kB});
}

TEST_F(DualSteerTest, ReversingRetracesTheArc) {
  ExpectPoseNear(dut_->Integrate(Travel(-1.0, 0.0, -1.0, 0.0)), {-1.0, 0.0, 0.0});
  const WheelSetpoint w = dut_->Inverse({0.3, -0.1, 0.25});
  const WheelIncrement arc{w.speed, w.steer, w.steer};  // one second of that twist
  ExpectPoseNear(dut_->Integrate(Negated(arc)), Inverse(dut_->Integrate(arc)));
}

TEST_F(DualSteerTest, InverseForwardRoundTripWithinAQuarterTurn) {
  for (const Twist2& t : {Twist2{0.5, 0.0, 0.0}, Twist2{-0.5, 0.0, 0.0}, Twist2{0.0, 0.4, 0.0},
                          Twist2{0.3, -0.2, 0.25}, Twist2{-0.4, 0.1, -0.3},
                          Twist2{0.0, 0.0, -0.6}}) {
    const WheelSetpoint w = dut_->Inverse(t);
    EXPECT_LE(std::abs(w.steer[0] - kOffset1), M_PI_2 + kTol);
    EXPECT_LE(std::abs(w.steer[1]), M_PI_2 + kTol);
    ExpectTwistNear(dut_->Forward(w), t);
  }
  // Straight reverse drives backwards rather than swinging both wheels round.
  const WheelSetpoint w = dut_->Inverse({-0.5, 0.0, 0.0});
  EXPECT_NEAR(w.steer[0], kOffset1, kTol);
  EXPECT_NEAR(w.steer[1], 0.0, kTol);
  EXPECT_LT(w.speed[0], 0.0);
  EXPECT_LT(w.speed[1], 0.0);
}

TEST_F(DualSteerTest, WheelAtTheCentreOfRotationKeepsItsZero) {
  // Rotation about a1's contact point: v_W = (0, -omega * b).
  const double omega = 0.5;
  const WheelSetpoint w = dut_->Inverse({0.0, -omega * kB, omega});
  EXPECT_EQ(w.speed[0], 0.0);
  EXPECT_NEAR(w.steer[0], kOffset1, kTol);
  ExpectTwistNear(dut_->Forward(w), {0.0, -omega * kB, omega});
}

TEST_F(DualSteerTest, RoundingNoiseDoesNotSwingAWheel) {
  // A contact-point velocity of ~1e-15 m/s has no meaningful direction.
  const WheelSetpoint w = dut_->Inverse({-1e-15, 1e-15, 0.0});
  EXPECT_NEAR(w.steer[0], kOffset1, kTol);
  EXPECT_NEAR(w.steer[1], 0.0, kTol);
}

TEST_F(DualSteerTest, IntegrateMatchesForwardOverDt) {
  const WheelSetpoint w = dut_->Inverse({0.4, 0.1, -0.3});
  const double dt = 0.7;
  ExpectPoseNear(dut_->Integrate({{w.speed[0] * dt, w.speed[1] * dt}, w.steer, w.steer}),
                 ExpTwist(dut_->Forward(w), dt));
}

TEST_F(DualSteerTest, ManySmallStepsEqualOneBigStep) {
  const WheelSetpoint w = dut_->Inverse({0.4, 0.3, 0.9});
  const WheelIncrement inc{{w.speed[0] * 2.0, w.speed[1] * 2.0}, w.steer, w.steer};
  ExpectPoseNear(IntegrateInSlices(*dut_, inc, 100), dut_->Integrate(inc));
}

TEST(DualSteerGeometry, CoincidentWheelsThrow) {
  EXPECT_THROW(MakeDriveModel(DriveType::kDualSteer, {{"a1_radius", 0.1},
                                                      {"a1_steer_offset", 0.0},
                                                      {"b", 0.0},
                                                      {"a2_radius", 0.1},
                                                      {"a", 0.0}}),
               std::invalid_argument);
}

TEST(DualSteerGeometry, SignedPlacement) {
  // a negative: a2 at (0, +0.6), to the left of W. A pure rotation then drives it backwards.
  auto model = MakeDriveModel(DriveType::kDualSteer, {{"a1_radius", 0.1},
                                                      {"a1_steer_offset", 0.0},
                                                      {"b", 1.5},
                                                      {"a2_radius", 0.1},
                                                      {"a", -0.6}});
  const WheelSetpoint w = model->Inverse({0.0, 0.0, 0.5});
  EXPECT_NEAR(w.speed[1], -0.5 * 0.6 / 0.1, kTol);
  EXPECT_NEAR(w.steer[1], 0.0, kTol);
}

// ---------------------------------------------------------------------------------------------
// Construction.

TEST(MakeDriveModel, MissingParameterIsNamed) {
  try {
    MakeDriveModel(DriveType::kTricycle, {{"drive_radius", 0.1}, {"steer_offset", 0.0}});
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("wheelbase"), std::string::npos) << e.what();
  }
}

TEST(MakeDriveModel, RejectsUnusableValues) {
  EXPECT_THROW(MakeDriveModel(DriveType::kDifferential,
                              {{"left_radius", 0.1}, {"right_radius", 0.0}, {"track", 0.5}}),
               std::invalid_argument);
  EXPECT_THROW(MakeDriveModel(DriveType::kTricycle,
                              {{"drive_radius", 0.1}, {"wheelbase", 0.0}, {"steer_offset", 0.0}}),
               std::invalid_argument);
}

TEST(MakeDriveModel, FromRobotDescription) {
  RobotDescription robot;
  robot.drive = DriveType::kDualSteer;
  robot.params = {{"a1_radius", 0.1}, {"a1_steer_offset", 0.02}, {"b", 1.5},
                  {"a2_radius", 0.12}, {"a", 0.6}};
  const auto model = MakeDriveModel(robot);
  EXPECT_EQ(model->type(), DriveType::kDualSteer);
  EXPECT_EQ(model->roles(), (std::vector<std::string>{"a1", "a2"}));
  EXPECT_EQ(model->params(), (std::vector<double>{0.1, 0.02, 1.5, 0.12, 0.6}));  // ParamNames order
}

// LogTwist undoes ExpTwist: straight, nearly straight (series branch), arcs,
// sideways, and a turn of almost half a revolution.
TEST(Se2Test, LogTwistInvertsExpTwist) {
  for (const Twist2& twist : {Twist2{0.8, 0.0, 0.0}, Twist2{0.5, 0.1, 1e-8}, Twist2{0.6, 0.0, 0.9},
                              Twist2{-0.3, 0.2, -1.1}, Twist2{0.0, 0.4, 0.0},
                              Twist2{0.2, 0.0, 3.0}}) {
    for (double dt : {0.001, 0.05, 1.0}) ExpectTwistNear(LogTwist(ExpTwist(twist, dt), dt), twist);
  }
}

}  // namespace
}  // namespace calib
