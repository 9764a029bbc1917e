#pragma once
// The trajectory commander: excitation trajectories that make each drive
// type's parameters observable, executed within the robot file's limits.
//
// The commander is a function of robot-clock time: Step(utime) is called with
// the time of the newest wheel state and returns the command to send then.
// It never reads the wall clock (the process adds stale-input detection and
// tells the commander through Interrupt()). It is open loop: a segment ends
// when the commanded speed profile, integrated in time, has covered its
// distance or angle.
//
// Trajectories (names; every drive type also has "demo", about 25 s of a few
// motions for end-to-end tests, and "straight", straight runs forward and back
// only: a degenerate recording):
//   differential: "default" (all of the below plus straight runs, about
//     3.3 min at the bundled robot's limits), "umbmark" (bidirectional
//     square, 2.5 m sides, CCW and CW), "turns" (turns in place both ways at
//     two rates), "figure8" (figure-eights both ways, 1.2 m loops), "imu" (the
//     lidar-less calibration of docs/imu.md: a straight run of imu.distance, default
//     3 m, two turns in place each way, the straight back, 10 s at rest after each).
//   tricycle: "default" (about 3.2 min): arcs at true steering angles of
//     +-0.2, +-0.4, +-0.7, +-1.0 rad (scaled down when max_steer is smaller),
//     each driven 3 m forward then back along the same arc in reverse, and
//     straight runs forward and back, so the robot stays near its start;
//     "route" (about 9 min): normal work, not excitation: three laps of
//     pallet runs from the start to four racks (out forward to the
//     north-east and south-east, in reverse to the north-west and
//     south-west: 2 m, a 90-degree corner at 0.7 rad steering, 2.5 m of
//     aisle, a stop, and the same way back).
//   dual_steer: "default" (about 3.8 min): the three-segment run (a1 steered
//     one way, straight, the other way; a2 held at zero; 1.8 m of a1 travel
//     each) at two angles and in both mirror images, each driven back in
//     reverse; crab runs (both wheels steered alike), counter-steered arcs
//     and straight runs, forward and back; "three_segment" alone.
//
// Every segment starts and ends at rest: the wheels stop, the steering turns
// at no more than max_steer_rate, settles, then the drive follows a
// trapezoidal speed profile (max_accel). The peak speed is the largest that
// keeps the reference point and every wheel contact point within max_speed
// and the turn rate within max_omega.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "calib/core/drive_command.h"
#include "calib/core/robot.h"

namespace calib {

// One piece of an excitation trajectory: hold a motion shape for a distance
// or an angle. The commander inserts the ramps (acceleration, steering rate)
// between pieces and stops the wheels while the steering turns.
struct TrajectorySegment {
  std::string description;  // e.g. "arc, steer +0.40 rad, forward 3.0 m"
  // Differential drives: the body twist (speed = vx, omega) at the peak of the
  // profile; both are scaled down together (keeping the curvature) where a
  // limit requires it. Steered drives: `steer` is the true steering angle of
  // each wheel role (rad, WheelRoles() order), which fixes the shape of the
  // motion, and `speed` the requested peak speed of the progress point (m/s,
  // negative = reverse), scaled down where a limit requires it.
  double speed = 0.0;          // m/s, signed (negative = reverse)
  double omega = 0.0;          // rad/s (differential only)
  std::vector<double> steer;   // true steering angle per role (steered drives)
  // Length: if `angle` > 0 the segment ends after turning by it; otherwise
  // after the progress point (the reference point; wheel a1 for dual steer)
  // has travelled `distance`.
  double distance = 0.0;       // m, >= 0
  double angle = 0.0;          // rad of heading change, >= 0
  double pause_s = 0.5;        // standstill after the segment
};

struct Trajectory {
  std::string name;
  std::vector<TrajectorySegment> segments;
};

// Names of the trajectories available for a drive type ("default" first).
std::vector<std::string> TrajectoryNames(DriveType type);

// Builds a named trajectory for the robot, scaled to its limits. Throws
// InputError for an unknown name (listing the known ones).
Trajectory MakeTrajectory(const RobotDescription& robot, const std::string& name);

enum class CommanderState { kRunning, kFinished };

struct CommanderStatus {
  CommanderState state = CommanderState::kRunning;
  int segment = 0;       // index of the current segment (0 during the start delay)
  int num_segments = 0;
  std::string segment_description;
};

struct CommanderOptions {
  double command_timeout_s = 0.5;  // sent with every command
  double start_delay_s = 1.0;      // standstill at the start (lets IMU biases be seen)
  double steer_settle_s = 0.5;     // standstill after the steering has turned, before driving
  // True steering angle of each wheel role at the start (rad, WheelRoles()
  // order; empty = 0): the first steering ramp starts here.
  std::vector<double> initial_steer;
};

class Commander {
 public:
  // Throws InputError if the trajectory does not fit the robot (a steering
  // angle beyond max_steer, a segment without motion, a degenerate geometry).
  Commander(const RobotDescription& robot, Trajectory trajectory,
            CommanderOptions options = CommanderOptions());
  ~Commander();
  Commander(const Commander& other);  // an independent copy, state included
  Commander& operator=(const Commander& other);
  Commander(Commander&&) noexcept;
  Commander& operator=(Commander&&) noexcept;

  // Command to send at robot-clock time `utime` (us); the first call starts
  // the trajectory. A time earlier than the previous one counts as the
  // previous one. The commands are computed with the robot file's nominal
  // parameters and never exceed its limits (speed, acceleration, turn rate,
  // steering angle and rate). Differential drives get mode kTwist, steered
  // drives kWheels (wheel speeds in rad/s, raw steering setpoints). After the
  // last segment it returns kStop commands and the state becomes kFinished.
  DriveCommand Step(int64_t utime);

  // The commands stopped reaching the robot at `utime` (stale inputs; the
  // robot has been told to stop). The next Step() resumes from rest: a drive
  // segment cut short restarts its remaining distance with a fresh speed ramp
  // after a settle time, a steering ramp continues from where it was.
  void Interrupt(int64_t utime);

  CommanderStatus status() const;
  const Trajectory& trajectory() const { return trajectory_; }

  // Duration of the whole trajectory without interruptions, s (start delay included).
  double nominal_duration_s() const;

 private:
  // Implementation state (see commander.cc).
  struct Impl;
  RobotDescription robot_;
  Trajectory trajectory_;
  CommanderOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace calib
