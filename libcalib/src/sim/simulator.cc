#include "calib/sim/simulator.h"

#include <algorithm>
#include <cmath>
#include <deque>

#include <Eigen/Geometry>

#include "agvcal/imu_t.hpp"
#include "agvcal/laser_scan_t.hpp"
#include "agvcal/mount_angle_t.hpp"
#include "agvcal/point_cloud_t.hpp"
#include "agvcal/pose2d_t.hpp"
#include "agvcal/wheel_state_t.hpp"
#include "calib/core/physics_terms.h"
#include "calib/io/messages.h"
#include "sim/lidar3d_model.h"
#include "sim/sim_terms.h"
#include "sim/wheel_physics.h"

namespace calib {

namespace {

constexpr double kGravity = 9.80665;

int64_t PeriodUs(double rate_hz) { return rate_hz > 0 ? std::llround(1e6 / rate_hz) : 0; }

}  // namespace

struct Simulator::State {
  World world;
  std::unique_ptr<DriveModel> nominal_model, true_model;
  std::vector<WheelState> wheels;
  std::vector<bool> steered;
  DriveCommand command;
  int64_t command_received = 0;
  bool have_command = false;
  // Sensor timers: time of the next sample (us).
  int64_t next_wheels = 0, next_scan_end = 0, next_imu = 0, next_cloud = 0, next_pose = 0,
          next_truth = 0, next_turret = 0;
  int64_t wheels_period = 0, scan_period = 0, imu_period = 0, cloud_period = 0, pose_period = 0,
          truth_period = 0, turret_period = 0;
  std::deque<std::pair<int64_t, Pose2>> history;  // true poses, for per-beam lidar timing
  Eigen::Vector2d velocity_world = Eigen::Vector2d::Zero();
  std::deque<std::pair<int64_t, Eigen::Vector2d>> velocity_history;  // for the accelerometer
  double omega_body = 0.0;
  // One random stream per sensor so that enabling one does not shift another.
  std::mt19937_64 rng_wheels, rng_scan, rng_imu, rng_cloud, rng_pose;
  std::normal_distribution<double> normal{0.0, 1.0};
  std::uniform_real_distribution<double> uniform{0.0, 1.0};

  Pose2 PoseAt(int64_t t) const {
    if (history.empty()) return {};
    if (t <= history.front().first) return history.front().second;
    if (t >= history.back().first) return history.back().second;
    auto it = std::lower_bound(history.begin(), history.end(), t,
                               [](const auto& h, int64_t v) { return h.first < v; });
    const auto& b = *it;
    const auto& a = *(it - 1);
    const double s = double(t - a.first) / double(b.first - a.first);
    return Interpolate(a.second, b.second, s);
  }
};

Simulator::Simulator(SimConfig config) : config_(std::move(config)), state_(new State) {
  State& s = *state_;
  s.world = World::Load(config_.world);
  s.nominal_model = MakeDriveModel(config_.robot);
  s.true_model = MakeDriveModel(config_.robot.drive, config_.true_params);
  const auto& roles = WheelRoles(config_.robot.drive);
  s.wheels.resize(roles.size());
  for (size_t i = 0; i < roles.size(); ++i)
    s.steered.push_back(config_.robot.drive != DriveType::kDifferential);
  // Wheels start pointing straight ahead: the actuator holds the raw reading
  // that the robot believes is zero (nominal offset).
  for (size_t i = 0; i < roles.size(); ++i) {
    const std::string offset_name = SteerOffsetParamName(roles[i]);
    const double nominal_offset = offset_name.empty() ? 0.0 : config_.robot.param(offset_name);
    s.wheels[i].steer_reading = s.wheels[i].steer_target = s.wheels[i].steer_lagged =
        s.steered[i] ? nominal_offset : 0.0;
  }
  // std::seed_seq keeps 32 bits per entry: pass the seed's high half as a
  // second entry (only when non-zero, so seeds below 2^32 keep their streams).
  std::vector<uint32_t> seed_entries{static_cast<uint32_t>(config_.seed)};
  if (config_.seed >> 32) seed_entries.push_back(static_cast<uint32_t>(config_.seed >> 32));
  std::seed_seq seq(seed_entries.begin(), seed_entries.end());
  std::vector<uint64_t> seeds(5);
  seq.generate(seeds.begin(), seeds.end());
  s.rng_wheels.seed(seeds[0]);
  s.rng_scan.seed(seeds[1]);
  s.rng_imu.seed(seeds[2]);
  s.rng_cloud.seed(seeds[3]);
  s.rng_pose.seed(seeds[4]);

  utime_ = last_wheels_utime_ = config_.start_utime;
  pose_ = config_.start;
  s.history.push_back({utime_, pose_});
  s.wheels_period = PeriodUs(config_.wheels.rate_hz);
  s.scan_period = config_.robot.lidar2d ? PeriodUs(config_.lidar2d.rate_hz) : 0;
  s.imu_period = config_.robot.imu ? PeriodUs(config_.imu.rate_hz) : 0;
  s.cloud_period = PeriodUs(config_.lidar3d.rate_hz);
  s.pose_period = config_.robot.pose ? PeriodUs(config_.pose.rate_hz) : 0;
  s.truth_period = PeriodUs(config_.ground_truth_rate_hz);
  if (config_.robot.lidar3d && config_.robot.lidar3d->rotation)
    s.turret_period = PeriodUs(config_.lidar3d.turret_rate_hz);
  s.next_wheels = s.next_imu = s.next_cloud = s.next_pose = s.next_truth = s.next_turret = utime_;
  s.next_scan_end = utime_ + s.scan_period;
}

Simulator::~Simulator() = default;

int64_t Simulator::next_wheels_utime() const { return state_->next_wheels; }

void Simulator::ApplyCommand(const DriveCommand& command) {
  state_->command = command;
  state_->command_received = utime_;
  state_->have_command = true;
  for (WheelState& w : state_->wheels) w.omega_from = w.omega_target, w.steer_from = w.steer_target;
}

void Simulator::StepPhysics(double dt) {
  State& s = *state_;
  const SimEffects& fx = config_.effects;
  const auto& roles = WheelRoles(config_.robot.drive);
  const size_t n = roles.size();

  // Setpoints: a command older than its timeout (on our clock) means stop.
  const bool live = s.have_command && s.command.mode != DriveMode::kStop &&
                    utime_ - s.command_received <= std::llround(s.command.timeout_s * 1e6);
  WheelSetpoint target;
  if (live && s.command.mode == DriveMode::kTwist) {
    target = s.nominal_model->Inverse(s.command.twist);  // the robot's controller uses nominal values
  } else if (live) {
    target = s.command.wheels;
  }
  // commands.between ramp: from the setpoints in force when the command came to the new ones
  // over one command period, at the step's middle (the mean of the linear ramp over the step: at
  // its end the setpoint would lead the ramp by half a step, which reads as a timing error).
  const double ramp = config_.command_between != CommandsBetween::kRamp || !s.have_command
                          ? 1.0
                          : std::min(1.0, (utime_ + dt * 0.5e6 - s.command_received) * 1e-6 * config_.command_rate_hz);
  for (size_t i = 0; i < n; ++i) {
    WheelState& w = s.wheels[i];
    const double omega = live ? target.speed.at(i) : 0.0;
    auto blend = [ramp](double from, double to) { return ramp >= 1.0 ? to : from + ramp * (to - from); };
    w.omega_target = blend(w.omega_from, omega);
    if (live && s.steered[i]) w.steer_target = blend(w.steer_from, target.steer.at(i));
  }

  std::vector<double> effective_omega(n), true_raw(n);
  for (size_t i = 0; i < n; ++i) {
    const double radius = config_.true_params.at(RadiusParamName(roles[i]));
    const WheelMotion m = StepWheel(&s.wheels[i], fx, roles[i], s.steered[i], radius, pose_, dt);
    effective_omega[i] = m.effective_omega;
    true_raw[i] = m.true_raw;
  }

  // Body motion from the wheels' true motion, with the true parameters.
  Twist2 twist = s.true_model->Forward({effective_omega, true_raw});
  if (!config_.terms.empty())
    twist = WithTerms(*s.true_model, config_, s.steered, (utime_ - config_.start_utime) * 1e-6, effective_omega, true_raw,
                      twist);
  if (fx.lateral_slip_gain != 0 && Inside(fx.lateral_slip_region, pose_)) twist.vy += -fx.lateral_slip_gain * twist.vx * twist.omega;
  pose_ = Compose(pose_, ExpTwist(twist, dt));
  s.omega_body = twist.omega;
  const double c = std::cos(pose_.theta), sn = std::sin(pose_.theta);
  s.velocity_world = Eigen::Vector2d(c * twist.vx - sn * twist.vy, sn * twist.vx + c * twist.vy);
}

// WHEELS: encoder ticks (with tick noise), wheel speeds and steering readings.
void Simulator::PublishWheels(MessageSink* sink) {
  State& s = *state_;
  const SimConfig& cfg = config_;
  const auto& roles = WheelRoles(cfg.robot.drive);
  agvcal::wheel_state_t msg{};
  msg.utime = utime_;
  msg.num_wheels = static_cast<int32_t>(roles.size());
  const double tick = 2.0 * M_PI / cfg.wheels.ticks_per_rev;
  for (size_t i = 0; i < roles.size(); ++i) {
    const WheelState& w = s.wheels[i];
    msg.name.push_back(cfg.robot.wheel_name(roles[i]));
    // The count read off the stamp: the angle then, to first order in the wheel's speed.
    const double read_early =
        cfg.wheels.count_jitter > 0
            ? cfg.wheels.count_jitter * (2 * s.uniform(s.rng_wheels) - 1) / cfg.wheels.rate_hz
            : 0.0;
    const double noisy = (w.phi + w.omega * read_early) / tick + cfg.wheels.tick_noise * s.normal(s.rng_wheels);
    msg.position.push_back(std::floor(noisy) * tick);
    msg.velocity.push_back(w.omega + cfg.wheels.velocity_noise * s.normal(s.rng_wheels));
    double steer = 0.0;
    if (s.steered[i]) {
      const double res = cfg.wheels.steer_resolution_rad;
      steer = w.steer_reading + cfg.wheels.steer_noise_rad * s.normal(s.rng_wheels);
      if (res > 0) steer = std::round(steer / res) * res;
    }
    msg.steer.push_back(steer);
  }
  sink->Publish(kWheelsChannel, utime_, Encode(msg));
  last_wheels_utime_ = utime_;
  s.next_wheels += s.wheels_period;
}

// IMU: the gyro's yaw rate (scale, bias, noise) and the accelerometer (from the velocity
// history) in the IMU's frame.
void Simulator::PublishImu(MessageSink* sink) {
  State& s = *state_;
  const SimConfig& cfg = config_;
  agvcal::imu_t msg{};
  msg.utime = utime_ + std::llround(cfg.imu.time_offset_s * 1e6);
  const double yaw = pose_.theta + cfg.true_imu.yaw;
  const auto& oldest = s.velocity_history.front();
  Eigen::Vector2d accel_world = Eigen::Vector2d::Zero();
  if (utime_ > oldest.first)
    accel_world = (s.velocity_world - oldest.second) / ((utime_ - oldest.first) * 1e-6);
  const double c = std::cos(yaw), sn = std::sin(yaw);
  const double gyro_sigma = cfg.imu.gyro_noise_density * std::sqrt(cfg.imu.rate_hz);
  const double accel_sigma = cfg.imu.accel_noise_density * std::sqrt(cfg.imu.rate_hz);
  msg.angular_velocity[0] = gyro_sigma * s.normal(s.rng_imu);
  msg.angular_velocity[1] = gyro_sigma * s.normal(s.rng_imu);
  msg.angular_velocity[2] = cfg.imu.gyro_scale * s.omega_body + cfg.imu.gyro_bias + gyro_sigma * s.normal(s.rng_imu);
  msg.linear_acceleration[0] = c * accel_world.x() + sn * accel_world.y() + cfg.imu.accel_bias +
                               accel_sigma * s.normal(s.rng_imu);
  msg.linear_acceleration[1] = -sn * accel_world.x() + c * accel_world.y() +
                               cfg.imu.accel_bias + accel_sigma * s.normal(s.rng_imu);
  msg.linear_acceleration[2] = kGravity + accel_sigma * s.normal(s.rng_imu);
  sink->Publish(kImuChannel, utime_, Encode(msg));
  s.next_imu += s.imu_period;
}

// SCAN: the 2D lidar's scan that ends now, each beam cast from the pose it was taken at.
void Simulator::PublishScan(MessageSink* sink) {
  State& s = *state_;
  const SimConfig& cfg = config_;
  // The scan started one period ago; beam j was taken at start + j * dt_beam.
  const Lidar2dSensorConfig& L = cfg.lidar2d;
  const int64_t start = s.next_scan_end - s.scan_period;
  const double increment = L.fov_rad / L.beams;
  // One revolution per scan: the beams of the field of view take their share of it.
  double dt_beam = s.scan_period * 1e-6 * increment / (2.0 * M_PI);
  // scan_distortion (spec/effects.md): beam j at utime + j * scan_period_s / nranges.
  if (cfg.effects.scan_distortion_period_s)
    dt_beam = *cfg.effects.scan_distortion_period_s / L.beams;
  agvcal::laser_scan_t msg{};
  TermMotion at_start;
  at_start.time = (start - cfg.start_utime) * 1e-6;
  const double offset_s = cfg.effects.time_offset_s.value_or(0.0) + ChannelChange(cfg.terms, TermChannel::kTiming, at_start);
  msg.utime = start + std::llround(offset_s * 1e6);
  msg.angle_min = static_cast<float>(-L.fov_rad / 2.0);
  msg.angle_increment = static_cast<float>(increment);
  msg.time_increment = cfg.effects.scan_distortion_period_s ? 0.0f : static_cast<float>(dt_beam);
  msg.scan_time = static_cast<float>(s.scan_period * 1e-6);
  msg.range_min = static_cast<float>(L.range_min);
  msg.range_max = static_cast<float>(L.range_max);
  msg.nranges = L.beams;
  msg.ranges.resize(L.beams);
  msg.nintensities = 0;
  const Pose2 mount{cfg.true_lidar2d.x, cfg.true_lidar2d.y, cfg.true_lidar2d.yaw};
  for (int j = 0; j < L.beams; ++j) {
    const int64_t t = start + std::llround(j * dt_beam * 1e6);
    const Pose2 sensor = Compose(s.PoseAt(t), mount);
    // Angles as the receiver will compute them, from the float fields.
    const double beam_angle = double(msg.angle_min) + j * double(msg.angle_increment);
    double range = s.world.CastRay2d({sensor.x, sensor.y}, sensor.theta + beam_angle,
                                     L.range_max);
    const double noise = L.range_noise * s.normal(s.rng_scan);
    const bool dropped = L.dropout > 0 && s.uniform(s.rng_scan) < L.dropout;
    if (range == kNoHit || range < L.range_min)
      msg.ranges[j] = std::numeric_limits<float>::infinity();
    else if (dropped)
      msg.ranges[j] = std::numeric_limits<float>::quiet_NaN();
    else
      msg.ranges[j] = static_cast<float>(range + noise);
  }
  sink->Publish(kScanChannel, utime_, Encode(msg));
  s.next_scan_end += s.scan_period;
}

// CLOUD: the 3D lidar's rings, cast from the robot's pose now and the turret at `turret_angle`.
void Simulator::PublishCloud(double turret_angle, MessageSink* sink) {
  State& s = *state_;
  agvcal::point_cloud_t msg = SimulateCloud(s.world, config_.lidar3d, config_.true_lidar3d, pose_,
                                            turret_angle, &s.rng_cloud, &s.normal);
  msg.utime = utime_;
  sink->Publish(kCloudChannel, utime_, Encode(msg));
  s.next_cloud += s.cloud_period;
}

void Simulator::AdvanceTo(int64_t until, MessageSink* sink) {
  State& s = *state_;
  const SimConfig& cfg = config_;
  const int64_t physics_step = PeriodUs(cfg.physics_rate_hz);

  while (utime_ < until) {
    StepPhysics(physics_step * 1e-6);
    utime_ += physics_step;
    s.history.push_back({utime_, pose_});
    const int64_t keep = std::max<int64_t>(2 * s.scan_period, 200000) + 200000;
    while (s.history.size() > 2 && s.history.front().first < utime_ - keep) s.history.pop_front();
    s.velocity_history.push_back({utime_, s.velocity_world});
    while (s.velocity_history.size() > 2 &&
           s.velocity_history.front().first < utime_ - std::max<int64_t>(s.imu_period, 1000))
      s.velocity_history.pop_front();

    // Sensors due at or before now, in a fixed order (ties: wheels first).
    if (s.wheels_period && s.next_wheels <= utime_) PublishWheels(sink);
    if (s.imu_period && s.next_imu <= utime_) PublishImu(sink);
    if (s.scan_period && s.next_scan_end <= utime_) PublishScan(sink);

    // Turret angle now (before the cloud, so a cloud at the same time finds it).
    const double turret_angle =
        s.turret_period ? WrapAngle(cfg.lidar3d.turret_start +
                                    cfg.lidar3d.turret_speed * (utime_ - cfg.start_utime) * 1e-6)
                        : 0.0;
    if (s.turret_period && s.next_turret <= utime_) {
      agvcal::mount_angle_t msg{};
      msg.utime = utime_;
      msg.angle = turret_angle;
      sink->Publish(cfg.robot.lidar3d->rotation->channel, utime_, Encode(msg));
      s.next_turret += s.turret_period;
    }

    if (s.cloud_period && s.next_cloud <= utime_) PublishCloud(turret_angle, sink);

    if (s.pose_period && s.next_pose <= utime_) {
      const Pose2 tracked =
          Compose(pose_, Pose2{cfg.true_pose.x, cfg.true_pose.y, cfg.true_pose.yaw});
      agvcal::pose2d_t msg{};
      msg.utime = utime_;
      msg.x = tracked.x + cfg.pose.noise_xy * s.normal(s.rng_pose);
      msg.y = tracked.y + cfg.pose.noise_xy * s.normal(s.rng_pose);
      msg.theta = WrapAngle(tracked.theta + cfg.pose.noise_theta * s.normal(s.rng_pose));
      msg.cov[0] = msg.cov[4] = cfg.pose.noise_xy * cfg.pose.noise_xy;
      msg.cov[8] = cfg.pose.noise_theta * cfg.pose.noise_theta;
      sink->Publish(kPoseChannel, utime_, Encode(msg));
      s.next_pose += s.pose_period;
    }

    if (s.truth_period && s.next_truth <= utime_) {
      agvcal::pose2d_t msg{};
      msg.utime = utime_;
      msg.x = pose_.x;
      msg.y = pose_.y;
      msg.theta = pose_.theta;
      sink->Publish(kGroundTruthChannel, utime_, Encode(msg));
      s.next_truth += s.truth_period;
    }
  }
}

}  // namespace calib
