// Reading simulation configs (format: calib/sim/simulator.h). Every key must be
// known, so a typo in an effect or a sensor setting fails loudly.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <sstream>
#include <string>

#include "calib/core/errors.h"
#include "calib/sim/simulator.h"
#include "calib/sim/world.h"
#include "core/yaml_checked.h"

namespace calib {
namespace {

using yaml::CheckedMap;
using yaml::Field;
using yaml::NumberOr;
using yaml::ReadNumber;
using yaml::ReadPositive;
using yaml::ReadString;
using yaml::Reporter;

// A number for a message, with up to 6 significant digits.
std::string Format(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// `physics_rate`: the config's (physics_step is read before the sensors).
double RateOr(const Reporter& r, const CheckedMap& map, double fallback, double physics_rate) {
  const double rate = NumberOr(r, map, "rate", fallback);
  if (rate < 0) r.Fail(*map.Find("rate"), "a rate must be >= 0 (0 turns the sensor off)");
  // A sensor samples at most once per physics step; a higher rate would be
  // emitted slower than configured (with noise scaled for the configured rate).
  if (rate > physics_rate * (1 + 1e-9))
    r.Fail(*map.Find("rate"), "a rate must be at most the simulator's physics rate (" +
                                  Format(physics_rate) + " Hz)");
  return rate;
}

// A count (beams, ticks, rings): a whole number >= 1.
int ReadCount(const Reporter& r, const Field& f) {
  const double v = ReadPositive(r, f);
  if (v != std::floor(v) || v > 1e9)
    r.Fail(f, "must be a whole number >= 1, got " + yaml::Describe(f.value));
  return static_cast<int>(v);
}

double NonNegativeOr(const Reporter& r, const CheckedMap& map, const std::string& key,
                     double fallback) {
  const auto f = map.Find(key);
  if (!f) return fallback;
  const double v = ReadNumber(r, *f);
  if (v < 0) r.Fail(*f, "must be >= 0, got " + yaml::Describe(f->value));
  return v;
}

Eigen::Vector3d ReadVector3(const Reporter& r, const Field& f) {
  if (!f.value.IsSequence() || f.value.size() != 3) r.Fail(f, "expected [x, y, z]");
  Eigen::Vector3d v;
  for (int i = 0; i < 3; ++i) v[i] = ReadNumber(r, Field{f.path, f.line, f.value[i]});
  return v;
}

void ReadTruth(const Reporter& r, const Field& field, SimConfig* cfg) {
  const CheckedMap top(r, field, {"params", "lidar2d", "lidar3d", "imu", "pose"});
  if (const auto f = top.Find("params")) {
    const CheckedMap params(r, *f, ParamNames(cfg->robot.drive));
    for (const auto& name : ParamNames(cfg->robot.drive))
      if (const auto p = params.Find(name)) cfg->true_params[name] = ReadNumber(r, *p);
  }
  auto read_mount2d = [&](const Field& f, Mount2d* m) {
    const CheckedMap map(r, f, {"x", "y", "yaw"});
    m->x = NumberOr(r, map, "x", m->x);
    m->y = NumberOr(r, map, "y", m->y);
    m->yaw = NumberOr(r, map, "yaw", m->yaw);
  };
  if (const auto f = top.Find("lidar2d")) read_mount2d(*f, &cfg->true_lidar2d);
  if (const auto f = top.Find("pose")) read_mount2d(*f, &cfg->true_pose);
  if (const auto f = top.Find("lidar3d")) {
    const CheckedMap map(r, *f, {"x", "y", "z", "roll", "pitch", "yaw"});
    Mount3d& m = cfg->true_lidar3d;
    m.x = NumberOr(r, map, "x", m.x);
    m.y = NumberOr(r, map, "y", m.y);
    m.z = NumberOr(r, map, "z", m.z);
    m.roll = NumberOr(r, map, "roll", m.roll);
    m.pitch = NumberOr(r, map, "pitch", m.pitch);
    m.yaw = NumberOr(r, map, "yaw", m.yaw);
  }
  if (const auto f = top.Find("imu")) {
    const CheckedMap map(r, *f, {"yaw"});
    cfg->true_imu.yaw = NumberOr(r, map, "yaw", cfg->true_imu.yaw);
  }
}

void ReadSensors(const Reporter& r, const Field& field, SimConfig* cfg) {
  const CheckedMap top(r, field, {"wheels", "lidar2d", "imu", "lidar3d", "pose", "ground_truth"});
  if (const auto f = top.Find("wheels")) {
    const CheckedMap m(r, *f, {"rate", "ticks_per_rev", "tick_noise", "steer_resolution",
                               "steer_noise", "velocity_noise", "count_jitter"});
    WheelSensorConfig& w = cfg->wheels;
    w.rate_hz = RateOr(r, m, w.rate_hz, cfg->physics_rate_hz);
    if (const auto t = m.Find("ticks_per_rev")) w.ticks_per_rev = ReadCount(r, *t);
    w.tick_noise = NonNegativeOr(r, m, "tick_noise", w.tick_noise);
    w.steer_resolution_rad = NonNegativeOr(r, m, "steer_resolution", w.steer_resolution_rad);
    w.steer_noise_rad = NonNegativeOr(r, m, "steer_noise", w.steer_noise_rad);
    w.velocity_noise = NonNegativeOr(r, m, "velocity_noise", w.velocity_noise);
    w.count_jitter = NonNegativeOr(r, m, "count_jitter", w.count_jitter);
    if (w.count_jitter > 0.5) r.Fail(*m.Find("count_jitter"), "must be at most 0.5 (half a sample period)");
  }
  if (const auto f = top.Find("lidar2d")) {
    const CheckedMap m(r, *f, {"rate", "beams", "fov", "range_min", "range_max", "range_noise",
                               "dropout"});
    Lidar2dSensorConfig& l = cfg->lidar2d;
    l.rate_hz = RateOr(r, m, l.rate_hz, cfg->physics_rate_hz);
    if (const auto b = m.Find("beams")) l.beams = ReadCount(r, *b);
    if (const auto v = m.Find("fov")) l.fov_rad = ReadPositive(r, *v);
    l.range_min = NonNegativeOr(r, m, "range_min", l.range_min);
    if (const auto v = m.Find("range_max")) l.range_max = ReadPositive(r, *v);
    l.range_noise = NonNegativeOr(r, m, "range_noise", l.range_noise);
    l.dropout = NonNegativeOr(r, m, "dropout", l.dropout);
    if (l.dropout > 1) r.Fail(*m.Find("dropout"), "a probability must be <= 1");
  }
  if (const auto f = top.Find("imu")) {
    const CheckedMap m(r, *f, {"rate", "gyro_noise_density", "gyro_bias", "accel_noise_density",
                               "accel_bias", "gyro_scale", "time_offset"});
    ImuSensorConfig& i = cfg->imu;
    i.rate_hz = RateOr(r, m, i.rate_hz, cfg->physics_rate_hz);
    i.gyro_noise_density = NonNegativeOr(r, m, "gyro_noise_density", i.gyro_noise_density);
    i.gyro_bias = NumberOr(r, m, "gyro_bias", i.gyro_bias);
    i.accel_noise_density = NonNegativeOr(r, m, "accel_noise_density", i.accel_noise_density);
    i.accel_bias = NumberOr(r, m, "accel_bias", i.accel_bias);
    if (const auto v = m.Find("gyro_scale")) i.gyro_scale = ReadPositive(r, *v);
    i.time_offset_s = NumberOr(r, m, "time_offset", i.time_offset_s);
    if (std::abs(i.time_offset_s) > 0.1)
      r.Fail(*m.Find("time_offset"), "an IMU time offset must be within 0.1 s");
  }
  if (const auto f = top.Find("lidar3d")) {
    const CheckedMap m(r, *f, {"rate", "rings", "elevation_min", "elevation_max",
                               "points_per_ring", "range_max", "range_noise", "body", "turret"});
    Lidar3dSensorConfig& l = cfg->lidar3d;
    l.rate_hz = RateOr(r, m, l.rate_hz, cfg->physics_rate_hz);
    if (const auto v = m.Find("rings")) l.rings = ReadCount(r, *v);
    l.elevation_min_rad = NumberOr(r, m, "elevation_min", l.elevation_min_rad);
    l.elevation_max_rad = NumberOr(r, m, "elevation_max", l.elevation_max_rad);
    if (const auto v = m.Find("points_per_ring")) l.points_per_ring = ReadCount(r, *v);
    if (const auto v = m.Find("range_max")) l.range_max = ReadPositive(r, *v);
    l.range_noise = NonNegativeOr(r, m, "range_noise", l.range_noise);
    if (const auto b = m.Find("body")) {
      const CheckedMap box(r, *b, {"min", "max"});
      l.body.min = ReadVector3(r, box.Get("min"));
      l.body.max = ReadVector3(r, box.Get("max"));
    }
    if (const auto t = m.Find("turret")) {
      const CheckedMap turret(r, *t, {"rate", "speed", "start", "axis_pitch", "axis_roll"});
      l.turret_rate_hz = RateOr(r, turret, l.turret_rate_hz, cfg->physics_rate_hz);
      l.turret_speed = NumberOr(r, turret, "speed", l.turret_speed);
      l.turret_start = NumberOr(r, turret, "start", l.turret_start);
      l.turret_axis_pitch = NumberOr(r, turret, "axis_pitch", l.turret_axis_pitch);
      l.turret_axis_roll = NumberOr(r, turret, "axis_roll", l.turret_axis_roll);
      if (l.turret_rate_hz > 0 && !(cfg->robot.lidar3d && cfg->robot.lidar3d->rotation))
        r.Fail(*t, "a turret needs lidar3d.rotation in the robot file (the channel of its angle)");
    }
  }
  if (const auto f = top.Find("pose")) {
    const CheckedMap m(r, *f, {"rate", "noise_xy", "noise_theta"});
    cfg->pose.rate_hz = RateOr(r, m, cfg->pose.rate_hz, cfg->physics_rate_hz);
    cfg->pose.noise_xy = NonNegativeOr(r, m, "noise_xy", cfg->pose.noise_xy);
    cfg->pose.noise_theta = NonNegativeOr(r, m, "noise_theta", cfg->pose.noise_theta);
  }
  if (const auto f = top.Find("ground_truth")) {
    const CheckedMap m(r, *f, {"rate"});
    cfg->ground_truth_rate_hz = RateOr(r, m, cfg->ground_truth_rate_hz, cfg->physics_rate_hz);
  }
}

// An effect's `region: [x0, y0, x1, y1]` (world frame, m; x0 < x1, y0 < y1), if given.
std::optional<std::array<double, 4>> ReadRegion(const Reporter& r, const CheckedMap& m) {
  const auto f = m.Find("region");
  if (!f) return std::nullopt;
  if (!f->value.IsSequence() || f->value.size() != 4) r.Fail(*f, "expected [x0, y0, x1, y1] (m, world frame)");
  std::array<double, 4> box{};
  for (int i = 0; i < 4; ++i) box[i] = ReadNumber(r, Field{f->path, f->line, f->value[i]});
  if (!(box[0] < box[2] && box[1] < box[3])) r.Fail(*f, "a region needs x0 < x1 and y0 < y1");
  return box;
}

// Effects of spec/effects.md with their parameter keys; `wheel` picks one wheel.
void ReadEffects(const Reporter& r, const Field& field, SimConfig* cfg) {
  const CheckedMap top(r, field,
                       {"time_offset", "scan_distortion", "longitudinal_slip", "lateral_slip",
                        "steering_lag", "steering_backlash", "wheel_eccentricity", "drive_lag",
                        "steering_rate_limit"});
  SimEffects& fx = cfg->effects;
  const auto& roles = WheelRoles(cfg->robot.drive);
  auto wheel = [&](const CheckedMap& m) -> std::string {
    const auto f = m.Find("wheel");
    if (!f) return "";
    const std::string role = ReadString(r, *f);
    if (std::find(roles.begin(), roles.end(), role) == roles.end())
      r.Fail(*f, "no wheel role '" + role + "' on a " + DriveTypeName(cfg->robot.drive) + " drive");
    return role;
  };
  const bool steered = cfg->robot.drive != DriveType::kDifferential;
  auto require_steering = [&](const Field& f) {
    if (!steered) r.Fail(f, "a differential drive has no steering");
  };
  // The steering effects share one wheel selection (SimEffects::steering_wheel):
  // a second one that names other wheels would silently override the first.
  std::optional<Field> steering_wheel_from;
  auto steering_wheel = [&](const CheckedMap& m, const Field& f) {
    const std::string role = wheel(m);
    if (steering_wheel_from && role != fx.steering_wheel) {
      auto describe = [](const std::string& w) {
        return w.empty() ? std::string("every steered wheel") : "wheel " + w;
      };
      r.Fail(f, "steering effects must act on the same wheels: this one acts on " +
                    describe(role) + ", " + steering_wheel_from->path + " (line " +
                    std::to_string(steering_wheel_from->line) + ") on " +
                    describe(fx.steering_wheel));
    }
    steering_wheel_from = f;
    fx.steering_wheel = role;
  };
  if (const auto f = top.Find("time_offset")) {
    const CheckedMap m(r, *f, {"offset_s"});
    fx.time_offset_s = ReadNumber(r, m.Get("offset_s"));
  }
  if (const auto f = top.Find("scan_distortion")) {
    const CheckedMap m(r, *f, {"scan_period_s"});
    const Field period = m.Get("scan_period_s");
    fx.scan_distortion_period_s = ReadPositive(r, period);
    // The simulator takes a scan's beams before it emits the scan, one scan
    // period after its start; beams spread beyond that would overlap the next scan.
    if (cfg->robot.lidar2d && cfg->lidar2d.rate_hz > 0 &&
        *fx.scan_distortion_period_s > 1.0 / cfg->lidar2d.rate_hz + 1e-9)
      r.Fail(period, "must not exceed the time between scans (1 / sensors.lidar2d.rate = " +
                         Format(1.0 / cfg->lidar2d.rate_hz) + " s)");
  }
  if (const auto f = top.Find("longitudinal_slip")) {
    const CheckedMap m(r, *f, {"slip_per_accel", "wheel", "region"});
    fx.longitudinal_slip_per_accel = ReadNumber(r, m.Get("slip_per_accel"));
    fx.longitudinal_slip_wheel = wheel(m);
    fx.longitudinal_slip_region = ReadRegion(r, m);
  }
  if (const auto f = top.Find("lateral_slip")) {
    const CheckedMap m(r, *f, {"gain", "region"});
    fx.lateral_slip_gain = ReadNumber(r, m.Get("gain"));
    fx.lateral_slip_region = ReadRegion(r, m);
  }
  if (const auto f = top.Find("steering_lag")) {
    require_steering(*f);
    const CheckedMap m(r, *f, {"tau_s", "wheel"});
    fx.steering_lag_tau_s = ReadPositive(r, m.Get("tau_s"));
    steering_wheel(m, *f);
  }
  if (const auto f = top.Find("steering_backlash")) {
    require_steering(*f);
    const CheckedMap m(r, *f, {"width_rad", "wheel"});
    fx.steering_backlash_width_rad = ReadPositive(r, m.Get("width_rad"));
    steering_wheel(m, *f);
  }
  if (const auto f = top.Find("wheel_eccentricity")) {
    const CheckedMap m(r, *f, {"amplitude", "phase", "wheel"});
    fx.eccentricity_amplitude = ReadNumber(r, m.Get("amplitude"));
    fx.eccentricity_phase = NumberOr(r, m, "phase", 0.0);
    fx.eccentricity_wheel = wheel(m);
  }
  if (const auto f = top.Find("drive_lag")) {
    const CheckedMap m(r, *f, {"tau_s"});
    fx.drive_lag_tau_s = ReadPositive(r, m.Get("tau_s"));
  }
  if (const auto f = top.Find("steering_rate_limit")) {
    require_steering(*f);
    const CheckedMap m(r, *f, {"rate_rad_s", "wheel"});
    fx.steering_rate_limit_rad_s = ReadPositive(r, m.Get("rate_rad_s"));
    steering_wheel(m, *f);
  }
}

// `terms:` (core/physics_terms.h): a list of {channel, regressor, coefficient}.
void ReadTerms(const Reporter& r, const Field& field, SimConfig* cfg) {
  if (!field.value.IsSequence()) r.Fail(field, "expected a list of {channel, regressor, coefficient}");
  for (std::size_t k = 0; k < field.value.size(); ++k) {
    const Field item{field.path + "[" + std::to_string(k) + "]", std::max(field.line, yaml::LineOf(field.value[k].Mark())), field.value[k]};
    const CheckedMap m(r, item, {"channel", "regressor", "coefficient"});
    PhysicsTerm term;
    const Field channel = m.Get("channel");
    if (!ParseTermChannel(ReadString(r, channel), &term.channel))
      r.Fail(channel, "expected yaw_rate, radius, steer or timing");
    if (term.channel == TermChannel::kSteer && cfg->robot.drive == DriveType::kDifferential)
      r.Fail(channel, "a differential drive has no steering");
    const Field regressor = m.Get("regressor");
    term.regressor = ReadString(r, regressor);
    if (!FindTermRegressor(term.regressor)) {
      std::vector<std::string> names;
      for (const TermRegressor& t : TermRegressors()) names.push_back(t.name);
      r.Fail(regressor, "unknown regressor '" + term.regressor + "' (known: " + yaml::Join(names, ", ") + ")");
    }
    term.coefficient = ReadNumber(r, m.Get("coefficient"));
    cfg->terms.push_back(term);
  }
}

}  // namespace

SimConfig ParseSimConfig(const std::string& yaml_text, const std::string& origin,
                         const std::string& base_dir) {
  const Reporter r(origin);
  const Field root = yaml::ParseSingleDocument(r, yaml_text, "simulation config");
  const CheckedMap top(r, root, {"robot", "seed", "world", "start", "start_utime", "physics_step",
                                 "commands", "truth", "sensors", "effects", "terms"});
  SimConfig cfg;
  cfg.source_file = origin;
  const Field robot_field = top.Get("robot", "path of the robot file");
  std::filesystem::path robot_path = ReadString(r, robot_field);
  if (robot_path.is_relative()) robot_path = std::filesystem::path(base_dir) / robot_path;
  cfg.robot = LoadRobotFile(robot_path.lexically_normal().string());
  // Truth starts at the nominal values: a config states only what differs.
  cfg.true_params = cfg.robot.params;
  if (cfg.robot.lidar2d) cfg.true_lidar2d = *cfg.robot.lidar2d;
  if (cfg.robot.lidar3d) cfg.true_lidar3d = *cfg.robot.lidar3d;
  if (cfg.robot.imu) cfg.true_imu = *cfg.robot.imu;
  if (cfg.robot.pose) cfg.true_pose = *cfg.robot.pose;

  if (const auto f = top.Find("seed")) {
    const double seed = ReadNumber(r, *f);
    // Up to 2^53: every whole number a YAML double holds exactly (and no overflow of uint64).
    if (seed < 0 || seed != std::floor(seed) || seed > 9007199254740992.0)
      r.Fail(*f, "a seed is a whole number from 0 to 2^53");
    cfg.seed = static_cast<uint64_t>(seed);
  }
  if (const auto f = top.Find("world")) {
    std::string world = ReadString(r, *f);
    // A bare name without extension is a bundled world (World::Load); anything
    // else is a file, relative to this config like the robot file.
    const std::filesystem::path world_path(world);
    const bool bundled = world.find('/') == std::string::npos && world_path.extension().empty();
    if (!bundled && world_path.is_relative())
      world = (std::filesystem::path(base_dir) / world_path).lexically_normal().string();
    cfg.world = world;
    // Fail here, at the key, rather than when a simulator is built.
    try {
      World::Load(world);
    } catch (const InputError& e) {
      r.Fail(*f, e.what());
    }
  }
  if (const auto f = top.Find("start")) {
    const CheckedMap m(r, *f, {"x", "y", "theta"});
    cfg.start = {NumberOr(r, m, "x", 0.0), NumberOr(r, m, "y", 0.0), NumberOr(r, m, "theta", 0.0)};
  }
  if (const auto f = top.Find("start_utime"))
    cfg.start_utime = static_cast<int64_t>(ReadPositive(r, *f));
  if (const auto f = top.Find("physics_step")) {
    const double step = ReadPositive(r, *f);
    if (step < 1e-4 || step > 0.05) r.Fail(*f, "the physics step must be within 0.0001 .. 0.05 s");
    cfg.physics_rate_hz = 1.0 / step;
  }
  if (const auto f = top.Find("commands")) {
    const CheckedMap m(r, *f, {"rate", "between"});
    if (const auto v = m.Find("rate")) {
      cfg.command_rate_hz = ReadPositive(r, *v);
      if (cfg.command_rate_hz > cfg.physics_rate_hz * (1 + 1e-9))
        r.Fail(*v, "the command rate must be at most the physics rate (" + Format(cfg.physics_rate_hz) + " Hz)");
    }
    if (const auto v = m.Find("between")) {
      const std::string between = ReadString(r, *v);
      const auto named = CommandsBetweenNamed(between);
      if (!named) r.Fail(*v, "expected hold, ramp or continuous, got '" + between + "'");
      cfg.command_between = *named;
    }
  }
  if (const auto f = top.Find("truth")) ReadTruth(r, *f, &cfg);
  if (const auto f = top.Find("sensors")) ReadSensors(r, *f, &cfg);
  if (const auto f = top.Find("effects")) ReadEffects(r, *f, &cfg);
  if (const auto f = top.Find("terms")) ReadTerms(r, *f, &cfg);
  return cfg;
}

SimConfig LoadSimConfig(const std::string& path) {
  const std::string text = yaml::ReadTextFile(path, "simulation config");
  return ParseSimConfig(text, path, std::filesystem::path(path).parent_path().string());
}

}  // namespace calib
