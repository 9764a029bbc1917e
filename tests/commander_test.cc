// The trajectory commander: every trajectory of every drive type stays within
// the robot's limits, finishes with stop commands, keeps the robot near its
// start, and covers the motions that make the parameters observable.
#include "calib/live/commander.h"
#include "calib/live/commander_safety.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "calib/core/errors.h"
#include "calib/core/kinematics.h"
#include "calib/core/robot.h"
#include "calib/core/se2.h"

namespace calib {
namespace {

constexpr double kEps = 1e-9;
constexpr int64_t kStart = 1700000000000000;
constexpr int64_t kStepUs = 20000;  // 50 Hz

std::string RobotPath(const std::string& file) {
  return std::string(AGVCAL_SOURCE_DIR) + "/config/robots/" + file;
}

// Robots of every drive type: the bundled files and variants with steering
// offsets, other geometry and tighter limits.
std::vector<RobotDescription> Robots() {
  std::vector<RobotDescription> robots;
  for (const char* f : {"diff_robot.yaml", "forklift.yaml", "dual_steer_agv.yaml"})
    robots.push_back(LoadRobotFile(RobotPath(f)));

  RobotDescription diff;
  diff.name = "diff-variant";
  diff.drive = DriveType::kDifferential;
  diff.wheels = {{"left", "l"}, {"right", "r"}};
  diff.params = {{"left_radius", 0.1}, {"right_radius", 0.102}, {"track", 0.6}};
  diff.limits = {0.4, 0.5, 0.3, 1.3, 1.0};
  robots.push_back(diff);

  RobotDescription tri;
  tri.name = "tricycle-variant";
  tri.drive = DriveType::kTricycle;
  tri.wheels = {{"drive", "d"}};
  tri.params = {{"drive_radius", 0.15}, {"wheelbase", 1.1}, {"steer_offset", 0.05}};
  tri.limits = {0.8, 0.4, 0.4, 0.8, 0.5};
  robots.push_back(tri);

  RobotDescription dual;
  dual.name = "dual-steer-variant";
  dual.drive = DriveType::kDualSteer;
  dual.wheels = {{"a1", "fl"}, {"a2", "rr"}};
  dual.params = {{"a1_radius", 0.12}, {"a1_steer_offset", -0.04}, {"b", -1.0},
                 {"a2_radius", 0.11}, {"a", -0.5}};
  dual.limits = {0.6, 0.5, 0.4, 1.1, 0.8};
  robots.push_back(dual);
  return robots;
}

std::vector<double> Offsets(const RobotDescription& r) {
  switch (r.drive) {
    case DriveType::kDifferential: return {0.0, 0.0};
    case DriveType::kTricycle: return {r.param("steer_offset")};
    case DriveType::kDualSteer: return {r.param("a1_steer_offset"), 0.0};
  }
  return {};
}

std::vector<double> Radii(const RobotDescription& r) {
  switch (r.drive) {
    case DriveType::kDifferential: return {r.param("left_radius"), r.param("right_radius")};
    case DriveType::kTricycle: return {r.param("drive_radius")};
    case DriveType::kDualSteer: return {r.param("a1_radius"), r.param("a2_radius")};
  }
  return {};
}

struct CommandRun {
  std::vector<DriveCommand> commands;
  std::vector<CommanderStatus> statuses;
};

// Steps the commander at 50 Hz until it has finished, plus `extra_s`.
CommandRun StepThrough(Commander* commander, double extra_s = 1.0) {
  CommandRun run;
  const int64_t end = kStart + static_cast<int64_t>((commander->nominal_duration_s() + extra_s) * 1e6);
  for (int64_t t = kStart; t <= end; t += kStepUs) {
    run.commands.push_back(commander->Step(t));
    run.statuses.push_back(commander->status());
  }
  return run;
}

// Body twist at the reference point that a command asks for (nominal model).
Twist2 CommandTwist(const DriveModel& model, const DriveCommand& c) {
  if (c.mode == DriveMode::kTwist) return c.twist;
  if (c.mode == DriveMode::kWheels) return model.Forward(c.wheels);
  return {};
}

// Signed contact-point speeds of the wheels, m/s.
std::vector<double> ContactSpeeds(const RobotDescription& robot, const DriveModel& model,
                                  const DriveCommand& c) {
  std::vector<double> radii = Radii(robot), speeds(radii.size(), 0.0);
  if (c.mode == DriveMode::kStop) return speeds;
  const WheelSetpoint w = c.mode == DriveMode::kTwist ? model.Inverse(c.twist) : c.wheels;
  for (size_t i = 0; i < radii.size(); ++i) speeds[i] = w.speed[i] * radii[i];
  return speeds;
}

// Checks every command of a run against the robot's limits.
void CheckLimits(const RobotDescription& robot, const CommandRun& run, double timeout_s) {
  const auto model = MakeDriveModel(robot);
  const Limits& lim = robot.limits;
  const std::vector<double> offsets = Offsets(robot);
  const bool steered = robot.drive != DriveType::kDifferential;
  const double dt = kStepUs * 1e-6;
  Twist2 prev_twist;
  std::vector<double> prev_contact(offsets.size(), 0.0);
  std::vector<double> prev_steer;
  for (size_t k = 0; k < run.commands.size(); ++k) {
    const DriveCommand& c = run.commands[k];
    SCOPED_TRACE("command " + std::to_string(k) + " (" + run.statuses[k].segment_description + ")");
    ASSERT_EQ(c.timeout_s, timeout_s);
    ASSERT_GT(c.timeout_s, 0.0);
    if (c.mode != DriveMode::kStop) {
      ASSERT_EQ(c.mode, steered ? DriveMode::kWheels : DriveMode::kTwist);
    }
    const Twist2 tw = CommandTwist(*model, c);
    ASSERT_LE(std::hypot(tw.vx, tw.vy), lim.max_speed + kEps);
    ASSERT_LE(std::abs(tw.omega), lim.max_omega + kEps);
    const std::vector<double> contact = ContactSpeeds(robot, *model, c);
    for (size_t i = 0; i < contact.size(); ++i) {
      ASSERT_LE(std::abs(contact[i]), lim.max_speed + kEps) << "wheel " << i;
      ASSERT_LE(std::abs(contact[i] - prev_contact[i]) / dt, lim.max_accel + 1e-6) << "wheel " << i;
    }
    // Acceleration of the reference point (velocity vector in the body frame).
    ASSERT_LE(std::hypot(tw.vx - prev_twist.vx, tw.vy - prev_twist.vy) / dt, lim.max_accel + 1e-6);
    if (steered && c.mode == DriveMode::kWheels) {
      ASSERT_EQ(c.wheels.steer.size(), offsets.size());
      for (size_t i = 0; i < offsets.size(); ++i) {
        ASSERT_LE(std::abs(c.wheels.steer[i] - offsets[i]), lim.max_steer + kEps) << "wheel " << i;
        if (!prev_steer.empty()) {
          ASSERT_LE(std::abs(c.wheels.steer[i] - prev_steer[i]) / dt, lim.max_steer_rate + 1e-6)
              << "wheel " << i;
        }
      }
      prev_steer = c.wheels.steer;
    }
    prev_twist = tw;
    prev_contact = contact;
  }
}

// Integrates the commanded motion with the nominal model; returns the largest distance from
// the start and the final pose.
double MaxExcursion(const RobotDescription& robot, const CommandRun& run, Pose2* final_pose = nullptr) {
  const auto model = MakeDriveModel(robot);
  Pose2 pose;
  double largest = 0.0;
  for (const DriveCommand& c : run.commands) {
    pose = Compose(pose, ExpTwist(CommandTwist(*model, c), kStepUs * 1e-6));
    largest = std::max(largest, std::hypot(pose.x, pose.y));
  }
  if (final_pose) *final_pose = pose;
  return largest;
}

// Two commands are the same setpoint, bit for bit (time aside).
void ExpectSameCommand(const DriveCommand& x, const DriveCommand& y) {
  EXPECT_EQ(x.mode, y.mode);
  EXPECT_EQ(x.twist.vx, y.twist.vx);
  EXPECT_EQ(x.twist.vy, y.twist.vy);
  EXPECT_EQ(x.twist.omega, y.twist.omega);
  EXPECT_EQ(x.wheels.speed, y.wheels.speed);
  EXPECT_EQ(x.wheels.steer, y.wheels.steer);
}

TEST(CommanderTest, EveryTrajectoryRespectsLimitsAndFinishes) {
  for (const RobotDescription& robot : Robots()) {
    for (const std::string& name : TrajectoryNames(robot.drive)) {
      SCOPED_TRACE(robot.name + " / " + name);
      CommanderOptions options;
      options.command_timeout_s = 0.4;
      Commander commander(robot, MakeTrajectory(robot, name), options);
      ASSERT_FALSE(commander.trajectory().segments.empty());
      const CommandRun run = StepThrough(&commander);
      CheckLimits(robot, run, 0.4);
      // Ends with stop commands and the finished state.
      ASSERT_EQ(commander.status().state, CommanderState::kFinished);
      for (size_t k = run.commands.size() - 10; k < run.commands.size(); ++k)
        EXPECT_EQ(run.commands[k].mode, DriveMode::kStop);
      // Finished after, not before, the nominal duration (open loop, time driven).
      size_t first_stop = 0;
      while (run.commands[first_stop].mode != DriveMode::kStop) ++first_stop;
      EXPECT_NEAR(first_stop * kStepUs * 1e-6, commander.nominal_duration_s(), 0.021);
      // Starts at rest, moves, stays near the start.
      EXPECT_EQ(run.statuses.front().state, CommanderState::kRunning);
      const double excursion = MaxExcursion(robot, run);
      EXPECT_LE(excursion, 7.0);
      std::printf("[ info     ] %-20s %-14s %3zu segments %6.1f s, within %.1f m of the start\n",
                  robot.name.c_str(), name.c_str(), commander.trajectory().segments.size(),
                  commander.nominal_duration_s(), excursion);
    }
  }
}

TEST(CommanderTest, DurationsFitTheirPurpose) {
  // At the bundled robots' limits: about 3-5 min for the default, 20-30 s for the demo.
  for (const char* file : {"diff_robot.yaml", "forklift.yaml", "dual_steer_agv.yaml"}) {
    const RobotDescription robot = LoadRobotFile(RobotPath(file));
    SCOPED_TRACE(robot.name);
    const double full = Commander(robot, MakeTrajectory(robot, "default")).nominal_duration_s();
    EXPECT_GE(full, 170.0);
    EXPECT_LE(full, 310.0);
    const double demo = Commander(robot, MakeTrajectory(robot, "demo")).nominal_duration_s();
    EXPECT_GE(demo, 18.0);
    EXPECT_LE(demo, 32.0);
  }
}

TEST(CommanderTest, TrajectoriesReturnNearTheStart) {
  // Every motion is undone (forward then back, or a closed figure), so the nominal robot ends
  // where it began.
  for (const RobotDescription& robot : Robots()) {
    for (const std::string& name : TrajectoryNames(robot.drive)) {
      SCOPED_TRACE(robot.name + " / " + name);
      Commander commander(robot, MakeTrajectory(robot, name));
      Pose2 end;
      MaxExcursion(robot, StepThrough(&commander), &end);
      EXPECT_LT(std::hypot(end.x, end.y), 0.15);
    }
  }
}

TEST(CommanderTest, StraightOnlyDrivesStraight) {
  for (const RobotDescription& robot : Robots()) {
    SCOPED_TRACE(robot.name);
    Commander commander(robot, MakeTrajectory(robot, "straight"));
    const auto model = MakeDriveModel(robot);
    const CommandRun run = StepThrough(&commander);
    bool moved = false;
    for (const DriveCommand& c : run.commands) {
      const Twist2 tw = CommandTwist(*model, c);
      EXPECT_NEAR(tw.omega, 0.0, 1e-9);
      EXPECT_NEAR(tw.vy, 0.0, 1e-9);
      moved = moved || std::abs(tw.vx) > 0.1;
    }
    EXPECT_TRUE(moved);
  }
}

TEST(CommanderTest, TricycleDefaultCoversSteeringAnglesBothWays) {
  for (const RobotDescription& robot : Robots()) {
    if (robot.drive != DriveType::kTricycle) continue;
    SCOPED_TRACE(robot.name);
    Commander commander(robot, MakeTrajectory(robot, "default"));
    const CommandRun run = StepThrough(&commander);
    const double offset = robot.param("steer_offset");
    // (rounded true angle in centi-radians, direction of travel) while driving.
    std::set<std::pair<int, int>> seen;
    for (const DriveCommand& c : run.commands) {
      if (c.mode != DriveMode::kWheels || std::abs(c.wheels.speed[0]) < 0.1) continue;
      const int angle = static_cast<int>(std::lround((c.wheels.steer[0] - offset) * 100.0));
      seen.insert({angle, c.wheels.speed[0] > 0 ? 1 : -1});
    }
    std::set<int> positive, negative;
    for (const auto& [angle, dir] : seen) {
      if (angle != 0 && seen.count({angle, -dir})) (angle > 0 ? positive : negative).insert(angle);
    }
    EXPECT_GE(positive.size(), 4u);
    EXPECT_GE(negative.size(), 4u);
    EXPECT_TRUE(seen.count({0, 1}) && seen.count({0, -1})) << "straight runs both ways";
  }
}

TEST(CommanderTest, DualSteerDefaultHasThreeSegmentRun) {
  for (const RobotDescription& robot : Robots()) {
    if (robot.drive != DriveType::kDualSteer) continue;
    SCOPED_TRACE(robot.name);
    Commander commander(robot, MakeTrajectory(robot, "default"));
    const CommandRun run = StepThrough(&commander);
    const double offset = robot.param("a1_steer_offset");
    // The sequence of distinct a1 angles driven while a2 is at zero (raw = true for a2).
    std::vector<int> driven;
    bool found = false;
    for (const DriveCommand& c : run.commands) {
      if (c.mode != DriveMode::kWheels || std::abs(c.wheels.speed[0]) < 0.1) continue;
      if (std::abs(c.wheels.steer[1]) > 1e-12) {
        driven.clear();
        continue;
      }
      const int a1 = static_cast<int>(std::lround((c.wheels.steer[0] - offset) * 100.0));
      if (driven.empty() || driven.back() != a1) driven.push_back(a1);
      const size_t n = driven.size();
      if (n >= 3 && driven[n - 2] == 0 && driven[n - 3] >= 10 && driven[n - 1] == -driven[n - 3])
        found = true;
      if (n >= 3 && driven[n - 2] == 0 && driven[n - 3] <= -10 && driven[n - 1] == -driven[n - 3])
        found = true;
    }
    EXPECT_TRUE(found);
    // Both wheels steered at some point too.
    bool both = false;
    for (const DriveCommand& c : run.commands) {
      both = both || (c.mode == DriveMode::kWheels && std::abs(c.wheels.speed[0]) > 0.1 &&
                      std::abs(c.wheels.steer[1]) > 0.1);
    }
    EXPECT_TRUE(both);
  }
}

TEST(CommanderTest, DifferentialDefaultHasSquaresTurnsAndFigureEights) {
  const RobotDescription robot = LoadRobotFile(RobotPath("diff_robot.yaml"));
  const Trajectory t = MakeTrajectory(robot, "default");
  int ccw = 0, cw = 0, turns_left = 0, turns_right = 0, loops = 0;
  for (const auto& s : t.segments) {
    if (s.description.find("umbmark CCW") == 0 && s.angle > 0) ++ccw;
    if (s.description.find("umbmark CW") == 0 && s.angle > 0) ++cw;
    if (s.description.find("turn in place") == 0) (s.omega > 0 ? turns_left : turns_right)++;
    if (s.description.find("figure-eight") == 0) ++loops;
  }
  EXPECT_EQ(ccw, 4);
  EXPECT_EQ(cw, 4);
  EXPECT_GE(turns_left, 2);
  EXPECT_GE(turns_right, 2);
  EXPECT_GE(loops, 4);
}

TEST(CommanderTest, Deterministic) {
  for (const RobotDescription& robot : Robots()) {
    SCOPED_TRACE(robot.name);
    Commander a(robot, MakeTrajectory(robot, "default"));
    Commander b(robot, MakeTrajectory(robot, "default"));
    const CommandRun ra = StepThrough(&a), rb = StepThrough(&b);
    ASSERT_EQ(ra.commands.size(), rb.commands.size());
    for (size_t k = 0; k < ra.commands.size(); ++k) {
      ASSERT_EQ(ra.commands[k].utime, rb.commands[k].utime);
      ExpectSameCommand(ra.commands[k], rb.commands[k]);
      if (HasFailure()) return;
    }
  }
}

TEST(CommanderTest, PureFunctionOfTime) {
  // Stepping at 20 Hz or at 50 Hz gives the same command at the same time.
  for (const RobotDescription& robot : Robots()) {
    SCOPED_TRACE(robot.name);
    Commander fast(robot, MakeTrajectory(robot, "demo"));
    Commander slow(robot, MakeTrajectory(robot, "demo"));
    for (int64_t t = kStart; t < kStart + 40000000; t += 10000) {
      const DriveCommand f = fast.Step(t);
      if ((t - kStart) % 50000 != 0) continue;
      ExpectSameCommand(f, slow.Step(t));
      if (HasFailure()) return;
    }
  }
}

TEST(CommanderTest, ResumesFromRestAfterInterruption) {
  // Inputs go stale in the middle of each of several segments: the robot is stopped, then
  // the commander resumes with fresh ramps, and still completes the same motion.
  for (const RobotDescription& robot : Robots()) {
    SCOPED_TRACE(robot.name);
    Commander reference(robot, MakeTrajectory(robot, "demo"));
    Pose2 expected;
    MaxExcursion(robot, StepThrough(&reference), &expected);

    Commander commander(robot, MakeTrajectory(robot, "demo"));
    CommandRun run;  // what the robot executed: the commands, and stops while interrupted
    const double total = commander.nominal_duration_s();
    std::vector<int64_t> interrupts;
    for (double f : {0.12, 0.31, 0.47, 0.66, 0.83})
      interrupts.push_back(kStart + static_cast<int64_t>(f * total * 1e6) / kStepUs * kStepUs);
    size_t next = 0;
    for (int64_t t = kStart; commander.status().state != CommanderState::kFinished ||
                             run.commands.back().mode != DriveMode::kStop;
         t += kStepUs) {
      ASSERT_LT(t, kStart + static_cast<int64_t>((total + 60.0) * 1e6));
      if (next < interrupts.size() && t >= interrupts[next]) {
        commander.Interrupt(t - kStepUs);  // last command the robot got was at t - step
        // The robot brakes instantly (worst case for the restart) and waits 1.5 s.
        for (int k = 0; k < 75; ++k, t += kStepUs) {
          DriveCommand stop;
          stop.mode = DriveMode::kStop;
          stop.timeout_s = 0.5;
          run.commands.push_back(stop);
          run.statuses.push_back(commander.status());
        }
        ++next;
      }
      run.commands.push_back(commander.Step(t));
      run.statuses.push_back(commander.status());
    }
    // The instant brake is the robot's, not the commander's: check limits from each restart.
    const auto model = MakeDriveModel(robot);
    const double dt = kStepUs * 1e-6;
    Twist2 prev;
    std::vector<double> prev_steer;
    for (size_t k = 0; k < run.commands.size(); ++k) {
      const DriveCommand& c = run.commands[k];
      const Twist2 tw = CommandTwist(*model, c);
      if (k > 0 && run.commands[k - 1].mode == DriveMode::kStop && c.mode != DriveMode::kStop) {
        EXPECT_LE(std::hypot(tw.vx, tw.vy) / dt, robot.limits.max_accel + 1e-6) << k;
      } else if (c.mode != DriveMode::kStop) {
        EXPECT_LE(std::hypot(tw.vx - prev.vx, tw.vy - prev.vy) / dt, robot.limits.max_accel + 1e-6)
            << k;
      }
      if (c.mode == DriveMode::kWheels) {
        if (!prev_steer.empty()) {
          for (size_t i = 0; i < prev_steer.size(); ++i)
            EXPECT_LE(std::abs(c.wheels.steer[i] - prev_steer[i]) / dt,
                      robot.limits.max_steer_rate + 1e-6);
        }
        prev_steer = c.wheels.steer;
      }
      prev = tw;
    }
    Pose2 end;
    MaxExcursion(robot, run, &end);
    EXPECT_NEAR(end.x, expected.x, 0.05);
    EXPECT_NEAR(end.y, expected.y, 0.05);
    EXPECT_NEAR(WrapAngle(end.theta - expected.theta), 0.0, 0.05);
  }
}

TEST(CommanderTest, StatusFollowsSegments) {
  const RobotDescription robot = LoadRobotFile(RobotPath("forklift.yaml"));
  Commander commander(robot, MakeTrajectory(robot, "demo"));
  const CommandRun run = StepThrough(&commander);
  EXPECT_EQ(run.statuses.front().segment, 0);
  EXPECT_EQ(run.statuses.front().num_segments,
            static_cast<int>(commander.trajectory().segments.size()));
  int last = 0;
  for (const auto& s : run.statuses) {
    EXPECT_GE(s.segment, last);
    last = s.segment;
    EXPECT_FALSE(s.segment_description.empty());
  }
  EXPECT_EQ(last, run.statuses.front().num_segments - 1);
}

TEST(CommanderTest, UnknownTrajectoryIsAnInputError) {
  const RobotDescription robot = LoadRobotFile(RobotPath("forklift.yaml"));
  EXPECT_THROW(MakeTrajectory(robot, "umbmark"), InputError);  // differential only
  try {
    MakeTrajectory(robot, "zigzag");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("zigzag"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("default"), std::string::npos) << e.what();
  }
}

TEST(CommanderTest, RejectsSteeringBeyondTheLimit) {
  const RobotDescription robot = LoadRobotFile(RobotPath("forklift.yaml"));
  Trajectory t;
  t.name = "custom";
  TrajectorySegment s;
  s.description = "too far";
  s.speed = 0.3;
  s.steer = {robot.limits.max_steer + 0.1};
  s.distance = 1.0;
  t.segments.push_back(s);
  EXPECT_THROW(Commander(robot, t), InputError);
}

TEST(CommanderTest, CopiesAreIndependent) {
  const RobotDescription robot = LoadRobotFile(RobotPath("diff_robot.yaml"));
  Commander a(robot, MakeTrajectory(robot, "demo"));
  for (int64_t t = kStart; t < kStart + 5000000; t += kStepUs) a.Step(t);
  Commander b = a;
  const DriveCommand ca = a.Step(kStart + 6000000);
  const DriveCommand cb = b.Step(kStart + 6000000);
  EXPECT_EQ(ca.twist.vx, cb.twist.vx);
  a.Step(kStart + 9000000);
  EXPECT_EQ(b.Step(kStart + 6020000).utime, kStart + 6020000);
}

}  // namespace
}  // namespace calib

namespace calib {
namespace {

constexpr int64_t kWall = 1000000000;  // an arbitrary wall-clock origin, us

CommanderSafety WatchedSafety() {
  CommanderSafety s;
  s.Watch("WHEELS", 0.5);
  s.Watch("SCAN", 0.5);
  s.Watch("own HEARTBEAT", 3.0);
  return s;
}

TEST(CommanderSafetyTest, HoldsUntilEveryInputHasArrived) {
  CommanderSafety s = WatchedSafety();
  EXPECT_EQ(s.HoldReason(kWall).value_or(""), "waiting for SCAN");  // the first missing, by name
  s.Seen("own HEARTBEAT", kWall);
  s.Seen("WHEELS", kWall);
  EXPECT_EQ(s.HoldReason(kWall).value_or(""), "waiting for SCAN");
  s.Seen("SCAN", kWall);
  EXPECT_FALSE(s.HoldReason(kWall).has_value());
  s.Seen("IMU", kWall);  // not watched: no effect
  EXPECT_FALSE(s.HoldReason(kWall + 400000).has_value());
}

TEST(CommanderSafetyTest, EachStaleInputHoldsTheRobotUntilItReturns) {
  for (const char* input : {"WHEELS", "SCAN", "own HEARTBEAT"}) {
    SCOPED_TRACE(input);
    const double timeout_s = std::string(input) == "own HEARTBEAT" ? 3.0 : 0.5;
    CommanderSafety s = WatchedSafety();
    int64_t t = kWall;
    // Every input arrives every 100 ms (heartbeats every second) except `input`, which stops at 1 s.
    std::optional<std::string> first_hold;
    int64_t held_at = 0;
    for (; t <= kWall + 6000000; t += 100000) {
      for (const char* other : {"WHEELS", "SCAN"})
        if (std::string(other) != input || t <= kWall + 1000000) s.Seen(other, t);
      if ((t - kWall) % 1000000 == 0 && (std::string(input) != "own HEARTBEAT" || t <= kWall + 1000000))
        s.Seen("own HEARTBEAT", t);
      const auto reason = s.HoldReason(t);
      if (reason && !first_hold) {
        first_hold = reason;
        held_at = t;
      }
    }
    ASSERT_TRUE(first_hold.has_value());
    EXPECT_EQ(first_hold->rfind(std::string("no ") + input + " for", 0), 0u) << *first_hold;
    // Held as soon as the silence exceeds the timeout, to the 100 ms step.
    EXPECT_NEAR((held_at - (kWall + 1000000)) * 1e-6, timeout_s + 0.1, 0.1 + 1e-9);
    EXPECT_TRUE(s.InputsStale(t));
    s.Seen(input, t);  // it returns
    EXPECT_FALSE(s.HoldReason(t).has_value());
  }
}

TEST(CommanderSafetyTest, OperatorStopLatchesUntilReleasedAndComesFirst) {
  CommanderSafety s = WatchedSafety();
  for (const char* input : {"WHEELS", "SCAN", "own HEARTBEAT"}) s.Seen(input, kWall);
  s.SetOperatorStop(true, "dashboard: key s");
  for (int64_t t = kWall; t < kWall + 400000; t += 100000) {
    for (const char* input : {"WHEELS", "SCAN", "own HEARTBEAT"}) s.Seen(input, t);
    EXPECT_EQ(s.HoldReason(t).value_or(""), "operator stop (dashboard: key s)");
    EXPECT_FALSE(s.InputsStale(t));
  }
  EXPECT_EQ(s.HoldReason(kWall + 9000000).value_or(""), "operator stop (dashboard: key s)");  // before staleness
  s.SetOperatorStop(false, "");
  EXPECT_FALSE(s.HoldReason(kWall + 300000).has_value());
  EXPECT_EQ(s.HoldReason(kWall + 9000000).value_or("").rfind("no ", 0), 0u);
}

// The commander as the process runs it: held (stops sent, Interrupt) whenever the monitor
// says so, for each kind of reason, over a whole default trajectory. No command it sends
// exceeds a limit; a restart after a hold ramps up from rest.
TEST(CommanderSafetyTest, LimitsHoldThroughEveryKindOfHold) {
  for (const RobotDescription& robot : Robots()) {
    SCOPED_TRACE(robot.name);
    CommanderOptions options;
    options.command_timeout_s = 0.5;
    Commander commander(robot, MakeTrajectory(robot, "default"), options);
    CommanderSafety safety = WatchedSafety();
    const double total = commander.nominal_duration_s();
    // Holds: the operator (2 s), scans silent (1.5 s), wheels silent (1 s), heartbeat lost (4 s).
    struct Episode { double at_fraction, length_s; const char* kind; };
    const std::vector<Episode> episodes = {
        {0.15, 2.0, "operator"}, {0.4, 1.5, "SCAN"}, {0.6, 1.0, "WHEELS"}, {0.8, 4.0, "own HEARTBEAT"}};
    CommandRun run;
    bool held = false;
    int holds = 0;
    int64_t t = kStart, wall = kWall;
    for (; commander.status().state != CommanderState::kFinished ||
           run.commands.back().mode != DriveMode::kStop;
         t += kStepUs, wall += kStepUs) {
      ASSERT_LT(t, kStart + static_cast<int64_t>((total + 60.0) * 1e6));
      const double elapsed = (t - kStart) * 1e-6;
      std::string silent;
      bool operator_stop = false;
      for (const Episode& e : episodes) {
        const double start = e.at_fraction * total;
        if (elapsed >= start && elapsed < start + e.length_s) {
          if (std::string(e.kind) == "operator") {
            operator_stop = true;
          } else {
            silent = e.kind;
          }
        }
      }
      safety.SetOperatorStop(operator_stop, "test");
      for (const char* input : {"WHEELS", "SCAN"})
        if (silent != input) safety.Seen(input, wall);
      if (silent != "own HEARTBEAT" && (wall - kWall) % 1000000 == 0) safety.Seen("own HEARTBEAT", wall);
      if (safety.HoldReason(wall)) {
        if (!held) commander.Interrupt(t - kStepUs);
        held = true;
        DriveCommand stop;
        stop.mode = DriveMode::kStop;
        stop.timeout_s = options.command_timeout_s;
        run.commands.push_back(stop);
        run.statuses.push_back(commander.status());
        continue;
      }
      if (held) ++holds;
      held = false;
      run.commands.push_back(commander.Step(t));
      run.statuses.push_back(commander.status());
    }
    EXPECT_EQ(holds, 4);
    // Full limits for every motion command; from a stop (the robot's own brake) the
    // acceleration counts from rest.
    const auto model = MakeDriveModel(robot);
    const double dt = kStepUs * 1e-6;
    const std::vector<double> offsets = Offsets(robot);
    const Limits& lim = robot.limits;
    Twist2 prev;
    std::vector<double> prev_contact(offsets.size(), 0.0), prev_steer;
    for (size_t k = 0; k < run.commands.size(); ++k) {
      const DriveCommand& c = run.commands[k];
      ASSERT_EQ(c.timeout_s, 0.5);
      const Twist2 tw = CommandTwist(*model, c);
      const std::vector<double> contact = ContactSpeeds(robot, *model, c);
      ASSERT_LE(std::hypot(tw.vx, tw.vy), lim.max_speed + kEps) << k;
      ASSERT_LE(std::abs(tw.omega), lim.max_omega + kEps) << k;
      if (c.mode != DriveMode::kStop) {
        ASSERT_LE(std::hypot(tw.vx - prev.vx, tw.vy - prev.vy) / dt, lim.max_accel + 1e-6) << k;
        for (size_t i = 0; i < contact.size(); ++i) {
          ASSERT_LE(std::abs(contact[i]), lim.max_speed + kEps) << k;
          ASSERT_LE(std::abs(contact[i] - prev_contact[i]) / dt, lim.max_accel + 1e-6) << k;
        }
      }
      if (c.mode == DriveMode::kWheels) {
        for (size_t i = 0; i < offsets.size(); ++i) {
          ASSERT_LE(std::abs(c.wheels.steer[i] - offsets[i]), lim.max_steer + kEps) << k;
          if (!prev_steer.empty()) {
            ASSERT_LE(std::abs(c.wheels.steer[i] - prev_steer[i]) / dt, lim.max_steer_rate + 1e-6) << k;
          }
        }
        prev_steer = c.wheels.steer;
      }
      prev = tw;
      prev_contact = contact;
    }
  }
}

}  // namespace
}  // namespace calib
