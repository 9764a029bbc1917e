#pragma once
// The trajectory commander: excitation trajectories that make each drive
// type's parameters observable, executed within the robot file's limits.
//
// The commander is a function of robot-clock time: Step(utime) is called with
// the time of the newest wheel state and returns the command to send then.
// It never reads the wall clock (the process adds stale-input detection).
//
// Trajectories (names):
//   differential: "default" (all of the below), "umbmark" (bidirectional
//     square, CW and CCW), "turns" (turns in place both ways), "figure8".
//   tricycle: "default": arcs at several steering angles both ways, straight
//     runs, each driven forward then back in reverse (so the robot stays near
//     its start), "straight" (straight runs only: a degenerate recording).
//   dual_steer: "default": the three-segment run (a1 steered one way,
//     straight, the other way; a2 held at zero), plus runs with both wheels
//     steered; "three_segment" alone; "straight".

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "calib/drive_command.h"
#include "calib/robot.h"

namespace calib {

// One piece of an excitation trajectory: hold the given setpoint for a
// distance or an angle. The commander inserts the ramps (acceleration,
// steering rate) between pieces and stops the wheels while steering turns.
struct TrajectorySegment {
  std::string description;  // e.g. "arc, steer +0.40 rad, forward 2.0 m"
  // Differential drives: twist (vx, omega); steered drives: true steering
  // angle of each wheel role (rad, WheelRoles() order) and the reference-point speed.
  double speed = 0.0;                // m/s, signed (negative = reverse)
  double omega = 0.0;                // rad/s (differential only)
  std::vector<double> steer;         // true steering angle per role (steered drives)
  double distance = 0.0;             // m travelled by the reference point (or a1 for dual steer), >= 0
  double angle = 0.0;                // rad turned (turns in place), >= 0
  double pause_s = 0.5;              // standstill after the segment
};

struct Trajectory {
  std::string name;
  std::vector<TrajectorySegment> segments;
};

// Names of the trajectories available for a drive type.
std::vector<std::string> TrajectoryNames(DriveType type);

// Builds a named trajectory for the robot, scaled to its limits. Throws
// InputError for an unknown name (listing the known ones).
Trajectory MakeTrajectory(const RobotDescription& robot, const std::string& name);

enum class CommanderState { kRunning, kFinished };

struct CommanderStatus {
  CommanderState state = CommanderState::kRunning;
  int segment = 0;
  int num_segments = 0;
  std::string segment_description;
};

struct CommanderOptions {
  double command_timeout_s = 0.5;  // sent with every command
  double start_delay_s = 1.0;      // standstill at the start (lets IMU biases be seen)
};

class Commander {
 public:
  Commander(const RobotDescription& robot, Trajectory trajectory,
            CommanderOptions options = CommanderOptions());

  // Command to send at robot-clock time `utime` (us); times must not decrease.
  // The commands are computed with the robot file's nominal parameters and
  // never exceed its limits (speed, acceleration, turn rate, steering angle
  // and rate). After the last segment it returns stop commands and the state
  // becomes kFinished.
  DriveCommand Step(int64_t utime);

  CommanderStatus status() const;
  const Trajectory& trajectory() const { return trajectory_; }

 private:
  // Implementation state (see commander.cc).
  struct Impl;
  RobotDescription robot_;
  Trajectory trajectory_;
  CommanderOptions options_;
  std::shared_ptr<Impl> impl_;
};

}  // namespace calib
