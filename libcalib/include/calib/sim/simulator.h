#pragma once
// The simulator: a robot of any drive type whose TRUE parameters differ from
// the nominal ones of its robot file, driving in a World, with the sensors of
// spec/messages.md (wheel and steering encoders, a raycast 2D lidar, an IMU, a
// 3D lidar, an external pose source) and every effect of spec/effects.md,
// each off unless configured. It emits encoded messages into a MessageSink
// with their robot-clock times; GROUND_TRUTH carries the true pose of the
// reference point.
//
// Determinism: every random draw comes from generators seeded from
// SimConfig::seed (one stream per sensor, so enabling one sensor does not
// change another's noise); the same config and commands give the same bytes.
//
// Simulation config file (YAML; every key optional except `robot`; unknown
// keys are errors):
//   robot: forklift.yaml              # robot file (nominal values), relative to this file
//   seed: 1
//   world: warehouse                  # bundled name or path to a .world file
//   start: {x: 0, y: 0, theta: 0}
//   start_utime: 1700000000000000     # robot clock at the start, us
//   physics_step: 0.001               # integration step of the physics, s (1e-4 .. 0.05); a
//                                     # sensor samples at most once per step, at the step's end
//   commands: {rate: 20, between: hold}
//       # DRIVE_CMD rate of the offline run (agvcal simulate), Hz; what the robot's controller
//       # does between commands: `hold` each setpoint until the next, `ramp` from the
//       # setpoint in force to the new one over one command period (1 / rate), then hold
//       # (each physics step holds the ramp's value at the step's middle), or `continuous`:
//       # the controller follows the commander's setpoint, taken anew every physics step, and
//       # the DRIVE_CMD messages are its samples at the rate (offline runs; a simulator fed
//       # only the messages, as the live one, holds them)
//   truth:                            # true values; anything omitted = nominal
//     params: {drive_radius: 0.1153, ...}
//     lidar2d: {x:, y:, yaw:}   lidar3d: {x:, y:, z:, roll:, pitch:, yaw:}
//     imu: {yaw:}               pose: {x:, y:, yaw:}
//   sensors:
//     wheels: {rate: 100, ticks_per_rev: 4096, tick_noise: 0.0, steer_resolution: 0.0002,
//              steer_noise: 0.0002, velocity_noise: 0.0, count_jitter: 0.0}
//       # count_jitter (0 .. 0.5): each sample's encoder count is read at a time off its stamp
//       # by up to this share of the sample period (uniform), so the counts per sample step
//       # unevenly (13 7 6 14 7 ... where 10 are due) as on encoders read by an unsynchronised bus
//     lidar2d: {rate: 20, beams: 720, fov: 6.283185, range_min: 0.05, range_max: 30,
//               range_noise: 0.01, dropout: 0.0}
//     imu: {rate: 200, gyro_noise_density: 8.7e-5, gyro_bias: 0.0017, accel_noise_density: 0.002,
//           accel_bias: 0.0, gyro_scale: 1.0, time_offset: 0.0}
//       # gyro z = gyro_scale * true rate + bias + noise; a sample stamped t is the rate at t - time_offset
//     lidar3d: {rate: 0, rings: 16, elevation_min: -0.2618, elevation_max: 0.2618,
//               points_per_ring: 1800, range_max: 100, range_noise: 0.02,
//               body: {min: [x, y, z], max: [x, y, z]},     # robot body box, robot frame
//               turret: {rate: 50, speed: 0.5, start: 0, axis_pitch: 0, axis_roll: 0}}
//       # turret (off unless rate > 0; the robot file's lidar3d needs a rotation): the lidar
//       # turns at `speed` rad/s from angle `start` about an axis tilted from the robot's
//       # vertical by Ry(axis_pitch) Rx(axis_roll); sensor orientation in the robot frame
//       # R(angle) = Ry(axis_pitch) Rx(axis_roll) Rz(angle) Rz(yaw) Ry(pitch) Rx(roll) (true
//       # mount); the angle goes out as mount_angle_t on lidar3d.rotation.channel at `rate`.
//     pose: {rate: 0, noise_xy: 0.002, noise_theta: 0.002}
//     ground_truth: {rate: 100}
//   effects:                          # spec/effects.md names and parameter keys
//     time_offset: {offset_s: 0.02}
//     longitudinal_slip: {slip_per_accel: 0.08, region: [x0, y0, x1, y1]}
//       # region (longitudinal_slip, lateral_slip): the effect acts only while the reference
//       # point is inside this box of the world frame, m (a wet patch); absent: everywhere
//     wheel_eccentricity: {amplitude: 0.003, phase: 0.4, wheel: left}
//     ...
//   terms:                            # physics outside effects.md (core/physics_terms.h)
//     - {channel: yaw_rate, regressor: "turn_rate*|turn_rate|", coefficient: -0.3}
//       # channel yaw_rate, radius, steer or timing; regressor and units: docs/effects.md
// A sensor with rate 0 is off. lidar2d is on when the robot file has a
// lidar2d, imu when it has an imu, pose when it has a pose source; lidar3d is
// off unless given a rate.

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "calib/core/drive_command.h"
#include "calib/core/kinematics.h"
#include "calib/core/physics_terms.h"
#include "calib/core/robot.h"
#include "calib/core/se2.h"
#include "calib/io/recording.h"
#include "calib/sim/world.h"

namespace calib {

// Parameters of the effects of spec/effects.md; an absent effect is off.
struct SimEffects {
  std::optional<double> time_offset_s;           // time_offset.offset_s
  std::optional<double> scan_distortion_period_s;  // scan_distortion.scan_period_s
  double longitudinal_slip_per_accel = 0.0;      // longitudinal_slip.slip_per_accel, s^2/m
  std::string longitudinal_slip_wheel;           // empty = every driven wheel
  std::optional<std::array<double, 4>> longitudinal_slip_region;  // [x0, y0, x1, y1], world
  double lateral_slip_gain = 0.0;                // lateral_slip.gain, s
  std::optional<std::array<double, 4>> lateral_slip_region;       // [x0, y0, x1, y1], world
  double steering_lag_tau_s = 0.0;               // steering_lag.tau_s
  double steering_backlash_width_rad = 0.0;      // steering_backlash.width_rad
  double eccentricity_amplitude = 0.0;           // wheel_eccentricity.amplitude
  double eccentricity_phase = 0.0;               // wheel_eccentricity.phase
  std::string eccentricity_wheel;                // empty = every wheel
  double drive_lag_tau_s = 0.0;                  // drive_lag.tau_s
  double steering_rate_limit_rad_s = 0.0;        // steering_rate_limit.rate_rad_s (0 = off)
  std::string steering_wheel;                    // steering effects: empty = every steered wheel
};

struct WheelSensorConfig {
  double rate_hz = 100.0;
  int ticks_per_rev = 4096;
  double tick_noise = 0.0;           // std of the encoder angle before quantisation, ticks
  double steer_resolution_rad = 0.0002;
  double steer_noise_rad = 0.0002;
  double velocity_noise = 0.0;       // rad/s on the reported wheel speed
  double count_jitter = 0.0;         // each count read up to this share of a period off its stamp
};

struct Lidar2dSensorConfig {
  double rate_hz = 20.0;
  int beams = 720;
  double fov_rad = 2.0 * M_PI;
  double range_min = 0.05, range_max = 30.0;
  double range_noise = 0.01;         // m, std
  double dropout = 0.0;              // probability a beam returns nothing
};

struct ImuSensorConfig {
  double rate_hz = 200.0;
  double gyro_noise_density = 8.7e-5;  // rad/s/sqrt(Hz) (0.005 deg/s/sqrt(Hz))
  double gyro_bias = 0.0017;           // rad/s on z (0.1 deg/s)
  double accel_noise_density = 0.002;  // m/s^2/sqrt(Hz)
  double accel_bias = 0.0;             // m/s^2 on x and y
  double gyro_scale = 1.0;             // measured / true rate about z
  double time_offset_s = 0.0;          // a sample stamped t measures the motion at t - time_offset_s
};

struct Lidar3dSensorConfig {
  double rate_hz = 0.0;
  int rings = 16;
  double elevation_min_rad = -15.0 * M_PI / 180.0, elevation_max_rad = 15.0 * M_PI / 180.0;
  int points_per_ring = 1800;
  double range_max = 100.0;
  double range_noise = 0.02;
  Box3 body{Eigen::Vector3d(-0.5, -0.5, 0.0), Eigen::Vector3d(0.5, 0.5, 0.5)};  // robot frame
  // Turret (see the config format above); off when turret_rate_hz is 0.
  double turret_rate_hz = 0.0;
  double turret_speed = 0.0, turret_start = 0.0;   // rad/s, rad
  double turret_axis_pitch = 0.0, turret_axis_roll = 0.0;  // rad
};

// Orientation of the 3D lidar in the robot frame at turret angle `angle`
// (rad; 0 without a turret): see the config format above.
Eigen::Matrix3d Lidar3dRotation(const Mount3d& mount, const Lidar3dSensorConfig& sensor, double angle);

struct PoseSensorConfig {
  double rate_hz = 0.0;
  double noise_xy = 0.002, noise_theta = 0.002;
};

struct SimConfig {
  RobotDescription robot;                      // nominal description (what the robot believes)
  std::map<std::string, double> true_params;   // true drive parameters (all of ParamNames)
  Mount2d true_lidar2d;
  Mount3d true_lidar3d;
  ImuMount true_imu;
  Mount2d true_pose;
  std::string world = "warehouse";
  Pose2 start;
  int64_t start_utime = 1700000000000000;
  uint64_t seed = 1;
  double physics_rate_hz = 1000.0;             // 1 / physics_step
  double command_rate_hz = 20.0;               // commands.rate (offline runs)
  CommandsBetween command_between = CommandsBetween::kHold;  // commands.between
  WheelSensorConfig wheels;
  Lidar2dSensorConfig lidar2d;
  ImuSensorConfig imu;
  Lidar3dSensorConfig lidar3d;
  PoseSensorConfig pose;
  double ground_truth_rate_hz = 100.0;
  SimEffects effects;
  std::vector<PhysicsTerm> terms;              // `terms:`, in the order given
  std::string source_file;
};

// Reads a simulation config (see the top of this file). Throws InputError
// naming file, line and key for any problem, including unknown keys.
SimConfig LoadSimConfig(const std::string& path);
SimConfig ParseSimConfig(const std::string& yaml_text, const std::string& origin,
                         const std::string& base_dir);

class Simulator {
 public:
  explicit Simulator(SimConfig config);
  ~Simulator();

  // The setpoint the robot follows from now on (until its timeout expires,
  // after which the robot brakes to a stop).
  void ApplyCommand(const DriveCommand& command);

  // Advances the simulation to robot-clock time `utime` (us), emitting every
  // sensor message that falls due into `sink`, in time order.
  void AdvanceTo(int64_t utime, MessageSink* sink);

  int64_t utime() const { return utime_; }
  Pose2 true_pose() const { return pose_; }
  const SimConfig& config() const { return config_; }
  // Time of the next WHEELS sample, us (the commander runs on wheel-state times).
  int64_t next_wheels_utime() const;
  // Robot-clock time of the newest emitted WHEELS sample, or start_utime.
  int64_t last_wheels_utime() const { return last_wheels_utime_; }

 private:
  struct State;
  void StepPhysics(double dt);
  // The sensor messages that fall due now (AdvanceTo), into `sink`.
  void PublishWheels(MessageSink* sink);
  void PublishImu(MessageSink* sink);
  void PublishScan(MessageSink* sink);
  void PublishCloud(double turret_angle, MessageSink* sink);
  SimConfig config_;
  std::unique_ptr<State> state_;
  int64_t utime_ = 0;
  int64_t last_wheels_utime_ = 0;
  Pose2 pose_;
};

}  // namespace calib
