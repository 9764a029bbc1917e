#include "calib/calibrate/recalibration.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <unsupported/Eigen/SpecialFunctions>
#include <yaml-cpp/yaml.h>

#include "calib/calibrate/calibration_data.h"
#include "calib/calibrate/recording_input.h"
#include "calib/calibrate/result_files.h"
#include "calib/core/errors.h"
#include "calib/core/statistics.h"
#include "calib/core/units.h"
#include "calib/io/atomic_file.h"
#include "calib/io/message_source.h"
#include "calib/io/messages.h"
#include "calib/match/scan_match.h"
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

// Wheel data kept either side of a segment, so that every motion inside is covered.
constexpr double kMarginS = 0.2;

double PositiveOr(const Reporter& r, const CheckedMap& map, const std::string& key, double fallback) {
  const auto f = map.Find(key);
  return f ? ReadPositive(r, *f) : fallback;
}

double LevelOr(const Reporter& r, const CheckedMap& map, const std::string& key, double fallback) {
  const auto f = map.Find(key);
  if (!f) return fallback;
  const double v = ReadNumber(r, *f);
  if (!(v > 0.0 && v < 0.5)) r.Fail(*f, "a test level must lie in (0, 0.5), got " + yaml::Describe(f->value));
  return v;
}

int CountOr(const Reporter& r, const CheckedMap& map, const std::string& key, int fallback, int min) {
  const auto f = map.Find(key);
  if (!f) return fallback;
  const double v = ReadNumber(r, *f);
  if (v != std::floor(v) || v < min || v > 1e6)
    r.Fail(*f, "must be a whole number >= " + std::to_string(min) + ", got " + yaml::Describe(f->value));
  return static_cast<int>(v);
}

Eigen::Vector2d ReadPoint(const Reporter& r, const Field& f) {
  if (!f.value.IsSequence() || f.value.size() != 2)
    r.Fail(f, "expected a point [x, y], got " + yaml::Describe(f.value));
  Eigen::Vector2d p;
  for (int i = 0; i < 2; ++i) p[i] = ReadNumber(r, Field{f.path, f.line, f.value[i]});
  return p;
}

Zone ReadZone(const Reporter& r, const Field& f) {
  const CheckedMap m(r, f, {"name", "polygon", "circle"});
  Zone zone;
  zone.name = ReadString(r, m.Get("name"));
  const auto polygon = m.Find("polygon");
  const auto circle = m.Find("circle");
  if (!polygon == !circle) r.Fail(f, "a zone has either a polygon or a circle");
  if (polygon) {
    if (!polygon->value.IsSequence() || polygon->value.size() < 3)
      r.Fail(*polygon, "expected a list of at least 3 points [x, y], got " + yaml::Describe(polygon->value));
    for (std::size_t i = 0; i < polygon->value.size(); ++i) {
      const YAML::Node point = polygon->value[i];
      zone.polygon.push_back(
          ReadPoint(r, Field{polygon->path + "[" + std::to_string(i) + "]",
                             yaml::LineOf(point.Mark()), point}));
    }
    double area = 0.0;
    for (std::size_t i = 0; i < zone.polygon.size(); ++i) {
      const Eigen::Vector2d& a = zone.polygon[i];
      const Eigen::Vector2d& b = zone.polygon[(i + 1) % zone.polygon.size()];
      area += a.x() * b.y() - b.x() * a.y();
    }
    if (std::abs(area) < 1e-6) r.Fail(*polygon, "the polygon encloses no area");
  } else {
    const CheckedMap c(r, *circle, {"x", "y", "radius"});
    zone.center = {ReadNumber(r, c.Get("x")), ReadNumber(r, c.Get("y"))};
    zone.radius = ReadPositive(r, c.Get("radius"));
  }
  return zone;
}

void ReadPriorMount(const Reporter& r, const CheckedMap& prior, const std::string& mount,
                    RecalConfig* config) {
  const auto f = prior.Find(mount);
  if (!f) return;
  const CheckedMap m(r, *f, {"x", "y", "yaw"});
  for (const char* axis : {"x", "y", "yaw"})
    if (const auto v = m.Find(axis)) config->prior_std[mount + "." + axis] = ReadPositive(r, *v);
}

RecalConfig ParseDocument(const Reporter& r, const Field& root) {
  RecalConfig config;
  const CheckedMap top(r, root, {"zones", "distance_windows", "segments", "decision", "prior_std"});
  if (top.Has("zones") == top.Has("distance_windows"))
    r.Fail(root.line, "", "give either zones or distance_windows (what starts a segment)");
  if (const auto f = top.Find("zones")) {
    if (!f->value.IsSequence() || f->value.size() == 0)
      r.Fail(*f, "expected a list of zones, got " + yaml::Describe(f->value));
    for (std::size_t i = 0; i < f->value.size(); ++i) {
      const YAML::Node z = f->value[i];
      const Field zf{f->path + "[" + std::to_string(i) + "]", yaml::LineOf(z.Mark()), z};
      config.zones.push_back(ReadZone(r, zf));
      for (std::size_t k = 0; k + 1 < config.zones.size(); ++k)
        if (config.zones[k].name == config.zones.back().name) r.Fail(zf, "zone name repeated");
    }
  }
  if (const auto f = top.Find("distance_windows")) {
    const CheckedMap m(r, *f, {"start_m", "length_m", "period_m"});
    DistanceWindows w;
    w.start_m = NumberOr(r, m, "start_m", 0.0);
    if (w.start_m < 0) r.Fail(*m.Find("start_m"), "must be >= 0");
    w.length_m = ReadPositive(r, m.Get("length_m"));
    w.period_m = NumberOr(r, m, "period_m", 0.0);
    if (w.period_m != 0.0 && w.period_m <= w.length_m)
      r.Fail(*m.Find("period_m"), "must exceed length_m (or be 0 for one window)");
    config.windows = w;
  }
  if (const auto f = top.Find("segments")) {
    const CheckedMap m(r, *f, {"min_duration_s", "max_duration_s", "min_distance_m", "max_pose_gap_s"});
    config.min_duration_s = PositiveOr(r, m, "min_duration_s", config.min_duration_s);
    config.max_duration_s = PositiveOr(r, m, "max_duration_s", config.max_duration_s);
    config.min_distance_m = NumberOr(r, m, "min_distance_m", config.min_distance_m);
    config.max_pose_gap_s = PositiveOr(r, m, "max_pose_gap_s", config.max_pose_gap_s);
    if (config.max_duration_s <= config.min_duration_s)
      r.Fail(f->line, f->path, "max_duration_s must exceed min_duration_s");
  }
  if (const auto f = top.Find("decision")) {
    const CheckedMap m(r, *f, {"segments", "holdout_every", "window_s", "alpha", "min_improvement",
                               "consistency_alpha"});
    config.holdout_every = CountOr(r, m, "holdout_every", config.holdout_every, 2);
    config.segments_per_decision = CountOr(r, m, "segments", config.segments_per_decision, 2);
    if (config.segments_per_decision < 2 * config.holdout_every)
      r.Fail(*f, "segments must be at least 2 x holdout_every (two held-out segments for the paired test)");
    config.window_s = PositiveOr(r, m, "window_s", config.window_s);
    config.alpha = LevelOr(r, m, "alpha", config.alpha);
    config.consistency_alpha = LevelOr(r, m, "consistency_alpha", config.consistency_alpha);
    config.min_improvement = NumberOr(r, m, "min_improvement", config.min_improvement);
    if (!(config.min_improvement >= 0.0 && config.min_improvement < 1.0))
      r.Fail(*m.Find("min_improvement"), "must lie in [0, 1)");
  }
  if (const auto f = top.Find("prior_std")) {
    const CheckedMap prior(r, *f, {"params", "lidar2d", "pose"});
    if (const auto p = prior.Find("params")) {
      if (!p->value.IsMap()) r.Fail(*p, "expected a map of parameter names to standard deviations");
      std::vector<std::string> known;
      for (DriveType type : {DriveType::kDifferential, DriveType::kTricycle, DriveType::kDualSteer})
        for (const std::string& name : ParamNames(type)) known.push_back(name);
      for (const auto& entry : p->value) {
        const Field v{p->path + "." + entry.first.Scalar(), yaml::LineOf(entry.first.Mark()), entry.second};
        if (std::find(known.begin(), known.end(), entry.first.Scalar()) == known.end()) {
          const std::string suggestion = yaml::Suggest(entry.first.Scalar(), known);
          r.Fail(v, "unknown drive parameter" + (suggestion.empty() ? "" : " (did you mean " + suggestion + "?)"));
        }
        config.prior_std[entry.first.Scalar()] = ReadPositive(r, v);
      }
    }
    ReadPriorMount(r, prior, "lidar2d", &config);
    ReadPriorMount(r, prior, "pose", &config);
  }
  return config;
}

// One-sided p-value P(T >= t) of Student's t with `dof` degrees of freedom.
double StudentUpperTail(double t, double dof) {
  if (std::isinf(t)) return t > 0 ? 0.0 : 1.0;
  const double tail = 0.5 * Eigen::numext::betainc(0.5 * dof, 0.5, dof / (dof + t * t));
  return t >= 0 ? tail : 1.0 - tail;
}

bool IsAngle(const std::string& name) {
  return name == "steer_offset" || name.find("_steer_offset") != std::string::npos ||
         (name.size() > 4 && name.compare(name.size() - 4, 4, ".yaw") == 0);
}

std::vector<std::string> ValueNames(DriveType drive, MotionSource source) {
  std::vector<std::string> names = ParamNames(drive);
  for (const char* axis : {".x", ".y", ".yaw"}) names.push_back(MotionSourceName(source) + std::string(axis));
  return names;
}

// The calibration as the robot file holds it once written (result_files.h): each value rounded
// to its sigma, the sigma to two digits, no correlations; so a restart from that file goes on
// bit for bit as this run does.
CalibrationInUse AsWrittenToRobotFile(const CalibrationInUse& c) {
  CalibrationInUse out = c;
  const int k = static_cast<int>(c.names.size());
  out.covariance = Eigen::MatrixXd::Zero(k, k);
  for (int i = 0; i < k; ++i) {
    const double sigma = std::sqrt(c.covariance(i, i));
    out.value[i] = std::strtod(RoundedToSigma(c.value[i], sigma).c_str(), nullptr);
    const double written_sigma =
        DecimalsForSigma(sigma) >= 0 ? std::strtod(RoundedToSigma(sigma, sigma).c_str(), nullptr) : sigma;
    out.covariance(i, i) = written_sigma * written_sigma;
    const std::string& name = c.names[i];
    const auto dot = name.find('.');
    if (dot == std::string::npos) {
      out.robot.params[name] = out.value[i];
      continue;
    }
    std::optional<Mount2d>& m = name.compare(0, dot, "pose") == 0 ? out.robot.pose : out.robot.lidar2d;
    const std::string axis = name.substr(dot + 1);
    (axis == "x" ? m->x : axis == "y" ? m->y : m->yaw) = out.value[i];
  }
  return out;
}

// The candidate from a fit: the in-use robot with the fitted values and the fit's covariance.
CalibrationInUse CandidateOf(const CalibrationInUse& in_use, const CalibrationResult& fit, int number) {
  CalibrationInUse c;
  c.robot = Calibrated(in_use.robot, fit);
  c.names = in_use.names;
  const int k = static_cast<int>(c.names.size());
  c.value.resize(k);
  c.covariance.resize(k, k);
  std::vector<int> index(k);
  for (int i = 0; i < k; ++i) {
    const auto it = std::find(fit.estimated_names.begin(), fit.estimated_names.end(), c.names[i]);
    index[i] = static_cast<int>(it - fit.estimated_names.begin());
    const int nparams = static_cast<int>(fit.param_names.size());
    c.value[i] = i < nparams ? fit.params.at(c.names[i]).value
                 : i == nparams ? fit.mount_x.value
                 : i == nparams + 1 ? fit.mount_y.value : fit.mount_yaw.value;
  }
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) c.covariance(i, j) = fit.covariance(index[i], index[j]);
  c.origin = "recalibration decision " + std::to_string(number);
  return c;
}

nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

nlohmann::json ValuesJson(const CalibrationInUse& c) {
  nlohmann::json j = nlohmann::json::object();
  for (std::size_t i = 0; i < c.names.size(); ++i)
    j[c.names[i]] = {{"value", Number(c.value[i])}, {"std", Number(std::sqrt(c.covariance(i, i)))}};
  return j;
}

nlohmann::json SegmentsJson(const std::vector<Segment>& segments) {
  nlohmann::json j = nlohmann::json::array();
  for (const Segment& s : segments) {
    j.push_back({{"index", s.index}, {"trigger", s.trigger}, {"utime_start", s.utime_start},
                 {"utime_end", s.utime_end}, {"distance_m", s.distance_m}});
  }
  return j;
}

}  // namespace

bool Zone::Contains(double x, double y) const {
  if (polygon.empty()) return (Eigen::Vector2d(x, y) - center).norm() <= radius;
  bool inside = false;  // even-odd rule
  for (std::size_t i = 0, j = polygon.size() - 1; i < polygon.size(); j = i++) {
    const Eigen::Vector2d& a = polygon[i];
    const Eigen::Vector2d& b = polygon[j];
    if ((a.y() > y) != (b.y() > y) && x < (b.x() - a.x()) * (y - a.y()) / (b.y() - a.y()) + a.x())
      inside = !inside;
  }
  return inside;
}

RecalConfig ParseRecalConfig(const std::string& yaml_text, const std::string& origin) {
  const Reporter reporter(origin);
  const Field root = yaml::ParseSingleDocument(reporter, yaml_text, "recalibration config");
  try {
    RecalConfig config = ParseDocument(reporter, root);
    config.source_file = origin;
    return config;
  } catch (const YAML::Exception& e) {  // Not expected: every access is checked first.
    reporter.Fail(yaml::LineOf(e.mark), "", std::string("YAML error: ") + e.what());
  }
}

RecalConfig LoadRecalConfig(const std::string& path) {
  return ParseRecalConfig(yaml::ReadTextFile(path, "recalibration config"), path);
}

// --- SegmentRecorder

SegmentRecorder::SegmentRecorder(const RecalConfig& config, const RobotDescription& robot,
                                 MotionSource source)
    : config_(config), source_(source), model_(MakeDriveModel(robot)) {}

SegmentRecorder::~SegmentRecorder() = default;

void SegmentRecorder::Open(int64_t utime, const std::string& trigger) {
  open_ = Segment{};
  open_->trigger = trigger;
  open_->utime_start = open_->utime_end = utime;
}

void SegmentRecorder::Close(int64_t utime) {
  if (!open_) return;
  open_->utime_end = utime;
  const double duration = (open_->utime_end - open_->utime_start) * 1e-6;
  if (duration >= config_.min_duration_s && open_->distance_m >= config_.min_distance_m)
    closed_.push_back(*open_);
  else
    ++dropped_;
  open_.reset();
}

void SegmentRecorder::AddWheels(const WheelSample& sample) {
  if (!wheels_.empty() && sample.utime <= wheels_.back().utime) return;  // as WheelTrack does
  if (config_.windows && !wheels_.empty()) {
    const WheelSample& prev = wheels_.back();
    WheelIncrement inc;
    for (std::size_t w = 0; w < sample.position.size(); ++w) {
      inc.rotation.push_back(sample.position[w] - prev.position[w]);
      inc.steer_start.push_back(prev.steer[w]);
      inc.steer_end.push_back(sample.steer[w]);
    }
    const Pose2 step = model_->Integrate(inc);
    const double d = std::hypot(step.x, step.y);
    distance_m_ += d;
    if (open_) open_->distance_m += d;
    const DistanceWindows& w = *config_.windows;
    const double into = distance_m_ - w.start_m;
    const int k = into < 0 ? -1 : w.period_m > 0 ? static_cast<int>(std::floor(into / w.period_m)) : 0;
    const bool inside = k >= 0 && into - k * w.period_m < w.length_m;
    const std::string trigger = "window " + std::to_string(k);
    if (open_ && (!inside || open_->trigger != trigger)) Close(sample.utime);
    if (inside && !open_) Open(sample.utime, trigger);
  }
  wheels_.push_back(sample);
  // Zone segments are cut on the POSE stream only, so the cut does not depend on interleaving.
  if (config_.windows && open_ && (sample.utime - open_->utime_start) * 1e-6 >= config_.max_duration_s) {
    const std::string trigger = open_->trigger;
    Close(sample.utime);
    Open(sample.utime, trigger);
  }
  Update();
}

void SegmentRecorder::AddMotion(const SensorMotion& motion) {
  if (!motions_.empty() && motion.utime_start < motions_.back().utime_start) return;
  motions_.push_back(motion);
  Update();
}

void SegmentRecorder::AddPose(const StampedPose& pose) {
  if (last_pose_ && pose.utime <= last_pose_->utime) return;
  if (source_ == MotionSource::kPose) {
    if (std::optional<SensorMotion> motion = pose_intervals_.Add(pose)) motions_.push_back(*motion);
  }
  if (!config_.zones.empty()) {
    if (open_ && last_pose_ && (pose.utime - last_pose_->utime) * 1e-6 > config_.max_pose_gap_s)
      Close(last_pose_->utime);
    const Zone* zone = nullptr;
    for (const Zone& z : config_.zones) {
      if (z.Contains(pose.x, pose.y)) {
        zone = &z;
        break;
      }
    }
    if (open_ && (!zone || zone->name != open_->trigger)) Close(last_pose_->utime);
    if (open_ && (pose.utime - open_->utime_start) * 1e-6 >= config_.max_duration_s) Close(pose.utime);
    if (open_) open_->distance_m += std::hypot(pose.x - last_pose_->x, pose.y - last_pose_->y);
    if (zone && !open_) Open(pose.utime, zone->name);
  }
  last_pose_ = pose;
  Update();
}

void SegmentRecorder::Update() {
  if (wheels_.empty()) return;
  const int64_t now = wheels_.back().utime;
  const int64_t margin = static_cast<int64_t>(kMarginS * 1e6);
  const int64_t lookback = static_cast<int64_t>(kLookbackS * 1e6);
  // A closed segment is complete once the wheels are past it and the motions (which lag the
  // wheels a little) are too, or, should they stop, the wheels are well past it.
  while (!closed_.empty()) {
    const Segment& s = closed_.front();
    const bool motions_past = !motions_.empty() && motions_.back().utime_start >= s.utime_end;
    if (now < s.utime_end + margin || !(motions_past || now >= s.utime_end + lookback)) break;
    SegmentData data;
    data.segment = s;
    data.segment.index = next_index_++;
    for (const WheelSample& w : wheels_)
      if (w.utime >= s.utime_start - margin && w.utime <= s.utime_end + margin) data.wheels.push_back(w);
    for (const SensorMotion& m : motions_)
      if (m.utime_start >= s.utime_start && m.utime_end <= s.utime_end) data.motions.push_back(m);
    complete_.push_back(std::move(data));
    closed_.pop_front();
  }
  // Keep what an open or waiting segment may need, and the last few seconds.
  int64_t keep = now - lookback;
  if (open_) keep = std::min(keep, open_->utime_start);
  if (!closed_.empty()) keep = std::min(keep, closed_.front().utime_start);
  keep -= margin;
  while (wheels_.size() > 1 && wheels_.front().utime < keep) wheels_.pop_front();
  while (motions_.size() > 1 && motions_.front().utime_start < keep) motions_.pop_front();
}

std::optional<SegmentBatch> SegmentRecorder::TakeBatch() {
  if (static_cast<int>(complete_.size()) < config_.segments_per_decision) return std::nullopt;
  SegmentBatch batch;
  batch.number = ++batches_;
  for (int i = 0; i < config_.segments_per_decision; ++i) {
    batch.segments.push_back(std::move(complete_.front()));
    complete_.pop_front();
  }
  return batch;
}

// --- The calibration in use

CalibrationInUse CalibrationFromRobot(const RobotDescription& robot, MotionSource source,
                                      const RecalConfig& config) {
  const std::string mount = MotionSourceName(source);
  const std::optional<Mount2d>& m = source == MotionSource::kPose ? robot.pose : robot.lidar2d;
  if (!m) throw InputError(robot.source_file, mount, "the robot has no " + mount + " mount to recalibrate");
  CalibrationInUse c;
  c.robot = robot;
  c.names = ValueNames(robot.drive, source);
  const int k = static_cast<int>(c.names.size());
  c.value.resize(k);
  for (int i = 0; i < k - 3; ++i) c.value[i] = robot.params.at(c.names[i]);
  c.value.tail<3>() << m->x, m->y, m->yaw;
  // std: of a calibrated robot file (spec/robot.md), else the config's prior.
  YAML::Node stds_file;
  if (!robot.source_file.empty()) {
    try {
      const YAML::Node root = YAML::LoadFile(robot.source_file);
      if (root.IsMap() && root["std"]) stds_file = root["std"];
    } catch (const YAML::Exception&) {
      // The robot file was read before; a file that changed since has no usable std:.
    }
  }
  const YAML::Node& stds = stds_file;
  auto from_file = [&](const std::string& name) -> std::optional<double> {
    if (!stds.IsMap()) return std::nullopt;
    const auto dot = name.find('.');
    const YAML::Node group = stds[dot == std::string::npos ? "params" : name.substr(0, dot)];
    if (!group.IsMap()) return std::nullopt;
    const YAML::Node v = group[dot == std::string::npos ? name : name.substr(dot + 1)];
    if (!v.IsScalar()) return std::nullopt;
    try {
      const double s = v.as<double>();
      if (s > 0 && std::isfinite(s)) return s;
    } catch (const YAML::Exception&) {
    }
    return std::nullopt;
  };
  c.covariance = Eigen::MatrixXd::Zero(k, k);
  bool any_file = false, any_prior = false;
  for (int i = 0; i < k; ++i) {
    double s = 0.0;
    if (const auto f = from_file(c.names[i])) {
      s = *f;
      any_file = true;
    } else if (const auto it = config.prior_std.find(c.names[i]); it != config.prior_std.end()) {
      s = it->second;
      any_prior = true;
    } else {
      throw InputError(config.source_file, "prior_std",
                       "no uncertainty for " + c.names[i] + ": " + robot.source_file +
                           " has no std: for it; give it under prior_std");
    }
    c.covariance(i, i) = s * s;
  }
  c.origin = robot.source_file + (any_file ? (any_prior ? " (std: and prior_std)" : " (std:)") : " (prior_std)");
  return c;
}

CalibrationInUse StartingCalibration(const RobotDescription& robot, const std::string& robot_out,
                                     MotionSource source, const RecalConfig& config) {
  if (!robot_out.empty() && std::ifstream(robot_out).good())
    return CalibrationFromRobot(LoadRobotFile(robot_out), source, config);
  return CalibrationFromRobot(robot, source, config);
}

// --- The decision

ImprovementTest TestImprovement(const std::vector<double>& current,
                                const std::vector<double>& candidate, double alpha,
                                double min_improvement) {
  ImprovementTest t;
  t.current = current;
  t.candidate = candidate;
  const std::size_t n = std::min(current.size(), candidate.size());
  if (n < 2) return t;
  double sum_d = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    t.mean_current += current[k] / n;
    t.mean_candidate += candidate[k] / n;
    sum_d += current[k] - candidate[k];
  }
  const double mean_d = sum_d / n;
  double ss = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double e = current[k] - candidate[k] - mean_d;
    ss += e * e;
  }
  const double sd = std::sqrt(ss / (n - 1));
  t.t = sd > 0 ? mean_d / (sd / std::sqrt(double(n)))
               : (mean_d > 0 ? INFINITY : mean_d < 0 ? -INFINITY : 0.0);
  t.p = mean_d == 0.0 && sd == 0.0 ? 1.0 : StudentUpperTail(t.t, n - 1.0);
  t.relative = t.mean_current > 0 ? mean_d / t.mean_current : 0.0;
  t.significant = t.p < alpha && t.relative >= min_improvement;
  return t;
}

ConsistencyTest TestConsistency(const CalibrationInUse& in_use, const CalibrationInUse& candidate,
                                double alpha) {
  const int k = static_cast<int>(in_use.names.size());
  Eigen::VectorXd delta = candidate.value - in_use.value;
  for (int i = 0; i < k; ++i)
    if (IsAngle(in_use.names[i])) delta[i] = WrapAngle(delta[i]);
  const EstimateDifference d = CompareEstimates(delta, in_use.covariance + candidate.covariance, in_use.names);
  ConsistencyTest c;
  c.d2 = d.d2, c.dof = d.dof, c.p = d.p, c.largest = d.largest, c.largest_sigmas = d.largest_sigmas;
  c.consistent = c.p >= alpha;
  return c;
}

const char* VerdictName(Verdict verdict) {
  switch (verdict) {
    case Verdict::kAccepted: return "accepted";
    case Verdict::kRejected: return "rejected";
    case Verdict::kNoFit: return "no_fit";
  }
  return "?";
}

RecalDecision Decide(const SegmentBatch& batch, const CalibrationInUse& in_use,
                     MotionSource source, const RecalConfig& config) {
  RecalDecision d;
  d.number = batch.number;
  d.in_use = d.after = in_use;
  if (!batch.segments.empty()) d.utime = batch.segments.back().segment.utime_end;
  // One track for all segments (they do not overlap; a sample repeated at a boundary is
  // refused), and the motions of the fit segments.
  WheelTrack track;
  std::vector<SensorMotion> fit_motions;
  std::vector<const SegmentData*> heldout;
  for (std::size_t i = 0; i < batch.segments.size(); ++i) {
    const SegmentData& s = batch.segments[i];
    for (const WheelSample& w : s.wheels) track.Append(w);
    if (static_cast<int>(i) % config.holdout_every == config.holdout_every - 1) {
      heldout.push_back(&s);
      d.heldout.push_back(s.segment);
    } else {
      fit_motions.insert(fit_motions.end(), s.motions.begin(), s.motions.end());
      d.fit.push_back(s.segment);
    }
  }
  const std::string origin = "recalibration decision " + std::to_string(d.number);
  try {
    d.fit_result = Calibrate(in_use.robot, track, fit_motions, source, CalibrationOptions(), origin);
  } catch (const UnobservableError& e) {
    d.verdict = Verdict::kNoFit;
    d.reason = std::string("the fit segments cannot determine the calibration: ") + e.what() + "; " + e.remedy();
    return d;
  } catch (const InputError& e) {
    d.verdict = Verdict::kNoFit;
    d.reason = std::string("no calibration from the fit segments: ") + e.problem();
    return d;
  }
  d.candidate = CandidateOf(in_use, *d.fit_result, d.number);

  std::vector<double> current, candidate;
  for (const SegmentData* s : heldout) {
    current.push_back(EvaluateOdometry(in_use.robot, source, track, s->motions, config.window_s).error_per_metre);
    candidate.push_back(
        EvaluateOdometry(d.candidate->robot, source, track, s->motions, config.window_s).error_per_metre);
  }
  d.improvement = TestImprovement(current, candidate, config.alpha, config.min_improvement);
  d.consistency = TestConsistency(in_use, *d.candidate, config.consistency_alpha);

  const ImprovementTest& imp = *d.improvement;
  const ConsistencyTest& con = *d.consistency;
  const std::string heldout_text =
      "held-out odometry error " + Formatted("%.3g", imp.mean_current * 1e3) + " -> " + Formatted("%.3g", imp.mean_candidate * 1e3) +
      " mm/m over " + std::to_string(heldout.size()) + " segments (" + (imp.relative < 0 ? "+" : "") +
      Formatted("%.2g", -imp.relative * 100) +
      "%, t = " + Formatted("%.3g", imp.t) + ", " + PValueText(imp.p);
  const std::string consistency_text =
      "d2 = " + Formatted("%.3g", con.d2) + ", " + std::to_string(con.dof) + " dof, " + PValueText(con.p) +
      (con.consistent ? " >= " : " < ") + Formatted("%.3g", config.consistency_alpha) + "; largest change " +
      con.largest + " " + Formatted("%.2g", con.largest_sigmas) + " sigma";
  const std::string better = imp.significant
                                 ? "significantly better: " + heldout_text + " < " + Formatted("%.3g", config.alpha) + ")"
                                 : "not significantly better: " + heldout_text + "; needs p < " +
                                       Formatted("%.3g", config.alpha) + " and at least " +
                                       Formatted("%.3g", config.min_improvement * 100) + "% less error)";
  const std::string consistent =
      std::string(con.consistent ? "consistent" : "inconsistent") + " with the calibration in use: " + consistency_text;
  if (imp.significant && con.consistent) {
    d.verdict = Verdict::kAccepted;
    d.after = AsWrittenToRobotFile(*d.candidate);
    d.reason = better + "; " + consistent;
  } else {
    d.verdict = Verdict::kRejected;
    // The failed test first.
    d.reason = (imp.significant ? consistent + "; " + better : better + "; " + consistent) +
               "; the calibration in use is kept";
  }
  return d;
}

std::string DecisionJson(const RecalDecision& d) {
  nlohmann::json j;
  j["decision"] = d.number;
  j["utime"] = d.utime;
  j["verdict"] = VerdictName(d.verdict);
  j["reason"] = d.reason;
  j["segments"] = {{"fit", SegmentsJson(d.fit)}, {"heldout", SegmentsJson(d.heldout)}};
  j["in_use"] = ValuesJson(d.in_use);
  j["in_use_origin"] = d.in_use.origin;
  if (d.candidate) j["candidate"] = ValuesJson(*d.candidate);
  if (d.fit_result) {
    const ResidualSummary& r = d.fit_result->residual;
    j["fit"] = {{"intervals", r.intervals}, {"outliers", r.outliers}, {"degenerate", r.degenerate},
                {"invalid", r.invalid}, {"condition", Number(d.fit_result->condition)},
                {"weak", d.fit_result->weak}};
  }
  if (d.improvement) {
    const ImprovementTest& t = *d.improvement;
    j["improvement"] = {{"error_per_metre_in_use", t.current}, {"error_per_metre_candidate", t.candidate},
                        {"mean_in_use", t.mean_current}, {"mean_candidate", t.mean_candidate},
                        {"relative", t.relative}, {"t", Number(t.t)}, {"p", t.p},
                        {"significant", t.significant}};
  }
  if (d.consistency) {
    const ConsistencyTest& c = *d.consistency;
    j["consistency"] = {{"d2", Number(c.d2)}, {"dof", c.dof}, {"p", c.p}, {"consistent", c.consistent},
                        {"largest", c.largest}, {"largest_sigmas", Number(c.largest_sigmas)}};
  }
  return j.dump();
}

void RecordDecision(const RecalDecision& d, const std::string& robot_out,
                    const std::string& decisions_path) {
  // Both or neither: an accepted robot file without its decision line (or the line without
  // the file) would leave the two disagreeing about the calibration in use.
  Outputs outputs;
  if (d.verdict == Verdict::kAccepted && !robot_out.empty()) {
    std::string source = "recalibration decision " + std::to_string(d.number) + ", segments";
    for (const Segment& s : d.fit) source += " " + std::to_string(s.index);
    outputs.WriteFile(robot_out, CalibratedRobotYaml(d.in_use.robot, *d.fit_result, source, "recal"));
  }
  if (!decisions_path.empty()) outputs.AppendFile(decisions_path, DecisionJson(d) + "\n");
  outputs.Commit();
}

RecalRun RecalibrateLog(const RobotDescription& scan_robot, const CalibrationInUse& start,
                        const std::string& log_path, MotionSource source, const RecalConfig& config,
                        const std::function<void(const RecalDecision&)>& on_decision) {
  RecalRun run;
  run.in_use = start;
  SegmentRecorder recorder(config, scan_robot, source);
  std::optional<ScanMatcher> matcher;
  if (source == MotionSource::kLidar2d) matcher.emplace(scan_robot);
  auto add_matches = [&](const std::vector<ScanMatchOutcome>& outcomes) {
    for (const ScanMatchOutcome& outcome : outcomes) {
      // Through the message, as the live process receives it.
      if (outcome.matched()) recorder.AddMotion(FromMessage(ToMessage(outcome.motion), log_path));
    }
  };

  RecordingSource log(log_path);
  SubscribeWheels(&log, scan_robot, [&](const WheelSample& sample) {
    recorder.AddWheels(sample);
    if (matcher) add_matches(matcher->AddWheels(sample));
  });
  if (matcher)
    SubscribeScans(&log, ScanChannel(scan_robot), [&](LaserScan scan) { add_matches(matcher->AddScan(scan)); });
  SubscribePoses(&log, PoseChannel(scan_robot), [&](const StampedPose& pose) { recorder.AddPose(pose); });
  // A decision as soon as an event completes a batch of segments.
  while (log.HandleNext(0)) {
    while (std::optional<SegmentBatch> batch = recorder.TakeBatch()) {
      RecalDecision d = Decide(*batch, run.in_use, source, config);
      if (on_decision) on_decision(d);
      run.in_use = d.after;
      run.decisions.push_back(std::move(d));
    }
  }
  log.Finish();
  if (matcher) {
    add_matches(matcher->Finish());
    ReportScanMatching(*matcher, log_path, nullptr);
  }
  run.segments = recorder.segments_complete();
  run.dropped = recorder.segments_dropped();
  run.waiting = recorder.segments_waiting();
  return run;
}

}  // namespace calib
