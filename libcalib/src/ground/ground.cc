#include "calib/ground/ground.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "calib/core/errors.h"
#include "calib/core/units.h"
#include "ground/median.h"

namespace calib {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

Eigen::Vector3d PoseOf(const FrameFit& fit) { return Eigen::Vector3d(fit.pose.z, fit.pose.pitch, fit.pose.roll); }

// Why none of `offered` frames shows enough floor: the most common problem
// (`problems`, grouped by their wording up to the numbers) and its first
// instance among `failed`, the unusable frames' problems in order.
std::string NoFloorReason(const std::map<std::string, int>& problems,
                          const std::vector<const std::string*>& failed, int offered) {
  const auto worst = std::max_element(problems.begin(), problems.end(),
                                      [](const auto& a, const auto& b) { return a.second < b.second; });
  std::string example;
  for (const std::string* problem : failed)
    if (problem->compare(0, worst->first.size(), worst->first) == 0) {
      example = *problem;
      break;
    }
  return "none of " + std::to_string(offered) + " frames shows enough floor (" +
         std::to_string(worst->second) + " of them: " + example + ")";
}

struct LevelFrames {
  std::vector<size_t> level;  // indices of the frames level with the others
  double worst_tilt = 0.0, worst_height = 0.0;  // the largest deviations of the others
};

// Frames whose floor tilts against the others: the robot stood on a slope or a bump.
// Deviation from the median, after an unweighted straight-line trend in the angle
// offsets (turning lidar, `trend`).
LevelFrames FindLevelFrames(const std::vector<const FrameFit*>& fits, const std::vector<double>& offsets,
                            bool trend, const FrameOptions& fo) {
  Eigen::Vector3d slope0 = Eigen::Vector3d::Zero();
  if (trend) {
    double sa = 0, saa = 0;
    Eigen::Vector3d sx = Eigen::Vector3d::Zero(), sax = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < fits.size(); ++k) {
      const double da = offsets[k];
      sa += da, saa += da * da, sx += PoseOf(*fits[k]), sax += da * PoseOf(*fits[k]);
    }
    const double nf = static_cast<double>(fits.size()), det = nf * saa - sa * sa;
    if (det > 1e-12) slope0 = (nf * sax - sa * sx) / det;
  }
  std::vector<double> zs, pitches, rolls;
  for (size_t k = 0; k < fits.size(); ++k) {
    const Eigen::Vector3d p = PoseOf(*fits[k]) - offsets[k] * slope0;
    zs.push_back(p[0]), pitches.push_back(p[1]), rolls.push_back(p[2]);
  }
  const double mz = Median(zs), mp = Median(pitches), mr = Median(rolls);
  LevelFrames out;
  for (size_t k = 0; k < fits.size(); ++k) {
    const double tilt = std::max(std::abs(pitches[k] - mp), std::abs(rolls[k] - mr));
    const double height = std::abs(zs[k] - mz);
    if (tilt > fo.max_tilt_rad || height > fo.max_height_m) {
      out.worst_tilt = std::max(out.worst_tilt, tilt);
      out.worst_height = std::max(out.worst_height, height);
    } else {
      out.level.push_back(k);
    }
  }
  return out;
}

// Inverse-covariance weighted least squares of the frames' poses on
// [I, da I, da^2 I] (a constant; for a turning lidar, `trend`, also the trend
// and its curvature, so the constant is the pose at the mean angle, da being
// the frames' `offsets` from it); the covariance is inflated by the scatter
// about it (Birge ratio) when > 1.
MountEstimate WeightedMount(const std::vector<const FrameFit*>& fits, const std::vector<double>& offsets,
                            bool trend) {
  const int order = !trend ? 0 : fits.size() >= 4 ? 2 : fits.size() >= 3 ? 1 : 0;
  const int unknowns = 3 * (order + 1);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(unknowns, unknowns);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(unknowns);
  std::vector<Eigen::Matrix3d> weights;
  weights.reserve(fits.size());
  long points = 0, inliers = 0;
  double sum_r2 = 0.0;
  for (size_t k = 0; k < fits.size(); ++k) {
    const FrameFit& f = *fits[k];
    const Eigen::Matrix3d w = f.cov.inverse();
    weights.push_back(w);
    const double da = offsets[k];
    Eigen::MatrixXd j(3, unknowns);
    for (int o = 0; o <= order; ++o) j.middleCols<3>(3 * o) = std::pow(da, o) * Eigen::Matrix3d::Identity();
    a += j.transpose() * w * j;
    rhs += j.transpose() * w * PoseOf(f);
    points += f.points;
    inliers += f.inliers;
    sum_r2 += f.rms_m * f.rms_m * f.inliers;
  }
  const Eigen::MatrixXd a_inv = a.inverse();
  const Eigen::VectorXd x = a_inv * rhs;
  double chi2 = 0.0;
  for (size_t k = 0; k < fits.size(); ++k) {
    Eigen::Vector3d e = PoseOf(*fits[k]);
    for (int o = 0; o <= order; ++o) e -= std::pow(offsets[k], o) * x.segment<3>(3 * o);
    chi2 += e.dot(weights[k] * e);
  }
  MountEstimate est;
  const int dof = 3 * static_cast<int>(fits.size()) - unknowns;
  est.birge_ratio = dof > 0 ? std::sqrt(chi2 / dof) : 1.0;
  const Eigen::Matrix3d cov = a_inv.topLeftCorner<3, 3>() * std::max(1.0, est.birge_ratio * est.birge_ratio);
  est.value = {x[0], x[1], x[2]};
  est.std = {std::sqrt(cov(0, 0)), std::sqrt(cov(1, 1)), std::sqrt(cov(2, 2))};
  est.frames = static_cast<int>(fits.size());
  est.inliers = points > 0 ? static_cast<double>(inliers) / static_cast<double>(points) : 0.0;
  est.rms_m = inliers > 0 ? std::sqrt(sum_r2 / static_cast<double>(inliers)) : 0.0;
  return est;
}

}  // namespace

GroundCalibrator::GroundCalibrator(Mount3d nominal, GroundOptions options)
    : nominal_(std::move(nominal)), options_(std::move(options)) {
  if (nominal_.rotation) {
    const MountRotation& r = *nominal_.rotation;
    if (!(r.sector_width > 0) || !(r.max > r.min))
      throw InputError("robot file", "lidar3d.rotation", "needs min < max and sector_width > 0");
    num_sectors_ = static_cast<int>(std::ceil((r.max - r.min) / r.sector_width - 1e-9));
  }
  grid_quota_ = options_.grid.points_per_frame > 0 ? static_cast<size_t>(options_.grid.points_per_frame)
                                                    : std::numeric_limits<size_t>::max();
}

int GroundCalibrator::SectorOf(double angle) const {
  if (!nominal_.rotation || !std::isfinite(angle)) return -1;
  const MountRotation& r = *nominal_.rotation;
  double a = angle;
  if (r.max - r.min >= 2 * kPi - 1e-9) {
    a = r.min + std::fmod(a - r.min, 2 * kPi);
    if (a < r.min) a += 2 * kPi;
  } else if (a < r.min || a > r.max) {
    return -1;
  }
  const int index = static_cast<int>(std::floor((a - r.min) / r.sector_width));
  return std::clamp(index, 0, num_sectors_ - 1);
}

int GroundCalibrator::HomeSector() const {
  if (!nominal_.rotation) return -1;
  const int home = SectorOf(0.0);
  if (home >= 0) return home;
  return std::abs(nominal_.rotation->min) < std::abs(nominal_.rotation->max) ? 0 : num_sectors_ - 1;
}

const FrameFit& GroundCalibrator::AddFrame(const float* xyz, size_t count, double mount_angle) {
  ++frames_seen_;
  Frame frame;
  frame.sector = SectorOf(mount_angle);
  frame.angle = mount_angle;
  const bool for_grid = options_.grid.max_points > 0 && frame.sector == HomeSector();
  std::vector<float> floor_points;
  if (nominal_.rotation && frame.sector < 0) {
    frame.fit.problem = "mount angle outside the rotation range";
  } else {
    frame.fit = FitFloor(xyz, count, nominal_, options_.fit, mount_angle,
                         for_grid ? &floor_points : nullptr);
  }
  if (for_grid && frame.fit.usable) {
    // An even share of each frame; every frame's share is halved when the total grows too big.
    auto thin = [](std::vector<float>* points, size_t keep) {
      const size_t n = points->size() / 3;
      if (n <= keep) return;
      const size_t stride = (n + keep - 1) / std::max<size_t>(keep, 1);
      std::vector<float> out;
      out.reserve(3 * (n / stride + 1));
      for (size_t i = 0; i < n; i += stride)
        out.insert(out.end(), points->begin() + 3 * i, points->begin() + 3 * i + 3);
      points->swap(out);
    };
    thin(&floor_points, grid_quota_);
    frame.grid_points = std::move(floor_points);
    size_t total = frame.grid_points.size() / 3;
    for (const Frame& f : frames_) total += f.grid_points.size() / 3;
    while (total > static_cast<size_t>(options_.grid.max_points) && grid_quota_ > 1) {
      size_t largest = frame.grid_points.size() / 3;
      for (const Frame& f : frames_) largest = std::max(largest, f.grid_points.size() / 3);
      grid_quota_ = largest / 2;
      total = 0;
      for (Frame& f : frames_) {
        thin(&f.grid_points, grid_quota_);
        total += f.grid_points.size() / 3;
      }
      thin(&frame.grid_points, grid_quota_);
      total += frame.grid_points.size() / 3;
    }
  }
  frames_.push_back(std::move(frame));
  if (options_.frames.max_frames > 0 && frames_.size() > static_cast<size_t>(options_.frames.max_frames))
    frames_.pop_front();
  return frames_.back().fit;
}

void GroundCalibrator::SkipFrame(const std::string& reason) {
  ++frames_seen_;
  ++frames_skipped_;
  last_skip_reason_ = reason;
}

MountEstimate GroundCalibrator::Estimate(int sector) const { return Combine(sector, nullptr); }

MountEstimate GroundCalibrator::Combine(int sector, std::vector<const Frame*>* used) const {
  std::vector<const Frame*> usable;
  std::map<std::string, int> problems;
  std::vector<const std::string*> failed;
  int offered = 0;
  for (const Frame& f : frames_) {
    if (f.sector != sector) continue;
    ++offered;
    if (f.fit.usable) {
      usable.push_back(&f);
    } else {
      // Group problems by their wording up to the numbers, for the message.
      ++problems[f.fit.problem.substr(0, f.fit.problem.find(" ("))];
      failed.push_back(&f.fit.problem);
    }
  }
  const std::string where =
      sector < 0 ? std::string() : " in sector " + std::to_string(sector);
  if (usable.empty()) {
    std::string why;
    if (offered == 0) {
      why = frames_skipped_ > 0 && sector < 0 ? "no frame could be used (" + last_skip_reason_ + ")"
                                              : "no frames";
    } else {
      why = NoFloorReason(problems, failed, offered);
    }
    throw UnobservableError(
        "3D lidar height, pitch and roll" + where + ": the floor is not visible enough: " + why,
        "record where the lidar sees open, level floor around the robot (not among obstacles or "
        "against walls), and check lidar3d.z, pitch, roll and body in the robot file");
  }

  // A turning lidar's pose changes with its angle within a sector: there each
  // frame is compared with a straight line in the angle about the frames' mean
  // angle, and the estimate is a parabola's value at that angle.
  const bool trend = sector >= 0 && usable.size() >= 3;
  double sum_sin = 0.0, sum_cos = 0.0;
  for (const Frame* f : usable) sum_sin += std::sin(f->angle), sum_cos += std::cos(f->angle);
  const double angle_mean = sector >= 0 ? std::atan2(sum_sin, sum_cos) : 0.0;
  std::vector<const FrameFit*> fits;
  std::vector<double> offsets;
  for (const Frame* f : usable) {
    fits.push_back(&f->fit);
    offsets.push_back(trend ? std::remainder(f->angle - angle_mean, 2 * kPi) : 0.0);
  }

  const FrameOptions& fo = options_.frames;
  const LevelFrames split = FindLevelFrames(fits, offsets, trend, fo);
  std::vector<const Frame*> level;
  std::vector<const FrameFit*> level_fits;
  std::vector<double> level_offsets;
  for (size_t k : split.level) {
    level.push_back(usable[k]);
    level_fits.push_back(fits[k]);
    level_offsets.push_back(offsets[k]);
  }
  const int tilted = static_cast<int>(usable.size() - level.size());
  if (level.empty() || tilted > fo.max_tilted_share * static_cast<double>(usable.size())) {
    throw UnobservableError(
        "3D lidar height, pitch and roll" + where + ": the floor is not one level plane across frames: " +
            std::to_string(tilted) + " of " + std::to_string(usable.size()) +
            " frames tilt against the others by up to " + FixedDecimals(split.worst_tilt / kDeg, 2) + " deg / " +
            FixedDecimals(split.worst_height, 3) + " m (limits " + FixedDecimals(fo.max_tilt_rad / kDeg, 2) + " deg, " +
            FixedDecimals(fo.max_height_m, 3) + " m)",
        "the robot stood on a slope, ramp or uneven floor in part of the recording: record on a "
        "level floor");
  }

  MountEstimate est = WeightedMount(level_fits, level_offsets, trend);
  est.angle = angle_mean;
  est.frames_tilted = tilted;
  if (used) *used = level;
  return est;
}

void GroundCalibrator::ReportSample(int home, GroundResult* result) const {
  for (const Frame& f : frames_) {
    result->frame_fits.push_back(f.fit);
    result->frame_angles.push_back(f.angle);
  }
  std::vector<const Frame*> used;
  Combine(home, &used);
  size_t total = 0;
  for (const Frame* f : used) total += f->grid_points.size() / 3;
  const size_t stride = std::max<size_t>(1, (total + GroundResult::kReportFloorPoints - 1) / GroundResult::kReportFloorPoints);
  size_t k = 0;
  for (const Frame* f : used)
    for (size_t i = 0; i < f->grid_points.size() / 3; ++i, ++k)
      if (k % stride == 0)
        result->floor_points.insert(result->floor_points.end(), f->grid_points.begin() + 3 * i, f->grid_points.begin() + 3 * i + 3);
}

GroundResult GroundCalibrator::Result(bool with_grid) const {
  GroundResult result;
  result.frames_seen = frames_seen_;
  result.frames_unusable = frames_skipped_;
  for (const Frame& f : frames_)
    if (!f.fit.usable) ++result.frames_unusable;
  const int home = HomeSector();
  if (nominal_.rotation) {
    std::vector<std::string> missing;
    std::string first_problem;
    for (int s = 0; s < num_sectors_; ++s) {
      SectorEstimate sector;
      sector.index = s;
      sector.angle_min = nominal_.rotation->min + s * nominal_.rotation->sector_width;
      sector.angle_max = std::min(nominal_.rotation->max, sector.angle_min + nominal_.rotation->sector_width);
      try {
        sector.estimate = Estimate(s);
      } catch (const UnobservableError& e) {
        missing.push_back(std::to_string(s) + " (" + FixedDecimals(sector.angle_min / kDeg, 1) + ".." +
                          FixedDecimals(sector.angle_max / kDeg, 1) + " deg)");
        if (first_problem.empty()) first_problem = e.what();
        continue;
      }
      sector.angle_mean = sector.estimate.angle;
      result.sectors.push_back(sector);
    }
    if (!missing.empty()) {
      std::string list;
      for (size_t i = 0; i < missing.size() && i < 8; ++i) list += (i ? ", " : "") + missing[i];
      if (missing.size() > 8) list += ", ... (" + std::to_string(missing.size()) + " in all)";
      throw UnobservableError(
          "3D lidar height, pitch and roll per sector: no estimate for sector " + list +
              " of " + std::to_string(num_sectors_) + "; first problem: " + first_problem,
          "turn the lidar through every sector of its rotation range while it sees open, level "
          "floor");
    }
    for (const SectorEstimate& s : result.sectors)
      if (s.index == home) result.lidar3d = s.estimate;
  } else {
    result.lidar3d = Estimate(-1);
  }
  ReportSample(home, &result);
  if (with_grid && options_.grid.max_points > 0) {
    // The grid scores the floor points of the frames that went into lidar3d.
    std::vector<const Frame*> used;
    Combine(home, &used);
    std::vector<float> points;
    for (const Frame* f : used) points.insert(points.end(), f->grid_points.begin(), f->grid_points.end());
    if (!points.empty()) {
      const FloorPose start{nominal_.z, nominal_.pitch, nominal_.roll};
      result.grid = GridSearch(points.data(), points.size() / 3, start, options_.grid);
    }
  }
  return result;
}

}  // namespace calib
