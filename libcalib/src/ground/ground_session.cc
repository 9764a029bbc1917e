#include "calib/ground/ground_session.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

#include <nlohmann/json.hpp>

#include "calib/core/errors.h"
#include "calib/core/robot_file_edit.h"
#include "calib/core/units.h"
#include "calib/io/cloud_file.h"
#include "calib/io/message_source.h"
#include "io/provenance_json.h"

namespace calib {

namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

const Mount3d& RequireLidar3d(const RobotDescription& robot) {
  if (!robot.lidar3d)
    throw InputError(robot.source_file, "lidar3d",
                     "the robot file has no 3D lidar (lidar3d: {channel: CLOUD, z: ..., ...})");
  return *robot.lidar3d;
}

}  // namespace

GroundSession::GroundSession(const RobotDescription& robot, GroundOptions options)
    : calibrator_(RequireLidar3d(robot), std::move(options)),
      cloud_channel_(robot.lidar3d->channel) {
  if (robot.lidar3d->rotation) {
    angle_channel_ = robot.lidar3d->rotation->channel;
    max_age_s_ = robot.lidar3d->rotation->max_age_s;
  }
}

void GroundSession::OnMountAngle(const MountAngle& angle) {
  angles_.emplace_back(angle.utime, angle.angle);
  // Keep what a late cloud could still need: the last 5 s (robot clock).
  const int64_t oldest = angle.utime - 5000000;
  while (angles_.size() > 1 && (angles_.front().first < oldest || angles_.size() > 10000))
    angles_.pop_front();
}

const FrameFit* GroundSession::OnCloud(const PointCloud& cloud) {
  ++clouds_;
  last_utime_ = cloud.utime;
  double angle = 0.0;
  if (!angle_channel_.empty()) {
    const std::pair<int64_t, double>* best = nullptr;
    for (const auto& a : angles_)
      if (a.first <= cloud.utime && (!best || a.first >= best->first)) best = &a;
    if (!best || cloud.utime - best->first > static_cast<int64_t>(std::llround(max_age_s_ * 1e6))) {
      last_sector_ = -1;
      calibrator_.SkipFrame("no mount angle on " + angle_channel_ + " within " +
                            Formatted("%g", max_age_s_) + " s before the cloud");
      return nullptr;
    }
    angle = best->second;
    last_angle_ = angle;
    last_sector_ = calibrator_.SectorOf(angle);
  }
  return &calibrator_.AddFrame(cloud.xyz.data(), cloud.xyz.size() / 3, angle);
}

void GroundSession::Subscribe(MessageSource* source, std::function<void()> after_cloud) {
  SubscribeClouds(source, cloud_channel_, [this, after_cloud = std::move(after_cloud)](const PointCloud& cloud) {
    OnCloud(cloud);
    if (after_cloud) after_cloud();
  });
  if (!angle_channel_.empty())
    SubscribeMountAngles(source, angle_channel_, [this](const MountAngle& angle) { OnMountAngle(angle); });
}

GroundEstimate GroundSession::CurrentEstimate() const {
  GroundEstimate out;
  out.utime = last_utime_;
  out.frames_seen = calibrator_.frames_seen();
  out.sector = angle_channel_.empty() ? -1 : last_sector_;
  out.angle = angle_channel_.empty() ? 0.0 : last_angle_;
  out.num_sectors = calibrator_.num_sectors();
  for (int s = 0; s < calibrator_.num_sectors(); ++s) {
    try {
      calibrator_.Estimate(s);
      ++out.sectors_done;
    } catch (const UnobservableError&) {
    }
  }
  try {
    if (!angle_channel_.empty() && last_sector_ < 0) {
      out.status = "waiting: no mount angle for the newest cloud";
      return out;
    }
    const MountEstimate e = calibrator_.Estimate(angle_channel_.empty() ? -1 : last_sector_);
    out.status = "ok";
    out.frames = e.frames;
    out.inliers = e.inliers;
    out.z = e.value.z, out.pitch = e.value.pitch, out.roll = e.value.roll;
    out.z_std = e.std.z, out.pitch_std = e.std.pitch, out.roll_std = e.std.roll;
  } catch (const UnobservableError& e) {
    out.status = std::string("refused: ") + e.what();
  }
  return out;
}

GroundResult CalibrateGroundFile(const RobotDescription& robot, const GroundOptions& options,
                                 const std::string& path, bool with_grid, GroundInput* input) {
  GroundInput info;
  info.path = path;
  GroundSession session(robot, options);
  if (IsCloudFileName(path)) {
    if (robot.lidar3d->rotation)
      throw InputError(path, "", "a cloud file carries no mount angle, but the robot file's lidar3d "
                                 "rotates (lidar3d.rotation): calibrate from a recording");
    const CloudFileData data = ReadCloudFile(path);
    info.kind = data.format;
    info.clouds = 1;
    info.points = data.xyz.size() / 3;
    GroundCalibrator calibrator(*robot.lidar3d, options);
    calibrator.AddFrame(data.xyz.data(), data.xyz.size() / 3);
    if (input) *input = info;
    return calibrator.Result(with_grid);
  }
  info.kind = "log";
  RecordingSource source(path);
  session.Subscribe(&source);
  source.HandleAll();
  info.clouds = session.clouds();
  info.dropped = source.dropped();
  info.drop_notes = source.drop_notes();
  if (input) *input = info;
  if (session.clouds() == 0)
    throw InputError(path, "", "no messages on channel " + session.cloud_channel() +
                                   " (the robot file's lidar3d.channel)");
  return session.calibrator().Result(with_grid);
}

std::string GroundResultJson(const GroundResult& result, const GroundInput& input) {
  using nlohmann::json;
  auto estimate = [](const MountEstimate& e) {
    return json{{"z", {{"value", e.value.z}, {"std", e.std.z}}},
                {"pitch", {{"value", e.value.pitch}, {"std", e.std.pitch}}},
                {"roll", {{"value", e.value.roll}, {"std", e.std.roll}}}};
  };
  json out;
  out["lidar3d"] = estimate(result.lidar3d);
  out["frames"] = result.lidar3d.frames;
  out["inliers"] = result.lidar3d.inliers;
  // Extra keys (docs/ground.md).
  out["frames_seen"] = result.frames_seen;
  out["frames_unusable"] = result.frames_unusable;
  out["frames_tilted"] = result.lidar3d.frames_tilted;
  out["floor_rms_m"] = result.lidar3d.rms_m;
  out["birge_ratio"] = result.lidar3d.birge_ratio;
  if (result.grid) {
    const GridEstimate& g = *result.grid;
    out["grid"] = {{"z", g.pose.z},
                   {"pitch", g.pose.pitch},
                   {"roll", g.pose.roll},
                   {"height_error_m", g.height_error_m},
                   {"accepted", g.accepted},
                   {"rounds", g.rounds},
                   {"step", {{"z", g.step.z}, {"pitch", g.step.pitch}, {"roll", g.step.roll}}},
                   {"candidates", g.candidates_scored},
                   {"points", g.points}};
  }
  if (!result.sectors.empty()) {
    json sectors = json::array();
    for (const SectorEstimate& s : result.sectors) {
      json entry = estimate(s.estimate);
      entry["index"] = s.index;
      entry["angle_min"] = s.angle_min;
      entry["angle_max"] = s.angle_max;
      entry["angle_mean"] = s.angle_mean;
      entry["frames"] = s.estimate.frames;
      entry["inliers"] = s.estimate.inliers;
      sectors.push_back(entry);
    }
    out["sectors"] = sectors;
  }
  out["source"] = {{"path", input.path}, {"kind", input.kind}, {"clouds", input.clouds}};
  AddProvenance(&out);
  return out.dump(2) + "\n";
}

std::string GroundResultText(const GroundResult& result, const GroundInput& input) {
  std::ostringstream out;
  const MountEstimate& e = result.lidar3d;
  out << "3D lidar from " << input.kind << " " << input.path << ": " << result.frames_seen
      << " frames, " << result.frames_unusable << " unusable";
  if (!result.sectors.empty()) {
    int home = 0;
    for (const SectorEstimate& s : result.sectors)
      if (s.angle_min <= 0.0 && 0.0 < s.angle_max) home = s.index;
    out << "; " << result.sectors.size() << " sectors, below: sector " << home << " (holding angle 0)";
  }
  out << "; " << e.frames << " frames used, " << e.frames_tilted << " tilted, floor inliers "
      << Formatted("%.1f", 100 * e.inliers) << " %, floor RMS " << Formatted("%.1f", 1000 * e.rms_m) << " mm\n";
  out << "  robust fit (value ± 1 sigma)";
  if (result.grid)
    out << "; grid search (" << (result.grid->accepted ? "accepted" : "NOT accepted") << ", "
        << result.grid->rounds << " rounds, height error " << Formatted("%.1f", 1000 * result.grid->height_error_m)
        << " mm)";
  out << "\n";
  // Radians, the robot file's unit, with degrees beside (units.h); the grid column alike.
  auto row = [&](const char* name, double value, double sigma, double grid, double step, const char* unit) {
    out << "  " << name << "  " << EstimateText(value, sigma, unit);
    if (result.grid)
      out << "   grid " << QuantityText(grid, unit, 6) << ", step " << QuantityText(step, unit, 2);
    out << "\n";
  };
  const GridEstimate g = result.grid.value_or(GridEstimate{});
  row("z    ", e.value.z, e.std.z, g.pose.z, g.step.z, "m");
  row("pitch", e.value.pitch, e.std.pitch, g.pose.pitch, g.step.pitch, "rad");
  row("roll ", e.value.roll, e.std.roll, g.pose.roll, g.step.roll, "rad");
  if (e.birge_ratio > 1.0)
    out << "  (frames scatter " << Formatted("%.2f", e.birge_ratio)
        << " x their own sigmas; sigmas inflated by that)\n";
  if (!result.sectors.empty()) {
    out << "per sector: index   from deg    to deg  mean deg  frames       z m  pitch rad (deg)       roll rad (deg)\n";
    for (const SectorEstimate& s : result.sectors)
      out << "            " << Formatted("%5d", s.index) << Formatted("%11.2f", s.angle_min / kDeg)
          << Formatted("%10.2f", s.angle_max / kDeg) << Formatted("%10.2f", s.angle_mean / kDeg)
          << Formatted("%8d", s.estimate.frames) << Formatted("%10.5f", s.estimate.value.z)
          << Formatted("%10.6f", s.estimate.value.pitch) << Formatted(" (%7.4f)", s.estimate.value.pitch / kDeg)
          << Formatted("%11.6f", s.estimate.value.roll) << Formatted(" (%7.4f)", s.estimate.value.roll / kDeg) << "\n";
  }
  return out.str();
}

std::string GroundCalibratedRobotYaml(const RobotDescription& robot, const GroundResult& result,
                                      const std::string& source) {
  const MountEstimate& e = result.lidar3d;
  return WriteCalibratedRobotFile(robot.source_file,
                                  {{"lidar3d.z", e.value.z, e.std.z},
                                   {"lidar3d.pitch", e.value.pitch, e.std.pitch},
                                   {"lidar3d.roll", e.value.roll, e.std.roll}},
                                  "ground", source,
                                  ProvenanceText() + std::to_string(e.frames) + " frames of the recording combined");
}

}  // namespace calib
